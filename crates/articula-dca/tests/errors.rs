//! Bad inputs and blow-ups give the exact `DynamicsError`, naming the URDF joint (or the body,
//! for external forces) — never a panic, never a silent NaN.

use articula_dca::{forward_dynamics_slices, step, Data, DynamicsError, Integrator, Method, State};
use articula_model::{LoadOptions, Model};
use articula_spatial::SpatialForce;
use glam::DVec3;

const METHODS: [Method; 3] = [Method::Dca, Method::Aba, Method::Crba];

fn load(name: &str, floating_base: bool) -> Model {
    articula_testkit::bundled_with(name, floating_base)
}

fn pendulum() -> Model {
    let urdf = r#"<robot name="pendulum"><link name="base"/>
      <link name="bob"><inertial><origin xyz="0 0 -1"/><mass value="1"/>
        <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <joint name="swing" type="continuous"><parent link="base"/><child link="bob"/>
        <axis xyz="0 1 0"/></joint></robot>"#;
    Model::from_urdf_str(urdf, &LoadOptions::default()).unwrap()
}

fn run(
    model: &Model,
    data: &mut Data,
    s: &State,
    method: Method,
) -> Result<Vec<f64>, DynamicsError> {
    forward_dynamics_slices(model, data, &s.q, &s.qd, &s.tau, &s.f_ext, method).map(<[f64]>::to_vec)
}

fn non_finite(what: &'static str, name: &str) -> DynamicsError {
    DynamicsError::NonFinite {
        what,
        name: name.to_string(),
    }
}

fn body_index(model: &Model, name: &str) -> usize {
    model.bodies.iter().position(|b| b.name == name).unwrap()
}

/// Every method on `s` must fail with exactly `expected`.
fn expect_err(model: &Model, s: &State, expected: &DynamicsError) {
    let mut data = Data::new(model);
    for method in METHODS {
        assert_eq!(
            run(model, &mut data, s, method).as_ref(),
            Err(expected),
            "{method:?}"
        );
    }
}

#[test]
fn non_finite_inputs_name_the_joint() {
    for floating_base in [false, true] {
        let model = load("humanoid", floating_base);
        let good = State::random(&model, 1, 1.0);
        // The clean state works (so the errors below come from the poisoned entry).
        let mut data = Data::new(&model);
        for method in METHODS {
            run(&model, &mut data, &good, method).unwrap();
        }
        // l_hip_x is the middle part of the composed hip joint l_hip_z + l_hip_x + l_hip_y:
        // the error names the URDF joint, not the composed body joint.
        let hip_x = model.find_joint("l_hip_x").unwrap().1;
        assert!(
            model.bodies[model.find_joint("l_hip_x").unwrap().0]
                .joint
                .len()
                > 1
        );
        let mut s = good.clone();
        s.q[hip_x.q_offset] = f64::NAN;
        expect_err(&model, &s, &non_finite("q", "l_hip_x"));

        let mut s = good.clone();
        s.qd[model.find_joint("l_knee").unwrap().1.v_offset] = f64::NAN;
        expect_err(&model, &s, &non_finite("qd", "l_knee"));

        let mut s = good.clone();
        s.tau[model.find_joint("r_elbow").unwrap().1.v_offset] = f64::INFINITY;
        expect_err(&model, &s, &non_finite("tau", "r_elbow"));

        let mut s = good.clone();
        s.tau[model.find_joint("neck_y").unwrap().1.v_offset] = f64::NEG_INFINITY;
        expect_err(&model, &s, &non_finite("tau", "neck_y"));

        // An infinite external force names the body (its URDF link).
        let mut s = good.clone();
        s.f_ext[body_index(&model, "l_shank")] =
            SpatialForce::new(DVec3::ZERO, DVec3::new(0.0, f64::INFINITY, 0.0));
        expect_err(&model, &s, &non_finite("external force", "l_shank"));
        let mut s = good.clone();
        s.f_ext[body_index(&model, "r_thigh")] =
            SpatialForce::new(DVec3::new(f64::NAN, 0.0, 0.0), DVec3::ZERO);
        expect_err(&model, &s, &non_finite("external force", "r_thigh"));

        if floating_base {
            // A NaN in the base's quaternion names the floating base.
            let base = model.find_joint("floating_base").unwrap().1;
            let mut s = good.clone();
            s.q[base.q_offset + 5] = f64::NAN;
            expect_err(&model, &s, &non_finite("q", "floating_base"));
            let mut s = good.clone();
            s.qd[base.v_offset + 4] = f64::INFINITY;
            expect_err(&model, &s, &non_finite("qd", "floating_base"));
        }
    }
}

#[test]
fn wrong_lengths_are_dimension_errors() {
    let model = load("humanoid", true);
    let good = State::random(&model, 2, 1.0);
    let (nq, nv, nb) = (model.nq, model.nv, model.bodies.len());
    let dim = |what, expected, found| DynamicsError::Dimension {
        what,
        expected,
        found,
    };
    let mut s = good.clone();
    s.q.pop();
    expect_err(&model, &s, &dim("q", nq, nq - 1));
    let mut s = good.clone();
    s.q.push(0.0);
    expect_err(&model, &s, &dim("q", nq, nq + 1));
    let mut s = good.clone();
    s.qd.push(0.0);
    expect_err(&model, &s, &dim("qd", nv, nv + 1));
    let mut s = good.clone();
    s.tau.clear();
    expect_err(&model, &s, &dim("tau", nv, 0));
    let mut s = good.clone();
    s.f_ext.truncate(1);
    expect_err(&model, &s, &dim("f_ext", nb, 1));
    // nv + 1 = nq: a q-length velocity vector is caught too.
    let mut s = good.clone();
    s.qd = s.q.clone();
    expect_err(&model, &s, &dim("qd", nv, nq));
    // Lengths are checked before values.
    let mut s = good.clone();
    s.q[0] = f64::NAN;
    s.tau.pop();
    expect_err(&model, &s, &dim("tau", nv, nv - 1));
    // An empty f_ext means "no external forces".
    let mut data = Data::new(&model);
    let mut s = good.clone();
    s.f_ext.clear();
    for method in METHODS {
        run(&model, &mut data, &s, method).unwrap();
    }
}

#[test]
fn steps_with_bad_inputs_fail() {
    let model = load("humanoid", true);
    let mut data = Data::new(&model);
    for integrator in [Integrator::SemiImplicitEuler, Integrator::Rk4] {
        let mut s = State::random(&model, 4, 1.0);
        s.qd[model.find_joint("l_toe").unwrap().1.v_offset] = f64::NAN;
        assert_eq!(
            step(&model, &mut data, &mut s, Method::Dca, integrator, 1e-3),
            Err(non_finite("qd", "l_toe"))
        );
    }
}

/// τ = 1e308 on a 0.1 kg link: q̈ overflows inside the solve, and every method reports it as a
/// non-finite q̈. The infinity spreads to every joint through the coupling, and the error names
/// the first joint in coordinate order (`joint1`), not the one that carried the torque.
#[test]
fn enormous_torque_overflows_to_an_error() {
    let model = load("chain10", false);
    let mut data = Data::new(&model);
    let mut s = State::random(&model, 5, 1.0);
    s.tau[model.find_joint("joint4").unwrap().1.v_offset] = 1e308;
    let expected = non_finite("qdd", "joint1");
    for method in METHODS {
        assert_eq!(
            run(&model, &mut data, &s, method),
            Err(expected.clone()),
            "{method:?}"
        );
        for integrator in [Integrator::SemiImplicitEuler, Integrator::Rk4] {
            let mut s2 = s.clone();
            assert_eq!(
                step(&model, &mut data, &mut s2, method, integrator, 1e-3),
                Err(expected.clone()),
                "{method:?} {integrator:?}"
            );
        }
    }
}

/// On a 1 kg bob at 1 m, τ = 1e308 still gives a finite q̈ = τ / (m l² + I) ≈ 1e308 (no
/// error: it is representable); a step of 10 s then overflows q̇ and q. Semi-implicit Euler
/// catches the infinite q after the step; RK4 catches the infinite stage velocity when it
/// checks the next stage's inputs (reported as a non-finite `qd` input). Either way the step
/// fails, naming the joint.
#[test]
fn a_step_that_overflows_is_an_error() {
    let model = pendulum();
    let mut data = Data::new(&model);
    let mut s = State::neutral(&model);
    s.tau[0] = 1e308;
    let expected = 1e308 / (1.0 + 1e-4);
    for method in METHODS {
        let qdd = run(&model, &mut data, &s, method).unwrap()[0];
        // DCA's relative error on this point-like bob is ~4e-12 (it grows as 1/r² of the bob's
        // radius of gyration; see analytic.rs), ABA's and CRBA's ~1e-16.
        assert!(
            (qdd - expected).abs() < 1e-10 * expected,
            "{method:?}: {qdd:e}"
        );
        let mut s2 = s.clone();
        assert_eq!(
            step(
                &model,
                &mut data,
                &mut s2,
                method,
                Integrator::SemiImplicitEuler,
                10.0
            ),
            Err(non_finite("q after the step", "swing")),
            "{method:?}"
        );
        let mut s2 = s.clone();
        assert_eq!(
            step(&model, &mut data, &mut s2, method, Integrator::Rk4, 10.0),
            Err(non_finite("qd", "swing")),
            "{method:?}"
        );
        // A tiny RK4 step: q stays finite, but the weighted sum of the stage accelerations
        // (6 × 1e308) overflows, so q̇ after the step is infinite. That too is an error, not a
        // silent infinity (the step used to check only q).
        let mut s2 = s.clone();
        assert_eq!(
            step(&model, &mut data, &mut s2, method, Integrator::Rk4, 1e-300),
            Err(non_finite("qd after the step", "swing")),
            "{method:?}"
        );
        assert!(s2.q[0].is_finite() && !s2.qd[0].is_finite());
        // Semi-implicit Euler with the same tiny step is fine: q̇ = 1e-300 × 1e308 = 1e8.
        let mut s2 = s.clone();
        step(
            &model,
            &mut data,
            &mut s2,
            method,
            Integrator::SemiImplicitEuler,
            1e-300,
        )
        .unwrap();
        assert!((s2.qd[0] - 1e-300 * expected).abs() < 1e-10 * s2.qd[0]);
    }
}
