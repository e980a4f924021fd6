//! Armature, damping and springs in adaptive dynamics (docs/loading.md#armature-and-damping):
//! with every joint active it is articula-dca's exact dynamics and stepping (armature in the
//! joint-space inertia, passive forces with implicit damping), and with a small budget a
//! locking impulse keeps the free joints' generalized momentum `(M + A) q̇` and a damped body
//! only loses energy. Checked against articula-dca's solvers, its `step`, and its dense mass
//! matrix (which has the armature on its diagonal).

use articula_adaptive::{Adaptive, Reselection, Settings};
use articula_dca::{
    forward_dynamics_slices, forward_kinematics, mass_matrix, step, Data, Integrator, Method, State,
};
use articula_model::{LoadOptions, Model};
use articula_testkit::bundled_with as load;

use articula_testkit::{ARMATURE_MJCF as MJCF, SWIMMER_MJCF as SWIMMER};

/// Per-DOF armature, damping and springs set programmatically on a bundled URDF model (none
/// on a floating base's six coordinates), different on every joint.
fn with_passive(mut model: Model, armature: bool, damping: bool, springs: bool) -> Model {
    let nv = model.nv;
    let base = if model.floating_base { 6 } else { 0 };
    let spread = |lo: f64, step: f64| -> Vec<f64> {
        (0..nv)
            .map(|i| {
                if i < base {
                    0.0
                } else {
                    lo + step * ((i * 7) % 11) as f64
                }
            })
            .collect()
    };
    if armature {
        model.dynamics.armature = spread(0.02, 0.03);
    }
    if damping {
        model.dynamics.damping = spread(0.1, 0.2);
    }
    if springs {
        model.dynamics.stiffness = spread(1.0, 0.5);
        model.dynamics.spring_ref = spread(-0.2, 0.04);
    }
    model
}

/// The models of these tests: chains (one-axis joins), the humanoid (composed joints),
/// floating and fixed, and the two MJCF models.
fn models(damping: bool, springs: bool) -> Vec<(String, Model)> {
    let mut v: Vec<(String, Model)> = [
        ("chain30", false),
        ("chain30", true),
        ("humanoid", false),
        ("humanoid", true),
    ]
    .iter()
    .map(|&(n, f)| {
        let m = with_passive(load(n, f), true, damping, springs);
        (format!("{n}{}", if f { " floating" } else { "" }), m)
    })
    .collect();
    for (name, text) in [("mjcf", MJCF), ("swimmer", SWIMMER)] {
        let mut m = Model::from_mjcf_str(text, &LoadOptions::default()).unwrap();
        assert!(m.dynamics.has_armature(), "{name}");
        // The swimmer has armature only: damping and springs set as on the URDF models.
        if damping && m.dynamics.damping.is_empty() {
            m = with_passive(m, false, true, false);
        }
        if springs && m.dynamics.stiffness.is_empty() {
            m = with_passive(m, false, false, true);
        }
        if !damping {
            m.dynamics.damping.clear();
        }
        if !springs {
            m.dynamics.stiffness.clear();
            m.dynamics.spring_ref.clear();
        }
        v.push((name.to_string(), m));
    }
    v
}

fn max_rel(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(1.0f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

/// Every joint active (no budget): adaptive forward dynamics is the exact `(M + A) q̈ = τ − b`
/// of articula-dca's DCA and ABA, through the main pass's joins; and a step's hybrid pass (the
/// reduced tree's articulated-body algorithm) gives the same `q̈`.
#[test]
fn all_active_forward_dynamics_with_armature_is_exact() {
    let mut worst = 0.0f64;
    for (name, model) in models(false, false) {
        assert!(model.dynamics.has_armature());
        // The same model without armature: the armature must change the answer.
        let mut rigid = model.clone();
        rigid.dynamics = Default::default();
        for seed in 0..4 {
            let mut s = State::random(&model, seed, 2.0);
            s.randomize_forces(seed ^ 0x33, 3.0);
            let mut ad = Adaptive::new(&model, Settings::default());
            let got = ad
                .forward_dynamics(&model, &s.q, &s.qd, &s.tau, &s.f_ext)
                .unwrap()
                .to_vec();
            assert_eq!(ad.selection().active_dofs, model.nv);
            for method in [Method::Dca, Method::Aba] {
                let mut data = Data::new(&model);
                let exact = forward_dynamics_slices(
                    &model, &mut data, &s.q, &s.qd, &s.tau, &s.f_ext, method,
                )
                .unwrap()
                .to_vec();
                let e = max_rel(&got, &exact);
                worst = worst.max(e);
                assert!(e < 1e-10, "{name} seed {seed} {method:?}: {e:e}");
            }
            let mut rd = Data::new(&rigid);
            let without = forward_dynamics_slices(
                &rigid,
                &mut rd,
                &s.q,
                &s.qd,
                &s.tau,
                &s.f_ext,
                Method::Aba,
            )
            .unwrap()
            .to_vec();
            assert!(
                max_rel(&got, &without) > 1e-4,
                "{name}: armature changed nothing"
            );
            // The hybrid step's q̈ (reduced-tree ABA over every joint), no passive forces.
            let mut s2 = s.clone();
            let mut ad = Adaptive::new(&model, Settings::default());
            ad.step(&model, &mut s2, 1e-3).unwrap();
            let e = max_rel(ad.qdd(), &got);
            worst = worst.max(e);
            assert!(e < 1e-10, "{name} seed {seed} hybrid step: {e:e}");
        }
    }
    eprintln!("all active, armature: worst relative q̈ difference to DCA/ABA {worst:.2e}");
}

/// Every joint active, armature + damping + springs: 300 adaptive steps are articula-dca's
/// steps (`τ + passive(q, q̇)`, damping implicit over the step in semi-implicit Euler,
/// explicit in RK4) to 1e-10; the same steps without the passive forces drift away.
#[test]
fn all_active_stepping_with_damping_and_springs_is_the_exact_step() {
    let mut worst = 0.0f64;
    for (name, model) in models(true, true) {
        assert!(model.dynamics.has_passive());
        for integrator in [Integrator::SemiImplicitEuler, Integrator::Rk4] {
            let start = {
                let mut s = State::random(&model, 17, 1.0);
                s.tau
                    .iter_mut()
                    .enumerate()
                    .for_each(|(i, t)| *t = 0.3 * (i as f64).sin());
                s
            };
            let (mut a, mut e) = (start.clone(), start.clone());
            let mut ad = Adaptive::new(&model, Settings::default());
            let mut data = Data::new(&model);
            // (articula-dca's momentum projection has no adaptive counterpart.)
            data.momentum_projection = false;
            let dt = 1e-3;
            for k in 0..300 {
                articula_adaptive::step(&model, &mut ad, &mut a, integrator, dt).unwrap();
                step(&model, &mut data, &mut e, Method::Dca, integrator, dt).unwrap();
                let dq = max_rel(&a.q, &e.q);
                let dv = max_rel(&a.qd, &e.qd);
                worst = worst.max(dq).max(dv);
                assert!(
                    dq < 1e-10 && dv < 1e-10,
                    "{name} {integrator:?} step {k}: q {dq:e}, qd {dv:e}"
                );
            }
            // Without the passive forces the motion is another one.
            let mut rigid = model.clone();
            rigid.dynamics.damping.clear();
            rigid.dynamics.stiffness.clear();
            rigid.dynamics.spring_ref.clear();
            let mut r = start.clone();
            let mut rd = Data::new(&rigid);
            rd.momentum_projection = false;
            for _ in 0..300 {
                step(&rigid, &mut rd, &mut r, Method::Dca, integrator, dt).unwrap();
            }
            assert!(
                max_rel(&r.qd, &e.qd) > 1e-3,
                "{name}: passive forces did nothing"
            );
        }
    }
    eprintln!(
        "all active, 300 steps with passive forces: worst relative q, q̇ difference {worst:.2e}"
    );
}

/// `(M + A)` of articula-dca's dense mass matrix (armature on its diagonal).
fn inertia_matrix(model: &Model, q: &[f64]) -> Vec<f64> {
    let mut data = Data::new(model);
    mass_matrix(model, &mut data, q).unwrap().to_vec()
}

fn mul(m: &[f64], x: &[f64]) -> Vec<f64> {
    let n = x.len();
    (0..n)
        .map(|r| (0..n).map(|c| m[r * n + c] * x[c]).sum())
        .collect()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// A locking impulse with armature keeps the generalized momentum `(M + A) q̇` of every joint
/// that stays free (hence a floating base's spatial momentum), zeroes the locked joints'
/// velocities and lowers the kinetic energy `½ q̇ᵀ (M + A) q̇`: checked on the dense
/// `M + A`, by both re-selection routes (whole-body passes, and the caches of the rigid
/// subassemblies from the second re-selection on).
#[test]
fn rigidification_with_armature_keeps_generalized_momentum() {
    for (name, model) in models(false, false) {
        for budget in [0, 1, 3, 8] {
            for how in [Reselection::ExactSolve, Reselection::Caches] {
                let mut s = State::random(&model, 400 + budget as u64, 0.0);
                s.tau.fill(0.0);
                let mut ad = Adaptive::new(
                    &model,
                    Settings {
                        budget: Some(budget),
                        reselect_every: 1,
                        ..Settings::default()
                    },
                );
                ad.set_reselection(how);
                for round in 0..3 {
                    let h = inertia_matrix(&model, &s.q);
                    let p0 = mul(&h, &s.qd);
                    let k0 = 0.5 * dot(&s.qd, &p0);
                    let before = s.qd.clone();
                    // A step's re-selection locks; compare at the state right after the
                    // impulse (q unchanged): step with dt = 0.
                    let report = ad.step(&model, &mut s, 0.0).unwrap();
                    assert!(report.reselected);
                    let p1 = mul(&h, &s.qd);
                    let k1 = 0.5 * dot(&s.qd, &p1);
                    let scale = p0.iter().fold(1e-300f64, |m, x| m.max(x.abs()));
                    for (i, b) in model.bodies.iter().enumerate() {
                        let r = b.v_offset..b.v_offset + b.nv;
                        if ad.is_active(&model, i) {
                            for v in r {
                                let e = (p1[v] - p0[v]).abs() / scale;
                                assert!(
                                    e < 1e-11,
                                    "{name} budget {budget} {how:?} round {round} dof {v}: \
                                     momentum change {e:e}"
                                );
                            }
                        } else {
                            assert!(s.qd[r].iter().all(|x| *x == 0.0));
                        }
                    }
                    assert!(k1 <= k0 * (1.0 + 1e-12), "{name} {budget}: {k1} > {k0}");
                    if round == 0 && before.iter().zip(&s.qd).any(|(x, y)| x != y) {
                        assert!(k1 < k0, "{name} {budget}: locking must dissipate");
                    }
                    // New velocities on some free joints for the next round (the locked ones
                    // stay at rest: the caches hold them).
                    for (i, b) in model.bodies.iter().enumerate() {
                        if ad.is_active(&model, i) && i % 2 == round % 2 {
                            for v in b.v_offset..b.v_offset + b.nv {
                                s.qd[v] += 0.5;
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Kinetic plus spring-free potential energy with gravity off: `½ q̇ᵀ (M + A) q̇`.
fn kinetic(model: &Model, s: &State) -> f64 {
    let h = inertia_matrix(model, &s.q);
    0.5 * dot(&s.qd, &mul(&h, &s.qd))
}

/// A small budget on a damped body with armature and no gravity, no τ, no springs: the
/// kinetic energy `½ q̇ᵀ (M + A) q̇` never grows from step to step (damping and locking only
/// take energy out), by both re-selection routes and both integrators, and it falls below
/// its start.
#[test]
fn a_damped_body_with_a_small_budget_only_loses_energy() {
    for (name, model) in models(true, false) {
        for how in [Reselection::ExactSolve, Reselection::Caches] {
            for integrator in [Integrator::SemiImplicitEuler, Integrator::Rk4] {
                let mut s = State::random(&model, 23, 0.0);
                s.tau.fill(0.0);
                let mut ad = Adaptive::new(
                    &model,
                    Settings {
                        budget: Some(3),
                        reselect_every: 5,
                        ..Settings::default()
                    },
                );
                ad.data.gravity = glam::DVec3::ZERO;
                ad.set_reselection(how);
                let e0 = kinetic(&model, &s);
                let mut last = e0;
                for k in 0..400 {
                    articula_adaptive::step(&model, &mut ad, &mut s, integrator, 1e-3).unwrap();
                    let e = kinetic(&model, &s);
                    assert!(
                        e <= last * (1.0 + 1e-9),
                        "{name} {how:?} {integrator:?} step {k}: {e} > {last}"
                    );
                    last = e;
                }
                // (A floating body keeps the energy of its momentum, which no joint damps.)
                let fall = if model.floating_base { 0.99 } else { 0.9 };
                assert!(
                    last < fall * e0,
                    "{name} {how:?} {integrator:?}: {last} vs {e0}"
                );
            }
        }
    }
}

/// Springs on locked joints are internal forces of rigid clusters: between re-selections
/// the locked joints keep `q̇ = 0` and their `q` however hard their springs pull.
#[test]
fn springs_on_locked_joints_move_nothing() {
    let model = with_passive(load("chain30", false), true, true, true);
    let mut s = State::random(&model, 5, 1.0);
    let mut ad = Adaptive::new(
        &model,
        Settings {
            budget: Some(4),
            reselect_every: 50,
            ..Settings::default()
        },
    );
    ad.step(&model, &mut s, 1e-3).unwrap();
    let locked: Vec<usize> = (0..model.bodies.len())
        .filter(|&i| !ad.is_active(&model, i))
        .collect();
    assert!(locked.len() > 20);
    let q = s.q.clone();
    for _ in 0..40 {
        ad.step(&model, &mut s, 1e-3).unwrap();
    }
    for &i in &locked {
        let b = &model.bodies[i];
        assert_eq!(s.qd[b.v_offset], 0.0);
        assert_eq!(s.q[b.q_offset], q[b.q_offset]);
    }
    let mut data = Data::new(&model);
    forward_kinematics(&model, &s.q, &s.qd, &mut data).unwrap();
    assert!(data.kinetic_energy().is_finite());
}

/// With armature and a budget, the predicted error (the metric left in the queue, from the
/// joins' Ψ, p, η) is the actual `Σ (q̈ − q̈_exact)²` against articula-dca's DCA with armature,
/// and it never grows with the budget.
#[test]
fn the_predicted_error_with_armature_is_the_actual_error() {
    for (name, model) in models(false, false) {
        let internal = model.nv - if model.floating_base { 6 } else { 0 };
        for seed in 0..3 {
            let mut s = State::random(&model, 50 + seed, 2.0);
            s.randomize_forces(seed, 2.0);
            let mut data = Data::new(&model);
            let exact = forward_dynamics_slices(
                &model,
                &mut data,
                &s.q,
                &s.qd,
                &s.tau,
                &s.f_ext,
                Method::Dca,
            )
            .unwrap()
            .to_vec();
            let mut last = f64::INFINITY;
            let mut budgets = vec![0, 1, 2, 4, internal / 2, internal];
            budgets.sort_unstable();
            budgets.dedup();
            for budget in budgets {
                let mut ad = Adaptive::new(
                    &model,
                    Settings {
                        budget: Some(budget),
                        ..Settings::default()
                    },
                );
                let qdd = ad
                    .forward_dynamics(&model, &s.q, &s.qd, &s.tau, &s.f_ext)
                    .unwrap()
                    .to_vec();
                let sel = ad.selection().clone();
                let actual: f64 = qdd.iter().zip(&exact).map(|(a, e)| (a - e).powi(2)).sum();
                assert!(
                    (sel.predicted_error - actual).abs() <= 1e-8 * sel.total_metric,
                    "{name} seed {seed} budget {budget}: predicted {:e}, actual {actual:e}",
                    sel.predicted_error
                );
                assert!(
                    actual <= last * (1.0 + 1e-9) + 1e-12 * sel.total_metric,
                    "{name} seed {seed} budget {budget}: {actual:e} > {last:e}"
                );
                last = actual;
            }
            assert!(last <= 1e-18 * (1.0 + exact.iter().map(|x| x * x).sum::<f64>()));
        }
    }
}

/// The two re-selection routes (an exact whole-body solve; the caches of the rigid
/// subassemblies) choose the same hybrid bodies with armature, damping and springs, side by
/// side for 60 steps re-selecting every 1 and 3 steps: the same active DOFs and predicted
/// errors (1e-9 of the total metric) and the same trajectory (1e-9).
#[test]
fn both_reselection_routes_agree_with_passive_dynamics() {
    for (name, model) in models(true, true) {
        for every in [1, 3] {
            let mut start = State::random(&model, 31, 1.0);
            start.f_ext.clear();
            let settings = Settings {
                budget: Some(4),
                reselect_every: every,
                ..Settings::default()
            };
            let mut cached = Adaptive::new(&model, settings.clone());
            cached.set_reselection(Reselection::Caches);
            let mut exact = Adaptive::new(&model, settings);
            exact.set_reselection(Reselection::ExactSolve);
            let (mut a, mut b) = (start.clone(), start.clone());
            for k in 0..60 {
                let ra = cached.step(&model, &mut a, 1e-3).unwrap();
                let rb = exact.step(&model, &mut b, 1e-3).unwrap();
                assert_eq!(
                    ra.active_dofs, rb.active_dofs,
                    "{name} every {every} step {k}"
                );
                let scale = cached.selection().total_metric.max(1e-300);
                let (pa, pb) = (ra.predicted_error, rb.predicted_error);
                assert!(
                    (pa - pb).abs() <= 1e-9 * scale,
                    "{name} every {every} step {k}: predicted {pa:e} vs {pb:e}"
                );
            }
            let (dq, dv) = (max_rel(&a.q, &b.q), max_rel(&a.qd, &b.qd));
            assert!(
                dq < 1e-9 && dv < 1e-9,
                "{name} every {every}: q {dq:e}, qd {dv:e}"
            );
        }
    }
}
