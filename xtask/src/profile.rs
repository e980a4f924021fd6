//! `cargo xtask profile`: fixed workloads for profilers (callgrind, perf), each timed as well.
//! The workload of interest runs inside a function of its own, `xtask::profile::measured`,
//! so that callgrind can collect only it:
//! `valgrind --tool=callgrind --toggle-collect='xtask::profile::measured*' target/release/xtask profile …`.
//! Instruction counts per call or step come from two runs with different counts, differenced.
//!
//! - `dynamics METHOD MODEL CALLS`: `CALLS` forward-dynamics calls (`MODEL` as in
//!   `cargo xtask time`) at `State::random(model, 42, 1.0)`; prints the wall-clock and CPU time
//!   per call (CPU time from /proc, 10 ms resolution: use runs of a second or more).
//! - `adaptive LINKS BUDGET PERIOD STEPS [FORCES] [--at-origin]`: adaptive steps (semi-implicit
//!   Euler, dt 1e-4) re-selecting every `PERIOD` steps on a chain crumpled at rest (random
//!   angles ±1.2 rad, seed 42), with `FORCES` constant external forces on evenly spread bodies,
//!   each at its body's origin as in the seeds table (`--at-origin`: at the computation frame's
//!   origin instead). The first step (a whole-body re-selection building every cache) runs
//!   before. Prints the median over batches of 100 steps and the nodes the last step visited.
//! - `exact LINKS STEPS [FORCES]`: the same run with exact DCA steps, for the ratio.
//! - `scene SCENE.json WARMUP STEPS`: `WARMUP` scene steps, then `STEPS` measured ones; prints
//!   the time per step, the mean number of active joints and the scene's state hash
//!   (`cargo xtask hash`).

use crate::args;
use articula_adaptive::{Adaptive, Reselection, Settings};
use articula_dca::{forward_dynamics_slices, step, Data, Integrator, Method, State};
use articula_model::Model;
use articula_spatial::SpatialForce;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

const DT: f64 = 1e-4;

/// External forces as `(body, world wrench)` pairs.
type Forces = Vec<(usize, SpatialForce)>;

/// The workloads of `cargo xtask profile`.
#[derive(clap::Subcommand, Debug)]
pub enum Workload {
    /// CALLS forward-dynamics calls at `State::random(model, 42, 1.0)`; prints the wall-clock
    /// and CPU time per call.
    Dynamics {
        /// The forward-dynamics method.
        #[arg(value_parser = args::method())]
        method: Method,
        /// A chain length (`300`), a bundled model (`humanoid`) or its floating-base version
        /// (`humanoid-floating`).
        #[arg(value_parser = args::model_name)]
        model: String,
        /// Forward-dynamics calls (0 runs one).
        #[arg(allow_negative_numbers = true)]
        calls: usize,
    },
    /// Adaptive steps re-selecting every PERIOD steps on a crumpled chain with FORCES forces.
    ///
    /// Semi-implicit Euler, dt 1e-4, on a chain crumpled at rest (random angles ±1.2 rad, seed
    /// 42), with FORCES constant external forces on evenly spread bodies, each at its body's
    /// origin as in the seeds table (--at-origin: at the computation frame's origin instead).
    /// The first step (a whole-body re-selection building every cache) runs before. Prints the
    /// median over batches of 100 steps and the nodes the last step visited.
    Adaptive {
        /// The chain's length (links).
        #[arg(allow_negative_numbers = true)]
        links: usize,
        /// The adaptive budget (joints).
        #[arg(allow_negative_numbers = true)]
        budget: usize,
        /// Steps between re-selections.
        #[arg(allow_negative_numbers = true)]
        period: u64,
        /// Measured steps (0 runs one).
        #[arg(allow_negative_numbers = true)]
        steps: usize,
        /// Constant external forces.
        #[arg(default_value_t = 0, allow_negative_numbers = true)]
        forces: usize,
        /// Apply the forces at the computation frame's origin instead of their bodies'.
        #[arg(long)]
        at_origin: bool,
    },
    /// The adaptive workload's run with exact DCA steps, for the ratio.
    Exact {
        /// The chain's length (links).
        #[arg(allow_negative_numbers = true)]
        links: usize,
        /// Measured steps (0 runs one).
        #[arg(allow_negative_numbers = true)]
        steps: usize,
        /// Constant external forces.
        #[arg(default_value_t = 0, allow_negative_numbers = true)]
        forces: usize,
        /// Apply the forces at the computation frame's origin instead of their bodies'.
        #[arg(long)]
        at_origin: bool,
    },
    /// WARMUP scene steps, then STEPS measured ones; prints the time per step, the mean number
    /// of active joints and the scene's state hash.
    Scene {
        /// The scene file.
        #[arg(value_name = "SCENE.json")]
        scene: PathBuf,
        /// Unmeasured steps first.
        #[arg(allow_negative_numbers = true)]
        warmup: u64,
        /// Measured steps (0 runs one).
        #[arg(allow_negative_numbers = true)]
        steps: u64,
    },
}

pub fn run(workload: &Workload) -> Result<()> {
    match *workload {
        Workload::Dynamics {
            method,
            ref model,
            calls,
        } => dynamics(method, model, calls.max(1)),
        Workload::Adaptive {
            links,
            budget,
            period,
            steps,
            forces,
            at_origin,
        } => {
            let (model, s, list) = crumpled_chain(links, forces, !at_origin)?;
            adaptive(&model, s, &list, budget, period, steps.max(1))
        }
        Workload::Exact {
            links,
            steps,
            forces,
            at_origin,
        } => {
            let (model, mut s, list) = crumpled_chain(links, forces, !at_origin)?;
            for (b, f) in list {
                s.f_ext[b] = f;
            }
            exact(&model, s, links, steps.max(1))
        }
        Workload::Scene {
            ref scene,
            warmup,
            steps,
        } => self::scene(scene, warmup, steps.max(1)),
    }
}

/// The measured workload: `f` called `n` times, in a function of its own for
/// `--toggle-collect`.
#[inline(never)]
fn measured<E>(
    n: usize,
    mut f: impl FnMut() -> std::result::Result<(), E>,
) -> std::result::Result<(), E> {
    for _ in 0..n {
        f()?;
    }
    Ok(())
}

/// User + system CPU time of this process in seconds (Linux; `None` elsewhere).
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

fn dynamics(method: Method, name: &str, calls: usize) -> Result<()> {
    let model = args::model(name)?;
    let s = State::random(&model, 42, 1.0);
    let mut data = Data::new(&model);
    let mut acc = 0.0;
    let c0 = cpu_seconds();
    let t = Instant::now();
    measured(calls, || {
        acc += forward_dynamics_slices(&model, &mut data, &s.q, &s.qd, &s.tau, &[], method)?[0];
        Ok::<(), articula_dca::DynamicsError>(())
    })?;
    let wall = t.elapsed().as_secs_f64() * 1e6 / calls as f64;
    black_box(acc);
    let cpu = match (c0, cpu_seconds()) {
        (Some(a), Some(b)) => format!("{:.3}", (b - a) * 1e6 / calls as f64),
        _ => "?".to_string(),
    };
    println!(
        "{} {name}: {wall:.3} us/call wall, {cpu} us/call cpu ({calls} calls)",
        method.name()
    );
    Ok(())
}

/// A chain of `n` links crumpled at rest (random angles, seed 42) and `forces` constant forces
/// of direction `(1, sin k, cos k)` on evenly spread bodies, at each body's origin
/// (`at_body`) or at the computation frame's origin.
fn crumpled_chain(n: usize, forces: usize, at_body: bool) -> Result<(Model, State, Forces)> {
    if n == 0 {
        return Err("a chain needs at least one link".into());
    }
    let model = articula_testkit::chain(n);
    let mut s = State::random(&model, 42, 0.0);
    s.qd.fill(0.0);
    s.f_ext.clear();
    let mut kin = Data::new(&model);
    articula_dca::forward_kinematics(&model, &s.q, &s.qd, &mut kin).unwrap();
    let list = (0..forces.min(n))
        .map(|k| {
            let body = k * n / forces.min(n);
            let dir = glam::DVec3::new(1.0, (k as f64).sin(), (k as f64).cos());
            let f = if at_body {
                kin.point_force(body, glam::DVec3::ZERO, dir)
            } else {
                SpatialForce::new(glam::DVec3::ZERO, dir)
            };
            (body, f)
        })
        .collect();
    if forces > 0 {
        s.f_ext = vec![SpatialForce::ZERO; n];
    }
    Ok((model, s, list))
}

/// The median time per step (µs) over batches of up to 100 steps of `step`.
fn batched_median(steps: usize, mut step: impl FnMut() -> Result<()>) -> Result<(f64, usize)> {
    let mut us = Vec::new();
    let mut done = 0;
    while done < steps {
        let batch = 100.min(steps - done);
        let t = Instant::now();
        measured(batch, &mut step)?;
        us.push(t.elapsed().as_secs_f64() * 1e6 / batch as f64);
        done += batch;
    }
    us.sort_by(f64::total_cmp);
    Ok((us[us.len() / 2], us.len()))
}

fn adaptive(
    model: &Model,
    mut s: State,
    forces: &[(usize, SpatialForce)],
    budget: usize,
    period: u64,
    steps: usize,
) -> Result<()> {
    s.f_ext.clear();
    let settings = Settings {
        budget: Some(budget),
        reselect_every: period,
        ..Settings::default()
    };
    let mut ad = Adaptive::new(model, settings);
    // The workload of the caches (the library's default route is the exact solve).
    ad.set_reselection(Reselection::Caches);
    let t = Instant::now();
    let first = ad.step_with_forces(model, &mut s, DT, forces)?;
    let first_ms = t.elapsed().as_secs_f64() * 1e3;
    let mut last = first.clone();
    let (median, batches) = batched_median(steps, || {
        last = ad.step_with_forces(model, &mut s, DT, forces)?;
        Ok(())
    })?;
    println!(
        "chain{} budget {budget} re-select every {period}: {median:.3} us per step (median of \
         {batches} batches; first step {first_ms:.1} ms, {} nodes; last step {} nodes, {} active DOFs)",
        model.bodies.len(),
        first.nodes_touched,
        last.nodes_touched,
        last.active_dofs
    );
    Ok(())
}

fn exact(model: &Model, mut s: State, n: usize, steps: usize) -> Result<()> {
    let mut data = Data::new(model);
    let (median, batches) = batched_median(steps, || {
        step(
            model,
            &mut data,
            &mut s,
            Method::Dca,
            Integrator::SemiImplicitEuler,
            DT,
        )?;
        Ok(())
    })?;
    println!("chain{n} DCA: {median:.3} us per step (median of {batches} batches)");
    Ok(())
}

fn scene(path: &Path, warmup: u64, steps: u64) -> Result<()> {
    let scene = articula_view::load_scene(path)?;
    let mut sim = articula_view::SceneSim::new(&scene).map_err(|e| e.to_string())?;
    // One thread: the profile of one core's work.
    sim.set_threads(articula_dca::Threads::serial());
    for _ in 0..warmup {
        sim.step()?;
    }
    let mut active = 0;
    let t = Instant::now();
    measured(steps as usize, || {
        active += sim.step()?.active_total;
        Ok::<(), articula_view::ViewError>(())
    })?;
    println!(
        "{:.3} ms/step over {steps} steps after {warmup}; mean active joints {:.1}",
        t.elapsed().as_secs_f64() * 1e3 / steps as f64,
        active as f64 / steps as f64
    );
    println!("state hash {:016x}", crate::hash::state_hash(&sim));
    Ok(())
}
