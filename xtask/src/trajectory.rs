//! The runs behind `cargo xtask bench`'s speed-against-accuracy charts: the 300-link chain
//! crumpled at rest (every angle uniform in ±[`CRUMPLE`] rad, `q̇ = 0`, `τ = 0`) falling under
//! gravity, the way a user runs `articula simulate` (docs/adaptive.md#defaults).
//!
//! - [`steady_time`]: time per step of a run, the first step (adaptive dynamics' whole-body
//!   selection) apart from the steady steps after it.
//! - [`study`]: every method over a short horizon ([`HORIZON`]): the deviation
//!   `‖q(T) − q_ref(T)‖` from an RK4 run with ABA at a tenth of the smallest step (a crumpled
//!   chain is chaotic: over a second every approximate method ends far from the reference,
//!   while over a tenth of a second the error still ranks the methods), and for adaptive
//!   dynamics the acceleration-metric error accumulated over the run,
//!   `∫ Σᵢ (q̈ᵢ − q̈ᵢ,exact)² dt`, `q̈_exact` the exact DCA solve at the state each step used
//!   (after its locking impulse). The exact methods' is zero by construction.

use crate::solver::{Runner, Solver};
use articula_adaptive::Settings;
use articula_dca::SplitMix64;
use articula_dca::{forward_dynamics_slices, Data, Integrator, Method, State};
use articula_model::Model;
use std::time::Instant;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// Largest joint angle of the crumpled start (rad).
pub const CRUMPLE: f64 = 0.3;
/// Simulated time of the trajectory study (s).
pub const HORIZON: f64 = 0.1;
/// Time steps of the exact methods with semi-implicit Euler (s); adaptive dynamics runs at
/// 1 ms ([`ADAPTIVE_DT`]).
pub const EXACT_DTS: [f64; 4] = [2e-3, 1e-3, 5e-4, 2.5e-4];
/// Time steps of the exact methods with RK4 (s).
pub const RK4_DTS: [f64; 4] = [4e-3, 2e-3, 1e-3, 5e-4];
/// Time step of the adaptive runs (s).
pub const ADAPTIVE_DT: f64 = 1e-3;
/// Budgets of the adaptive runs.
pub const BUDGETS: [usize; 5] = [10, 50, 100, 200, 300];
/// Re-selection policies of the adaptive runs (period, through the caches): every step by
/// the default exact solve, every step through the caches, and the library's default.
pub const POLICIES: [(u64, bool); 3] = [(1, false), (1, true), (Settings::BALANCED, false)];
/// Timed repetitions of each run (the times are their minima).
const REPEATS: usize = 5;

/// The crumpled start: angles uniform in ±[`CRUMPLE`] rad (seed 25), at rest, no torque. No
/// external force: an empty `f_ext` for adaptive dynamics (which scans a dense one every step).
pub fn crumpled_start(model: &Model, solver: Solver) -> State {
    let mut s = State::neutral(model);
    let mut rng = SplitMix64(25);
    for q in s.q.iter_mut() {
        *q = rng.uniform(-CRUMPLE, CRUMPLE);
    }
    if matches!(solver, Solver::Adaptive { .. }) {
        s.f_ext.clear();
    }
    s
}

/// First step and steady time per step (µs) of `steps` steps from `start`: the first step of
/// a fresh workspace, then the mean of the others (a mean: re-selections every few steps are
/// part of the steady cost); each the minimum over `repeats` runs (a shared host pre-empts a
/// run of a few milliseconds now and then, and a pre-empted run's mean says nothing).
pub fn steady_time(
    model: &Model,
    solver: Solver,
    integrator: Integrator,
    dt: f64,
    start: &State,
    steps: usize,
    repeats: usize,
) -> Result<(f64, f64)> {
    let (mut first, mut steady) = (Vec::new(), Vec::new());
    for _ in 0..repeats.max(1) {
        let mut r = Runner::new(model, solver);
        let mut s = start.clone();
        let t = Instant::now();
        r.step(&mut s, integrator, dt)?;
        first.push(t.elapsed().as_secs_f64() * 1e6);
        let t = Instant::now();
        for _ in 1..steps.max(2) {
            r.step(&mut s, integrator, dt)?;
        }
        steady.push(t.elapsed().as_secs_f64() * 1e6 / (steps.max(2) - 1) as f64);
    }
    let min = |v: Vec<f64>| v.into_iter().fold(f64::INFINITY, f64::min);
    Ok((min(first), min(steady)))
}

/// One run of the study.
pub struct Run {
    /// Method as in the tables (`DCA`, `adaptive b=50`, …).
    pub method: String,
    /// Re-selection policy of an adaptive run (`every step`, `every step (caches)`,
    /// `balanced (every 12)`).
    pub policy: Option<String>,
    pub integrator: Integrator,
    pub dt: f64,
    /// First step and steady time per step (µs).
    pub first_us: f64,
    pub steady_us: f64,
    /// `‖q(T) − q_ref(T)‖` (rad).
    pub deviation: f64,
    /// `∫ Σᵢ (q̈ᵢ − q̈ᵢ,exact)² dt` over the run (adaptive runs only).
    pub accel_error: Option<f64>,
}

impl Run {
    /// Cost per simulated second (CPU ms on one thread): the steady time per step over the
    /// time step.
    pub fn ms_per_sim_s(&self) -> f64 {
        self.steady_us * 1e-3 / self.dt
    }
}

/// The study's runs and its reference.
pub struct Study {
    pub runs: Vec<Run>,
    /// The runs that stopped (a non-finite state), with the error.
    pub diverged: Vec<String>,
    /// Time step of the RK4 ABA reference (s).
    pub reference_dt: f64,
    /// `‖q_ref(2·dt_ref) − q_ref(dt_ref)‖` at the horizon (RK4's own error is ~1/16 of it).
    pub reference_check: f64,
    /// The reference's `q` at the horizon.
    pub q_ref: Vec<f64>,
}

/// Final `q` of a run over [`HORIZON`]; for adaptive dynamics also the accumulated
/// acceleration-metric error against exact DCA solves (untimed).
fn final_q(
    model: &Model,
    solver: Solver,
    integrator: Integrator,
    dt: f64,
) -> Result<(Vec<f64>, Option<f64>)> {
    let mut r = Runner::new(model, solver);
    let mut s = crumpled_start(model, solver);
    let mut exact = Data::new(model);
    let steps = (HORIZON / dt).round() as usize;
    let mut acc = None;
    for _ in 0..steps {
        let q0 = s.q.clone();
        r.step(&mut s, integrator, dt)?;
        // (With RK4 the last q̈ is a stage's: no accumulated error is kept.)
        let euler = integrator == Integrator::SemiImplicitEuler;
        if let Some(qdd) = r.adaptive_qdd().filter(|_| euler) {
            // The state the step's accelerations belong to: its start's q, and its q̇ after
            // the locking impulse (semi-implicit Euler: q̇' = q̇ + h q̈; locked joints 0).
            let qd: Vec<f64> = s.qd.iter().zip(qdd).map(|(v, a)| v - dt * a).collect();
            let e = forward_dynamics_slices(model, &mut exact, &q0, &qd, &s.tau, &[], Method::Dca)?;
            *acc.get_or_insert(0.0) += metric_error(qdd, e) * dt;
        }
    }
    Ok((s.q, acc))
}

pub fn norm_diff(a: &[f64], b: &[f64]) -> f64 {
    metric_error(a, b).sqrt()
}

/// The label of a re-selection policy on `model` at `budget`.
pub fn policy_label(model: &Model, budget: usize, every: u64, caches: bool) -> String {
    if caches {
        format!("{} (caches)", policy_label(model, budget, every, false))
    } else if every == Settings::BALANCED {
        format!(
            "balanced (every {})",
            Settings::balanced_period(model, Some(budget))
        )
    } else if every == 1 {
        "every step".into()
    } else {
        format!("every {every}")
    }
}

/// The trajectory study on `model` (the 300-link chain).
pub fn study(model: &Model) -> Result<Study> {
    let aba = Solver::Exact(Method::Aba);
    let reference_dt = EXACT_DTS[EXACT_DTS.len() - 1] / 10.0;
    debug_assert!(RK4_DTS.iter().all(|dt| *dt > reference_dt));
    let (q_ref, _) = final_q(model, aba, Integrator::Rk4, reference_dt)?;
    let (q_ref2, _) = final_q(model, aba, Integrator::Rk4, 2.0 * reference_dt)?;
    let mut configs: Vec<(Solver, Integrator, f64, Option<String>)> = Vec::new();
    for m in [Method::Dca, Method::Aba] {
        for dt in EXACT_DTS {
            configs.push((Solver::Exact(m), Integrator::SemiImplicitEuler, dt, None));
        }
        for dt in RK4_DTS {
            configs.push((Solver::Exact(m), Integrator::Rk4, dt, None));
        }
    }
    // Semi-implicit Euler at every policy; RK4 at the library's default (balanced) period.
    let policies = POLICIES
        .iter()
        .map(|&p| (p, Integrator::SemiImplicitEuler))
        .chain([((Settings::BALANCED, false), Integrator::Rk4)]);
    for ((every, caches), integrator) in policies {
        for budget in BUDGETS {
            let solver = Solver::Adaptive {
                budget,
                every,
                caches,
            };
            let policy = policy_label(model, budget, every, caches);
            configs.push((solver, integrator, ADAPTIVE_DT, Some(policy)));
        }
    }
    let mut runs = Vec::new();
    let mut diverged = Vec::new();
    for (solver, integrator, dt, policy) in configs {
        let (q, accel_error) = match final_q(model, solver, integrator, dt) {
            Ok(r) => r,
            Err(e) => {
                let what = format!(
                    "{} {} {} dt {} ms: {e}",
                    solver.label(),
                    policy.as_deref().unwrap_or(""),
                    integrator_name(integrator),
                    dt * 1e3
                );
                println!("  trajectory diverged: {what}");
                diverged.push(what);
                continue;
            }
        };
        let start = crumpled_start(model, solver);
        let steps = (HORIZON / dt).round() as usize;
        let (first_us, steady_us) =
            steady_time(model, solver, integrator, dt, &start, steps, REPEATS)?;
        let method = match solver {
            Solver::Adaptive { budget, .. } => format!("adaptive b={budget}"),
            s => s.label(),
        };
        let run = Run {
            method,
            policy,
            integrator,
            dt,
            first_us,
            steady_us,
            deviation: norm_diff(&q, &q_ref),
            accel_error,
        };
        println!(
            "  trajectory {} {} {:?} dt {:.2e}: first {:.1} µs, steady {:.1} µs/step, deviation {:.3e} rad, accel error {:?}",
            run.method,
            run.policy.as_deref().unwrap_or(""),
            integrator,
            dt,
            first_us,
            steady_us,
            run.deviation,
            accel_error
        );
        runs.push(run);
    }
    Ok(Study {
        runs,
        diverged,
        reference_dt,
        reference_check: norm_diff(&q_ref2, &q_ref),
        q_ref,
    })
}

/// The integrator's name in tables and legends.
pub fn integrator_name(i: Integrator) -> &'static str {
    match i {
        Integrator::SemiImplicitEuler => "semi-implicit Euler",
        Integrator::Rk4 => "RK4",
    }
}

/// `Σ (a − b)²`: the acceleration metric (identity weights) of the difference.
pub fn metric_error(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}
