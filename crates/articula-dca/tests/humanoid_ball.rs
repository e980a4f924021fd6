//! The ball-joint humanoid (models/humanoid_ball.xml) passes through the poses where the
//! composed neck of models/humanoid.urdf locks: its neck turns through 90° and beyond while it
//! falls freely, every step succeeds, and the energy stays constant.

use articula_dca::{forward_dynamics, forward_kinematics, step, Data, Integrator, Method, State};
use articula_model::{JointKind, LoadOptions, Model};
use articula_testkit::rel_error;

fn model(file: &str, floating_base: bool) -> Model {
    let path = format!("{}/../../models/{file}", env!("CARGO_MANIFEST_DIR"));
    Model::from_file(
        &path,
        &LoadOptions::default().with_floating_base(floating_base),
    )
    .unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// The model as documented: 16 bodies, 10 ball joints, 5 hinges, a free root, 69.5 kg.
#[test]
fn humanoid_ball_loads() {
    let m = model("humanoid_ball.xml", true);
    assert!(m.floating_base);
    assert_eq!(m.bodies.len(), 16);
    let count = |k: JointKind| m.joint_parts().filter(|(_, p)| p.kind == k).count();
    assert_eq!(count(JointKind::Ball), 10);
    assert_eq!(
        m.joint_parts().filter(|(_, p)| p.kind.is_hinge()).count(),
        5
    );
    assert_eq!((m.nq, m.nv), (7 + 40 + 5, 6 + 30 + 5));
    assert!((m.moving_mass() - 69.5).abs() < 1e-9, "{}", m.moving_mass());
}

/// The neck of the URDF humanoid (z, x, y hinges through massless links) loses a degree of
/// freedom at neck_x = 90°; the ball neck at the same head orientation does not: DCA, ABA and
/// CRBA (a Cholesky factorisation of M) agree there to 1e-10.
#[test]
fn ball_neck_has_no_lock_where_the_composed_neck_does() {
    let urdf = model("humanoid.urdf", true);
    let (b, _) = urdf.find_joint("neck_x").unwrap();
    let mut q = urdf.neutral_q();
    q[urdf.find_joint("neck_x").unwrap().1.q_offset] = std::f64::consts::FRAC_PI_2;
    let volume = urdf.bodies[b].euler_axes_volume(&q).unwrap();
    assert!(
        volume < 1e-12,
        "composed neck at 90°: axes volume {volume:e}"
    );

    let m = model("humanoid_ball.xml", true);
    let mut data = Data::new(&m);
    let neck = m.find_joint("neck").unwrap().1.q_offset;
    for angle in [90.0f64, 135.0, 180.0, 270.0] {
        let mut s = State::random(&m, 1, 1.0);
        let h = angle.to_radians() / 2.0;
        s.q[neck..neck + 4].copy_from_slice(&[h.cos(), h.sin(), 0.0, 0.0]);
        let mut solve = |method| {
            forward_dynamics(&m, &mut data, &s, method)
                .unwrap()
                .to_vec()
        };
        let (dca, aba, crba) = (solve(Method::Dca), solve(Method::Aba), solve(Method::Crba));
        let e = rel_error(&dca, &aba).max(rel_error(&dca, &crba));
        assert!(e < 1e-10, "neck at {angle}°: methods differ by {e:e}");
    }
}

/// Falling freely with the neck spinning about the head's x axis (sideways tilt) at 6 rad/s:
/// 2 s of RK4 steps at dt = 1e-3 take the neck through 90° and beyond, every step succeeds,
/// and the total energy (kinetic + potential) stays within 1e-6 of its scale.
#[test]
fn neck_turns_through_ninety_degrees_and_energy_is_conserved() {
    let m = model("humanoid_ball.xml", true);
    let mut data = Data::new(&m);
    let mut s = State::neutral(&m);
    let neck = m.find_joint("neck").unwrap().1;
    let (nq, nv) = (neck.q_offset, neck.v_offset);
    s.qd[nv] = 6.0;
    s.qd[nv + 2] = 1.0;
    let energy = |data: &mut Data, s: &State| {
        forward_kinematics(&m, &s.q, &s.qd, data).unwrap();
        data.kinetic_energy() + data.potential_energy()
    };
    let e0 = energy(&mut data, &s);
    let scale = data.kinetic_energy();
    let (mut max_angle, mut max_error) = (0.0f64, 0.0f64);
    for k in 0..2000 {
        step(&m, &mut data, &mut s, Method::Dca, Integrator::Rk4, 1e-3)
            .unwrap_or_else(|e| panic!("step {k}: {e}"));
        let angle = 2.0 * s.q[nq].abs().min(1.0).acos();
        max_angle = max_angle.max(angle.to_degrees());
        max_error = max_error.max((energy(&mut data, &s) - e0).abs() / scale);
    }
    eprintln!("neck up to {max_angle:.1}°, energy error {max_error:.2e} of {scale:.3} J");
    assert!(max_angle > 120.0, "the neck turned only {max_angle}°");
    assert!(max_error < 1e-6, "energy error {max_error:e}");
}
