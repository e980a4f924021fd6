//! Collision geometry and joint limits read from URDF for ground contact (`docs/contact.md`):
//! capsules, limits of revolute and prismatic joints only, shapes carried through fixed-joint
//! merging into the merged body's frame, inertia boxes for bodies without shapes or with meshes.

use articula_model::{CollisionModel, LoadOptions, Model, Shape};
use glam::DVec3;

const INERTIAL: &str = r#"<inertial><mass value="2"/>
  <inertia ixx="0.0416666666666667" iyy="0.0333333333333333" izz="0.0216666666666667" ixy="0" ixz="0" iyz="0"/></inertial>"#;

fn load(urdf: &str) -> Model {
    Model::from_urdf_str(urdf, &LoadOptions::default()).unwrap()
}

#[test]
fn limits_are_read_for_revolute_and_prismatic_joints_only() {
    let urdf = format!(
        r#"<robot name="r"><link name="base"/>
        <link name="a">{INERTIAL}</link><link name="b">{INERTIAL}</link>
        <link name="c">{INERTIAL}</link><link name="d">{INERTIAL}</link>
        <joint name="rev" type="revolute"><parent link="base"/><child link="a"/>
          <limit lower="-1.5" upper="0.25" effort="1" velocity="1"/></joint>
        <joint name="pri" type="prismatic"><parent link="a"/><child link="b"/>
          <limit lower="0" upper="0.3" effort="1" velocity="1"/></joint>
        <joint name="cont" type="continuous"><parent link="b"/><child link="c"/>
          <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
        <joint name="bad" type="revolute"><parent link="c"/><child link="d"/>
          <limit lower="1" upper="-1" effort="1" velocity="1"/></joint>
        </robot>"#
    );
    let m = load(&urdf);
    let limits: Vec<_> = m
        .joint_parts()
        .map(|(_, p)| (p.name.as_str(), p.limits))
        .collect();
    assert_eq!(
        limits,
        [
            ("rev", Some([-1.5, 0.25])),
            ("pri", Some([0.0, 0.3])),
            ("cont", None),
            ("bad", None),
        ]
    );
}

#[test]
fn shapes_follow_fixed_joint_merging() {
    // Body "a" (a 0.2 × 0.3 × 0.4 box at its origin) with "tip" welded 1 m up x, rotated 90°
    // about z, carrying a capsule along its own z and a sphere 0.5 m along its own x.
    let urdf = format!(
        r#"<robot name="r"><link name="base"/>
        <link name="a">{INERTIAL}<collision><geometry><box size="0.2 0.3 0.4"/></geometry></collision></link>
        <link name="tip"><collision><geometry><capsule radius="0.05" length="0.2"/></geometry></collision>
          <collision><origin xyz="0.5 0 0"/><geometry><sphere radius="0.1"/></geometry></collision></link>
        <joint name="j" type="continuous"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/></joint>
        <joint name="weld" type="fixed"><parent link="a"/><child link="tip"/>
          <origin xyz="1 0 0" rpy="0 0 1.5707963267948966"/></joint>
        </robot>"#
    );
    let m = load(&urdf);
    assert_eq!(m.bodies.len(), 1);
    let shapes: Vec<_> = m.bodies[0].geometry.iter().map(|g| g.shape).collect();
    assert_eq!(
        shapes[1],
        Shape::Capsule {
            radius: 0.05,
            length: 0.2
        }
    );
    let c = CollisionModel::new(&m);
    assert_eq!((c.urdf_shapes, c.inertia_boxes, c.mesh_bodies), (3, 0, 0));
    assert_eq!(c.spheres.len(), 8 + 2 + 1);
    let close = |a: DVec3, b: DVec3| (a - b).length() < 1e-12;
    // Box corners at (±0.1, ±0.15, ±0.2).
    assert!(c.spheres[..8]
        .iter()
        .all(|s| close(s.center.abs(), DVec3::new(0.1, 0.15, 0.2)) && s.radius == 0.0));
    // Capsule ends at (1, 0, ±0.1); the sphere at 1 m + R_z(90°) (0.5, 0, 0) = (1, 0.5, 0).
    assert!(close(c.spheres[8].center, DVec3::new(1.0, 0.0, -0.1)));
    assert!(close(c.spheres[9].center, DVec3::new(1.0, 0.0, 0.1)));
    assert_eq!(c.spheres[9].radius, 0.05);
    assert!(close(c.spheres[10].center, DVec3::new(1.0, 0.5, 0.0)));
    assert_eq!(c.spheres[10].radius, 0.1);
}

#[test]
fn bodies_without_shapes_or_with_meshes_get_their_inertia_box() {
    let urdf = format!(
        r#"<robot name="r"><link name="base"/>
        <link name="a">{INERTIAL}</link>
        <link name="b">{INERTIAL}<collision><geometry><mesh filename="x.stl"/></geometry></collision></link>
        <joint name="j" type="continuous"><parent link="base"/><child link="a"/></joint>
        <joint name="k" type="continuous"><parent link="a"/><child link="b"/></joint>
        </robot>"#
    );
    let m = load(&urdf);
    let c = CollisionModel::new(&m);
    assert_eq!((c.urdf_shapes, c.inertia_boxes, c.mesh_bodies), (0, 2, 1));
    // The inertia of a 2 kg box 0.2 × 0.3 × 0.4 m: its inertia box is that box.
    assert_eq!(c.spheres.len(), 16);
    for s in &c.spheres {
        let a = s.center.abs();
        let mut sorted = [a.x, a.y, a.z];
        sorted.sort_by(f64::total_cmp);
        for (got, want) in sorted.iter().zip([0.1, 0.15, 0.2]) {
            assert!((got - want).abs() < 1e-9, "{a}");
        }
    }
    assert_eq!(
        c.summary(),
        "0 shapes from URDF, 2 inertia boxes, 16 contact points (1 bodies with meshes use their inertia box)"
    );
}

/// The rest configuration moves a coordinate whose limits exclude 0 to the nearer bound (a
/// knee bent like go1's, a slider that starts extended) and leaves the others at neutral.
#[test]
fn rest_q_is_the_neutral_pose_moved_into_the_limits() {
    let urdf = format!(
        r#"<robot name="r"><link name="base"/>
        <link name="a">{INERTIAL}</link><link name="b">{INERTIAL}</link>
        <link name="c">{INERTIAL}</link><link name="d">{INERTIAL}</link>
        <joint name="knee" type="revolute"><parent link="base"/><child link="a"/>
          <limit lower="-2.82" upper="-0.89" effort="1" velocity="1"/></joint>
        <joint name="slide" type="prismatic"><parent link="a"/><child link="b"/>
          <limit lower="0.1" upper="0.3" effort="1" velocity="1"/></joint>
        <joint name="hip" type="revolute"><parent link="b"/><child link="c"/>
          <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
        <joint name="wheel" type="continuous"><parent link="c"/><child link="d"/></joint>
        </robot>"#
    );
    let model = load(&urdf);
    assert_eq!(model.rest_q(), [-0.89, 0.1, 0.0, 0.0]);
    let floating =
        Model::from_urdf_str(&urdf, &LoadOptions::default().with_floating_base(true)).unwrap();
    assert_eq!(
        floating.rest_q(),
        [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -0.89, 0.1, 0.0, 0.0]
    );
}
