//! Adaptive dynamics on the 300-link chain: the seeds' table (budget × external forces) and
//! the step time against chain length at a fixed budget.
//! `cargo bench -p articula-adaptive --bench adaptive`

use articula_adaptive::{Adaptive, Settings};
use articula_benches::chain;
use articula_dca::{step, Data, Integrator, Method, State};
use articula_model::Model;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;

/// The seeds' state: a random configuration at rest with `forces` external forces on evenly
/// spread bodies.
fn seeded_state(model: &Model, forces: usize) -> State {
    let mut s = State::random(model, 42, 0.0);
    s.qd.fill(0.0);
    let data = {
        let mut d = Data::new(model);
        articula_dca::forward_kinematics(model, &s.q, &s.qd, &mut d);
        d
    };
    let n = model.bodies.len();
    for k in 0..forces.min(n) {
        let body = (k * n) / forces.min(n);
        let dir = glam::DVec3::new(1.0, (k as f64).sin(), (k as f64).cos());
        s.f_ext[body] = data.point_force(body, glam::DVec3::ZERO, dir);
    }
    s
}

/// Back to the start every 1000 steps (0.1 s): long semi-implicit Euler runs of a whipping
/// chain diverge, even exact ones.
fn restart(calls: &mut u64, s: &mut State, s0: &State, ad: &mut Adaptive) {
    *calls += 1;
    if calls.is_multiple_of(1000) {
        s.q.copy_from_slice(&s0.q);
        s.qd.copy_from_slice(&s0.qd);
        ad.invalidate();
    }
}

fn seeds_table(c: &mut Criterion) {
    let model = chain(300);
    let mut g = c.benchmark_group("adaptive_seeds_table");
    for forces in [1usize, 5, 10, 20, 50, 250] {
        let s0 = seeded_state(&model, forces);
        let mut data = Data::new(&model);
        let mut s = s0.clone();
        let mut calls = 0u64;
        g.bench_with_input(
            BenchmarkId::new("dca", format!("f{forces}")),
            &(),
            |b, _| {
                b.iter(|| {
                    calls += 1;
                    if calls.is_multiple_of(1000) {
                        s.clone_from(&s0);
                    }
                    step(
                        &model,
                        &mut data,
                        &mut s,
                        Method::Dca,
                        Integrator::SemiImplicitEuler,
                        1e-4,
                    )
                    .unwrap();
                    black_box(s.qd[0]);
                })
            },
        );
        for budget in [1usize, 50, 100, 150, 200, 250, 300] {
            let mut ad = Adaptive::new(
                &model,
                Settings {
                    budget: Some(budget),
                    ..Settings::default()
                },
            );
            let mut s = s0.clone();
            let mut calls = 0u64;
            g.bench_with_input(
                BenchmarkId::new(format!("budget{budget}"), format!("f{forces}")),
                &(),
                |b, _| {
                    b.iter(|| {
                        restart(&mut calls, &mut s, &s0, &mut ad);
                        ad.step(&model, &mut s, 1e-4).unwrap();
                        black_box(s.qd[0]);
                    })
                },
            );
        }
    }
    g.finish();
}

fn scaling(c: &mut Criterion) {
    // Between re-selections (the hierarchical state): the step time at budget 50 should not
    // grow with the chain. One re-selection first, outside the timing; a crumpled chain at rest
    // under gravity does not diverge within the measured time.
    let mut g = c.benchmark_group("adaptive_scaling_budget50");
    for n in [1000usize, 10_000, 100_000] {
        let model = chain(n);
        let mut ad = Adaptive::new(
            &model,
            Settings {
                budget: Some(50),
                reselect_every: u64::MAX,
                ..Settings::default()
            },
        );
        let mut s = State::random(&model, 42, 0.0);
        s.qd.fill(0.0);
        s.f_ext.clear();
        ad.step(&model, &mut s, 1e-4).unwrap();
        g.bench_with_input(BenchmarkId::new("between_reselections", n), &(), |b, _| {
            b.iter(|| {
                ad.step(&model, &mut s, 1e-4).unwrap();
                black_box(s.qd[0]);
            })
        });
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10).warm_up_time(std::time::Duration::from_millis(200)).measurement_time(std::time::Duration::from_millis(600));
    targets = seeds_table, scaling
}
criterion_main!(benches);
