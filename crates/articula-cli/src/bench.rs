//! `articula bench`: time forward-dynamics calls on a seeded random state.
//!
//! A warm-up (at least 10 calls and 0.2 s) estimates the cost of a call; then `reps` calls
//! (default: about one second's worth, at least 100) run in up to 30 near-equal batches, each timed
//! with [`Instant`]. The reported figure is the median over batches of the time per call.
//!
//! `--threads T` spreads one body's DCA solve over T threads from
//! [`articula_dca::PARALLEL_DCA_MIN_BODIES`] bodies (serial below: the same bits for any T),
//! and with `--method adaptive` a hybrid step's per-joint sweeps from
//! [`articula_adaptive::PARALLEL_HYBRID_MIN_JOINTS`] active joints.
//! `--states N` times [`Batch::forward_dynamics`] of `N` seeded states instead (seeds
//! `SEED..SEED+N`), spread over `--threads`: one call solves all of them.

use crate::{print_out, CliError, DynamicsArgs};
use articula_dca::{forward_dynamics_threads, Batch, State};
use std::hint::black_box;
use std::time::{Duration, Instant};

/// Arguments of `articula bench`.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    #[command(flatten)]
    pub dynamics: DynamicsArgs,
    /// Number of timed calls (default: about one second's worth, at least 100).
    #[arg(long, value_name = "N", value_parser = parse_reps, allow_hyphen_values = true)]
    pub reps: Option<u64>,
    /// `--method adaptive`: re-select the hybrid body every N steps (1: every timed step
    /// includes the selection). Default: the balanced period ⌈2 · internal DOFs / budget⌉, at
    /// most 50, as `articula simulate` (docs/adaptive.md#defaults).
    #[arg(long, value_name = "N", value_parser = parse_reps)]
    pub reselect_every: Option<u64>,
    /// Time the batch API instead: forward dynamics of N seeded states per call, spread over
    /// `--threads` (exact methods only).
    #[arg(long, value_name = "N", value_parser = parse_reps, allow_hyphen_values = true)]
    pub states: Option<u64>,
}

/// The seed of the benchmarked state (`State::random(model, SEED, 1.0)`).
pub const SEED: u64 = 42;
/// Most batches the timed calls are split into.
const BATCHES: u64 = 30;

fn parse_reps(s: &str) -> Result<u64, String> {
    crate::simulate::parse_count(s).map_err(|e| format!("the number of repetitions {e}"))
}

/// Time step of the adaptive simulation timed by `--method adaptive`.
const ADAPTIVE_DT: f64 = 1e-4;
/// Steps after which the timed adaptive simulation restarts from its initial state (0.1 s).
const ADAPTIVE_RUN: u64 = 1000;

/// Median of a non-empty slice.
fn median(xs: &mut [f64]) -> f64 {
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    if n % 2 == 1 {
        xs[n / 2]
    } else {
        0.5 * (xs[n / 2 - 1] + xs[n / 2])
    }
}

/// The sizes of the batches `reps` calls are split into: at most [`BATCHES`], as equal as can be.
fn batching(reps: u64) -> Vec<u64> {
    let batches = reps.clamp(1, BATCHES);
    (0..batches)
        .map(|i| reps / batches + u64::from(i < reps % batches))
        .collect()
}

/// Runs `articula bench`.
pub fn run(args: &BenchArgs) -> Result<(), CliError> {
    let (model, mut data) = args.dynamics.load()?;
    let method = args.dynamics.method;
    let state = State::random(&model, SEED, 1.0);
    // Adaptive: one full step (re-selecting at the balanced period unless --reselect-every),
    // continuing the same simulation call after call — from the seeded pose at rest and
    // without joint torques: the seeded velocities (up to 1 rad/s at every joint) whip a
    // 1,000-link chain's tip past what a 0.1 ms Euler step follows, and torques would pump
    // energy into a long run.
    let threads = crate::threads(args.dynamics.threads)?;
    let mut batch = match (args.states, method.exact()) {
        (None, _) => None,
        (Some(_), None) => {
            return Err(CliError(
                "--states needs an exact method (dca, aba or crba)".to_string(),
            ))
        }
        (Some(n), Some(_)) => {
            let states: Vec<State> = (0..n)
                .map(|i| State::random(&model, SEED + i, 1.0))
                .collect();
            let qdd = vec![0.0; states.len() * model.nv];
            Some((Batch::with_data(&data, threads.clone()), states, qdd))
        }
    };
    let every = args.reselect_every.unwrap_or_else(|| {
        articula_adaptive::Settings::balanced_period(&model, args.dynamics.budget)
    });
    let mut adaptive = method.exact().is_none().then(|| {
        let mut sim = state.clone();
        sim.tau.fill(0.0);
        sim.qd.fill(0.0);
        // No external force: an empty list (`Adaptive::step` scans a dense one every step,
        // which would put an O(n) pass into steps that are otherwise O(active)).
        if sim
            .f_ext
            .iter()
            .all(|f| *f == articula_spatial::SpatialForce::ZERO)
        {
            sim.f_ext.clear();
        }
        let mut ad = args.dynamics.adaptive(&model, every);
        ad.set_threads(threads.clone());
        (ad, sim.clone(), sim, 0u64)
    });
    // Returns the time of a call to leave out of the timing: a restart of the adaptive run,
    // with the whole-body re-selection and cache build of the step that follows it.
    let mut call = || -> Result<Option<Duration>, CliError> {
        match (method.exact(), adaptive.as_mut()) {
            (Some(m), _) if batch.is_some() => {
                let (b, states, qdd) = batch.as_mut().expect("batch checked above");
                b.forward_dynamics(&model, black_box(states), m, qdd)?;
                black_box(qdd);
                Ok(None)
            }
            (Some(m), _) => {
                // One body: DCA split over the threads from PARALLEL_DCA_MIN_BODIES bodies.
                let qdd = forward_dynamics_threads(
                    &model,
                    &mut data,
                    black_box(&state.q),
                    black_box(&state.qd),
                    black_box(&state.tau),
                    &state.f_ext,
                    m,
                    &threads,
                )?;
                black_box(qdd);
                Ok(None)
            }
            (None, Some((ad, start, sim, calls))) => {
                // Back to the start every ADAPTIVE_RUN steps: long semi-implicit Euler runs of
                // a whipping chain diverge, even exact ones. The restart and the step after it
                // (the whole-body re-selection that builds every cache, O(n)) are not timed.
                *calls += 1;
                let restart = calls.is_multiple_of(ADAPTIVE_RUN);
                let t0 = restart.then(Instant::now);
                if restart {
                    sim.q.copy_from_slice(&start.q);
                    sim.qd.copy_from_slice(&start.qd);
                    ad.invalidate();
                }
                ad.step(&model, sim, ADAPTIVE_DT)?;
                black_box(&sim.qd);
                Ok(t0.map(|t| t.elapsed()))
            }
            (None, None) => unreachable!("adaptive workspace built for --method adaptive"),
        }
    };

    // Warm-up, which also checks that the state can be solved at all.
    let warm = Instant::now();
    let mut n_warm = 0u64;
    while n_warm < 10 || warm.elapsed() < Duration::from_millis(200) {
        call()?;
        n_warm += 1;
    }
    let estimate = warm.elapsed().as_secs_f64() / n_warm as f64;
    let reps = args
        .reps
        .unwrap_or_else(|| ((1.0 / estimate).ceil() as u64).max(100));
    let sizes = batching(reps);

    let mut us = Vec::with_capacity(sizes.len());
    for &n in &sizes {
        let (mut left_out, mut timed) = (Duration::ZERO, n);
        let t0 = Instant::now();
        for _ in 0..n {
            if let Some(t) = call()? {
                left_out += t;
                timed -= 1;
            }
        }
        let t = t0.elapsed().saturating_sub(left_out);
        if timed > 0 {
            us.push(t.as_secs_f64() * 1e6 / timed as f64);
        }
    }
    let min = us.iter().copied().fold(f64::INFINITY, f64::min);
    let max = us.iter().copied().fold(0.0, f64::max);
    let med = median(&mut us);
    let extra = match &adaptive {
        Some((ad, ..)) => format!(
            " budget={} reselect_every={} active_dofs={}",
            args.dynamics
                .budget
                .map_or("none".to_string(), |b| b.to_string()),
            every,
            ad.active_dofs(&model)
        ),
        None => String::new(),
    };
    let extra = match args.states {
        Some(n) => format!(
            "{extra} states={n} us_per_state={:.3}",
            med / n.max(1) as f64
        ),
        None => extra,
    };
    print_out(&format!(
        "model={} method={} dof={} reps={reps} batches={} us_per_call={med:.3} min_us={min:.3} max_us={max:.3} threads={}{extra}\n",
        model.name,
        method.name(),
        model.nv,
        sizes.len(),
        threads.count(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&mut [7.0]), 7.0);
    }

    #[test]
    fn batching_covers_reps() {
        assert_eq!(batching(1), vec![1]);
        assert_eq!(batching(29), vec![1; 29]);
        assert_eq!(batching(30), vec![1; 30]);
        assert_eq!(batching(3000), vec![100; 30]);
        let b = batching(100);
        assert_eq!(b.len(), 30);
        assert_eq!(b.iter().sum::<u64>(), 100);
        assert_eq!((b[0], b[29]), (4, 3));
    }
}
