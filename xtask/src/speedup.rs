//! `cargo xtask speedup`: adaptive against exact dynamics, the two interleaved in one process
//! so that a machine whose speed drifts times both alike; prints each round and the ratio of
//! the minima and the median round ratio.
//!
//! - `seeds [ROUNDS] [BUDGET...]` (defaults 8 rounds, budgets 1 and 50): the seeds table's
//!   runs (the criterion bench `adaptive_seeds_table/*/f1`): the 300-link chain in the seeds'
//!   state with one external force ([`articula_testkit::seeds::seeded_state`]), semi-implicit
//!   Euler at dt = 1e-4; full DCA steps against adaptive steps re-selecting every 10 steps
//!   (selection included); runs restarted every 1,000 steps, the restart and the whole-body
//!   re-selection after it untimed. Each round times a batch of DCA steps, then a batch of each
//!   budget's steps of about the same duration.
//! - `crowd SCENE.json [ROUNDS] [STEPS] [BUDGET...]` (defaults 8 and 500; each budget replaces
//!   the scene's in turn, and the weighted metric left unsimulated at the last re-selection is
//!   printed beside the times): each round times `STEPS` scene steps from a fresh scene
//!   (re-selections, pushes and all, as the criterion bench `adaptive_step`), then `STEPS`
//!   steps of the same scene's exact reference ([`SceneMethod::Exact`] by DCA: the same
//!   springs, pushes and floor, every joint moving, semi-implicit Euler), both on one thread;
//!   then how far the adaptive crowd is from the exact one after 0.1 s (60 steps), per
//!   character (root position, joint coordinates: median and largest), and its view-weighted
//!   error (screen distance of the visible links, px; world distance, m) after 0.1, 0.5 and
//!   2 s (both runs continue to 2 s for it).

use articula_adaptive::{Adaptive, Reselection, Settings};
use articula_dca::{step, Data, Integrator, Method, State, Threads};
use articula_testkit::seeds::{force_list, seeded_state};
use articula_view::{SceneMethod, SceneSim};
use std::hint::black_box;
use std::path::PathBuf;
use std::time::{Duration, Instant};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// The comparisons of `cargo xtask speedup`.
#[derive(clap::Subcommand, Debug)]
pub enum Comparison {
    /// The seeds table's runs: DCA steps against adaptive ones on the 300-link chain.
    ///
    /// The 300-link chain in the seeds' state with one external force, semi-implicit Euler at
    /// dt = 1e-4; full DCA steps against adaptive steps re-selecting every 10 steps (selection
    /// included); runs restarted every 1,000 steps.
    Seeds {
        /// Interleaved rounds (0 runs one).
        #[arg(default_value_t = 8, allow_negative_numbers = true)]
        rounds: usize,
        /// Adaptive budgets (joints).
        #[arg(value_name = "BUDGET", default_values_t = [1, 50], allow_negative_numbers = true)]
        budgets: Vec<usize>,
    },
    /// A scene's adaptive steps against its exact reference, one thread.
    ///
    /// Each round times STEPS scene steps from a fresh scene, then STEPS steps of the scene's
    /// exact reference (DCA on every character: the same springs, pushes and floor); then how
    /// far the adaptive crowd is from the exact one after 0.1 s, and its view-weighted error
    /// after 0.1, 0.5 and 2 s.
    Crowd {
        /// The scene file.
        #[arg(value_name = "SCENE.json")]
        scene: PathBuf,
        /// Interleaved rounds (0 runs one).
        #[arg(default_value_t = 8, allow_negative_numbers = true)]
        rounds: usize,
        /// Scene steps per round (0 runs one).
        #[arg(default_value_t = 500, allow_negative_numbers = true)]
        steps: u64,
        /// Budgets that replace the scene's in turn [default: the scene's].
        #[arg(value_name = "BUDGET", allow_negative_numbers = true)]
        budgets: Vec<usize>,
    },
}

pub fn run(comparison: &Comparison) -> Result<()> {
    match comparison {
        Comparison::Seeds { rounds, budgets } => seeds((*rounds).max(1), budgets),
        Comparison::Crowd {
            scene: path,
            rounds,
            steps,
            budgets,
        } => {
            let (rounds, steps) = ((*rounds).max(1), (*steps).max(1));
            let scene = articula_view::load_scene(path)?;
            if budgets.is_empty() {
                return crowd(&scene, rounds, steps);
            }
            for &b in budgets {
                let mut scene = scene.clone();
                scene.budget = Some(b);
                println!("budget {b}:");
                crowd(&scene, rounds, steps)?;
            }
            Ok(())
        }
    }
}

/// Steps per run of the seeds comparison before a restart.
const RUN: u64 = 1000;
const DT: f64 = 1e-4;

fn seeds(rounds: usize, budgets: &[usize]) -> Result<()> {
    let model = articula_testkit::chain(300);
    let s0 = seeded_state(&model, 1);
    let list = force_list(&s0.f_ext);
    let mut a0 = s0.clone();
    a0.f_ext.clear();

    // Full DCA: `n` steps, restarted every RUN (the restart untimed).
    let mut data = Data::new(&model);
    let mut s = s0.clone();
    let mut dca_calls = 0u64;
    let mut dca = |n: u64| -> Result<f64> {
        let mut total = Duration::ZERO;
        let mut t = Instant::now();
        for _ in 0..n {
            dca_calls += 1;
            if dca_calls.is_multiple_of(RUN) {
                total += t.elapsed();
                s.clone_from(&s0);
                t = Instant::now();
            }
            step(
                &model,
                &mut data,
                &mut s,
                Method::Dca,
                Integrator::SemiImplicitEuler,
                DT,
            )?;
            black_box(s.qd[0]);
        }
        Ok((total + t.elapsed()).as_secs_f64() * 1e6 / n as f64)
    };
    // Adaptive, per budget: its workspace, state and step count.
    let mut runs: Vec<(Adaptive, State, u64)> = budgets
        .iter()
        .map(|&b| {
            let settings = Settings {
                budget: Some(b),
                reselect_every: 10,
                ..Settings::default()
            };
            {
                // Re-selections through the caches, as the seeds table's criterion bench.
                let mut ad = Adaptive::new(&model, settings);
                ad.set_reselection(Reselection::Caches);
                (ad, a0.clone(), 0)
            }
        })
        .collect();
    let mut adaptive = |k: usize, n: u64| -> Result<f64> {
        let (ad, s, calls) = &mut runs[k];
        let mut total = Duration::ZERO;
        let mut t = Instant::now();
        for _ in 0..n {
            *calls += 1;
            if calls.is_multiple_of(RUN) || *calls == 1 {
                // Restart: untimed, with the whole-body re-selection that follows it.
                total += t.elapsed();
                s.q.copy_from_slice(&a0.q);
                s.qd.copy_from_slice(&a0.qd);
                ad.invalidate();
                ad.step_with_forces(&model, s, DT, &list)?;
                t = Instant::now();
            }
            ad.step_with_forces(&model, s, DT, &list)?;
            black_box(s.qd[0]);
        }
        Ok((total + t.elapsed()).as_secs_f64() * 1e6 / n as f64)
    };
    // Warm-up.
    dca(200)?;
    for k in 0..budgets.len() {
        adaptive(k, 2000)?;
    }
    let mut best_dca = f64::MAX;
    let mut best = vec![f64::MAX; budgets.len()];
    let mut ratios = vec![Vec::new(); budgets.len()];
    for round in 0..rounds {
        let d = dca(300)?;
        best_dca = best_dca.min(d);
        print!("round {round}: dca {d:.2} us");
        for (k, &b) in budgets.iter().enumerate() {
            // About as long a batch as the DCA one (0.1-1 ms per step class).
            let n = if b <= 10 { 100_000 } else { 3_000 };
            let a = adaptive(k, n)?;
            best[k] = best[k].min(a);
            ratios[k].push(d / a);
            print!(", budget {b} {a:.3} us ({:.1}x)", d / a);
        }
        println!();
    }
    for (k, &b) in budgets.iter().enumerate() {
        let r = &mut ratios[k];
        r.sort_by(f64::total_cmp);
        println!(
            "budget {b} every 10: minima dca {best_dca:.2} us / adaptive {:.3} us = {:.1}x; median round ratio {:.1}x",
            best[k],
            best_dca / best[k],
            r[r.len() / 2]
        );
    }
    Ok(())
}

fn crowd(scene: &articula_view::LoadedScene, rounds: usize, steps: u64) -> Result<()> {
    // Each side from a fresh scene, on one thread, for `steps` steps.
    let run = |method: SceneMethod| -> Result<(f64, f64)> {
        let mut sim = SceneSim::new(scene).map_err(|e| e.to_string())?;
        sim.set_threads(Threads::serial());
        sim.set_method(method);
        let t = Instant::now();
        let mut error = 0.0;
        for _ in 0..steps {
            error = sim.step()?.total_error;
        }
        Ok((t.elapsed().as_secs_f64() * 1e3 / steps as f64, error))
    };
    let (mut best_a, mut best_e) = (f64::MAX, f64::MAX);
    let mut ratios = Vec::new();
    for round in 0..rounds {
        let (a, error) = run(SceneMethod::Adaptive)?;
        let (e, _) = run(SceneMethod::Exact(Method::Dca))?;
        best_a = best_a.min(a);
        best_e = best_e.min(e);
        ratios.push(e / a);
        println!(
            "round {round}: adaptive {a:.3} ms/step, exact DCA {e:.3} ms/step, ratio {:.2}; weighted error left {error:.4e}",
            e / a
        );
    }
    ratios.sort_by(f64::total_cmp);
    println!(
        "minima: adaptive {best_a:.3} ms/step, exact DCA {best_e:.3} ms/step, ratio {:.2}; median round ratio {:.2}",
        best_e / best_a,
        ratios[ratios.len() / 2]
    );
    crowd_deviation(scene, DEVIATION_HORIZON.min(steps))
}

/// Steps after which [`crowd_deviation`] compares the adaptive crowd's joints with its exact
/// reference: 0.1 s at the bundled scenes' 600 steps a second, before the characters' chaotic
/// motions (a fall, a stagger) separate any two integrations.
const DEVIATION_HORIZON: u64 = 60;

/// How far the adaptive scene has drifted from its exact reference, both from the scene's
/// start: after `steps` steps, per character the largest deviation of its root position (m)
/// and of any internal joint coordinate (rad), printed as the median and the largest over the
/// crowd; and the view-weighted error ([`articula_view::SceneSim::view_deviation`]: screen
/// distance of the visible links, px, and world distance, m) at each of
/// [`crate::crowd_chart::CHECKPOINTS`].
fn crowd_deviation(scene: &articula_view::LoadedScene, steps: u64) -> Result<()> {
    let mut adaptive = SceneSim::new(scene).map_err(|e| e.to_string())?;
    let mut exact = SceneSim::new(scene).map_err(|e| e.to_string())?;
    exact.set_method(SceneMethod::Exact(Method::Dca));
    let marks: Vec<u64> = crate::crowd_chart::CHECKPOINTS
        .iter()
        .map(|t| (t / scene.dt).round() as u64)
        .collect();
    let last = marks.iter().copied().max().unwrap_or(0).max(steps);
    for k in 1..=last {
        adaptive.step()?;
        exact.step()?;
        if k == steps {
            joint_deviation(scene, &adaptive, &exact, steps);
        }
        if marks.contains(&k) {
            let d = exact.view_deviation(&adaptive)?;
            println!(
                "view-weighted error after {:.2} s: {:.3} px mean ({:.2} px largest) over {} visible and {} occluded links at {}×{}, {:.2e} m",
                d.time,
                d.pixels,
                d.max_pixels,
                d.visible_links,
                d.occluded_links,
                scene.image.width,
                scene.image.height,
                d.metres
            );
        }
    }
    Ok(())
}

/// The per-character joint and root deviations of [`crowd_deviation`].
fn joint_deviation(
    scene: &articula_view::LoadedScene,
    adaptive: &SceneSim,
    exact: &SceneSim,
    steps: u64,
) {
    let (mut root, mut joint) = (Vec::new(), Vec::new());
    for (a, e) in adaptive.bodies.iter().zip(&exact.bodies) {
        let model = &scene.models[a.model].model;
        // A floating base's position is q[0..3]; its orientation and every internal joint
        // follow (composed joints as their angles).
        let skip = if model.floating_base { 7 } else { 0 };
        let d = |r: std::ops::Range<usize>| {
            a.state.q[r.clone()]
                .iter()
                .zip(&e.state.q[r])
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        };
        root.push(if model.floating_base { d(0..3) } else { 0.0 });
        joint.push(d(skip..model.nq));
    }
    for v in [&mut root, &mut joint] {
        v.sort_by(f64::total_cmp);
    }
    let (n, t) = (root.len(), steps as f64 * scene.dt);
    println!(
        "deviation from exact DCA after {steps} steps ({t:.3} s), per character: root position median {:.2e} m, largest {:.2e} m; joint coordinates median {:.2e} rad, largest {:.2e} rad",
        root[n / 2],
        root[n - 1],
        joint[n / 2],
        joint[n - 1]
    );
}
