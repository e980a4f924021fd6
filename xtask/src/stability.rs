//! `cargo xtask stability`: where each method fails. Writes charts to `docs/img/` (and
//! `target/articula-stability/`) and `docs/stability.md` with the measured figures.
//!
//! 1. Accuracy of DCA, ABA and CRBA against the double-double reference ([`articula_testkit::reference`]) as
//!    chains grow (10 → 10,000 links).
//! 2. The same as the mass and inertia ratio between neighbouring links grows (1 → 1e8).
//! 3. Energy drift of semi-implicit Euler and RK4 against dt (10-link chain, 10 s).
//! 4. Adaptive dynamics: trajectory deviation from exact DCA against budget and re-selection
//!    rate, and against the strength of a short push.
//! 5. The hard cases of issue 24 (`stress.rs`): straight, near-straight and tilted chains to
//!    100,000 links, neighbour mass ratios to 1e9, a hub with 2,000 children.

use crate::chart::{self, LogLogPlot, Series};
use crate::solver::{Runner, Solver};
use articula_adaptive::{Adaptive, Settings};
use articula_dca::{forward_kinematics, step, Data, Integrator, Method, State};
use articula_model::{LoadOptions, Model};
use articula_testkit::rel_error;
use articula_testkit::Dd;
use articula_testkit::ReferenceModel;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// Chain lengths of the accuracy study.
pub const LENGTHS: [usize; 7] = [10, 30, 100, 300, 1000, 3000, 10_000];
/// Neighbour mass (and inertia) ratios.
pub const RATIOS: [f64; 5] = [1.0, 1e2, 1e4, 1e6, 1e8];
/// Links of the mass-ratio chains.
pub const RATIO_LINKS: usize = 100;
/// Seeds of the random states (the worst error over them is reported).
pub const SEEDS: [u64; 3] = [1, 2, 3];
/// Steps of the energy study (10-link chain, 10 s).
pub const DTS: [f64; 5] = [1e-2, 3e-3, 1e-3, 3e-4, 1e-4];
pub const DURATION: f64 = 10.0;
/// Adaptive study on the 100-link chain: budgets, re-selection periods (steps), pushes (N).
pub const AD_BUDGETS: [usize; 6] = [1, 5, 10, 25, 50, 100];
pub const AD_RESELECT: [u64; 4] = [1, 5, 20, 100];
pub const AD_PUSHES: [f64; 5] = [0.1, 1.0, 10.0, 100.0, 1000.0];
/// Adaptive study: 0.2 s at dt = 1e-4, semi-implicit Euler (at dt = 1e-3 the exact run itself
/// diverges on this chain within the first second).
const AD_DT: f64 = 1e-4;
const AD_STEPS: usize = 2000;
/// Steps the push lasts (10 ms).
const AD_PUSH_STEPS: usize = 100;

/// One adaptive run against the exact one.
struct AdRun {
    budget: usize,
    every: u64,
    push: f64,
    /// RMS of q − q_exact after 0.2 s (rad).
    deviation: f64,
    /// Mean predicted acceleration-metric error at re-selections, relative to the whole metric.
    rel_metric: f64,
    us_per_step: f64,
}

/// The adaptive study's start: chain100 at a random configuration, rates ±0.5 rad/s, τ = 0.
fn ad_start(model: &Model) -> State {
    let mut s = State::random(model, 5, 0.0);
    s.qd.iter_mut().for_each(|x| *x *= 0.25);
    s
}

/// Runs 0.2 s of adaptive dynamics (and returns q at the end with statistics); `push` newtons
/// along +x at the origin of link 80 during the first 10 ms.
fn ad_run(
    model: &Model,
    budget: Option<usize>,
    every: u64,
    push: f64,
) -> Result<(Vec<f64>, f64, f64)> {
    let mut s = ad_start(model);
    s.f_ext.clear();
    let mut data = Data::new(model);
    let mut ad = Adaptive::new(
        model,
        Settings {
            budget,
            reselect_every: every,
            ..Settings::default()
        },
    );
    let (mut rel, mut n_rel) = (0.0, 0usize);
    let t0 = Instant::now();
    for k in 0..AD_STEPS {
        let forces = if push != 0.0 && k < AD_PUSH_STEPS {
            forward_kinematics(model, &s.q, &s.qd, &mut data).unwrap();
            vec![(
                79usize,
                data.point_force(79, glam::DVec3::ZERO, glam::DVec3::new(push, 0.0, 0.0)),
            )]
        } else {
            vec![]
        };
        let r = ad.step_with_forces(model, &mut s, AD_DT, &forces)?;
        if r.reselected && ad.selection().total_metric > 0.0 {
            rel += ad.selection().predicted_error / ad.selection().total_metric;
            n_rel += 1;
        }
    }
    let us = t0.elapsed().as_secs_f64() * 1e6 / AD_STEPS as f64;
    Ok((s.q, rel / n_rel.max(1) as f64, us))
}

/// Exact DCA over the same 0.2 s (semi-implicit Euler, same push).
fn ad_exact(model: &Model, push: f64) -> Result<Vec<f64>> {
    let mut s = ad_start(model);
    let mut data = Data::new(model);
    for k in 0..AD_STEPS {
        s.f_ext.iter_mut().for_each(|f| *f = Default::default());
        if push != 0.0 && k < AD_PUSH_STEPS {
            forward_kinematics(model, &s.q, &s.qd, &mut data).unwrap();
            s.f_ext[79] = data.point_force(79, glam::DVec3::ZERO, glam::DVec3::new(push, 0.0, 0.0));
        }
        step(
            model,
            &mut data,
            &mut s,
            Method::Dca,
            Integrator::SemiImplicitEuler,
            AD_DT,
        )?;
    }
    Ok(s.q)
}

fn rms_diff(a: &[f64], b: &[f64]) -> f64 {
    (metric_error(a, b) / a.len() as f64).sqrt()
}

fn metric_error(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// The adaptive study: budget × re-selection period without push, then pushes at budgets 10
/// and 50 with re-selection every step.
fn adaptive_study(model: &Model) -> Result<Vec<AdRun>> {
    let mut runs = Vec::new();
    let exact0 = ad_exact(model, 0.0)?;
    for every in AD_RESELECT {
        for budget in AD_BUDGETS {
            let (q, rel, us) = ad_run(model, Some(budget), every, 0.0)?;
            let r = AdRun {
                budget,
                every,
                push: 0.0,
                deviation: rms_diff(&q, &exact0),
                rel_metric: rel,
                us_per_step: us,
            };
            println!(
                "  adaptive b={budget} every {every}: deviation {} rad, {:.0} µs/step",
                sci(Some(r.deviation)),
                us
            );
            runs.push(r);
        }
    }
    for push in AD_PUSHES {
        let exact = ad_exact(model, push)?;
        for budget in [10usize, 50] {
            let (q, rel, us) = ad_run(model, Some(budget), 1, push)?;
            let r = AdRun {
                budget,
                every: 1,
                push,
                deviation: rms_diff(&q, &exact),
                rel_metric: rel,
                us_per_step: us,
            };
            println!(
                "  adaptive push {push} N b={budget}: deviation {} rad",
                sci(Some(r.deviation))
            );
            runs.push(r);
        }
    }
    Ok(runs)
}

/// The worst relative error of each method (`None` where it failed or was not run).
type Errors = Vec<(Solver, Option<f64>)>;

pub use articula_testkit::ratio_chain_urdf;

/// Worst relative error of each method over [`SEEDS`] on `model` (`None` where it fails or is
/// not run).
fn errors(model: &Model) -> Result<Errors> {
    let reference = ReferenceModel::new(model)?;
    let mut worst: Errors = Solver::EXACT
        .into_iter()
        .filter(|s| s.runs_at(model.nv))
        .map(|s| (s, Some(0.0)))
        .collect();
    for seed in SEEDS {
        let state = State::random(model, seed, 1.0);
        let exact: Vec<f64> = reference
            .aba::<Dd>(&state.q, &state.qd, &state.tau, &state.f_ext)
            .iter()
            .map(|x| x.to_f64())
            .collect();
        for (solver, w) in worst.iter_mut() {
            let mut r = Runner::new(model, *solver);
            *w = match (r.forward(&state), *w) {
                (Ok(q), Some(w)) => Some(w.max(rel_error(q, &exact))),
                _ => None,
            };
        }
    }
    Ok(worst)
}

struct Drift {
    method: Method,
    integrator: Integrator,
    dt: f64,
    drift: f64,
    /// The same over the first second only.
    drift_1s: f64,
    us_per_step: f64,
}

/// The 10-link chain's energy study start: the conservation test's state (seed 8, rates
/// scaled to ≤ 0.5 rad/s, τ = 0).
fn chain10_start(model: &Model) -> State {
    let mut s = State::random(model, 8, 0.0);
    s.qd.iter_mut().for_each(|x| *x *= 0.25);
    s.tau.iter_mut().for_each(|x| *x = 0.0);
    s
}

fn energy(model: &Model, data: &mut Data, s: &State) -> f64 {
    forward_kinematics(model, &s.q, &s.qd, data).unwrap();
    data.kinetic_energy() + data.potential_energy()
}

fn drift(model: &Model, method: Method, integrator: Integrator, dt: f64) -> Result<Drift> {
    let mut r = Runner::new(model, Solver::Exact(method));
    let mut data = Data::new(model);
    let mut s = chain10_start(model);
    let e0 = energy(model, &mut data, &s);
    let steps = (DURATION / dt).round() as usize;
    let mut worst = 0.0f64;
    let mut worst_1s = 0.0f64;
    // Each step's time: their median does not count the steps a loaded host descheduled.
    let mut stepping = Vec::with_capacity(steps);
    for k in 0..steps {
        let t = Instant::now();
        let ok = r.step(&mut s, integrator, dt);
        stepping.push(t.elapsed().as_secs_f64());
        if ok.is_err() {
            worst = f64::INFINITY;
            break;
        }
        worst = worst.max((energy(model, &mut data, &s) - e0).abs() / e0.abs());
        if (k + 1) as f64 * dt <= 1.0 + 1e-9 {
            worst_1s = worst;
        }
    }
    Ok(Drift {
        method,
        integrator,
        dt,
        drift: worst,
        drift_1s: worst_1s,
        us_per_step: crate::timing::median(&mut stepping) * 1e6,
    })
}

fn sci(x: Option<f64>) -> String {
    match x {
        Some(x) if x.is_finite() => format!("{x:.1e}"),
        Some(_) => "diverged".into(),
        None => "—".into(),
    }
}

/// The arguments of `cargo xtask stability`.
#[derive(clap::Args, Debug)]
pub struct Options {
    #[command(subcommand)]
    pub only: Option<Only>,
}

/// A part of the study run alone.
#[derive(clap::Subcommand, Debug)]
pub enum Only {
    /// Print the table of the hard cases (section 5) only; writes nothing.
    Cases {
        /// Also the 100,000-link chains.
        #[arg(long)]
        full: bool,
    },
}

pub fn run(root: &Path, o: &Options) -> Result<()> {
    if let Some(Only::Cases { full }) = o.only {
        return crate::stress::print(full);
    }
    let started = Instant::now();
    let img = root.join("docs/img");
    let out = root.join("target/articula-stability");

    // 1. Chain length.
    let mut by_length = Vec::new();
    for n in LENGTHS {
        let t = Instant::now();
        let model = articula_testkit::chain(n);
        let e = errors(&model)?;
        println!(
            "  chain{n:<6} {}  ({:.1} s)",
            e.iter()
                .map(|(s, x)| format!("{} {}", s.label(), sci(*x)))
                .collect::<Vec<_>>()
                .join("  "),
            t.elapsed().as_secs_f64()
        );
        by_length.push((n, e));
    }

    // 2. Mass ratio.
    let mut by_ratio = Vec::new();
    for ratio in RATIOS {
        let model = Model::from_urdf_str(
            &ratio_chain_urdf(RATIO_LINKS, ratio),
            &LoadOptions::default(),
        )?;
        let e = errors(&model)?;
        println!(
            "  ratio {ratio:<6e} {}",
            e.iter()
                .map(|(s, x)| format!("{} {}", s.label(), sci(*x)))
                .collect::<Vec<_>>()
                .join("  ")
        );
        by_ratio.push((ratio, e));
    }

    // 3. Energy drift.
    let chain10 = Model::from_urdf_file(root.join("models/chain10.urdf"), &LoadOptions::default())?;
    let mut drifts = Vec::new();
    for method in [Method::Dca, Method::Aba] {
        for integrator in [Integrator::SemiImplicitEuler, Integrator::Rk4] {
            for dt in DTS {
                let d = drift(&chain10, method, integrator, dt)?;
                println!(
                    "  energy {} {:?} dt={dt:e}: drift {}",
                    method.name(),
                    integrator,
                    sci(Some(d.drift))
                );
                drifts.push(d);
            }
        }
    }

    // 5. The hard cases (issue 24).
    let mut hard = Vec::new();
    for case in crate::stress::cases(true) {
        let o = crate::stress::run_case(case)?;
        println!(
            "  {:<52} DCA {:>8}  ABA {:>8}",
            case.label(),
            crate::stress::cell(&o.dca),
            crate::stress::cell(&o.aba)
        );
        hard.push(o);
    }

    // 4. Adaptive dynamics.
    let chain100 = articula_testkit::chain(100);
    let ad_runs = adaptive_study(&chain100)?;

    let studies = Studies {
        by_length: &by_length,
        by_ratio: &by_ratio,
        drifts: &drifts,
        ad_runs: &ad_runs,
        hard: &hard,
    };
    let files = write_charts(&[&out, &img], &studies)?;

    let doc = document(
        &by_length,
        &by_ratio,
        &drifts,
        &ad_runs,
        &hard,
        started.elapsed().as_secs_f64(),
    );
    let path = root.join("docs/stability.md");
    std::fs::write(&path, doc)?;
    println!("wrote {}", path.display());
    // The longest chain's errors, quoted in docs/performance.md.
    if let Some((n, e)) = by_length.last() {
        let errors: Vec<String> = e
            .iter()
            .map(|(s, x)| format!("{} {}", s.label(), sci(*x)))
            .collect();
        crate::docs::write_between_markers(
            &root.join("docs/performance.md"),
            "stability",
            &format!(
                "Relative error `max |q̈ − q̈_ref| / max |q̈_ref|` at {n} links, the worst of \
                 [stability.md](stability.md)'s states: {}.",
                errors.join(", ")
            ),
        )?;
    }
    for f in &files {
        println!("wrote {}", f.display());
    }
    println!("stability took {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// The results of `cargo xtask stability`'s studies, for its charts.
#[derive(Clone, Copy)]
struct Studies<'a> {
    by_length: &'a [(usize, Errors)],
    by_ratio: &'a [(f64, Errors)],
    drifts: &'a [Drift],
    ad_runs: &'a [AdRun],
    hard: &'a [crate::stress::Outcome],
}

/// The stability charts (tilted chain, chain length, mass ratio, energy, adaptive), written
/// into each of `dirs`; the files written.
fn write_charts(dirs: &[&Path], studies: &Studies) -> Result<Vec<std::path::PathBuf>> {
    let Studies {
        by_length,
        by_ratio,
        drifts,
        ad_runs,
        hard,
    } = *studies;
    let mut files = Vec::new();
    let series_of = |rows: &[(f64, Errors)]| -> Vec<Series> {
        Solver::EXACT
            .iter()
            .map(|&s| Series {
                name: s.label(),
                points: rows
                    .iter()
                    .filter_map(|(x, e)| {
                        e.iter()
                            .find(|(t, _)| *t == s)
                            .and_then(|(_, v)| *v)
                            .map(|v| (*x, v.max(1e-17)))
                    })
                    .collect(),
                labels: vec![],
            })
            .collect()
    };
    let len_rows: Vec<(f64, Errors)> = by_length
        .iter()
        .map(|(n, e)| (*n as f64, e.clone()))
        .collect();
    let length_plot = LogLogPlot {
        title: "Accuracy against chain length (vs double-double ABA)".into(),
        x_desc: "links n".into(),
        y_desc: "relative error max|Δqdd| / max|qdd|".into(),
        series: series_of(&len_rows),
        lines: true,
        vlines: vec![],
    };
    let ratio_plot = LogLogPlot {
        title: format!("Accuracy against neighbour mass ratio ({RATIO_LINKS}-link chain)"),
        x_desc: "mass and inertia ratio of neighbouring links".into(),
        y_desc: "relative error max|Δqdd| / max|qdd|".into(),
        series: series_of(by_ratio),
        lines: true,
        vlines: vec![],
    };
    let energy_plot = LogLogPlot {
        title: format!("Energy drift, 10-link chain, {DURATION} s"),
        x_desc: "time step dt (s)".into(),
        y_desc: "max |E(t) − E(0)| / |E(0)|".into(),
        series: drifts
            .chunks(DTS.len())
            .map(|c| Series {
                name: format!(
                    "{} + {}",
                    c[0].method.name().to_uppercase(),
                    match c[0].integrator {
                        Integrator::SemiImplicitEuler => "semi-implicit Euler",
                        Integrator::Rk4 => "RK4",
                    }
                ),
                points: c
                    .iter()
                    .filter(|d| d.drift.is_finite())
                    .map(|d| (d.dt, d.drift))
                    .collect(),
                labels: vec![],
            })
            .collect(),
        lines: true,
        vlines: vec![],
    };
    let adaptive_plot = LogLogPlot {
        title: "Adaptive, 100-link chain: deviation from exact DCA after 0.2 s".into(),
        x_desc: "budget (active joints)".into(),
        y_desc: "RMS of q − q_exact (rad)".into(),
        series: AD_RESELECT
            .iter()
            .map(|&every| Series {
                name: format!("re-selection every {every} step(s)"),
                points: ad_runs
                    .iter()
                    .filter(|r| r.every == every && r.push == 0.0)
                    .map(|r| (r.budget as f64, r.deviation.max(1e-17)))
                    .collect(),
                labels: vec![],
            })
            .collect(),
        lines: true,
        vlines: vec![],
    };
    let tilted_plot = LogLogPlot {
        title: "Straight chain tilted by its first joint (0.5 rad), from rest".into(),
        x_desc: "links n".into(),
        y_desc: "relative error max|Δqdd| / max|qdd|".into(),
        series: [("DCA", true), ("ABA", false)]
            .iter()
            .map(|&(name, dca)| Series {
                name: name.into(),
                points: hard
                    .iter()
                    .filter(|o| o.case.pose == crate::stress::Pose::Tilted)
                    .filter_map(|o| match o.case.shape {
                        crate::stress::Shape::Chain { links, ratio: 1.0 } => {
                            let e = if dca { &o.dca } else { &o.aba };
                            e.as_ref().ok().map(|&e| (links as f64, e.max(1e-17)))
                        }
                        _ => None,
                    })
                    .collect(),
                labels: vec![],
            })
            .collect(),
        lines: true,
        vlines: vec![],
    };
    for &dir in dirs {
        files.extend(chart::write_loglog(dir, "stability_tilted", &tilted_plot)?);
        files.extend(chart::write_loglog(
            dir,
            "stability_chain_length",
            &length_plot,
        )?);
        files.extend(chart::write_loglog(
            dir,
            "stability_mass_ratio",
            &ratio_plot,
        )?);
        files.extend(chart::write_loglog(dir, "stability_energy", &energy_plot)?);
        files.extend(chart::write_loglog(
            dir,
            "stability_adaptive",
            &adaptive_plot,
        )?);
    }

    Ok(files)
}

fn table<X: std::fmt::Display>(s: &mut String, head: &str, rows: &[(X, Errors)]) {
    let _ = writeln!(s, "| {head} | DCA | ABA | CRBA |\n|---:|---:|---:|---:|");
    for (x, e) in rows {
        let cell = |m: Method| {
            sci(e
                .iter()
                .find(|(t, _)| *t == Solver::Exact(m))
                .and_then(|(_, v)| *v))
        };
        let _ = writeln!(
            s,
            "| {x} | {} | {} | {} |",
            cell(Method::Dca),
            cell(Method::Aba),
            cell(Method::Crba)
        );
    }
}

fn get(rows: &[(Solver, Option<f64>)], m: Method) -> Option<f64> {
    rows.iter()
        .find(|(t, _)| *t == Solver::Exact(m))
        .and_then(|(_, v)| *v)
}

fn document(
    by_length: &[(usize, Errors)],
    by_ratio: &[(f64, Errors)],
    drifts: &[Drift],
    ad_runs: &[AdRun],
    hard: &[crate::stress::Outcome],
    took: f64,
) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Stability and accuracy\n\n\
         Where each method of articula loses accuracy, measured. Everything on this page — \
         figures, tables and charts — is written by `cargo xtask stability` (it took {took:.0} s \
         on a 2-core machine); rerun it after changing a solver. The charts are in `docs/img/`.\n"
    );
    let _ = writeln!(
        s,
        "**The reference.** `crates/articula-testkit/src/reference.rs` runs the articulated-body algorithm in body \
         coordinates (RBDA Table 7.1, explicit 6×6 Plücker transforms) in double-double \
         arithmetic (`crates/articula-testkit/src/dd.rs`, ~32 significant digits). It shares no code or \
         formulation with the library's f64 solvers, which work with the world's axes, and it \
         reads the model's f64 numbers as exact. Its q̈ is therefore exact to far below f64 \
         rounding, and every error below is the f64 method's own. Errors are relative, \
         `max_i |q̈_i − q̈_i,ref| / max_i |q̈_i,ref|`, the worst over {} random states \
         (`State::random(model, seed, 1.0)`: angles ±1.2 rad, rates ±2 rad/s, torques ±1 N·m, \
         seeds {:?}).\n",
        SEEDS.len(),
        SEEDS
    );

    // Chain length.
    let _ = writeln!(s, "## 1. Accuracy as chains grow\n");
    let _ = writeln!(
        s,
        "Planar pendulum chains of n rods (0.1 m, 0.1 kg; `articula_testkit::chain(n)`). CRBA \
         is not run past 1000 links (dense O(n³)).\n"
    );
    table(&mut s, "links", by_length);
    let first = &by_length[0].1;
    let last = &by_length[by_length.len() - 1].1;
    let (n0, n1) = (by_length[0].0, by_length[by_length.len() - 1].0);
    let _ = writeln!(
        s,
        "\n![accuracy against chain length](img/stability_chain_length.png)\n"
    );
    let _ = writeln!(s, "Findings:\n");
    for m in [Method::Dca, Method::Aba] {
        if let (Some(a), Some(b)) = (get(first, m), get(last, m)) {
            let _ = writeln!(
                s,
                "- {}: {a:.1e} at {n0} links, {b:.1e} at {n1} links ({:.0}× for {}× the links).",
                m.name().to_uppercase(),
                b / a.max(1e-300),
                n1 / n0
            );
        }
    }
    let crba: Vec<(usize, f64)> = by_length
        .iter()
        .filter_map(|(n, e)| get(e, Method::Crba).map(|v| (*n, v)))
        .collect();
    if let (Some(a), Some(b)) = (crba.first(), crba.last()) {
        let _ = writeln!(
            s,
            "- CRBA: {:.1e} at {} links, {:.1e} at {} links. The joint-space inertia matrix of \
             a long chain is badly conditioned (cond(H) ~ n⁴) and the dense Cholesky solution \
             alone pays for it (2.9e-7 at 1000 links); CRBA's refinement steps against the \
             Newton–Euler residual, which never forms H, recover the digits.",
            a.1, a.0, b.1, b.0
        );
    }
    if let (Some(d), Some(a)) = (get(last, Method::Dca), get(last, Method::Aba)) {
        let (better, worse, r) = if d <= a {
            ("DCA", "ABA", a / d.max(1e-300))
        } else {
            ("ABA", "DCA", d / a.max(1e-300))
        };
        let _ = writeln!(
            s,
            "- At {n1} links {better} is {r:.0}× more accurate than {worse}. Both work with \
             the world's axes about points near each body (ABA about each body's origin, DCA \
             about each handle's joint, lever arms taken from the joint origins: \
             `docs/algorithms.md`); the reference, like Pinocchio, works in body coordinates.\n"
        );
    }

    // Mass ratio.
    let _ = writeln!(s, "## 2. Accuracy as neighbouring links differ in mass\n");
    let _ = writeln!(
        s,
        "{RATIO_LINKS}-link chains whose odd links weigh 0.1 kg and whose even links weigh \
         0.1·r kg, with inertias scaled alike (same shapes, density ratio r).\n"
    );
    table(
        &mut s,
        "ratio r",
        &by_ratio
            .iter()
            .map(|(r, e)| (format!("{r:.0e}"), e.clone()))
            .collect::<Vec<_>>(),
    );
    let _ = writeln!(
        s,
        "\n![accuracy against mass ratio](img/stability_mass_ratio.png)\n"
    );
    let _ = writeln!(s, "Findings:\n");
    let (r0, e0) = &by_ratio[0];
    let (r1, e1) = &by_ratio[by_ratio.len() - 1];
    for m in [Method::Dca, Method::Aba, Method::Crba] {
        if let (Some(a), Some(b)) = (get(e0, m), get(e1, m)) {
            let _ = writeln!(
                s,
                "- {}: {a:.1e} at r = {r0:.0e}, {b:.1e} at r = {r1:.0e} (ratio {:.1e}).",
                m.name().to_uppercase(),
                b / a.max(1e-300)
            );
        }
    }
    if let Some(best) = [Method::Dca, Method::Aba, Method::Crba]
        .into_iter()
        .filter_map(|m| get(e1, m).map(|v| (m, v)))
        .min_by(|x, y| x.1.total_cmp(&y.1))
    {
        let _ = writeln!(
            s,
            "- At r = {r1:.0e} the most accurate is {} ({:.1e}).",
            best.0.name().to_uppercase(),
            best.1
        );
        if best.0 != Method::Dca {
            let _ = writeln!(
                s,
                "  Here DCA loses: its error grows with the ratio while ABA's does not. Where a \
                 light body is joined to a heavy one, the compliance of the pair in the \
                 directions the joint holds rigid is the small difference of the light body's \
                 large compliances, so the join loses about log10(r) digits; on models with a \
                 neighbour mass ratio above 1e4 DCA's leaves of light bodies between heavy ones \
                 invert an inertia 1e4 below their neighbours' and the solve is refined against \
                 the Newton–Euler residual with the exact inertias \
                 (`docs/algorithms.md#mass-ratio`), which is what the rows from 1e4 up show."
            );
        }
        for m in [Method::Dca, Method::Aba, Method::Crba] {
            if let Some(v) = get(e1, m).filter(|_| m != best.0) {
                let _ = writeln!(
                    s,
                    "  {} is {:.0e}× less accurate there.",
                    m.name().to_uppercase(),
                    v / best.1
                );
            }
        }
    }
    let _ = writeln!(s);

    energy_section(&mut s, drifts);
    adaptive_section(&mut s, ad_runs, hard);
    s
}

/// Section 3 of docs/stability.md: the integrators' energy drift.
fn energy_section(s: &mut String, drifts: &[Drift]) {
    // Energy.
    let _ = writeln!(s, "## 3. Energy drift of the integrators\n");
    let _ = writeln!(
        s,
        "The 10-link chain (`models/chain10.urdf`) from the conservation test's start \
         (seed 8, angles ±1.2 rad, rates ≤ 0.5 rad/s, τ = 0, gravity only: a conservative \
         system), run for {DURATION} s. Drift is `max_t |E(t) − E(0)| / |E(0)|` over the run, \
         E = kinetic + potential energy (E(0) < 0: potential energy is measured from the \
         base). µs per step is the integration step alone, the median over the run's steps, \
         on the machine of the run that wrote this page: the drifts do not depend on the \
         machine, the times do (compare them with each other, not with another machine's).\n"
    );
    let _ = writeln!(
        s,
        "| solver | integrator | dt (s) | steps | drift over {DURATION} s | drift over the first 1 s | µs per step |\n|---|---|---:|---:|---:|---:|---:|"
    );
    for d in drifts {
        let _ = writeln!(
            s,
            "| {} | {} | {:e} | {} | {} | {} | {:.1} |",
            d.method.name().to_uppercase(),
            match d.integrator {
                Integrator::SemiImplicitEuler => "semi-implicit Euler",
                Integrator::Rk4 => "RK4",
            },
            d.dt,
            (DURATION / d.dt).round(),
            sci(Some(d.drift)),
            sci(Some(d.drift_1s)),
            d.us_per_step
        );
    }
    let _ = writeln!(
        s,
        "\n![energy drift against dt](img/stability_energy.png)\n"
    );
    let _ = writeln!(s, "Findings:\n");
    for integ in [Integrator::SemiImplicitEuler, Integrator::Rk4] {
        let pts: Vec<&Drift> = drifts
            .iter()
            .filter(|d| d.method == Method::Dca && d.integrator == integ)
            .collect();
        // Observed order between the two smallest steps, over 10 s and over the first 1 s.
        let (a, b) = (pts[pts.len() - 2], pts[pts.len() - 1]);
        let order = |x: f64, y: f64| (x / y).log10() / (a.dt / b.dt).log10();
        let _ = writeln!(
            s,
            "- {} (DCA): over {DURATION} s, drift {} at dt = {:e} s and {} at dt = {:e} s \
             (observed order {:.1}); over the first second {} and {} (order {:.1}).",
            match integ {
                Integrator::SemiImplicitEuler => "Semi-implicit Euler",
                Integrator::Rk4 => "RK4",
            },
            sci(Some(a.drift)),
            a.dt,
            sci(Some(b.drift)),
            b.dt,
            order(a.drift, b.drift),
            sci(Some(a.drift_1s)),
            sci(Some(b.drift_1s)),
            order(a.drift_1s, b.drift_1s),
        );
        if let Some(d) = pts.iter().find(|d| !d.drift.is_finite()) {
            let _ = writeln!(
                s,
                "  At dt = {:e} s it diverges (a non-finite state stops the run).",
                d.dt
            );
        }
    }
    let pick = |m: Method, i: Integrator| {
        drifts
            .iter()
            .rfind(|d| d.method == m && d.integrator == i)
            .map(|d| (d.drift, d.drift_1s, d.dt))
    };
    if let (Some(d), Some(a)) = (
        pick(Method::Dca, Integrator::Rk4),
        pick(Method::Aba, Integrator::Rk4),
    ) {
        let _ = writeln!(
            s,
            "- DCA against ABA, RK4 at dt = {:e} s: over the first second {} and {}; over \
             {DURATION} s {} and {}. The solvers differ only by rounding, but the chain is \
             chaotic: over 10 s those differences grow into different trajectories, and with \
             them different drift figures.\n",
            d.2,
            sci(Some(d.1)),
            sci(Some(a.1)),
            sci(Some(d.0)),
            sci(Some(a.0))
        );
    }
}

/// Section 4 of docs/stability.md: adaptive dynamics (and section 5, the hard cases).
fn adaptive_section(s: &mut String, ad_runs: &[AdRun], hard: &[crate::stress::Outcome]) {
    // Adaptive.
    let _ = writeln!(s, "## 4. Adaptive dynamics\n");
    let _ = writeln!(
        s,
        "The 100-link chain from a random configuration (rates ±0.5 rad/s, no torques), 0.2 s at \
         dt = 1e-4 with semi-implicit Euler (at dt = 1e-3 the exact run itself diverges within \
         the first second); the deviation is the RMS of `q − q_exact` at the end, \
         the exact run being DCA with the same integrator and step. Joints not selected are \
         locked at each re-selection (`articula-adaptive`, velocity tolerance unset). \
         *metric* is the mean predicted acceleration-metric error at the re-selections relative \
         to the whole body's metric.\n\n![Adaptive deviation against budget](img/stability_adaptive.png)\n"
    );
    let _ = writeln!(s, "| re-selection every | budget | deviation (rad) | metric | µs/step |\n|---|---|---|---|---|");
    for r in ad_runs.iter().filter(|r| r.push == 0.0) {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.0} |",
            r.every,
            r.budget,
            sci(Some(r.deviation)),
            sci(Some(r.rel_metric)),
            r.us_per_step
        );
    }
    let _ = writeln!(
        s,
        "\n**Stiff pushes.** The same start with a push of F newtons along +x at the origin of \
         link 80 for the first 10 ms, re-selection every step:\n\n| push (N) | budget | deviation (rad) | metric |\n|---|---|---|---|"
    );
    for r in ad_runs.iter().filter(|r| r.push != 0.0) {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} |",
            r.push,
            r.budget,
            sci(Some(r.deviation)),
            sci(Some(r.rel_metric))
        );
    }
    let at = |every: u64, budget: usize| {
        ad_runs
            .iter()
            .find(|r| r.every == every && r.budget == budget && r.push == 0.0)
    };
    let dev = |every, budget| at(every, budget).map(|r| r.deviation);
    let us = |every, budget| at(every, budget).map_or(f64::NAN, |r| r.us_per_step);
    let push = |p: f64, budget: usize| {
        ad_runs
            .iter()
            .find(|r| r.push == p && r.budget == budget)
            .map(|r| r.deviation)
    };
    let _ = writeln!(
        s,
        "\n**Findings.** Locking every joint the budget leaves out is a strong approximation on \
         a freely swinging chain: with re-selection every step the deviation after 0.2 s is {} rad \
         at budget 1, {} at 10, {} at 50 and {} at 100 (all joints: exact up to round-off). The \
         re-selection period changes it {} (budget 10: {} every step, {} every 100 steps) \
         while the time per step falls from {:.0} µs to {:.0} µs, because a re-selection \
         computes the whole body's articulated coefficients and metric (O(n)) and the steps in \
         between only the active region. Pushes: at budget 10 the deviation goes from {} rad \
         (0.1 N) to {} (100 N) and {} (1000 N); at budget 50 from {} to {} and {}.\n",
        sci(dev(1, 1)),
        sci(dev(1, 10)),
        sci(dev(1, 50)),
        sci(dev(1, 100)),
        match (dev(1, 10), dev(100, 10)) {
            (Some(a), Some(b)) if a > 0.0 && (b / a) < 2.0 && (a / b) < 2.0 => "by less than 2×",
            _ => "by 2× or more",
        },
        sci(dev(1, 10)),
        sci(dev(100, 10)),
        us(1, 10),
        us(100, 10),
        sci(push(0.1, 10)),
        sci(push(100.0, 10)),
        sci(push(1000.0, 10)),
        sci(push(0.1, 50)),
        sci(push(100.0, 50)),
        sci(push(1000.0, 50)),
    );
    hard_cases(s, hard);
}

/// Section 5: the hard cases of issue 24.
fn hard_cases(s: &mut String, hard: &[crate::stress::Outcome]) {
    let _ = writeln!(s, "\n## 5. Long, straight, tilted and stiff chains\n");
    let _ = writeln!(
        s,
        "Chains of `articula_testkit::chain(n)` (and `ratio_chain_urdf(n, r)` for a neighbour \
         mass ratio r) hanging straight down from rest with τ₁ = 1 N·m (at rest with τ = 0 \
         q̈ = 0 exactly), near-straight (every joint at ±0.01 rad, seeded), tilted (the first \
         joint at 0.5, 0.3 or 0.2 rad, the rest straight: a straight chain at that angle from \
         the vertical), or \
         at a random state (seed 1); and a fixed hub with 2,000 children \
         (`articula_testkit::star_urdf`). Same reference and error as above; \"refused\" is an \
         error returned instead of q̈. Reproduce the table alone with \
         `cargo xtask stability cases --full`.\n"
    );
    let _ = writeln!(
        s,
        "Pinocchio's `pin.aba` (default convention, local frames; `peers/pin_qdd.py` with \
         `target/peers-venv`) runs up to {} links: its `Data` takes 1.8 GiB at 300 \
         (— where not run).\n",
        crate::stress::PIN_MAX_LINKS
    );
    let _ = writeln!(s, "| case | DCA | ABA | Pinocchio |\n|---|---:|---:|---:|");
    for o in hard {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} |",
            o.case.label(),
            crate::stress::cell(&o.dca),
            crate::stress::cell(&o.aba),
            o.pin.as_ref().map_or("—".into(), crate::stress::cell)
        );
    }
    let _ = writeln!(
        s,
        "\n![accuracy of a tilted straight chain](img/stability_tilted.png)\n"
    );
    let refused: Vec<String> = hard
        .iter()
        .filter_map(|o| {
            o.dca
                .as_ref()
                .err()
                .map(|e| format!("{} ({e})", o.case.label()))
        })
        .collect();
    let _ = writeln!(
        s,
        "Findings:\n\n\
         - ABA works about each body's origin and DCA's leaves take their lever arms from the \
         joint origins (`docs/algorithms.md`), so a chain's tilt in the world costs no digits: \
         the errors of the tilted chains grow about linearly with n, not as n².\n\
         - Where a light link is joined to a heavy one DCA's join loses about log10(ratio) \
         digits. On models with a neighbour mass ratio above 1e4 the leaf of a light link \
         between heavy ones inverts an inertia 1e4 below its neighbours' (the joins then lose \
         at most 4 digits) and the solve is refined to convergence against the Newton–Euler \
         residual with the exact inertias: two steps, each shrinking the error ~5,000-fold \
         (`docs/algorithms.md#mass-ratio`). A join pivot that rounding made non-positive is \
         taken by magnitude and the solve refined.\n\
         - At 0.2 and 0.3 rad the 100,000-link chain loses join pivots out of its plane and \
         DCA's fixed-point refinement diverges; it refines by GMRES instead, with no fallback \
         to ABA (`docs/algorithms.md`, \"When the refinement diverges\").\n\
         - DCA still returns an error on: {}.\n",
        if refused.is_empty() {
            "none of these".to_string()
        } else {
            refused.join("; ")
        }
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratio_chain_alternates_masses() {
        let m = Model::from_urdf_str(&ratio_chain_urdf(4, 1e4), &LoadOptions::default()).unwrap();
        let masses: Vec<f64> = m.bodies.iter().map(|b| b.inertia.mass).collect();
        assert_eq!(masses, vec![0.1, 1000.0, 0.1, 1000.0]);
    }

    #[test]
    fn rel_error_is_max_norm_relative() {
        assert_eq!(rel_error(&[1.0, 2.5], &[1.0, 2.0]), 0.25);
    }

    /// On short chains every exact method agrees with the double-double reference.
    #[test]
    fn exact_methods_are_accurate_on_a_short_chain() {
        let m = articula_testkit::chain(10);
        for (s, e) in errors(&m).unwrap() {
            assert!(e.unwrap() < 1e-12, "{}: {e:?}", s.label());
        }
    }
}
