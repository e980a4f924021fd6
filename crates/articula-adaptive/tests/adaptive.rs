//! Adaptive dynamics against exact DCA (articula-dca), direct metric sums and conservation laws.

use articula_adaptive::{Adaptive, Settings};
use articula_dca::{forward_dynamics_slices, forward_kinematics, Data, Method, State};
use articula_model::{LoadOptions, Model, NodeKind};
use articula_spatial::SpatialForce;

/// A workspace re-selecting through the caches (what these tests exercise; the library's
/// default route is `Reselection::ExactSolve`).
fn caches(mut ad: Adaptive) -> Adaptive {
    ad.set_reselection(articula_adaptive::Reselection::Caches);
    ad
}

const MODELS: [&str; 8] = [
    "chain10",
    "chain30",
    "chain100",
    "chain300",
    "chain1000",
    "humanoid",
    "plant",
    "rope",
];

use articula_testkit::bundled_with as load;

/// Every bundled model, fixed base, plus the floating humanoid and floating chain30.
fn models() -> Vec<(String, Model)> {
    let mut v: Vec<(String, Model)> = MODELS
        .iter()
        .map(|n| (n.to_string(), load(n, false)))
        .collect();
    v.push(("humanoid floating".into(), load("humanoid", true)));
    v.push(("chain30 floating".into(), load("chain30", true)));
    v
}

fn state(model: &Model, seed: u64) -> State {
    let mut s = State::random(model, seed, 2.0);
    s.randomize_forces(seed ^ 0x5a5a, 3.0);
    s
}

fn solve(model: &Model, s: &State, method: Method) -> Vec<f64> {
    let mut data = Data::new(model);
    forward_dynamics_slices(model, &mut data, &s.q, &s.qd, &s.tau, &s.f_ext, method)
        .unwrap()
        .to_vec()
}

fn exact(model: &Model, s: &State) -> Vec<f64> {
    solve(model, s, Method::Dca)
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

#[test]
fn unlimited_budget_and_zero_tolerance_give_exact_dca() {
    for (name, model) in models() {
        let seeds = if model.nv > 300 { 2 } else { 5 };
        for seed in 0..seeds {
            let s = state(&model, seed);
            let e = exact(&model, &s);
            let aba = solve(&model, &s, Method::Aba);
            let scale = max_abs(&e).max(1.0);
            // The independent reference ABA differs from DCA by ≈2e-10 relative on chain1000.
            let dca_gap = max_diff(&e, &aba);
            for settings in [
                Settings::default(),
                Settings {
                    tolerance: Some(0.0),
                    ..Settings::default()
                },
                Settings {
                    budget: Some(model.nv),
                    ..Settings::default()
                },
            ] {
                let mut ad = caches(Adaptive::new(&model, settings));
                let qdd = ad
                    .forward_dynamics(&model, &s.q, &s.qd, &s.tau, &s.f_ext)
                    .unwrap();
                let (err, err_aba) = (max_diff(qdd, &e), max_diff(qdd, &aba));
                assert!(
                    err <= 1e-10 * scale && err_aba <= 1e-9 * scale,
                    "{name} seed {seed}: {err:e} from DCA, {err_aba:e} from ABA, DCA–ABA {dca_gap:e} (scale {scale:e})"
                );
                assert!(
                    ad.selection().predicted_error <= 1e-12 * ad.selection().total_metric.max(1.0)
                );
            }
        }
    }
}

#[test]
fn predicted_metric_at_every_node_equals_the_direct_sum() {
    for (name, model) in models() {
        let tree = &model.assembly;
        let seeds = if model.nv > 300 { 2 } else { 4 };
        for seed in 0..seeds {
            let s = state(&model, 100 + seed);
            // The exact solve: articula-dca's DCA.
            let e = exact(&model, &s);
            let mut ad = caches(Adaptive::new(&model, Settings::default()));
            let mut predicted = vec![0.0; tree.nodes.len()];
            ad.predicted_node_metrics(&model, &s.q, &s.qd, &s.tau, &s.f_ext, &mut predicted)
                .unwrap();
            // The scene layer's fast path (one exact solve, summed bottom-up): same values.
            let mut summed = vec![0.0; tree.nodes.len()];
            ad.node_metrics(&model, &s.q, &s.qd, &s.tau, &s.f_ext, &mut summed)
                .unwrap();
            // Direct: Σ q̈ᵀq̈ over the principal joints of the node's subtree (bottom-up).
            let mut direct = vec![0.0; tree.nodes.len()];
            for (n, node) in tree.nodes.iter().enumerate() {
                if let NodeKind::Join {
                    joint,
                    parent_side,
                    child_side,
                } = node.kind
                {
                    let b = &model.bodies[joint];
                    let own: f64 = e[b.v_offset..b.v_offset + b.nv].iter().map(|x| x * x).sum();
                    direct[n] = own + direct[parent_side] + direct[child_side];
                }
            }
            let total = direct[tree.root()];
            for n in 0..tree.nodes.len() {
                let err = (predicted[n] - direct[n]).abs();
                assert!(
                    err <= 1e-8 * direct[n].max(1e-6 * total),
                    "{name} seed {seed} node {n}: predicted {} direct {} ",
                    predicted[n],
                    direct[n]
                );
                let err = (summed[n] - direct[n]).abs();
                assert!(
                    err <= 1e-8 * direct[n].max(1e-6 * total),
                    "{name} seed {seed} node {n}: summed {} direct {} ",
                    summed[n],
                    direct[n]
                );
            }
        }
    }
}

#[test]
fn error_falls_as_the_budget_grows_and_matches_the_prediction() {
    for name in ["chain30", "humanoid", "plant", "rope"] {
        for floating in [false, true] {
            let model = load(name, floating);
            for seed in 0..3 {
                let s = state(&model, 200 + seed);
                let e = exact(&model, &s);
                let mut last = f64::INFINITY;
                let free = if floating { 6 } else { 0 };
                for budget in 0..=(model.nv - free) {
                    let mut ad = caches(Adaptive::new(
                        &model,
                        Settings {
                            budget: Some(budget),
                            ..Settings::default()
                        },
                    ));
                    let qdd = ad
                        .forward_dynamics(&model, &s.q, &s.qd, &s.tau, &s.f_ext)
                        .unwrap()
                        .to_vec();
                    let sel = ad.selection().clone();
                    assert!(sel.budget_used <= budget);
                    let actual: f64 = qdd.iter().zip(&e).map(|(a, b)| (a - b) * (a - b)).sum();
                    let tol = 1e-9 * sel.total_metric;
                    assert!(
                        (sel.predicted_error - actual).abs() <= tol,
                        "{name} budget {budget}: predicted {} actual {actual}",
                        sel.predicted_error
                    );
                    assert!(
                        actual <= last + tol,
                        "{name} budget {budget}: {actual} > {last}"
                    );
                    last = actual;
                    // Selected joints carry their exact accelerations, the others zero.
                    for (i, b) in model.bodies.iter().enumerate() {
                        let r = b.v_offset..b.v_offset + b.nv;
                        if ad.is_selected(&model, i) {
                            for (a, x) in qdd[r.clone()].iter().zip(&e[r]) {
                                assert!((a - x).abs() <= 1e-9 * max_abs(&e).max(1.0));
                            }
                        } else {
                            assert!(qdd[r].iter().all(|x| *x == 0.0));
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn tolerance_stops_when_the_metric_mass_left_is_small_enough() {
    let model = load("chain100", false);
    let s = state(&model, 7);
    let mut ad = caches(Adaptive::new(&model, Settings::default()));
    ad.forward_dynamics(&model, &s.q, &s.qd, &s.tau, &s.f_ext)
        .unwrap();
    let total = ad.selection().total_metric;
    for frac in [0.5, 0.1, 1e-2, 1e-4] {
        let tol = frac * total;
        let mut ad = caches(Adaptive::new(
            &model,
            Settings {
                tolerance: Some(tol),
                ..Settings::default()
            },
        ));
        ad.forward_dynamics(&model, &s.q, &s.qd, &s.tau, &s.f_ext)
            .unwrap();
        let sel = ad.selection();
        assert!(
            sel.predicted_error <= tol,
            "{frac}: {} > {tol}",
            sel.predicted_error
        );
        assert!(sel.active_dofs < model.nv);
    }
}

fn momentum(model: &Model, s: &State) -> SpatialForce {
    let mut data = Data::new(model);
    forward_kinematics(model, &s.q, &s.qd, &mut data).unwrap();
    data.momentum()
}

fn kinetic(model: &Model, s: &State) -> f64 {
    let mut data = Data::new(model);
    forward_kinematics(model, &s.q, &s.qd, &mut data).unwrap();
    data.kinetic_energy()
}

#[test]
fn rigidification_locks_joints_keeps_momentum_and_never_adds_energy() {
    for name in ["humanoid", "chain30", "plant", "rope"] {
        let model = load(name, true);
        for budget in [0, 1, 3, 8] {
            let mut s = State::random(&model, 300 + budget as u64, 0.0);
            let h0 = momentum(&model, &s);
            let k0 = kinetic(&model, &s);
            let mut ad = caches(Adaptive::new(
                &model,
                Settings {
                    budget: Some(budget),
                    ..Settings::default()
                },
            ));
            assert!(ad.reselect(&model, &mut s).unwrap());
            // Locked joints: exactly zero.
            for (i, b) in model.bodies.iter().enumerate() {
                if !ad.is_active(&model, i) {
                    assert!(s.qd[b.v_offset..b.v_offset + b.nv]
                        .iter()
                        .all(|x| *x == 0.0));
                }
            }
            assert!(ad.active_dofs(&model) <= budget + 6);
            let h1 = momentum(&model, &s);
            let k1 = kinetic(&model, &s);
            let dh = (h1 - h0).to_array();
            let rel = dh.iter().map(|x| x * x).sum::<f64>().sqrt()
                / h0.to_array().iter().map(|x| x * x).sum::<f64>().sqrt();
            assert!(
                rel <= 1e-12,
                "{name} budget {budget}: momentum change {rel:e}"
            );
            assert!(
                k1 <= k0 * (1.0 + 1e-12),
                "{name} budget {budget}: {k1} > {k0}"
            );
            assert!(k1 < k0, "locking moving joints must dissipate energy");
        }
    }
}

#[test]
fn budget_zero_moves_a_floating_body_as_one_rigid_body() {
    let model = load("humanoid", true);
    let mut s = State::random(&model, 11, 0.0);
    let mut ad = caches(Adaptive::new(
        &model,
        Settings {
            budget: Some(0),
            ..Settings::default()
        },
    ));
    let mut data = Data::new(&model);
    data.gravity = glam::DVec3::ZERO;
    ad.data.gravity = glam::DVec3::ZERO;
    let q_joints = s.q[7..].to_vec();
    for _ in 0..50 {
        let r = ad.step(&model, &mut s, 1e-3).unwrap();
        assert_eq!(r.active_dofs, 6);
    }
    // Internal joints frozen at their initial angles, velocities zero.
    assert_eq!(&s.q[7..], &q_joints[..]);
    assert!(s.qd[6..].iter().all(|x| *x == 0.0));
}

#[test]
fn invalid_settings_are_errors() {
    let model = load("chain10", false);
    let s = State::neutral(&model);
    for settings in [
        Settings {
            tolerance: Some(-1.0),
            ..Settings::default()
        },
        Settings {
            tolerance: Some(f64::NAN),
            ..Settings::default()
        },
        Settings {
            tolerance: Some(f64::INFINITY),
            ..Settings::default()
        },
        Settings {
            velocity_tolerance: Some(-0.5),
            ..Settings::default()
        },
        Settings {
            velocity_tolerance: Some(f64::INFINITY),
            ..Settings::default()
        },
    ] {
        let mut ad = caches(Adaptive::new(&model, settings.clone()));
        assert!(ad
            .forward_dynamics(&model, &s.q, &s.qd, &s.tau, &s.f_ext)
            .is_err());
        // A step checks them too, and the message names the setting.
        let e = ad
            .step(&model, &mut s.clone(), 1e-3)
            .unwrap_err()
            .to_string();
        let named = if settings.velocity_tolerance.is_some() {
            "velocity tolerance"
        } else {
            "tolerance"
        };
        assert!(e.contains(named), "{e}");
        assert!(settings.validate().is_err());
    }
    // Valid values pass.
    for settings in [
        Settings::default(),
        Settings {
            tolerance: Some(0.0),
            velocity_tolerance: Some(1e-3),
            reselect_every: 7,
            ..Settings::default()
        },
    ] {
        assert!(settings.validate().is_ok());
    }
}

#[test]
fn a_hybrid_step_visits_the_active_region_and_its_frontier_only() {
    // Between re-selections the main pass visits the active joins and the rigid frontier:
    // 2·(active joins) + 1 nodes, whatever the chain's length.
    for n in ["chain100", "chain1000"] {
        let model = load(n, false);
        let mut s = State::random(&model, 5, 0.0);
        let mut ad = caches(Adaptive::new(
            &model,
            Settings {
                budget: Some(20),
                reselect_every: 1000,
                ..Settings::default()
            },
        ));
        let first = ad.step(&model, &mut s, 1e-3).unwrap();
        assert!(first.reselected);
        let joins = first.active_dofs;
        assert_eq!(joins, 20);
        for _ in 0..5 {
            let r = ad.step(&model, &mut s, 1e-3).unwrap();
            assert!(!r.reselected);
            assert_eq!(r.nodes_touched, 2 * joins + 1, "{n}");
        }
    }
}

#[test]
fn velocity_tolerance_keeps_fast_subassemblies_moving() {
    // Budget 0 selects nothing; with a velocity tolerance every active subassembly whose
    // velocity metric V(C) = Σ q̇ᵀq̇ exceeds it stays in the hybrid body, the others lock.
    let model = load("chain30", false);
    let mut s = State::random(&model, 9, 0.0);
    s.qd.fill(0.0);
    for j in 20..30 {
        s.qd[j] = 3.0; // joints 21..30 move fast, the rest are at rest
    }
    let mut ad = caches(Adaptive::new(
        &model,
        Settings {
            budget: Some(0),
            velocity_tolerance: Some(1.0),
            ..Settings::default()
        },
    ));
    let before = s.qd.clone();
    let locked = ad.reselect(&model, &mut s).unwrap();
    assert!(
        !locked,
        "every moving joint sits in a subassembly above the tolerance"
    );
    assert_eq!(s.qd, before);
    for (i, b) in model.bodies.iter().enumerate() {
        if before[b.v_offset] != 0.0 {
            assert!(ad.is_active(&model, i), "{}", b.joint_name());
        }
    }
    // A tolerance above the whole body's velocity metric (10 × 9 = 90) locks everything.
    ad.set_settings(Settings {
        budget: Some(0),
        velocity_tolerance: Some(100.0),
        ..Settings::default()
    })
    .unwrap();
    assert!(ad.reselect(&model, &mut s).unwrap());
    assert!(s.qd.iter().all(|x| *x == 0.0));
}

#[test]
fn a_force_list_steps_like_dense_forces() {
    let model = load("chain300", false);
    let mut dense = State::random(&model, 21, 0.0);
    let forces: Vec<(usize, SpatialForce)> = [(17usize, 1.0), (150, -2.0), (299, 0.5)]
        .iter()
        .map(|&(b, s)| {
            (
                b,
                SpatialForce::new(glam::DVec3::new(0.0, s, 0.0), glam::DVec3::new(s, 0.0, 0.3)),
            )
        })
        .collect();
    for &(b, f) in &forces {
        dense.f_ext[b] = f;
    }
    let mut sparse = dense.clone();
    sparse.f_ext.clear();
    let settings = Settings {
        budget: Some(25),
        reselect_every: 5,
        ..Settings::default()
    };
    let (mut a, mut b) = (
        caches(Adaptive::new(&model, settings.clone())),
        caches(Adaptive::new(&model, settings)),
    );
    for _ in 0..12 {
        a.step(&model, &mut dense, 1e-3).unwrap();
        b.step_with_forces(&model, &mut sparse, 1e-3, &forces)
            .unwrap();
        assert_eq!(dense.q, sparse.q);
        assert_eq!(dense.qd, sparse.qd);
    }
    // Both ways at once, a bad index and a non-finite force are errors.
    let mut both = dense.clone();
    assert!(b
        .step_with_forces(&model, &mut both, 1e-3, &forces)
        .is_err());
    assert!(b
        .step_with_forces(&model, &mut sparse, 1e-3, &[(300, SpatialForce::ZERO)])
        .is_err());
    let nan = SpatialForce::new(glam::DVec3::ZERO, glam::DVec3::new(f64::NAN, 0.0, 0.0));
    assert!(b
        .step_with_forces(&model, &mut sparse, 1e-3, &[(3, nan)])
        .is_err());
}

/// The hybrid body against an independent model: the same URDF with the locked joints turned
/// into fixed joints (welded at q = 0), solved by exact DCA.
#[test]
fn hybrid_body_equals_the_model_with_its_locked_joints_welded() {
    for (name, floating) in [
        ("chain30", false),
        ("plant", false),
        ("chain30", true),
        ("plant", true),
    ] {
        let model = load(name, floating);
        let text = articula_testkit::bundled_urdf(name);
        for seed in 0..3u64 {
            let pick = |b: usize| !(b as u64 * 7 + seed).is_multiple_of(3);
            // The final active set (closed upward) first, then a state with the locked joints
            // at q = 0, q̇ = 0 so that welding them at zero is the same body.
            let mut probe = State::random(&model, seed, 0.5);
            let mut ad = caches(Adaptive::new(
                &model,
                Settings {
                    reselect_every: u64::MAX,
                    ..Settings::default()
                },
            ));
            ad.set_active(&model, &mut probe, pick).unwrap();
            let active: Vec<bool> = (0..model.bodies.len())
                .map(|i| ad.is_active(&model, i))
                .collect();
            let mut s = State::random(&model, seed, 0.5);
            s.randomize_forces(seed + 50, 1.0);
            for (i, b) in model.bodies.iter().enumerate() {
                if !active[i] {
                    s.q[b.q_offset] = 0.0;
                    s.qd[b.v_offset] = 0.0;
                }
            }
            assert!(!ad.set_active(&model, &mut s, |b| active[b]).unwrap());
            ad.step(&model, &mut s.clone(), 1e-9).unwrap();
            let hybrid = ad.qdd().to_vec();
            // The welded model.
            let mut welded_text = text.to_string();
            for (i, b) in model.bodies.iter().enumerate() {
                if !active[i] {
                    let name = &b.joint[0].name;
                    welded_text = welded_text.replace(
                        &format!("<joint name=\"{name}\" type=\"revolute\">"),
                        &format!("<joint name=\"{name}\" type=\"fixed\">"),
                    );
                }
            }
            let welded = Model::from_urdf_str(
                &welded_text,
                &LoadOptions::default().with_floating_base(floating),
            )
            .unwrap();
            let mut ws = State::neutral(&welded);
            for (_, part) in model.joint_parts() {
                if let Some((_, wp)) = welded.find_joint(&part.name) {
                    let (n, m) = (part.nq(), part.nv());
                    ws.q[wp.q_offset..wp.q_offset + n]
                        .copy_from_slice(&s.q[part.q_offset..part.q_offset + n]);
                    ws.qd[wp.v_offset..wp.v_offset + m]
                        .copy_from_slice(&s.qd[part.v_offset..part.v_offset + m]);
                    ws.tau[wp.v_offset..wp.v_offset + m]
                        .copy_from_slice(&s.tau[part.v_offset..part.v_offset + m]);
                }
            }
            for (i, b) in model.bodies.iter().enumerate() {
                // A body welded to the ground passes its force to the world.
                if let Some(k) = welded
                    .bodies
                    .iter()
                    .position(|wb| wb.links.iter().any(|(l, _)| *l == b.name))
                {
                    ws.f_ext[k] += s.f_ext[i];
                }
            }
            let e = exact(&welded, &ws);
            let scale = max_abs(&e).max(1.0);
            for (_, part) in model.joint_parts() {
                if let Some((_, wp)) = welded.find_joint(&part.name) {
                    for p in 0..part.nv() {
                        let (h, x) = (hybrid[part.v_offset + p], e[wp.v_offset + p]);
                        assert!(
                            (h - x).abs() <= 1e-9 * scale,
                            "{name} floating {floating} seed {seed} {}: {h} vs {x}",
                            part.name
                        );
                    }
                } else {
                    assert!(hybrid[part.v_offset..part.v_offset + part.nv()]
                        .iter()
                        .all(|x| *x == 0.0));
                }
            }
        }
    }
}

/// `exact_solve` then `scaled_node_metrics` (weights given per body, as a scene classifies
/// them after the solve) equal `set_weight` of every body then `node_metrics` to the bit, and
/// both equal the subtree sums `Σ wᵢ |q̈ᵢ|²` of an independent ABA solve (to rounding).
#[test]
fn scaled_node_metrics_equal_set_weights_then_node_metrics() {
    for (name, model) in models() {
        let nodes = model.assembly.nodes.len();
        let (mut a, mut b) = (
            caches(Adaptive::new(&model, Settings::default())),
            caches(Adaptive::new(&model, Settings::default())),
        );
        for seed in 0..6u64 {
            let s = state(&model, seed);
            // Weights of every kind: zero, tiny, one, large.
            let w: Vec<f64> = (0..model.bodies.len())
                .map(|i| [0.0, 1e-3, 1.0, 37.5, 0.25][(i + seed as usize) % 5])
                .collect();
            for (i, &wi) in w.iter().enumerate() {
                a.set_weight(&model, i, wi);
            }
            let (mut ma, mut mb) = (vec![0.0; nodes], vec![f64::NAN; nodes]);
            a.node_metrics(&model, &s.q, &s.qd, &s.tau, &s.f_ext, &mut ma)
                .unwrap();
            b.exact_solve(&model, &s.q, &s.qd, &s.tau, &s.f_ext)
                .unwrap();
            b.scaled_node_metrics(&model, &w, &mut mb);
            assert!(
                ma.iter().zip(&mb).all(|(x, y)| x.to_bits() == y.to_bits()),
                "{name} seed {seed}: {ma:?} vs {mb:?}"
            );
            // Independent: ABA's accelerations, each join's subtree summed by walking it.
            let qdd = solve(&model, &s, Method::Aba);
            for (n, &got) in mb.iter().enumerate() {
                let mut want = 0.0;
                let mut stack = vec![n];
                while let Some(m) = stack.pop() {
                    if let NodeKind::Join {
                        joint,
                        parent_side,
                        child_side,
                    } = model.assembly.nodes[m].kind
                    {
                        let body = &model.bodies[joint];
                        let x = &qdd[body.v_offset..body.v_offset + body.nv];
                        want += w[joint] * x.iter().map(|v| v * v).sum::<f64>();
                        stack.extend([parent_side, child_side]);
                    }
                }
                assert!(
                    (got - want).abs() <= 1e-9 * want.abs().max(1.0),
                    "{name} seed {seed} node {n}: {got} vs {want}"
                );
            }
        }
    }
}

/// `articula_adaptive::step` takes the arguments of `articula_dca::step` (less the method):
/// with every joint active it follows the exact step of the same integrator (RK4: see
/// `tests/rk4.rs`).
#[test]
fn the_uniform_step_follows_the_exact_euler_step() {
    use articula_dca::Integrator;
    for (name, model) in [
        ("chain30", load("chain30", false)),
        ("humanoid", load("humanoid", false)),
    ] {
        let mut data = Data::new(&model);
        let mut adaptive = caches(Adaptive::new(&model, Settings::default()));
        let start = state(&model, 9);
        let (mut a, mut e) = (start.clone(), start.clone());
        let dt = 1e-3;
        for _ in 0..20 {
            articula_adaptive::step(
                &model,
                &mut adaptive,
                &mut a,
                Integrator::SemiImplicitEuler,
                dt,
            )
            .unwrap();
            articula_dca::step(
                &model,
                &mut data,
                &mut e,
                Method::Dca,
                Integrator::SemiImplicitEuler,
                dt,
            )
            .unwrap();
        }
        let dq = max_diff(&a.q, &e.q);
        let dv = max_diff(&a.qd, &e.qd);
        assert!(
            dq < 1e-10 && dv < 1e-8,
            "{name}: q off by {dq:e}, q̇ by {dv:e}"
        );
        assert_ne!(a.q, start.q);
    }
}

/// A model whose assembly tree has a gather node (a hub with more than `GATHER_ABOVE`
/// children) is refused with `AdaptiveError::Unsupported` naming the hub, by every call that
/// computes (adaptive dynamics has no gather node), while the exact methods solve it.
#[test]
fn gather_trees_are_refused_cleanly() {
    use articula_adaptive::AdaptiveError;
    let k = articula_model::GATHER_ABOVE + 4;
    let urdf = articula_testkit::star_urdf(k);
    let model =
        Model::from_urdf_str(&urdf, &LoadOptions::default().with_floating_base(true)).unwrap();
    assert!(model.assembly.has_gather());
    let mut s = State::random(&model, 3, 1.0);
    let mut adaptive = caches(Adaptive::new(&model, Settings::default()));
    let check = |r: Result<(), AdaptiveError>| match r {
        Err(AdaptiveError::Unsupported(msg)) => {
            assert!(msg.contains("link hub has 20 children"), "{msg}");
        }
        other => panic!("expected Unsupported, got {other:?}"),
    };
    check(
        adaptive
            .forward_dynamics(&model, &s.q, &s.qd, &s.tau, &s.f_ext)
            .map(|_| ()),
    );
    check(adaptive.step(&model, &mut s, 1e-3).map(|_| ()));
    check(adaptive.step_rk4(&model, &mut s, 1e-3).map(|_| ()));
    check(adaptive.reselect(&model, &mut s).map(|_| ()));
    // The exact solvers take it.
    let (dca, aba) = (
        solve(&model, &s, Method::Dca),
        solve(&model, &s, Method::Aba),
    );
    let scale = aba.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let diff = dca
        .iter()
        .zip(&aba)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(diff <= 1e-10 * scale, "{:e}", diff / scale);
}

/// An adaptive workspace used with another model is an error naming both, never a panic: its
/// exact workspace checks the model's fingerprint before anything is read.
#[test]
fn a_workspace_of_another_model_is_refused() {
    let fixed = load("humanoid", false);
    let floating = load("humanoid", true);
    for (built_for, used_with) in [(&fixed, &floating), (&floating, &fixed)] {
        let mut ad = Adaptive::new(built_for, Settings::default());
        let mut s = State::neutral(used_with);
        let e = ad.step(used_with, &mut s, 1e-3).unwrap_err().to_string();
        assert!(e.contains("another model"), "{e}");
        let e = ad
            .forward_dynamics(used_with, &s.q, &s.qd, &s.tau, &s.f_ext)
            .unwrap_err()
            .to_string();
        assert!(e.contains("another model"), "{e}");
    }
}
