//! The view-dependent scene: invisible bodies move rigidly, the global queue beats an equal
//! split and equals a frontier scan, and the classified poses are the state's kinematics.

// Bodies are indexed alike in several parallel vectors.
#![allow(clippy::needless_range_loop)]

use super::global_selection;
use crate::visibility::{body_poses, Classifier, Placed};
use crate::{LoadedScene, SceneOptions, SceneSim, Visibility};
use articula_adaptive::{Adaptive, Settings};
use articula_dca::State;
use articula_model::Model;
use articula_spatial::{SpatialForce, SpatialInertia, SpatialMotion};
use glam::{DMat3, DQuat, DVec3};
use std::path::{Path, PathBuf};

fn models() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

fn scene(text: &str) -> LoadedScene {
    SceneOptions::default()
        .parse(text, Path::new("test.json"), &models())
        .unwrap()
}

// ---------------------------------------------------------------------------------------------
// 1. An invisible body: no joint, and the exact rigid motion of the whole.

/// The composite spatial inertia of the whole model in the root frame, in the neutral pose.
fn composite_in_root(model: &Model) -> SpatialInertia {
    let mut poses = Vec::new();
    body_poses(model, &model.neutral_q(), &mut poses);
    let mut total = SpatialInertia::ZERO;
    for (b, &(r, p)) in model.bodies.iter().zip(&poses) {
        // The body's inertia expressed in the root frame (root at the identity here).
        let i = &b.inertia;
        total += SpatialInertia::new(
            i.mass,
            r * i.com() + p,
            r * i.inertia_about_com() * r.transpose(),
        );
    }
    total
}

/// `exp` of a rotation vector as a matrix (Rodrigues).
fn rodrigues(phi: DVec3) -> DMat3 {
    let th = phi.length();
    if th < 1e-300 {
        return DMat3::IDENTITY;
    }
    DMat3::from_axis_angle(phi / th, th)
}

#[test]
fn an_invisible_body_moves_as_one_rigid_body() {
    // Position (m) and rotation-matrix entries agree to rounding over 150 steps, with and
    // without gravity, pushes and spin.
    for (g, f, w) in [
        (0.0, 0.0, 0.0),
        (-9.81, 0.0, 0.0),
        (0.0, 120.0, 1.5),
        (-9.81, 120.0, 1.5),
    ] {
        let worst = invisible_case(g, f, w);
        assert!(
            worst < 1e-9,
            "gravity {g}, push {f}, spin {w}: trajectories differ by {worst}"
        );
    }
}

fn invisible_case(gz: f64, fz: f64, wz: f64) -> f64 {
    // Behind the camera, spinning and drifting, under gravity, pushed at its chest.
    let s = scene(&format!(
        r#"{{"models": {{"h": "humanoid.urdf"}},
            "bodies": [{{"model": "h", "position": [-6, 0.5, 1.0], "rpy": [0.2, -0.1, 0.7],
                        "velocity": {{"linear": [-1.0, 0.3, 2.0], "angular": [0.4, -0.3, {wz}]}}}}],
            "camera": {{"eye": [0, 0, 1.5], "target": [10, 0, 1]}},
            "budget": 100, "dt": 0.002, "reselect_every": 3, "gravity": [0, 0, {gz}],
            "pushes": [{{"bodies": "all", "link": "chest", "point": [0.05, 0.1, 0.2],
                        "force": [-80, 40, {fz}], "t0": 0.01, "t1": 0.05}}]}}"#,
    ));
    let model = &s.models[0].model;
    let chest = model.bodies.iter().position(|b| b.name == "chest").unwrap();
    let mut poses = Vec::new();
    body_poses(model, &model.neutral_q(), &mut poses);
    // The push point in root coordinates, in the neutral pose (the joints never move).
    let (rc, pc) = poses[chest];
    let push_point = rc * s.pushes[0].point + pc;
    let inertia = composite_in_root(model);
    let inv = inertia.inverse().unwrap();
    // Rigid state: root orientation R, position p, body-frame twist [w; v] (v: velocity of
    // the root origin in root coordinates).
    let q0 = &s.placements[0].q;
    let mut r = DMat3::from_quat(DQuat::from_xyzw(q0[4], q0[5], q0[6], q0[3]));
    let mut p = DVec3::new(q0[0], q0[1], q0[2]);
    let qd0 = &s.placements[0].qd;
    let mut tw = SpatialMotion::new(
        DVec3::new(qd0[0], qd0[1], qd0[2]),
        DVec3::new(qd0[3], qd0[4], qd0[5]),
    );

    let mut sim = SceneSim::new(&s).unwrap();
    let g = DVec3::new(0.0, 0.0, gz);
    let dt = s.dt;
    let mut worst: f64 = 0.0;
    for k in 0..150 {
        let t = k as f64 * dt;
        let step = sim.step().unwrap();
        assert_eq!(step.active_total, 0, "step {k}");
        assert_eq!(sim.views[0].summary(), Visibility::Invisible);
        // Independent rigid body: in root coordinates, f = I a + v ×* I v.
        let mut f = SpatialForce::new(
            inertia.h.cross(r.transpose() * g),
            r.transpose() * g * inertia.mass,
        );
        if s.pushes[0].t0 <= t && t < s.pushes[0].t1 {
            let fb = r.transpose() * s.pushes[0].force;
            f += SpatialForce::new(push_point.cross(fb), fb);
        }
        let h = inertia.mul_motion(tw);
        // v ×* h = [w × n + v × f; w × f]
        let bias = SpatialForce::new(tw.w.cross(h.n) + tw.v.cross(h.f), tw.w.cross(h.f));
        let a = inv.force_to_motion(f - bias);
        tw = SpatialMotion::new(tw.w + a.w * dt, tw.v + a.v * dt);
        // Exact motion at constant body twist over dt: R ← R exp(ω dt),
        // p ← p + R ∫₀^dt exp(ω s) v ds (by quadrature of the closed-form rotation).
        let n = 64;
        let mut disp = DVec3::ZERO;
        for i in 0..n {
            // Simpson-free midpoint rule with many points is accurate to ~1e-12 here.
            let s_mid = (i as f64 + 0.5) / n as f64 * dt;
            disp += rodrigues(tw.w * s_mid) * tw.v * (dt / n as f64);
        }
        p += r * disp;
        r *= rodrigues(tw.w * dt);
        let q = &sim.bodies[0].state.q;
        let p_sim = DVec3::new(q[0], q[1], q[2]);
        let r_sim = DMat3::from_quat(DQuat::from_xyzw(q[4], q[5], q[6], q[3]));
        let dr = (r_sim - r)
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        worst = worst.max((p_sim - p).length()).max(dr);
        // Joints stay where they were.
        assert!(q[7..].iter().all(|x| *x == 0.0));
        assert!(sim.bodies[0].state.qd[6..].iter().all(|x| *x == 0.0));
    }
    // And the body did move (drift, fall, spin).
    assert!((sim.bodies[0].state.q[0] - q0[0]).abs() > 0.2);
    worst
}

// ---------------------------------------------------------------------------------------------
// 2. The global queue's total error is at most that of an equal split.

#[test]
fn the_global_queue_beats_an_equal_split() {
    let s = scene(
        r#"{"models": {"h": "humanoid.urdf"},
            "bodies": [
              {"model": "h", "position": [3, 0, 1], "rpy": [0, 0, 3.1]},
              {"model": "h", "position": [7, 2, 1], "rpy": [0, 0, 2.5]},
              {"model": "h", "position": [15, -4, 1], "rpy": [0, 0, 3.5]},
              {"model": "h", "position": [30, 3, 1]},
              {"model": "h", "position": [12, 40, 1]},
              {"model": "h", "position": [-5, 0, 1]}],
            "camera": {"eye": [0, 0, 1.5], "target": [10, 0, 1]}}"#,
    );
    let model = &s.models[0].model;
    let parents: Vec<Option<usize>> = model.bodies.iter().map(|b| b.parent).collect();
    // Random joint velocities and forces so that every body has its own metric.
    let states: Vec<State> = s
        .placements
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let mut st = State::random(model, 100 + i as u64, 5.0);
            st.q[..7].copy_from_slice(&p.q[..7]);
            st
        })
        .collect();
    let poses: Vec<Vec<(DMat3, DVec3)>> = states
        .iter()
        .map(|st| {
            let mut ps = Vec::new();
            body_poses(model, &st.q, &mut ps);
            ps
        })
        .collect();
    let placed: Vec<Placed> = poses
        .iter()
        .map(|ps| Placed {
            volumes: &s.models[0].volumes,
            poses: ps,
            parents: &parents,
            margin: 0.0,
        })
        .collect();
    let mut cl = Classifier::new(&s.visibility);
    let mut views = Vec::new();
    cl.classify(&s.camera.at(0.0), &s.visibility, &placed, &mut views);
    let classes: Vec<Visibility> = views.iter().map(|v| v.summary()).collect();
    assert!(classes.contains(&Visibility::Invisible) && classes.contains(&Visibility::Visible));
    let workspace = |b: usize, budget: Option<usize>| {
        let mut a = Adaptive::new(
            model,
            Settings {
                budget,
                ..Settings::default()
            },
        );
        for (i, w) in views[b].joint_weights.iter().enumerate() {
            a.set_weight(model, i, *w);
        }
        a
    };
    let metrics: Vec<Vec<f64>> = (0..states.len())
        .map(|b| {
            let mut m = vec![0.0; model.assembly.nodes.len()];
            let st = &states[b];
            workspace(b, None)
                .node_metrics(model, &st.q, &st.qd, &st.tau, &st.f_ext, &mut m)
                .unwrap();
            m
        })
        .collect();
    let models: Vec<&Model> = vec![model; states.len()];
    let refs: Vec<&[f64]> = metrics.iter().map(|m| m.as_slice()).collect();
    let n = states.len();
    let mut strictly_better = 0;
    for k in [6, 12, 30, 60, 120] {
        let global = global_selection(&models, &refs, Some(k), None);
        assert!(global.used <= k);
        // Equal split: each body's own queue with K / n joints.
        let mut equal = 0.0;
        for b in 0..n {
            let st = &states[b];
            let mut a = workspace(b, Some(k / n));
            a.forward_dynamics(model, &st.q, &st.qd, &st.tau, &st.f_ext)
                .unwrap();
            equal += a.selection().predicted_error;
        }
        assert!(
            global.total_error <= equal * (1.0 + 1e-12),
            "K = {k}: global {} > equal split {equal}",
            global.total_error
        );
        if global.total_error < 0.99 * equal {
            strictly_better += 1;
        }
        // Each body's share, as its own budget, reproduces the global choice and its error.
        for b in 0..n {
            let st = &states[b];
            let mut a = workspace(b, Some(global.allocation[b]));
            a.forward_dynamics(model, &st.q, &st.qd, &st.tau, &st.f_ext)
                .unwrap();
            let sel = a.selection();
            assert_eq!(sel.budget_used, global.allocation[b], "K = {k}, body {b}");
            let e = global.error[b];
            assert!(
                (sel.predicted_error - e).abs() <= 1e-9 * e.max(1.0),
                "K = {k}, body {b}: {} vs {e}",
                sel.predicted_error
            );
        }
        // Invisible bodies get nothing.
        for b in 0..n {
            if classes[b] == Visibility::Invisible {
                assert_eq!(global.allocation[b], 0);
            }
        }
    }
    assert!(
        strictly_better >= 3,
        "the global queue should usually be strictly better"
    );
}

/// The global queue against a plain reference: a frontier list scanned for its largest metric
/// at every pop, the mass left summed afresh each time (no heap, no running sums).
#[test]
fn the_global_queue_equals_a_frontier_scan_with_budget_and_tolerance() {
    let s = scene(
        r#"{"models": {"h": "humanoid.urdf"},
            "bodies": [{"model": "h", "position": [3, 0, 1]},
                       {"model": "h", "position": [5, 0, 1]},
                       {"model": "h", "position": [7, 0, 1]},
                       {"model": "h", "position": [9, 0, 1]}],
            "camera": {"eye": [0, 0, 1.5], "target": [10, 0, 1]}}"#,
    );
    let model = &s.models[0].model;
    let tree = &model.assembly;
    let join = |n: usize| match tree.nodes[n].kind {
        articula_model::NodeKind::Join {
            joint,
            parent_side,
            child_side,
        } => Some((joint, parent_side, child_side)),
        _ => None,
    };
    // Metrics from a fixed generator; about one node in four weighs 0 (an invisible part).
    let mut x = 0x2545f4914f6cdd1du64;
    let metrics: Vec<Vec<f64>> = (0..4)
        .map(|_| {
            (0..tree.nodes.len())
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    let u = (x >> 11) as f64 / (1u64 << 53) as f64;
                    if u < 0.25 {
                        0.0
                    } else {
                        u * u * 10.0
                    }
                })
                .collect()
        })
        .collect();
    let total: f64 = metrics.iter().flatten().sum();
    let models: Vec<&Model> = vec![model; 4];
    let refs: Vec<&[f64]> = metrics.iter().map(|m| m.as_slice()).collect();
    let mut cases = 0;
    for budget in [None, Some(0), Some(7), Some(40), Some(1000)] {
        for tolerance in [
            None,
            Some(0.5 * total),
            Some(0.1 * total),
            Some(0.01 * total),
        ] {
            if budget.is_none() && tolerance.is_none() {
                continue;
            }
            let got = global_selection(&models, &refs, budget, tolerance);
            // The reference: the frontier as (body, node) pairs; floating roots are free.
            let mut frontier: Vec<(usize, usize)> = Vec::new();
            let mut popped = vec![Vec::new(); 4];
            let mut used = 0;
            for b in 0..4 {
                let root = tree.root();
                popped[b].push(root);
                let (_, a, c) = join(root).unwrap();
                frontier.extend(
                    [a, c]
                        .into_iter()
                        .filter(|&n| join(n).is_some())
                        .map(|n| (b, n)),
                );
            }
            loop {
                let left: f64 = frontier.iter().map(|&(b, n)| metrics[b][n]).sum();
                let Some(k) = (0..frontier.len()).max_by(|&i, &j| {
                    let (bi, ni) = frontier[i];
                    let (bj, nj) = frontier[j];
                    metrics[bi][ni]
                        .total_cmp(&metrics[bj][nj])
                        .then(bj.cmp(&bi))
                        .then(nj.cmp(&ni))
                }) else {
                    break;
                };
                let (b, n) = frontier[k];
                if metrics[b][n] <= 0.0 || tolerance.is_some_and(|t| left <= t) {
                    break;
                }
                let (j, a, c) = join(n).unwrap();
                let cost = model.bodies[j].nv;
                if budget.is_some_and(|k| used + cost > k) {
                    break;
                }
                used += cost;
                frontier.swap_remove(k);
                popped[b].push(n);
                frontier.extend(
                    [a, c]
                        .into_iter()
                        .filter(|&m| join(m).is_some())
                        .map(|m| (b, m)),
                );
            }
            assert_eq!(got.used, used, "budget {budget:?}, tolerance {tolerance:?}");
            assert_eq!(
                got.popped, popped,
                "budget {budget:?}, tolerance {tolerance:?}"
            );
            let error: f64 = frontier.iter().map(|&(b, n)| metrics[b][n]).sum();
            assert!(
                (got.total_error - error).abs() <= 1e-12 * total,
                "budget {budget:?}, tolerance {tolerance:?}: {} vs {error}",
                got.total_error
            );
            if let Some(t) = tolerance {
                if budget.is_none() {
                    assert!(got.total_error <= t * (1.0 + 1e-12));
                }
            }
            cases += 1;
        }
    }
    assert_eq!(cases, 19);
}

// ---------------------------------------------------------------------------------------------
// 3. The link poses the camera classifies come from each re-selection's exact solve.

#[test]
fn reselection_poses_are_the_forward_kinematics_of_the_state() {
    let s = crate::load_scene(models().join("scenes/crowd200.json")).unwrap();
    let mut sim = SceneSim::new(&s).unwrap();
    let mut checked = 0;
    for _ in 0..(3 * s.reselect_every) {
        let before: Vec<Vec<f64>> = sim.bodies.iter().map(|b| b.state.q.clone()).collect();
        if !sim.step().unwrap().reselected {
            continue;
        }
        // (A body that steps as one rigid body refreshed its poses to the new state.)
        for (b, q) in sim
            .bodies
            .iter()
            .zip(&before)
            .filter(|(b, _)| b.rigid.is_none())
        {
            // Independent: the pose-only kinematics composed in world coordinates.
            let mut want = Vec::new();
            body_poses(&s.models[b.model].model, q, &mut want);
            assert_eq!(b.poses.len(), want.len());
            for (&(r, p), &(wr, wp)) in b.poses.iter().zip(&want) {
                let dr = (r - wr)
                    .to_cols_array()
                    .iter()
                    .fold(0.0f64, |m, x| m.max(x.abs()));
                assert!(
                    dr < 1e-12,
                    "rotation off by {dr} checked {checked} r {r} wr {wr}"
                );
                assert!((p - wp).abs().max_element() < 1e-12, "origin {p} vs {wp}");
                checked += 1;
            }
        }
    }
    // Most bodies are articulated at every re-selection.
    assert!(
        checked > 3 * 150 * sim.bodies[0].poses.len(),
        "{checked} poses checked"
    );
}

// ---------------------------------------------------------------------------------------------
// 5. A floor: an invisible, fully rigid character lands on it; a visible one lands on it too.

#[test]
fn characters_land_and_stand_on_the_floor() {
    // The crowd's time step, 1/600 s. The humanoid's lowest contact point is 1.02 m below its
    // root in the neutral pose:
    // one behind the camera dropped from 0.3 m above its standing height, one in view with
    // its feet 1 mm above the floor.
    let s = scene(
        r#"{"models": {"h": "humanoid.urdf"},
            "bodies": [{"name": "hidden", "model": "h", "position": [-6, 0.5, 1.32]},
                       {"name": "seen", "model": "h", "position": [5, 0, 1.021], "rpy": [0, 0, 3.14]}],
            "camera": {"eye": [0, 0, 1.5], "target": [10, 0, 1]},
            "budget": 34, "dt": 0.0016666666666666668, "reselect_every": 5,
            "joint_springs": {"frequency_hz": 2.0, "damping_ratio": 0.5},
            "ground": {"height": 0, "friction": 1}}"#,
    );
    let mut sim = SceneSim::new(&s).unwrap();
    let (mut worst, mut seen_lowest) = (0.0f64, f64::INFINITY);
    let mut settled = Vec::new();
    for i in 0..600 {
        let step = sim.step().unwrap();
        worst = worst.max(step.max_penetration);
        seen_lowest = seen_lowest.min(sim.bodies[1].state.q[2]);
        if i == 299 {
            settled = sim.bodies[0].state.q[..6].to_vec();
        }
    }
    // The hidden body: every internal joint locked, one rigid body at rest on the floor, its
    // root down by the 0.3 m gap (the slop of the position correction aside).
    let hidden = &sim.bodies[0];
    assert_eq!(sim.views[0].summary(), Visibility::Invisible);
    assert_eq!(hidden.active, 0);
    let (q, qd) = (&hidden.state.q, &hidden.state.qd);
    assert!((q[2] - 1.02).abs() < 2e-4, "hidden root at {} m", q[2]);
    // At rest to the contact solve's tolerance (1e-6 m/s at the contact points; the root,
    // a metre above the feet, may keep a few times that for a while before it decays), and
    // no creep: its root pose moved less than a micrometre (microradian) over the last 0.5 s.
    assert!(
        qd.iter().all(|v| v.abs() < 1e-5),
        "hidden body moves: {qd:?}"
    );
    let creep = q[..6]
        .iter()
        .zip(&settled)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(creep < 1e-6, "hidden body creeps {creep:e}");
    let hc = hidden.contact.as_ref().unwrap();
    assert!(hc.contact.stats.contacts >= 3);
    // The visible one is articulated, lands on its feet and stands on its pose springs
    // (stance-scaled: docs/view.md#pose-springs): its pelvis never 2 cm below where it
    // started.
    let seen = &sim.bodies[1];
    let sc = seen.contact.as_ref().unwrap();
    eprintln!(
        "floor: hidden root {:.6} m, seen root {:.4} m (lowest {seen_lowest:.4}) with {} contacts, worst penetration {worst:.2e} m",
        q[2], seen.state.q[2], sc.contact.stats.contacts
    );
    assert!(sc.contact.stats.contacts >= 3);
    assert!(
        seen_lowest > 1.0 && seen.state.q[2] < 1.03,
        "the seen body's root at {} m, down to {seen_lowest} m",
        seen.state.q[2]
    );
    assert!(seen
        .state
        .q
        .iter()
        .chain(&seen.state.qd)
        .all(|x| x.is_finite()));
    assert!(worst < 5e-3, "penetration {worst} m");
}

#[test]
fn a_bad_ground_names_its_field() {
    for (ground, field) in [
        (r#"{"friction": -1}"#, "ground.friction"),
        (r#"{"restitution": 2}"#, "ground.restitution"),
        (r#"{"tolerance": 0}"#, "ground.tolerance"),
        (r#"{"max_iterations": 0}"#, "ground.max_iterations"),
    ] {
        let text = format!(
            r#"{{"models": {{"h": "humanoid.urdf"}}, "camera": {{"eye": [0, 0, 1.5], "target": [10, 0, 1]}},
                "ground": {ground}}}"#
        );
        let e = SceneOptions::default()
            .parse(&text, Path::new("test.json"), &models())
            .unwrap_err();
        assert!(e.to_string().contains(field), "{e}");
    }
}

// ---------------------------------------------------------------------------------------------
// The exact reference.

/// Two pushed humanoids in view on their pose springs under gravity `gz`, `ground` a
/// scene-file `ground` entry (with its leading comma) or nothing, with a budget of every joint.
fn two_in_view(gz: f64, ground: &str) -> LoadedScene {
    scene(&format!(
        r#"{{"models": {{"h": "humanoid.urdf"}},
            "bodies": [{{"name": "a", "model": "h", "position": [5, -0.5, 1.021], "rpy": [0, 0, 3.14]}},
                       {{"name": "b", "model": "h", "position": [6, 0.6, 1.021], "rpy": [0.1, 0, 3.0]}}],
            "camera": {{"eye": [0, 0, 1.5], "target": [10, 0, 1]}},
            "budget": 68, "dt": 0.0016666666666666668, "reselect_every": 5,
            "gravity": [0, 0, {gz}],
            "joint_springs": {{"frequency_hz": 2.0, "damping_ratio": 0.2}},
            "pushes": [{{"bodies": "all", "link": "chest", "point": [0.05, 0.1, 0.2],
                        "force": [-80, 40, 10], "t0": 0.0, "t1": 0.05}}]{ground}}}"#
    ))
}

/// [`two_in_view`]: the adaptive scene and the exact DCA reference stepped side by side for
/// `steps` steps; returns the largest difference of any `q` or `q̇` coordinate over the run.
fn full_budget_against_exact(gz: f64, ground: &str, steps: usize) -> f64 {
    use super::SceneMethod;
    let s = two_in_view(gz, ground);
    let mut adaptive = SceneSim::new(&s).unwrap();
    let mut exact = SceneSim::new(&s).unwrap();
    exact.set_method(SceneMethod::Exact(articula_dca::Method::Dca));
    let mut worst = 0.0f64;
    for _ in 0..steps {
        let a = adaptive.step().unwrap();
        let e = exact.step().unwrap();
        // Every joint of both bodies moves in both.
        assert_eq!((a.active_total, e.active_total), (68, 68));
        for (x, y) in adaptive.bodies.iter().zip(&exact.bodies) {
            for (u, v) in x
                .state
                .q
                .iter()
                .chain(&x.state.qd)
                .zip(y.state.q.iter().chain(&y.state.qd))
            {
                worst = worst.max((u - v).abs());
            }
        }
    }
    worst
}

#[test]
fn the_exact_reference_is_the_full_budget_adaptive_scene() {
    // With every joint in the budget the hybrid body is the whole body, so the adaptive scene
    // (reduced-tree ABA) and the exact reference (DCA) are two exact algorithms on the same
    // springs, pushes and integrator: equal to rounding.
    let free = full_budget_against_exact(0.0, "", 300);
    let gravity = full_budget_against_exact(-9.81, "", 120);
    eprintln!("full budget against exact DCA: zero gravity {free:.2e}, gravity {gravity:.2e}");
    assert!(free < 1e-9, "zero gravity: {free:e}");
    assert!(gravity < 1e-9, "gravity: {gravity:e}");
    // On the floor both run the same contact step on the same articulated tree (every joint
    // a node), so the solves take the same sweeps and agree to rounding too.
    let floor =
        full_budget_against_exact(-9.81, r#", "ground": {"height": 0, "friction": 1}"#, 300);
    eprintln!("on the floor: {floor:.2e}");
    assert!(floor < 1e-8, "floor: {floor:e}");
}

#[test]
fn switching_from_exact_back_to_adaptive_reselects() {
    // 23 exact steps, then adaptive ones: the first adaptive step re-selects although 23 is
    // not a multiple of the period (5), from the states the exact steps left; with every
    // joint in the budget the run then equals exact steps all along, to rounding.
    use super::SceneMethod;
    let exact = SceneMethod::Exact(articula_dca::Method::Dca);
    let s = two_in_view(-9.81, r#", "ground": {"height": 0, "friction": 1}"#);
    let (mut switched, mut reference) = (SceneSim::new(&s).unwrap(), SceneSim::new(&s).unwrap());
    switched.set_method(exact);
    reference.set_method(exact);
    for k in 0..60 {
        if k == 23 {
            switched.set_method(SceneMethod::Adaptive);
        }
        let step = switched.step().unwrap();
        reference.step().unwrap();
        if k == 23 {
            assert!(step.reselected && step.active_total == 68, "{step:?}");
        }
    }
    let worst = switched
        .bodies
        .iter()
        .zip(&reference.bodies)
        .flat_map(|(a, b)| {
            let (x, y) = (&a.state, &b.state);
            x.q.iter().chain(&x.qd).zip(y.q.iter().chain(&y.qd))
        })
        .fold(0.0f64, |m, (u, v)| m.max((u - v).abs()));
    assert!(worst < 1e-8, "switched run differs by {worst:e}");
}

#[test]
fn the_ground_block_sets_the_contact_solve() {
    // Defaults: 1e-6 m/s and 50 sweeps; a ground block's own values otherwise.
    let text = |ground: &str| {
        format!(
            r#"{{"models": {{"h": "humanoid.urdf"}}, "camera": {{"eye": [0, 0, 1.5], "target": [10, 0, 1]}},
                "bodies": [{{"name": "a", "model": "h", "position": [5, 0, 1.021]}}],
                "ground": {ground}}}"#
        )
    };
    let plain = scene(&text("{}")).contact_settings();
    assert_eq!((plain.tolerance, plain.max_iterations), (1e-6, 50));
    let set = scene(&text(r#"{"tolerance": 1e-4, "max_iterations": 20}"#)).contact_settings();
    assert_eq!((set.tolerance, set.max_iterations), (1e-4, 20));
    assert!(set.ground.is_some());
}

// ---------------------------------------------------------------------------------------------
// A model whose neutral pose breaks its joint limits.

/// A 5 kg box on four two-joint legs (0.2 m thigh and shank, a 2 cm ball foot) whose knees
/// bend only within `[−2.6, −0.8]` rad, like go1's: the straight legs of the neutral pose
/// are outside the limits.
fn quadruped_urdf() -> String {
    let inertial = |m: f64, i: f64| {
        format!(
            r#"<inertial><mass value="{m}"/><inertia ixx="{i}" iyy="{i}" izz="{i}" ixy="0" ixz="0" iyz="0"/></inertial>"#
        )
    };
    let mut urdf = format!(
        r#"<robot name="quad"><link name="torso">{}<collision><geometry><box size="0.4 0.2 0.1"/></geometry></collision></link>"#,
        inertial(5.0, 0.03)
    );
    for (leg, x, y) in [
        ("fl", 0.2, 0.1),
        ("fr", 0.2, -0.1),
        ("hl", -0.2, 0.1),
        ("hr", -0.2, -0.1),
    ] {
        urdf += &format!(
            r#"<link name="{leg}_thigh">{}</link>
            <link name="{leg}_shank">{}<collision><origin xyz="0 0 -0.2"/><geometry><sphere radius="0.02"/></geometry></collision></link>
            <joint name="{leg}_hip" type="revolute"><parent link="torso"/><child link="{leg}_thigh"/>
              <origin xyz="{x} {y} 0"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="10"/></joint>
            <joint name="{leg}_knee" type="revolute"><parent link="{leg}_thigh"/><child link="{leg}_shank"/>
              <origin xyz="0 0 -0.2"/><axis xyz="0 1 0"/><limit lower="-2.6" upper="-0.8" effort="10" velocity="10"/></joint>"#,
            inertial(0.5, 2e-3),
            inertial(0.2, 7e-4),
        );
    }
    urdf + "</robot>"
}

/// A scene starts such a model in its rest pose (`Model::rest_q`: the knees at −0.8 rad) and
/// its pose springs hold that pose, so it stands on the floor: its knees never leave their
/// limits (beyond the position correction's slop), and its torso stays within 2 cm of the
/// height the rest pose puts it at.
#[test]
fn a_model_whose_neutral_pose_breaks_its_limits_starts_and_stands_in_its_rest_pose() {
    let dir = std::env::temp_dir().join(format!("articula-quad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("quad.urdf");
    std::fs::write(&path, quadruped_urdf()).unwrap();
    let model = Model::from_urdf_file(
        &path,
        &articula_model::LoadOptions::default().with_floating_base(true),
    )
    .unwrap();
    let rest = model.rest_q();
    // The rest pose's standing height: the feet (balls of 2 cm) at the floor.
    let mut data = articula_dca::Data::new(&model);
    articula_dca::forward_kinematics(&model, &rest, &vec![0.0; model.nv], &mut data).unwrap();
    let contact = articula_dca::ContactData::new(&model);
    let stand = -contact.lowest_point(&data);
    let s = scene(&format!(
        r#"{{"models": {{"quad": "{}"}},
            "bodies": [{{"name": "q", "model": "quad", "position": [3, 0, {}]}}],
            "camera": {{"eye": [0, 0, 0.5], "target": [3, 0, 0.2]}},
            "budget": 8, "dt": 0.001, "reselect_every": 10,
            "joint_springs": {{"frequency_hz": 4.0, "damping_ratio": 0.5}},
            "ground": {{"height": 0, "friction": 1}}}}"#,
        path.display(),
        stand + 1e-3
    ));
    let mut sim = SceneSim::new(&s).unwrap();
    let knees: Vec<usize> = model
        .joint_parts()
        .filter(|(_, p)| p.limits == Some([-2.6, -0.8]))
        .map(|(_, p)| p.q_offset)
        .collect();
    assert_eq!(knees.len(), 4);
    for &k in &knees {
        assert_eq!(sim.bodies[0].state.q[k], -0.8);
    }
    let (mut lowest, mut highest) = (f64::INFINITY, f64::NEG_INFINITY);
    for _ in 0..1000 {
        sim.step().unwrap();
        let q = &sim.bodies[0].state.q;
        for &k in &knees {
            assert!(
                (-2.6 - 1e-3..=-0.8 + 1e-3).contains(&q[k]),
                "knee at {}",
                q[k]
            );
        }
        lowest = lowest.min(q[2]);
        highest = highest.max(q[2]);
    }
    eprintln!("quadruped: torso between {lowest:.4} and {highest:.4} m, rest height {stand:.4} m");
    assert!(
        (lowest - stand).abs() < 0.02 && (highest - stand).abs() < 0.02,
        "torso between {lowest} and {highest} m, rest height {stand} m"
    );
    std::fs::remove_dir_all(&dir).ok();
}
