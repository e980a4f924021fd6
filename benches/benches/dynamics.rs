//! Forward dynamics: DCA, ABA and CRBA on chains of 10 … 10,000 links and on the humanoid.
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

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).warm_up_time(std::time::Duration::from_millis(300)).measurement_time(std::time::Duration::from_secs(1));
    targets = chains, humanoid
}
criterion_main!(benches);
