//! Collision and visual primitives: read leniently into `Body::geometry`, in the body frame.

mod common;

use articula_model::{GeometryRole, Shape};
use common::*;
use glam::{DMat3, DVec3};

fn inertial() -> &'static str {
    "<inertial><mass value=\"1\"/><inertia ixx=\"0.01\" ixy=\"0\" ixz=\"0\" iyy=\"0.01\" iyz=\"0\" izz=\"0.01\"/></inertial>"
}

fn one_link(inner: &str) -> String {
    robot(
        &[
            link("base", 1.0),
            format!("  <link name=\"arm\">{}{inner}</link>\n", inertial()),
            joint("j", "revolute", "base", "arm"),
        ]
        .concat(),
    )
}

#[test]
fn primitives_are_read_with_their_origins() {
    let m = load(&one_link(
        "<collision><origin xyz=\"0 0 0.5\" rpy=\"0 1.5707963267948966 0\"/>\
         <geometry><cylinder radius=\"0.1\" length=\"1\"/></geometry></collision>\
         <collision><geometry><box size=\"0.1 0.2 0.3\"/></geometry></collision>\
         <collision><origin xyz=\"1 2 3\"/><geometry><sphere radius=\"0.25\"/></geometry></collision>\
         <collision><geometry><mesh filename=\"x.stl\"/></geometry></collision>",
    ))
    .unwrap();
    let g = &m.bodies[0].geometry;
    assert_eq!(g.len(), 4);
    assert_eq!(
        g[0].shape,
        Shape::Cylinder {
            radius: 0.1,
            length: 1.0
        }
    );
    let (rot, pos) = g[0].origin.to_pose();
    assert!((pos - DVec3::new(0.0, 0.0, 0.5)).length() < 1e-12);
    // The cylinder's z axis is rotated onto the link's x axis.
    assert!((rot * DVec3::Z - DVec3::X).length() < 1e-12);
    assert_eq!(
        g[1].shape,
        Shape::Box {
            size: DVec3::new(0.1, 0.2, 0.3)
        }
    );
    assert_eq!(g[2].shape, Shape::Sphere { radius: 0.25 });
    assert!((g[2].origin.to_pose().1 - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
    assert_eq!(g[3].shape, Shape::Mesh);
    assert!(g.iter().all(|g| g.role == GeometryRole::Collision));
}

#[test]
fn collision_is_preferred_to_visual() {
    let m = load(&one_link(
        "<visual><geometry><sphere radius=\"9\"/></geometry></visual>\
         <collision><geometry><sphere radius=\"1\"/></geometry></collision>",
    ))
    .unwrap();
    assert_eq!(m.bodies[0].geometry.len(), 1);
    assert_eq!(m.bodies[0].geometry[0].shape, Shape::Sphere { radius: 1.0 });
    let m = load(&one_link(
        "<visual><geometry><sphere radius=\"9\"/></geometry></visual>",
    ))
    .unwrap();
    assert_eq!(m.bodies[0].geometry[0].shape, Shape::Sphere { radius: 9.0 });
    assert_eq!(m.bodies[0].geometry[0].role, GeometryRole::Visual);
}

#[test]
fn malformed_geometry_is_dropped_not_an_error() {
    let m = load(&one_link(
        "<collision><geometry><box size=\"1 2\"/></geometry></collision>\
         <collision><geometry><sphere radius=\"-1\"/></geometry></collision>\
         <collision><geometry><sphere radius=\"nan\"/></geometry></collision>\
         <collision><geometry><cylinder radius=\"1\"/></geometry></collision>\
         <collision><geometry><teapot/></geometry></collision>\
         <collision><geometry/></collision>\
         <collision><origin xyz=\"a b c\"/><geometry><sphere radius=\"1\"/></geometry></collision>\
         <visual><geometry><sphere radius=\"2\"/></geometry></visual>",
    ))
    .unwrap();
    // No collision primitive survived: the visual one is used.
    assert_eq!(m.bodies[0].geometry.len(), 1);
    assert_eq!(m.bodies[0].geometry[0].shape, Shape::Sphere { radius: 2.0 });
    assert!(m.warnings.is_empty());
}

#[test]
fn welded_links_bring_their_geometry_into_the_body_frame() {
    let text = robot(
        &[
            link("base", 1.0),
            link("arm", 1.0),
            format!(
                "  <link name=\"tool\">{}<collision><origin xyz=\"0.1 0 0\"/><geometry><sphere radius=\"0.05\"/></geometry></collision></link>\n",
                inertial()
            ),
            joint("j", "revolute", "base", "arm"),
            joint_with(
                "weld",
                "fixed",
                "arm",
                "tool",
                "<origin xyz=\"0 0 1\" rpy=\"0 0 1.5707963267948966\"/>",
            ),
        ]
        .concat(),
    );
    let m = load(&text).unwrap();
    let g = &m.bodies[0].geometry;
    assert_eq!(g.len(), 1);
    // Tool frame: at (0, 0, 1), rotated 90° about z: its x axis is the arm's y axis.
    let (rot, pos) = g[0].origin.to_pose();
    assert!((pos - DVec3::new(0.0, 0.1, 1.0)).length() < 1e-12, "{pos}");
    assert!((rot - DMat3::from_rotation_z(std::f64::consts::FRAC_PI_2))
        .to_cols_array()
        .iter()
        .all(|x| x.abs() < 1e-12));
}

#[test]
fn bundled_humanoid_has_geometry_on_every_body() {
    let m = load_floating(&read_model("humanoid")).unwrap();
    for b in &m.bodies {
        assert!(!b.geometry.is_empty(), "{} has no geometry", b.name);
    }
    // The head carries its camera (welded) and its sphere.
    let head = m.bodies.iter().find(|b| b.name == "head").unwrap();
    assert!(head
        .geometry
        .iter()
        .any(|g| g.shape == Shape::Sphere { radius: 0.1 }));
}
