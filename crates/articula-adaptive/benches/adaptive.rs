//! Adaptive dynamics on the 300-link chain: the seeds' table (budget × external forces) and
//! the step time against chain length at a fixed budget.
//! `cargo bench -p articula-adaptive --bench adaptive`
//!
//! Every benchmark times steps the same way ([`timed_steps`]: runs restarted every [`RUN`]
//! steps, the restart and the step after it untimed), full DCA included, and builds its
//! workspace on its first call, so a filtered run sets up only what it measures. Criterion
//! runs one benchmark after another: a ratio of two of its figures (DCA against an adaptive
//! budget) carries the machine's drift between them — on the shared 2-core host, up to
//! 1.5× from one minute to the next. `cargo xtask speedup seeds` times the same steps
//! interleaved in one process, for the ratio.

// `criterion_group!` makes a public function without documentation.
#![allow(missing_docs)]

use articula_adaptive::{Adaptive, Reselection, Settings};
use articula_dca::{step, Data, Integrator, Method, State};
use articula_testkit::chain;
use articula_testkit::seeds::{force_list, seeded_state};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;
use std::time::{Duration, Instant};

/// Steps after which a run restarts from its initial state (0.1 s at dt = 1e-4): long
/// semi-implicit Euler runs of a whipping chain diverge, even exact ones.
const RUN: u64 = 1000;

/// Times `iters` adaptive steps of a run that restarts every [`RUN`] steps. The restart and
/// the step right after it — a whole-body re-selection that rebuilds every cache of the rigid
/// subassemblies, O(n) — are left out of the timing (`iter_custom`): the figures are the
/// steady-state cost of a step, selection included.
/// `call(true)` restarts the run, `call(false)` steps it.
fn timed_steps(iters: u64, calls: &mut u64, mut call: impl FnMut(bool)) -> Duration {
    let mut total = Duration::ZERO;
    let mut t = Instant::now();
    for _ in 0..iters {
        *calls += 1;
        if calls.is_multiple_of(RUN) {
            total += t.elapsed();
            call(true);
            call(false);
            t = Instant::now();
        }
        call(false);
    }
    total + t.elapsed()
}

fn seeds_table(c: &mut Criterion) {
    let model = chain(300);
    let mut g = c.benchmark_group("adaptive_seeds_table");
    for forces in [1usize, 5, 10, 20, 50, 250] {
        let s0 = seeded_state(&model, forces);
        let mut dca = None;
        let mut calls = 0u64;
        g.bench_with_input(
            BenchmarkId::new("dca", format!("f{forces}")),
            &(),
            |b, _| {
                let (data, s) = dca.get_or_insert_with(|| (Data::new(&model), s0.clone()));
                b.iter_custom(|iters| {
                    timed_steps(iters, &mut calls, |restart| {
                        if restart {
                            s.clone_from(&s0);
                        } else {
                            step(
                                &model,
                                data,
                                s,
                                Method::Dca,
                                Integrator::SemiImplicitEuler,
                                1e-4,
                            )
                            .unwrap();
                            black_box(s.qd[0]);
                        }
                    })
                })
            },
        );
        // The adaptive runs take the forces as a list (no O(n) scan of a dense one).
        let list = force_list(&s0.f_ext);
        let mut a0 = s0.clone();
        a0.f_ext.clear();
        for budget in [1usize, 50, 100, 150, 200, 250, 300] {
            // Re-selection every step (the selection is in every timed step) and every tenth.
            for period in [1u64, 10] {
                let settings = Settings {
                    budget: Some(budget),
                    reselect_every: period,
                    ..Settings::default()
                };
                let mut run = None;
                let mut calls = 0u64;
                let name = if period == 1 {
                    format!("budget{budget}")
                } else {
                    format!("budget{budget}_every{period}")
                };
                g.bench_with_input(BenchmarkId::new(name, format!("f{forces}")), &(), |b, _| {
                    let (ad, s) = run.get_or_insert_with(|| {
                        // The first step (a whole-body re-selection building every cache)
                        // outside the timing, as after each restart.
                        let mut ad = Adaptive::new(&model, settings.clone());
                        ad.set_reselection(Reselection::Caches);
                        let mut s = a0.clone();
                        ad.step_with_forces(&model, &mut s, 1e-4, &list).unwrap();
                        calls = 1;
                        (ad, s)
                    });
                    b.iter_custom(|iters| {
                        timed_steps(iters, &mut calls, |restart| {
                            if restart {
                                s.q.copy_from_slice(&a0.q);
                                s.qd.copy_from_slice(&a0.qd);
                                ad.invalidate();
                            } else {
                                ad.step_with_forces(&model, s, 1e-4, &list).unwrap();
                                black_box(s.qd[0]);
                            }
                        })
                    })
                });
            }
        }
    }
    g.finish();
}

fn scaling(c: &mut Criterion) {
    // Step time at budget 50 against chain length: between re-selections (the hierarchical
    // state), and with a re-selection through the caches every step and every tenth step. One
    // whole-body re-selection (building every cache) first, outside the timing; the crumpled
    // chain starts at rest under gravity.
    let mut g = c.benchmark_group("adaptive_scaling_budget50");
    for n in [1000usize, 10_000, 100_000] {
        let mut model = None;
        for (name, period, check) in [
            ("between_reselections", u64::MAX, true),
            ("reselect_every1", 1, true),
            ("reselect_every1_no_tau_check", 1, false),
            ("reselect_every10", 10, true),
        ] {
            let mut run = None;
            let mut calls = 0u64;
            g.bench_with_input(BenchmarkId::new(name, n), &(), |b, _| {
                let model = model.get_or_insert_with(|| chain(n));
                let (ad, s0, s) = run.get_or_insert_with(|| {
                    let mut ad = Adaptive::new(
                        model,
                        Settings {
                            budget: Some(50),
                            reselect_every: period,
                            ..Settings::default()
                        },
                    );
                    ad.set_check_locked_torques(check);
                    ad.set_reselection(Reselection::Caches);
                    let mut s0 = State::random(model, 42, 0.0);
                    s0.qd.fill(0.0);
                    s0.f_ext.clear();
                    let mut s = s0.clone();
                    ad.step(model, &mut s, 1e-4).unwrap();
                    (ad, s0, s)
                });
                // The falling chain also diverges after some thousand steps: restarts as in
                // the seeds table, left out of the timing.
                b.iter_custom(|iters| {
                    timed_steps(iters, &mut calls, |restart| {
                        if restart {
                            s.q.copy_from_slice(&s0.q);
                            s.qd.copy_from_slice(&s0.qd);
                            ad.invalidate();
                        } else {
                            ad.step(model, s, 1e-4).unwrap();
                            black_box(s.qd[0]);
                        }
                    })
                })
            });
        }
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10).warm_up_time(std::time::Duration::from_millis(200)).measurement_time(std::time::Duration::from_millis(600));
    targets = seeds_table, scaling
}
criterion_main!(benches);
