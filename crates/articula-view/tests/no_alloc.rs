//! A scene step on one thread allocates nothing once its buffers have grown: the bundled
//! crowd200 scene (pushes, re-selections every 10 steps, bodies changing their hybrid bodies)
//! stepped with the system allocator counting, in zero gravity without its floor (bodies turning rigid and
//! back), and on its floor, where a step allocates only when some body meets more candidate
//! contact points or rows than at any step before (its contact workspace grows to them).

use articula_dca::Threads;
use articula_testkit::{count_allocations, CountingAllocator};
use articula_view::{load_scene, LoadedScene, SceneSim};
use std::path::Path;

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

fn crowd200() -> LoadedScene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/scenes/crowd200.json");
    load_scene(path).unwrap()
}

/// Steps before the counted ones: the first whole-body selection, re-selections, and the
/// crowd landing on its floor and settling (most contact workspaces reach their size).
const WARM_UP: usize = 150;

/// Per step after the warm-up, `steps` steps: the allocations, and whether some body met
/// more candidates or contact rows than ever before.
fn count(scene: &LoadedScene, steps: usize) -> (Vec<usize>, Vec<bool>, usize) {
    let mut sim = SceneSim::new(scene).unwrap();
    // One thread: with several, each thread's buffers grow to the largest body it has met,
    // and which bodies a thread meets depends on the scheduling.
    sim.set_threads(Threads::serial());
    // Per body: the most candidate spheres and rows met so far.
    let mut most = vec![(0, 0); sim.bodies.len()];
    let rows = |sim: &SceneSim, most: &mut [(usize, usize)]| {
        let mut grew = false;
        for (m, b) in most.iter_mut().zip(&sim.bodies) {
            if let Some(c) = &b.contact {
                let s = &c.contact.stats;
                grew |= s.candidates > m.0 || s.rows > m.1;
                *m = (m.0.max(s.candidates), m.1.max(s.rows));
            }
        }
        grew
    };
    // Warm-up: the first whole-body selection and a few re-selections size every buffer (the
    // counter counts them).
    let warm = count_allocations(|| {
        for _ in 0..WARM_UP {
            sim.step().unwrap();
        }
    });
    assert!(warm > 0, "the warm-up allocates");
    rows(&sim, &mut most);
    let (mut per_step, mut grew) = (Vec::new(), Vec::new());
    let mut reselections = 0;
    for _ in 0..steps {
        let mut reselected = false;
        per_step.push(count_allocations(|| {
            reselected = sim.step().unwrap().reselected;
        }));
        grew.push(rows(&sim, &mut most));
        reselections += usize::from(reselected);
    }
    (per_step, grew, reselections)
}

#[test]
fn scene_steps_allocate_nothing_after_warm_up() {
    let mut scene = crowd200();
    scene.gravity = glam::DVec3::ZERO;
    scene.ground = None;
    let (per_step, _, reselections) = count(&scene, 120);
    assert!(reselections >= 5, "the window must hold re-selections");
    assert!(
        per_step.iter().all(|&n| n == 0),
        "allocations per step: {per_step:?}"
    );
}

#[test]
fn floor_steps_allocate_only_when_contact_rows_grow() {
    // How many of the steps meet a body's new largest row count depends on the crowd's last
    // bits (23 of the first 60 were quiet, 73 of 120, in one build).
    let (per_step, grew, reselections) = count(&crowd200(), 120);
    assert!(reselections >= 5, "the window must hold re-selections");
    let quiet = per_step.iter().zip(&grew).filter(|(_, g)| !**g).count();
    assert!(quiet >= 30, "{quiet} steps without new rows");
    assert!(
        per_step.iter().zip(&grew).all(|(&n, &g)| n == 0 || g),
        "allocations per step: {per_step:?}, rows grew: {grew:?}"
    );
}
