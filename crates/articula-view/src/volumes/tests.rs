//! Bounding volumes: equivalent inertia boxes, URDF primitives.

use super::{body_volumes, inertia_box, Volume};
use articula_model::{LoadOptions, Model};
use articula_spatial::SpatialInertia;
use glam::{DMat3, DVec3, EulerRot};

fn models() -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

#[test]
fn inertia_box_recovers_a_solid_box() {
    // A solid box of half extents (a, b, c), mass m, rotated and offset: I_xx = m (b² + c²)/3.
    let (m, a, b, c) = (3.0, 0.4, 0.1, 0.25);
    let ic = DMat3::from_diagonal(DVec3::new(
        m * (b * b + c * c) / 3.0,
        m * (a * a + c * c) / 3.0,
        m * (a * a + b * b) / 3.0,
    ));
    let rot = DMat3::from_euler(EulerRot::ZYX, 0.3, -0.7, 1.1);
    let com = DVec3::new(0.1, -0.2, 0.3);
    let inertia = SpatialInertia::new(m, com, rot * ic * rot.transpose());
    let Some(Volume::Box { center, axes, half }) = inertia_box(&inertia) else {
        panic!("a box")
    };
    assert!((center - com).length() < 1e-12);
    // Each half extent along its axis: match them to the rotated box's axes.
    for (e, axis) in [(a, rot.x_axis), (b, rot.y_axis), (c, rot.z_axis)] {
        let k = (0..3)
            .max_by(|&i, &j| {
                axes.col(i)
                    .dot(axis)
                    .abs()
                    .total_cmp(&axes.col(j).dot(axis).abs())
            })
            .unwrap();
        assert!((axes.col(k).dot(axis).abs() - 1.0).abs() < 1e-9);
        assert!((half[k] - e).abs() < 1e-9, "{} vs {e}", half[k]);
    }
    assert!(inertia_box(&SpatialInertia::ZERO).is_none());
}

#[test]
fn humanoid_uses_its_urdf_primitives() {
    let model = Model::from_urdf_file(
        models().join("humanoid.urdf"),
        &LoadOptions::default().with_floating_base(true),
    )
    .unwrap();
    let vols = body_volumes(&model);
    assert_eq!(vols.len(), model.bodies.len());
    for (b, v) in model.bodies.iter().zip(&vols) {
        assert!(!v.from_inertia, "{}", b.name);
        assert_eq!(v.primitives.len(), b.geometry.len());
        // The bound encloses every primitive and skeleton capsule.
        let (c, r) = v.bound;
        for p in v.primitives.iter().chain(&v.skeleton) {
            let (pc, pr) = p.bounding_sphere();
            assert!((pc - c).length() + pr <= r + 1e-12, "{}", b.name);
        }
        // A skeleton capsule per child (or one for a leaf).
        assert_eq!(v.skeleton.len(), b.children.len().max(1));
        assert!(
            v.radius > 0.009 && v.radius < 0.2,
            "{}: {}",
            b.name,
            v.radius
        );
    }
    // The pelvis box is 0.18 × 0.30 × 0.14.
    let pelvis = &vols[0];
    assert!(pelvis
        .primitives
        .iter()
        .any(|p| matches!(p, Volume::Box { half, .. }
        if (*half - DVec3::new(0.09, 0.15, 0.07)).length() < 1e-12)));
}

#[test]
fn models_without_geometry_fall_back_to_the_inertia_box() {
    let urdf = r#"<robot name="r"><link name="a"><inertial><mass value="2"/>
        <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.02"/></inertial></link>
        <link name="b"><inertial><origin xyz="0 0 0.3"/><mass value="1"/>
        <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
        <visual><geometry><mesh filename="b.stl"/></geometry></visual></link>
        <joint name="j" type="revolute"><origin xyz="0 0 0.5"/><parent link="a"/><child link="b"/>
        <axis xyz="0 1 0"/></joint></robot>"#;
    let model =
        Model::from_urdf_str(urdf, &LoadOptions::default().with_floating_base(true)).unwrap();
    let vols = body_volumes(&model);
    for v in &vols {
        assert!(v.from_inertia);
        assert_eq!(v.primitives.len(), 1);
    }
    // Body a: I = diag(0.1, 0.1, 0.02), m = 2 → half extents √(3(Iⱼ+Iₖ−Iᵢ)/(2m)).
    let Volume::Box { half, .. } = vols[0].primitives[0] else {
        panic!()
    };
    let mut h = half.to_array();
    h.sort_by(f64::total_cmp);
    let e = |i: f64, j: f64, k: f64| (3.0 * (j + k - i) / 4.0).sqrt();
    let mut want = [e(0.1, 0.1, 0.02), e(0.1, 0.02, 0.1), e(0.02, 0.1, 0.1)];
    want.sort_by(f64::total_cmp);
    for (x, y) in h.iter().zip(want) {
        assert!((x - y).abs() < 1e-12);
    }
    // Body a's skeleton goes to the joint of b; b (a leaf) through its centre of mass.
    assert_eq!(
        vols[0].skeleton[0],
        Volume::Capsule {
            a: DVec3::ZERO,
            b: DVec3::new(0.0, 0.0, 0.5),
            radius: vols[0].radius
        }
    );
    let Volume::Capsule { b, .. } = vols[1].skeleton[0] else {
        panic!()
    };
    assert!((b - DVec3::new(0.0, 0.0, 0.6)).length() < 1e-12);
}

#[test]
fn inner_spheres_lie_inside_their_volume() {
    let rot = DMat3::from_euler(EulerRot::ZYX, 0.5, 0.2, -0.4);
    let vols = [
        Volume::Box {
            center: DVec3::new(1.0, 2.0, 3.0),
            axes: rot,
            half: DVec3::new(0.5, 0.1, 0.3),
        },
        Volume::Capsule {
            a: DVec3::ZERO,
            b: DVec3::new(1.0, 1.0, 0.0),
            radius: 0.1,
        },
        Volume::Sphere {
            center: DVec3::ONE,
            radius: 0.3,
        },
    ];
    for v in vols {
        let mut s = Vec::new();
        v.inner_spheres(&mut s);
        assert!(!s.is_empty());
        for (c, r) in s {
            match v {
                Volume::Box { center, axes, half } => {
                    let d = axes.transpose() * (c - center);
                    for k in 0..3 {
                        assert!(d[k].abs() + r <= half[k] + 1e-12);
                    }
                }
                Volume::Capsule { a, b, radius } => {
                    let t = ((c - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
                    assert!((c - a.lerp(b, t)).length() + r <= radius + 1e-12);
                }
                Volume::Sphere { center, radius } => {
                    assert!((c - center).length() + r <= radius + 1e-12)
                }
            }
        }
    }
}
