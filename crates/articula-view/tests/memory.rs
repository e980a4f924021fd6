//! The scene memory estimate against the heap a scene really takes (a byte-counting global
//! allocator): per body, built and stepped.

use articula_model::{LoadOptions, Model};
use articula_view::{BodySpec, CameraSpec, CrowdSpec, SceneBuilder, SceneSim};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicIsize, Ordering};

/// The system allocator, keeping the bytes live (allocated and not yet freed).
struct Live;
static LIVE: AtomicIsize = AtomicIsize::new(0);

// SAFETY: every call forwards to `System` with the caller's arguments; the counter is atomic.
unsafe impl GlobalAlloc for Live {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        LIVE.fetch_add(l.size() as isize, Ordering::Relaxed);
        unsafe { System.alloc(l) }
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        LIVE.fetch_add(l.size() as isize, Ordering::Relaxed);
        unsafe { System.alloc_zeroed(l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        LIVE.fetch_add(n as isize - l.size() as isize, Ordering::Relaxed);
        unsafe { System.realloc(p, l, n) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        LIVE.fetch_sub(l.size() as isize, Ordering::Relaxed);
        unsafe { System.dealloc(p, l) }
    }
}

#[global_allocator]
static ALLOCATOR: Live = Live;

fn floating(urdf: &str) -> Model {
    Model::from_urdf_str(urdf, &LoadOptions::default().with_floating_base(true)).unwrap()
}

/// Live heap bytes of a loaded scene of `n` bodies of `model` after one step.
fn scene_bytes(model: &Model, n: usize) -> isize {
    let before = LIVE.load(Ordering::Relaxed);
    let scene = SceneBuilder::new()
        .model("m", model.clone())
        .crowd(CrowdSpec {
            origin: [10.0, 0.0, 1.0],
            ..CrowdSpec::new("m", 1, n)
        })
        .body(BodySpec::new("m", [5.0, 0.0, 1.0]))
        .camera(CameraSpec::look_at([0.0, 0.0, 1.0], [10.0, 0.0, 1.0]))
        .build()
        .unwrap();
    let mut sim = SceneSim::new(&scene).unwrap();
    sim.step().unwrap();
    let after = LIVE.load(Ordering::Relaxed);
    drop(sim);
    drop(scene);
    after - before
}

fn star_urdf(children: usize) -> String {
    let mut s = String::from("<robot name=\"star\">\n");
    let inertial = |m: f64| {
        format!("<inertial><mass value=\"{m}\"/><inertia ixx=\"0.01\" iyy=\"0.01\" izz=\"0.01\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial>")
    };
    s += &format!("<link name=\"hub\">{}</link>\n", inertial(5.0));
    for i in 0..children {
        s += &format!("<link name=\"c{i}\">{}</link>\n", inertial(0.1));
        s += &format!("<joint name=\"j{i}\" type=\"revolute\"><parent link=\"hub\"/><child link=\"c{i}\"/><origin xyz=\"0.1 0 {}\"/><axis xyz=\"0 1 0\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint>\n", i as f64 * 0.01);
    }
    s + "</robot>\n"
}

/// Per body, the estimate is at least the heap a scene body takes (measured as the difference
/// between scenes of 7 and 3 bodies: models and shared buffers cancel) and at most three
/// times it, on a humanoid, chains and a hub with as many children as adaptive dynamics takes
/// (`GATHER_ABOVE`; more give a gather node, which scenes refuse).
#[test]
fn the_scene_memory_estimate_bounds_what_a_body_takes() {
    let models = [
        ("humanoid", articula_testkit::bundled_with("humanoid", true)),
        ("chain 10", floating(&articula_testkit::chain_urdf(10))),
        ("chain 200", floating(&articula_testkit::chain_urdf(200))),
        ("hub 16", floating(&star_urdf(articula_model::GATHER_ABOVE))),
    ];
    let mut wrong = Vec::new();
    for (name, model) in &models {
        let per_body = (scene_bytes(model, 6) - scene_bytes(model, 2)) as f64 / 4.0;
        let estimate = articula_view::body_memory_estimate(model) as f64;
        let nodes = &model.assembly.nodes;
        let sh: usize = nodes.iter().map(|n| n.handles.len()).sum();
        let sh2: usize = nodes.iter().map(|n| n.handles.len().pow(2)).sum();
        eprintln!(
            "{name}: measured {per_body:.0} B per body, estimate {estimate:.0} \
             (bodies {}, nv {}, nodes {}, Σh {sh}, Σh² {sh2})",
            model.bodies.len(),
            model.nv,
            nodes.len()
        );
        if !(per_body <= estimate && estimate <= 3.0 * per_body) {
            wrong.push(format!("{name}: estimate {estimate}, measured {per_body}"));
        }
    }
    assert!(wrong.is_empty(), "{wrong:?}");
}
