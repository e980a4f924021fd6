//! What the energy guard costs a scene: one step of the bundled crowd (200 humanoids, adaptive,
//! with its floor) against one evaluation of the scene's energy, the check `articula scene`
//! runs after every step. `cargo bench -p articula-benches --bench scene`

use articula_view::{load_scene, SceneSim};
use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::path::Path;

fn crowd(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/scenes/crowd200.json");
    let scene = load_scene(&path).expect("the bundled crowd loads");
    let mut sim = SceneSim::new(&scene).expect("the bundled crowd starts");
    // Past the first re-selections, so the steps measured are typical ones.
    for _ in 0..20 {
        sim.step().expect("the crowd steps");
    }
    let mut g = c.benchmark_group("crowd200");
    g.sample_size(20);
    g.bench_function("step", |b| {
        b.iter(|| black_box(sim.step().expect("the crowd steps")))
    });
    g.bench_function("energy", |b| b.iter(|| black_box(sim.energy().total())));
    g.finish();
}

criterion_group!(benches, crowd);
criterion_main!(benches);
