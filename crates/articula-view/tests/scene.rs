//! The view-dependent scene: bodies entering the view regain joints, occluded bodies get fewer
//! joints, and a snapshot of the bundled crowd (the scene's internals are tested in
//! `src/sim/tests.rs`).

use articula_view::{LoadedScene, SceneOptions, SceneSim, Visibility};
use glam::DVec3;
use std::path::{Path, PathBuf};

fn models() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

fn scene(text: &str) -> LoadedScene {
    SceneOptions::default()
        .parse(text, Path::new("test.json"), &models())
        .unwrap()
}

/// A folder with a floating "wall" model (one box).
fn wall_urdf() -> PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("articula-view-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("wall.urdf");
    std::fs::write(
        &path,
        r#"<robot name="wall"><link name="wall"><inertial><mass value="100"/>
        <inertia ixx="150" ixy="0" ixz="0" iyy="80" iyz="0" izz="80"/></inertial>
        <collision><geometry><box size="0.2 4 4"/></geometry></collision></link></robot>"#,
    )
    .unwrap();
    path
}

// ---------------------------------------------------------------------------------------------
// 1. Entering the view: joints come back within one re-selection.

#[test]
fn a_body_entering_the_view_regains_joints_within_one_reselection() {
    // Camera along +x, 60° vertical at 16:9 (horizontal half angle ≈ 45.7°). The body starts
    // 6 m left of the view's left edge at x = 8 and walks right at 6 m/s, spinning (so that its
    // joints have something to do once free).
    let s = scene(
        r#"{"models": {"h": "humanoid.urdf"},
            "bodies": [{"model": "h", "position": [8, 14.2, 1.0],
                        "velocity": {"linear": [0, -6, 0], "angular": [0, 0, 3]}}],
            "camera": {"eye": [0, 0, 1.0], "target": [10, 0, 1.0], "fov_y_deg": 60},
            "image": {"width": 640, "height": 360},
            "budget": 20, "dt": 0.004, "reselect_every": 10, "gravity": [0, 0, 0]}"#,
    );
    let cam = s.camera.at(0.0);
    let mut sim = SceneSim::new(&s).unwrap();
    let mut entered = None;
    let mut first_after = None;
    for k in 0..400u64 {
        // In the image (independently of the classifier): the root origin projects inside.
        let q = &sim.bodies[0].state.q;
        let root = DVec3::new(q[0], q[1], q[2]);
        let inside = cam
            .project(root)
            .is_some_and(|(uv, _)| uv.x.abs() <= 1.0 && uv.y.abs() <= 1.0);
        if k == 0 {
            assert!(!inside);
        }
        if inside && entered.is_none() {
            entered = Some(k);
        }
        let step = sim.step().unwrap();
        if k < 20 {
            assert_eq!(step.active_total, 0, "far outside at step {k}");
        }
        if let Some(e) = entered {
            // The first re-selection at or after entering.
            if step.reselected && k >= e && first_after.is_none() {
                first_after = Some(k);
                assert!(
                    step.active_total > 0,
                    "re-selection at step {k} (entered at {e}) gave no joint"
                );
            }
            if first_after.is_some() && inside {
                assert!(step.active_total > 0, "in view at step {k} without joints");
            }
        }
    }
    let (e, f) = (
        entered.expect("the body enters the view"),
        first_after.unwrap(),
    );
    assert!(f < e + 10, "re-selected at {f}, entered at {e}");
}

// ---------------------------------------------------------------------------------------------
// 2. Occlusion: fewer joints behind a wall than in the open at the same distance.

#[test]
fn an_occluded_body_gets_fewer_joints_than_a_visible_one() {
    let wall = wall_urdf();
    let text = format!(
        r#"{{"models": {{"h": "humanoid.urdf", "wall": "{}"}},
            "bodies": [
              {{"name": "hidden", "model": "h", "position": [9, -2.5, 1.0], "velocity": {{"angular": [0, 0, 2]}}}},
              {{"name": "open", "model": "h", "position": [9, 2.5, 1.0], "velocity": {{"angular": [0, 0, 2]}}}},
              {{"name": "wall", "model": "wall", "position": [4, -1.2, 1.0]}}],
            "camera": {{"eye": [0, 0, 1.0], "target": [10, 0, 1.0]}},
            "budget": 30, "dt": 0.002, "gravity": [0, 0, 0]}}"#,
        wall.display()
    );
    let s = scene(&text);
    let mut sim = SceneSim::new(&s).unwrap();
    sim.step().unwrap();
    assert_eq!(
        sim.views[0].summary(),
        Visibility::Occluded,
        "{:?}",
        sim.views[0].links
    );
    assert_eq!(sim.views[1].summary(), Visibility::Visible);
    assert_eq!(sim.views[2].summary(), Visibility::Visible);
    // Same distance from the eye, mirrored: the same projected size.
    assert!((sim.views[0].projected_size - sim.views[1].projected_size).abs() < 1e-9);
    let (hidden, open) = (sim.bodies[0].active, sim.bodies[1].active);
    assert!(hidden < open, "hidden {hidden}, open {open}");
    assert!(open > 0);
    // The hidden body's weights are the open one's times the occluded factor.
    for (h, o) in sim.views[0]
        .joint_weights
        .iter()
        .zip(&sim.views[1].joint_weights)
    {
        assert!((h - o * s.visibility.occluded_factor).abs() < 1e-12);
    }
}

// ---------------------------------------------------------------------------------------------
// 3. Snapshot of the bundled crowd's first re-selections.

#[test]
fn crowd200_active_joints_snapshot() {
    let s = articula_view::load_scene(models().join("scenes/crowd200.json")).unwrap();
    assert_eq!(s.placements.len(), 200);
    let mut sim = SceneSim::new(&s).unwrap();
    let mut out = String::new();
    for k in 0..(2 * s.reselect_every as u64 + 1) {
        let step = sim.step().unwrap();
        if step.reselected {
            assert!(step.active_total <= s.budget.unwrap());
            // Every body simulates exactly its share of the global queue, whether it
            // re-selected or kept its hybrid body.
            for b in &sim.bodies {
                assert_eq!(b.active, b.allocation);
            }
            out.push_str(&format!(
                "step {k}: active {} visible {} occluded {} invisible {}\n",
                step.active_total, step.classes[0], step.classes[1], step.classes[2]
            ));
            for row in sim.bodies.chunks(20) {
                let line: Vec<String> = row.iter().map(|b| format!("{:2}", b.active)).collect();
                out.push_str(&line.join(" "));
                out.push('\n');
            }
        }
    }
    insta::assert_snapshot!(out);
}

// ---------------------------------------------------------------------------------------------
// 4. The bundled crowd stays finite and away from gimbal lock.

/// The bundled crowd in zero gravity and without its floor (so without joint limits) for
/// 2,000 steps (past step 1,448, where a shoulder used to reach gimbal lock and the run
/// diverged): every state finite, every composed joint of every character well away from
/// gimbal lock (its axes span more than 0.5, a middle angle within 60°), and the scene's
/// energy never above its start plus the pushes' work by more than 1% of that work (pose
/// springs' damping and the rigidification only remove energy).
#[test]
fn crowd200_stays_finite_and_away_from_gimbal_lock() {
    let mut s = articula_view::load_scene(models().join("scenes/crowd200.json")).unwrap();
    s.gravity = DVec3::ZERO;
    s.ground = None;
    let mut sim = SceneSim::new(&s).unwrap();
    let e0 = sim.energy();
    let mut min_volume = f64::INFINITY;
    for k in 0..STEPS {
        sim.step().unwrap();
        if k % 50 == 49 {
            for b in &sim.bodies {
                let model = &s.models[b.model].model;
                assert!(b.state.q.iter().chain(&b.state.qd).all(|x| x.is_finite()));
                for body in &model.bodies {
                    if let Some(v) = body.euler_axes_volume(&b.state.q) {
                        min_volume = min_volume.min(v);
                    }
                }
            }
            let e = sim.energy();
            let growth = e.total() - e0.total() - e.push_work;
            assert!(growth <= 0.01 * e.push_work, "step {k}: {growth} J, {e:?}");
        }
    }
    assert!(min_volume > 0.5, "{min_volume}");
}

/// Steps of [`crowd200_stays_finite_and_away_from_gimbal_lock`].
const STEPS: usize = 2_000;

// ---------------------------------------------------------------------------------------------
// 5. On the floor: characters stand on their pose springs, the strongly pushed fall.

/// The bundled crowd's settings (gravity, floor, 2 Hz pose springs, dt = 1/600 s, 10 joints
/// a character) on a 3 × 4 grid for 1.2 s: every character gets the light push (30 N at the
/// chest for 0.5 s), four also the strong one (120 N). Every lightly pushed character stays
/// on its feet (pelvis above 0.95 m at every step: it stands 1.02 m high), every strongly
/// pushed one falls (pelvis below 0.5 m at the end), nothing sinks more than 5 mm into the
/// floor, and the scene's energy never exceeds its start plus the pushes' work (contact
/// impulses, the position correction and the springs' damping only remove energy).
#[test]
fn the_crowd_stands_and_the_strongly_pushed_fall() {
    let strong = ["crowd[0,0]", "crowd[0,3]", "crowd[1,1]", "crowd[2,2]"];
    let text = format!(
        r#"{{"models": {{"humanoid": "humanoid.urdf"}},
            "crowds": [{{"name": "crowd", "model": "humanoid", "rows": 3, "columns": 4,
                         "origin": [4.0, -1.35, 1.021], "spacing": [1.2, 0.9], "jitter": 0.3,
                         "seed": 2005, "yaw": 3.141592653589793, "yaw_jitter": 0.6}}],
            "camera": {{"eye": [0, 0, 1.4], "target": [12, 0, 1.1]}},
            "budget": 120, "dt": 0.0016666666666666668, "reselect_every": 10,
            "pushes": [
              {{"bodies": "all", "link": "chest", "point": [0, 0, 0.2], "force": [30, 0, 0], "t0": 0, "t1": 0.5}},
              {{"bodies": {strong:?}, "link": "chest", "point": [0, 0, 0.2], "force": [120, 0, 0], "t0": 0, "t1": 0.5}}],
            "joint_springs": {{"frequency_hz": 2.0, "damping_ratio": 0.2}},
            "ground": {{"height": 0, "friction": 1}}}}"#
    );
    let s = scene(&text);
    let mut sim = SceneSim::new(&s).unwrap();
    let e0 = sim.energy().total();
    let n = s.placements.len();
    let mut lowest = vec![f64::INFINITY; n];
    let (mut worst, mut growth) = (0.0f64, f64::NEG_INFINITY);
    for _ in 0..720 {
        let step = sim.step().unwrap();
        worst = worst.max(step.max_penetration);
        let e = sim.energy();
        growth = growth.max(e.total() - e0 - e.push_work);
        for (l, b) in lowest.iter_mut().zip(&sim.bodies) {
            *l = l.min(b.state.q[2]);
        }
    }
    eprintln!("floor crowd: lowest pelvis {lowest:.3?}, worst penetration {worst:.2e} m, largest energy growth {growth:.3e} J");
    for (i, p) in s.placements.iter().enumerate() {
        let end = sim.bodies[i].state.q[2];
        if strong.contains(&p.name.as_str()) {
            assert!(end < 0.5, "{} still up: pelvis at {end} m", p.name);
        } else {
            assert!(
                lowest[i] > 0.95,
                "{} fell: pelvis down to {} m",
                p.name,
                lowest[i]
            );
        }
    }
    assert!(worst < 5e-3, "penetration {worst} m");
    assert!(growth < 1e-6 * e0, "energy grew by {growth} J");
}

// ---------------------------------------------------------------------------------------------
// 6. The bodies' steps across threads: the same bits for any thread count.

/// The bundled crowd for 25 steps — three re-selections, the pushes acting — on 1, 2 and 3
/// threads, on the floor (contact included) and floating in zero gravity without a floor (as
/// `crowd2000.json`: bodies turning rigid): every body's state, share and error the same
/// bits, and each step's summary equal. On 2 and 3 threads the bodies go in chunks of 3–4
/// that the threads take as they come free, so which thread steps which body changes from
/// run to run.
#[test]
fn crowd_steps_are_the_same_bits_on_any_thread_count() {
    for (file, floating) in [
        ("scenes/crowd200.json", false),
        ("scenes/crowd200.json", true),
    ] {
        let mut s = articula_view::load_scene(models().join(file)).unwrap();
        if floating {
            s.gravity = DVec3::ZERO;
            s.ground = None;
        }
        let run = |threads: usize| {
            let mut sim = SceneSim::new(&s).unwrap();
            sim.set_threads(articula_dca::Threads::new(threads).unwrap());
            assert_eq!(sim.threads().count(), threads);
            let steps: Vec<_> = (0..25).map(|_| sim.step().unwrap()).collect();
            let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            let bodies: Vec<_> = sim
                .bodies
                .iter()
                .map(|b| {
                    (
                        bits(&b.state.q),
                        bits(&b.state.qd),
                        b.active,
                        b.allocation,
                        b.error.to_bits(),
                    )
                })
                .collect();
            (steps, bodies)
        };
        let one = run(1);
        assert!(one.0.iter().filter(|s| s.reselected).count() >= 3);
        // Some bodies are hidden and some seen: the chunks cost unequal work.
        let last = one.0.last().unwrap();
        assert!(last.classes[0] > 0 && last.classes[2] + last.classes[1] > 0);
        for threads in [2, 3] {
            let other = run(threads);
            assert_eq!(
                other.0, one.0,
                "{file} on {threads} threads: step summaries"
            );
            assert!(other.1 == one.1, "{file} on {threads} threads: body states");
        }
    }
}
