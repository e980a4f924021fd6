//! Gimbal lock of composed three-rotation joints: `Body::euler_axes_volume`.

use articula_model::{LoadOptions, Model};

fn humanoid() -> Model {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/humanoid.urdf");
    Model::from_urdf_file(path, &LoadOptions::default().with_floating_base(true)).unwrap()
}

/// The humanoid's hips, shoulders, lumbar and neck are three orthogonal rotations: the volume
/// their axes span is `|cos|` of the middle angle, whatever the outer two angles (they rotate
/// all three axes together, or spin about an axis of their own), and 0 at gimbal lock.
#[test]
fn euler_axes_volume_is_the_cosine_of_the_middle_angle() {
    let model = humanoid();
    let composed: Vec<_> = model
        .bodies
        .iter()
        .filter(|b| b.euler_axes_volume(&model.neutral_q()).is_some())
        .collect();
    // Lumbar, neck, two shoulders, two hips.
    assert_eq!(
        composed.len(),
        6,
        "{:?}",
        composed.iter().map(|b| &b.name).collect::<Vec<_>>()
    );
    for body in composed {
        let mut q = model.neutral_q();
        assert!(
            (body.euler_axes_volume(&q).unwrap() - 1.0).abs() < 1e-15,
            "{}",
            body.name
        );
        for (a, b, c) in [
            (0.3, 1.1, -0.7),
            (-2.0, -0.4, 2.5),
            (0.0, std::f64::consts::FRAC_PI_2, 0.9),
        ] {
            q[body.joint[0].q_offset] = a;
            q[body.joint[1].q_offset] = b;
            q[body.joint[2].q_offset] = c;
            let v = body.euler_axes_volume(&q).unwrap();
            assert!(
                (v - f64::cos(b).abs()).abs() < 1e-14,
                "{}: {v} at middle {b}",
                body.name
            );
        }
    }
    // Single-axis joints (elbows) and the floating base are not Euler joints.
    let elbow = model.bodies.iter().find(|b| b.name == "l_forearm").unwrap();
    assert_eq!(elbow.euler_axes_volume(&model.neutral_q()), None);
    assert_eq!(model.bodies[0].euler_axes_volume(&model.neutral_q()), None);
    // A q too short is not a panic.
    assert_eq!(
        model.bodies[composed_index(&model)].euler_axes_volume(&[0.0; 3]),
        None
    );
}

fn composed_index(model: &Model) -> usize {
    model
        .bodies
        .iter()
        .position(|b| b.joint.len() == 3)
        .unwrap()
}
