//! Forward dynamics: DCA, ABA and CRBA on chains of 10 … 10,000 links and on the humanoid; the
//! small dense Cholesky family against faer on the sizes the solvers factor.
//! `cargo bench -p articula-benches --bench dynamics`

use articula_dca::{forward_dynamics_slices, Data, Method, State};
use articula_model::Model;
use articula_testkit::{bundled, chain};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::hint::black_box;

fn bench_model(c: &mut Criterion, group: &str, label: &str, model: &Model, methods: &[Method]) {
    let mut g = c.benchmark_group(group);
    g.throughput(Throughput::Elements(model.nv as u64));
    let state = State::random(model, 42, 1.0);
    let mut data = Data::new(model);
    for &m in methods {
        g.bench_with_input(BenchmarkId::new(m.name(), label), &m, |b, &m| {
            b.iter(|| {
                let qdd = forward_dynamics_slices(
                    model,
                    &mut data,
                    &state.q,
                    &state.qd,
                    &state.tau,
                    &[],
                    m,
                )
                .unwrap();
                black_box(qdd[0]);
            })
        });
    }
    g.finish();
}

fn chains(c: &mut Criterion) {
    for n in [10usize, 30, 100, 300, 1000, 3000, 10_000] {
        let model = chain(n);
        // CRBA's dense n×n Cholesky is O(n³): only up to 1000 links.
        let methods: &[Method] = if n <= 1000 {
            &[Method::Dca, Method::Aba, Method::Crba]
        } else {
            &[Method::Dca, Method::Aba]
        };
        bench_model(c, "chain", &n.to_string(), &model, methods);
    }
}

fn humanoid(c: &mut Criterion) {
    let model = bundled("humanoid");
    bench_model(
        c,
        "humanoid",
        "34dof",
        &model,
        &[Method::Dca, Method::Aba, Method::Crba],
    );
}

/// A row-major symmetric positive definite `n × n`: `B Bᵀ + n 1` for a fixed `B`.
fn spd(n: usize) -> Vec<f64> {
    let b = |i: usize, j: usize| ((i * 7 + j * 3) % 11) as f64 / 5.0 - 1.0;
    let mut a = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            a[i * n + j] = (0..n).map(|p| b(i, p) * b(j, p)).sum::<f64>()
                + if i == j { n as f64 } else { 0.0 };
        }
    }
    a
}

/// Factor and solve `A x = b`: the family's `cholesky_rows` (the contact solvers' systems,
/// MJCF spring-dampers) against faer's `llt` (CRBA's mass matrix) for `n` from a joint block
/// to a contact system; and on 6×6 blocks `cholesky_inv_diag` with its two triangular solves
/// (DCA's joins) and `invert_spd_into` (joint-space inverses).
fn cholesky(c: &mut Criterion) {
    use articula_spatial::numerics::{
        cholesky_inv_diag, cholesky_rows, cholesky_rows_solve, invert_spd_into,
        solve_lower_inv_diag, solve_lower_t_inv_diag,
    };
    use faer::prelude::*;
    let mut g = c.benchmark_group("cholesky");
    for n in [6usize, 12, 24, 48, 96] {
        let a = spd(n);
        let rhs: Vec<f64> = (0..n).map(|i| 1.0 - 0.1 * i as f64).collect();
        g.bench_with_input(BenchmarkId::new("cholesky_rows", n), &n, |bch, &n| {
            let (mut l, mut x) = (a.clone(), rhs.clone());
            bch.iter(|| {
                l.copy_from_slice(black_box(&a));
                x.copy_from_slice(&rhs);
                assert!(cholesky_rows(&mut l, n));
                cholesky_rows_solve(&l, n, &mut x);
                black_box(x[0])
            })
        });
        let m = faer::Mat::<f64>::from_fn(n, n, |i, j| a[i * n + j]);
        g.bench_with_input(BenchmarkId::new("faer_llt", n), &n, |bch, &n| {
            bch.iter(|| {
                let llt = black_box(&m).llt(faer::Side::Lower).unwrap();
                let mut x = faer::Mat::<f64>::from_fn(n, 1, |i, _| rhs[i]);
                llt.solve_in_place(&mut x);
                black_box(x[(0, 0)])
            })
        });
    }
    let a6: [[f64; 6]; 6] = {
        let a = spd(6);
        std::array::from_fn(|i| std::array::from_fn(|j| a[i * 6 + j]))
    };
    let b6 = [1.0, -0.5, 0.25, 2.0, -1.0, 0.5];
    g.bench_function("cholesky_inv_diag_solve/6", |bch| {
        bch.iter(|| {
            let l = cholesky_inv_diag(black_box(&a6), 6).unwrap();
            black_box(solve_lower_t_inv_diag(&l, &solve_lower_inv_diag(&l, &b6)))
        })
    });
    g.bench_function("invert_spd_into/6", |bch| {
        let mut inv = [[0.0; 6]; 6];
        bch.iter(|| {
            assert!(invert_spd_into(black_box(&a6), 6, &mut inv));
            black_box(inv[0][0])
        })
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).warm_up_time(std::time::Duration::from_millis(300)).measurement_time(std::time::Duration::from_secs(1));
    targets = chains, humanoid, cholesky
}
criterion_main!(benches);
