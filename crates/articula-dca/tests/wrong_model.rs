//! A workspace used with another model (issue 39, item 5): every entry point returns
//! `DynamicsError::WrongModel` naming both models' sizes — never an index out of bounds.

use articula_dca::{
    bias_forces, forward_dynamics, forward_dynamics_threads, forward_kinematics, inverse_dynamics,
    mass_matrix, step, step_with_contact, Batch, ContactData, ContactError, ContactSettings, Data,
    DynamicsError, Ground, Integrator, Method, ReferenceFrame, State, Threads,
};
use articula_model::Model;

fn models() -> (Model, Model) {
    (
        articula_testkit::bundled_with("humanoid", false),
        articula_testkit::bundled_with("humanoid", true),
    )
}

fn assert_wrong(r: Result<impl Sized, DynamicsError>, what: &str) {
    match r {
        Err(DynamicsError::WrongModel { data, model }) => {
            assert_ne!(data, model, "{what}");
            assert!(
                data.contains("bodies") && model.contains("bodies"),
                "{what}"
            );
        }
        Err(e) => panic!("{what}: expected WrongModel, got {e}"),
        Ok(_) => panic!("{what}: expected WrongModel, got a result"),
    }
}

#[test]
fn every_entry_point_refuses_another_models_data() {
    let (fixed, floating) = models();
    let s = State::neutral(&fixed);
    for (model, other) in [(&fixed, &floating), (&floating, &fixed)] {
        let s = State::neutral(model);
        let mut data = Data::new(other);
        for m in [Method::Dca, Method::Aba, Method::Crba] {
            assert_wrong(
                forward_dynamics(model, &mut data, &s, m),
                "forward_dynamics",
            );
        }
        let threads = Threads::new(2).unwrap();
        assert_wrong(
            forward_dynamics_threads(
                model,
                &mut data,
                &s.q,
                &s.qd,
                &s.tau,
                &[],
                Method::Dca,
                &threads,
            ),
            "forward_dynamics_threads",
        );
        let zero = vec![0.0; model.nv];
        assert_wrong(
            inverse_dynamics(model, &mut data, &s.q, &s.qd, &zero, &[]),
            "inverse_dynamics",
        );
        assert_wrong(bias_forces(model, &mut data, &s.q, &s.qd), "bias_forces");
        assert_wrong(mass_matrix(model, &mut data, &s.q), "mass_matrix");
        assert_wrong(
            forward_kinematics(model, &s.q, &s.qd, &mut data),
            "forward_kinematics",
        );
        let link = model.find_link("l_foot").unwrap();
        for frame in [ReferenceFrame::World, ReferenceFrame::Local] {
            assert_wrong(data.link_jacobian(model, &link, frame), "link_jacobian");
        }
        assert_wrong(
            data.point_jacobian(model, &link, glam::DVec3::X),
            "point_jacobian",
        );
        assert_wrong(data.com_jacobian(model), "com_jacobian");
        for integrator in [Integrator::SemiImplicitEuler, Integrator::Rk4] {
            let mut st = s.clone();
            assert_wrong(
                step(model, &mut data, &mut st, Method::Dca, integrator, 1e-3),
                "step",
            );
        }
    }
    // Same model, another workspace of it: fine.
    let mut data = Data::new(&fixed);
    assert!(forward_dynamics(&fixed, &mut data, &s, Method::Dca).is_ok());
}

/// Kinematics checks its inputs as the dynamics does, and a link frame of a model with more
/// bodies than this one is refused by the Jacobians and the link pose: errors, never an index
/// out of bounds.
#[test]
fn kinematics_and_jacobians_refuse_bad_inputs_and_foreign_links() {
    let (fixed, _) = models();
    let chain = articula_testkit::bundled_with("chain10", false);
    let mut data = Data::new(&chain);
    let s = State::neutral(&chain);
    match forward_kinematics(&chain, &s.q[1..], &s.qd, &mut data) {
        Err(DynamicsError::Dimension { what: "q", .. }) => {}
        other => panic!("expected a q dimension error, got {other:?}"),
    }
    let mut nan = s.q.clone();
    nan[3] = f64::NAN;
    match forward_kinematics(&chain, &nan, &s.qd, &mut data) {
        Err(DynamicsError::NonFinite { what: "q", .. }) => {}
        other => panic!("expected a non-finite q error, got {other:?}"),
    }
    forward_kinematics(&chain, &s.q, &s.qd, &mut data).unwrap();
    // The humanoid's foot is on a body index the 10-link chain does not have.
    let foot = fixed.find_link("l_foot").unwrap();
    assert!(foot.body.unwrap() >= chain.bodies.len());
    match data.link_jacobian(&chain, &foot, ReferenceFrame::World) {
        Err(DynamicsError::WrongLink { body, bodies }) => {
            assert_eq!((body, bodies), (foot.body.unwrap(), chain.bodies.len()))
        }
        other => panic!("expected WrongLink, got {other:?}"),
    }
    assert!(data.point_jacobian(&chain, &foot, glam::DVec3::X).is_err());
    assert_eq!(
        data.link_pose(&foot),
        Err(DynamicsError::WrongLink {
            body: foot.body.unwrap(),
            bodies: chain.bodies.len()
        })
    );
    // The chain's own last link: its pose, the chain hanging straight down the z axis.
    let tip = chain.find_link(&chain.bodies.last().unwrap().name).unwrap();
    let (_, p) = data.link_pose(&tip).unwrap();
    assert!(
        p.is_finite() && p.x.abs() < 1e-12 && p.y.abs() < 1e-12,
        "{p}"
    );
}

#[test]
fn contact_and_batch_refuse_another_models_workspace() {
    let (fixed, floating) = models();
    let settings = ContactSettings {
        ground: Some(Ground::horizontal(0.0)),
        ..ContactSettings::default()
    };
    // A ContactData of the other model, with a right Data.
    let mut s = State::neutral(&floating);
    s.q[2] = 1.2;
    let mut data = Data::new(&floating);
    let mut contact = ContactData::new(&fixed);
    match step_with_contact(
        &floating,
        &mut data,
        &mut contact,
        &mut s,
        Method::Dca,
        1e-3,
        &settings,
    ) {
        Err(ContactError::Dynamics(DynamicsError::WrongModel { data, .. })) => {
            assert!(data.starts_with("ContactData"), "{data}")
        }
        other => panic!("expected WrongModel, got {other:?}"),
    }
    // A batch built for the other model: every state's error, the first reported.
    let mut batch = Batch::new(&fixed, Threads::new(1).unwrap());
    let states = vec![State::neutral(&floating); 3];
    let mut out = vec![0.0; 3 * floating.nv];
    let e = batch
        .forward_dynamics(&floating, &states, Method::Dca, &mut out)
        .unwrap_err();
    assert!(e.to_string().contains("another model"), "{e}");
}

#[test]
fn contact_iterations_are_capped() {
    let (_, floating) = models();
    let settings = ContactSettings {
        ground: Some(Ground::horizontal(0.0)),
        max_iterations: articula_dca::CONTACT_MAX_ITERATIONS + 1,
        ..ContactSettings::default()
    };
    let mut s = State::neutral(&floating);
    s.q[2] = 1.2;
    let mut data = Data::new(&floating);
    let mut contact = ContactData::new(&floating);
    let e = step_with_contact(
        &floating,
        &mut data,
        &mut contact,
        &mut s,
        Method::Dca,
        1e-3,
        &settings,
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            ContactError::Invalid {
                what: "max_iterations",
                ..
            }
        ),
        "{e}"
    );
}
