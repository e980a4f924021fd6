//! The adaptive RK4 step against articula-dca's RK4 step (every joint active), against RK4 on
//! an independent model (the hybrid body's locked joints welded), and against semi-implicit
//! Euler on energy conservation.

use articula_adaptive::{Adaptive, Settings};
use articula_dca::{forward_kinematics, Data, Integrator, Method, State};
use articula_model::{LoadOptions, Model};
use articula_testkit::bundled_with as load;

/// A workspace re-selecting through the caches (what these tests exercise; the library's
/// default route is `Reselection::ExactSolve`).
fn caches(mut ad: Adaptive) -> Adaptive {
    ad.set_reselection(articula_adaptive::Reselection::Caches);
    ad
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// Twenty exact RK4 steps (no momentum projection: adaptive dynamics has none).
fn exact_rk4(model: &Model, s: &mut State, steps: usize, dt: f64) {
    let mut data = Data::new(model);
    data.momentum_projection = false;
    for _ in 0..steps {
        articula_dca::step(model, &mut data, s, Method::Dca, Integrator::Rk4, dt).unwrap();
    }
}

/// With every joint active (no budget, no tolerance) the adaptive RK4 step is the exact one:
/// chains and the humanoid, fixed and floating (the floating base by the Munthe-Kaas stages),
/// with torques and external forces. Euler is far from both (the comparison can fail).
#[test]
fn full_budget_rk4_equals_exact_rk4() {
    for (name, floating) in [
        ("chain30", false),
        ("chain30", true),
        ("humanoid", false),
        ("humanoid", true),
    ] {
        let model = load(name, floating);
        let mut start = State::random(&model, 11, 2.0);
        start.randomize_forces(3, 2.0);
        let dt = 1e-3;
        let mut e = start.clone();
        exact_rk4(&model, &mut e, 20, dt);
        let mut ad = caches(Adaptive::new(&model, Settings::default()));
        let (mut a, mut euler) = (start.clone(), start.clone());
        for _ in 0..20 {
            let r = articula_adaptive::step(&model, &mut ad, &mut a, Integrator::Rk4, dt).unwrap();
            assert_eq!(r.active_dofs, model.nv);
        }
        let mut ad_euler = caches(Adaptive::new(&model, Settings::default()));
        for _ in 0..20 {
            ad_euler.step(&model, &mut euler, dt).unwrap();
        }
        let (dq, dv) = (max_diff(&a.q, &e.q), max_diff(&a.qd, &e.qd));
        assert!(
            dq < 1e-10 && dv < 1e-9,
            "{name} floating {floating}: q off by {dq:e}, q̇ by {dv:e}"
        );
        let euler_off = max_diff(&euler.q, &e.q);
        assert!(
            euler_off > 1e3 * dq.max(1e-12),
            "{name} floating {floating}: Euler {euler_off:e} vs RK4 {dq:e}"
        );
    }
}

/// A hybrid body kept over the steps (locked joints at q = 0, q̇ = 0) against exact RK4 on
/// the same URDF with those joints turned into fixed joints: the same trajectory of the free
/// joints, and the locked ones do not move.
#[test]
fn rk4_of_a_hybrid_body_equals_rk4_of_the_welded_model() {
    for (name, floating) in [("chain30", false), ("chain30", true), ("plant", true)] {
        let model = load(name, floating);
        let pick = |b: usize| !(b * 7 + 1).is_multiple_of(3);
        let mut s = State::random(&model, 5, 0.5);
        s.randomize_forces(8, 1.0);
        let mut ad = caches(Adaptive::new(
            &model,
            Settings {
                reselect_every: u64::MAX,
                ..Settings::default()
            },
        ));
        // The active set (closed upward), then the locked joints at rest at zero.
        ad.set_active(&model, &mut s.clone(), pick).unwrap();
        let active: Vec<bool> = (0..model.bodies.len())
            .map(|i| ad.is_active(&model, i))
            .collect();
        assert!(active.iter().filter(|a| !**a).count() >= 5, "{name}");
        for (i, b) in model.bodies.iter().enumerate() {
            if !active[i] {
                s.q[b.q_offset] = 0.0;
                s.qd[b.v_offset] = 0.0;
            }
        }
        assert!(!ad.set_active(&model, &mut s, |b| active[b]).unwrap());
        let mut text = articula_testkit::bundled_urdf(name).to_string();
        for (i, b) in model.bodies.iter().enumerate() {
            if !active[i] {
                let joint = &b.joint[0].name;
                text = text.replace(
                    &format!("<joint name=\"{joint}\" type=\"revolute\">"),
                    &format!("<joint name=\"{joint}\" type=\"fixed\">"),
                );
            }
        }
        let welded =
            Model::from_urdf_str(&text, &LoadOptions::default().with_floating_base(floating))
                .unwrap();
        assert!(welded.nv < model.nv, "{name}: joints welded");
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
            if let Some(k) = welded
                .bodies
                .iter()
                .position(|wb| wb.links.iter().any(|(l, _)| *l == b.name))
            {
                ws.f_ext[k] += s.f_ext[i];
            }
        }
        let dt = 2e-3;
        for _ in 0..20 {
            let r = ad.step_rk4(&model, &mut s, dt).unwrap();
            assert!(!r.reselected);
        }
        exact_rk4(&welded, &mut ws, 20, dt);
        for (_, part) in model.joint_parts() {
            let (q, qd) = (
                &s.q[part.q_offset..part.q_offset + part.nq()],
                &s.qd[part.v_offset..part.v_offset + part.nv()],
            );
            if let Some((_, wp)) = welded.find_joint(&part.name) {
                let wq = &ws.q[wp.q_offset..wp.q_offset + part.nq()];
                let wqd = &ws.qd[wp.v_offset..wp.v_offset + part.nv()];
                let (dq, dv) = (max_diff(q, wq), max_diff(qd, wqd));
                assert!(
                    dq < 1e-10 && dv < 1e-8,
                    "{name} floating {floating} {}: q off by {dq:e}, q̇ by {dv:e}",
                    part.name
                );
            } else {
                assert!(q.iter().chain(qd).all(|x| *x == 0.0), "{}", part.name);
            }
        }
    }
}

/// Total energy `T + V` of a state.
fn energy(model: &Model, s: &State) -> f64 {
    let mut data = Data::new(model);
    forward_kinematics(model, &s.q, &s.qd, &mut data).unwrap();
    data.kinetic_energy() + data.potential_energy()
}

/// Largest relative change of `T + V` over one second after the first step (whose locking
/// impulse removes energy), with a budget of ten joints and no re-selection after it.
fn energy_drift(model: &Model, start: &State, integrator: Integrator, dt: f64) -> f64 {
    let settings = Settings {
        budget: Some(10),
        reselect_every: u64::MAX,
        ..Settings::default()
    };
    let mut ad = caches(Adaptive::new(model, settings));
    let mut s = start.clone();
    let r = articula_adaptive::step(model, &mut ad, &mut s, integrator, dt).unwrap();
    assert!(r.rigidified && r.active_dofs == 10, "{r:?}");
    let e0 = energy(model, &s);
    let mut drift = 0.0f64;
    for _ in 1..(1.0 / dt).round() as usize {
        let r = articula_adaptive::step(model, &mut ad, &mut s, integrator, dt).unwrap();
        assert!(!r.reselected);
        drift = drift.max((energy(model, &s) - e0).abs() / e0.abs());
    }
    drift
}

/// A conservative chain (no torques, no external forces) with a budget of ten joints: after
/// the first step's locking impulse the hybrid body is conservative. RK4 keeps its energy far
/// better than semi-implicit Euler at the same time step, and its drift falls with the step as
/// a high-order method's (measured: 2.0e-4 at 1 ms, 7.1e-6 at 0.5 ms; Euler 4.8e-2 at 0.5 ms).
#[test]
fn rk4_drifts_less_in_energy_than_euler_under_a_budget() {
    let model = load("chain30", false);
    // Released from random angles, slowly moving: a stiff whip of 0.1 m links all the same.
    let mut start = State::random(&model, 21, 0.0);
    start.qd.iter_mut().for_each(|v| *v *= 0.2);
    let euler = energy_drift(&model, &start, Integrator::SemiImplicitEuler, 5e-4);
    let rk4 = energy_drift(&model, &start, Integrator::Rk4, 5e-4);
    let rk4_coarse = energy_drift(&model, &start, Integrator::Rk4, 1e-3);
    assert!(
        rk4 < 1e-3 * euler && rk4_coarse > 8.0 * rk4,
        "relative energy drift over 1 s: Euler {euler:e}, RK4 {rk4:e} (1 ms: {rk4_coarse:e})"
    );
}

/// A step whose stages overflow is an error naming the joint, and leaves the state as it was.
#[test]
fn a_failing_rk4_step_is_an_error() {
    let model = load("chain30", false);
    let mut s = State::random(&model, 2, 0.5);
    let mut ad = caches(Adaptive::new(&model, Settings::default()));
    // A huge time step makes the stages' velocities overflow.
    s.qd[3] = 1e300;
    let before = s.clone();
    let err = ad.step_rk4(&model, &mut s, 1e300).unwrap_err();
    assert!(err.to_string().contains("non-finite"), "{err}");
    assert_eq!(s, before);
}
