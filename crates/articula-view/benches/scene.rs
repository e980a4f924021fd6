//! Scene benchmarks (docs/design.md#view):
//! - `crowd200/adaptive_step`: one step of the bundled crowd200 scene (200 humanoids, budget
//!   2,000 internal joints, re-selection every 10 steps amortised), against
//!   `crowd200/exact_dca_step`: one step of the same scene's exact reference
//!   (`SceneMethod::Exact`: DCA on every body, the same springs, pushes and integrator).
//! - `crowd2000/adaptive_step`: 2,000 humanoids (40 rows × 50 columns), budget 4,000.
//!
//! `cargo bench -p articula-view --bench scene` (add `-- --quick` for a short run).

// `criterion_group!` makes a public function without documentation.
#![allow(missing_docs)]

use articula_dca::{Method, Threads};
use articula_view::{load_scene, SceneMethod, SceneOptions, SceneSim};
use criterion::{criterion_group, criterion_main, Criterion};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn models() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

/// Time of `iters` scene steps by `method` (adaptive: re-selections included), on runs restarted every 500 steps (the
/// bundled crowd is stable for about 2 s of simulated time: see docs/view.md). Restarting is
/// not timed.
fn timed_steps(scene: &articula_view::LoadedScene, method: SceneMethod, iters: u64) -> Duration {
    let mut total = Duration::ZERO;
    let mut done = 0;
    while done < iters {
        let mut sim = SceneSim::new(scene).unwrap();
        // One thread, for both methods.
        sim.set_threads(Threads::serial());
        sim.set_method(method);
        let n = (iters - done).min(500);
        let t = Instant::now();
        for _ in 0..n {
            sim.step().unwrap();
        }
        total += t.elapsed();
        done += n;
    }
    total
}

fn crowd200(c: &mut Criterion) {
    let scene = load_scene(models().join("scenes/crowd200.json")).unwrap();
    let mut g = c.benchmark_group("crowd200");
    g.sample_size(10).measurement_time(Duration::from_secs(8));
    g.bench_function("adaptive_step", |b| {
        b.iter_custom(|iters| timed_steps(&scene, SceneMethod::Adaptive, iters))
    });
    g.bench_function("exact_dca_step", |b| {
        b.iter_custom(|iters| timed_steps(&scene, SceneMethod::Exact(Method::Dca), iters))
    });
    g.finish();
}

/// 2,000 humanoids: the crowd200 scene's settings on a 40 × 50 grid.
pub fn crowd2000_text() -> String {
    let mut v: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(models().join("scenes/crowd200.json")).unwrap(),
    )
    .unwrap();
    v["crowds"][0]["rows"] = 40.into();
    v["crowds"][0]["columns"] = 50.into();
    v["crowds"][0]["origin"] = serde_json::json!([4.0, -22.05, 1.021]);
    v["budget"] = 4000.into();
    v["models"]["humanoid"] = models().join("humanoid.urdf").display().to_string().into();
    v.to_string()
}

fn crowd2000(c: &mut Criterion) {
    let scene = SceneOptions::default()
        .parse(&crowd2000_text(), Path::new("crowd2000.json"), &models())
        .unwrap();
    assert_eq!(scene.placements.len(), 2000);
    let mut g = c.benchmark_group("crowd2000");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("adaptive_step", |b| {
        b.iter_custom(|iters| timed_steps(&scene, SceneMethod::Adaptive, iters))
    });
    g.finish();
}

criterion_group!(benches, crowd200, crowd2000);
criterion_main!(benches);
