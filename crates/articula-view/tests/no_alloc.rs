//! A scene step allocates nothing once its buffers have grown: the bundled crowd200 scene
//! (pushes, re-selections every 10 steps, bodies changing their hybrid bodies and turning
//! rigid) stepped with the system allocator counting.

use articula_testkit::{count_allocations, CountingAllocator};
use articula_view::{load_scene, SceneSim};
use std::path::Path;

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

#[test]
fn scene_steps_allocate_nothing_after_warm_up() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/scenes/crowd200.json");
    let scene = load_scene(path).unwrap();
    let mut sim = SceneSim::new(&scene).unwrap();
    // Warm-up: the first whole-body selection and a few re-selections size every buffer (the
    // counter counts them).
    let warm = count_allocations(|| {
        for _ in 0..60 {
            sim.step().unwrap();
        }
    });
    assert!(warm > 0, "the warm-up allocates");
    let mut per_step = Vec::new();
    let mut reselections = 0;
    for _ in 0..60 {
        let mut reselected = false;
        per_step.push(count_allocations(|| {
            reselected = sim.step().unwrap().reselected;
        }));
        reselections += usize::from(reselected);
    }
    assert!(reselections >= 5, "the window must hold re-selections");
    assert!(
        per_step.iter().all(|&n| n == 0),
        "allocations per step: {per_step:?}"
    );
}
