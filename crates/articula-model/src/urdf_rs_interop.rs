//! Robots read by the `urdf-rs` crate (feature `urdf-rs`): converted to what the built-in reader
//! extracts, then validated and built the same way ([`crate::Model::from_urdf_robot`]).

use crate::urdf::{GeometryRole, JointData, LinkData, Origin, RobotData, Shape};
use crate::{Geometry, JointKind, LoadWarning, ModelError};
use glam::DVec3;
use std::borrow::Cow;
use urdf_rs as u;

fn origin(p: &u::Pose) -> Origin {
    Origin {
        xyz: DVec3::from_array(p.xyz.0),
        rpy: DVec3::from_array(p.rpy.0),
    }
}

/// One primitive, dropped (like the built-in reader) when a dimension is negative or not
/// finite, its origin is not finite, or its shape is unknown to articula (a capsule).
fn primitive(g: &u::Geometry, pose: &u::Pose, role: GeometryRole) -> Option<Geometry> {
    let ok = |x: f64| x.is_finite() && x >= 0.0;
    let shape = match g {
        u::Geometry::Box { size } if size.0.iter().all(|&x| ok(x)) => Shape::Box {
            size: DVec3::from_array(size.0),
        },
        u::Geometry::Cylinder { radius, length } if ok(*radius) && ok(*length) => Shape::Cylinder {
            radius: *radius,
            length: *length,
        },
        u::Geometry::Sphere { radius } if ok(*radius) => Shape::Sphere { radius: *radius },
        u::Geometry::Mesh { .. } => Shape::Mesh,
        _ => return None,
    };
    Some(Geometry {
        shape,
        origin: crate::urdf::pose(&origin(pose))?,
        role,
    })
}

/// The links and joints of `robot` as the built-in reader would have extracted them.
pub(crate) fn robot_data(robot: &u::Robot) -> Result<RobotData<'_>, ModelError> {
    let mut warnings = Vec::new();
    let links = robot
        .links
        .iter()
        .map(|l| {
            let i = &l.inertial.inertia;
            let mut geometry: Vec<Geometry> = l
                .collision
                .iter()
                .filter_map(|c| primitive(&c.geometry, &c.origin, GeometryRole::Collision))
                .collect();
            if geometry.is_empty() {
                geometry = l
                    .visual
                    .iter()
                    .filter_map(|v| primitive(&v.geometry, &v.origin, GeometryRole::Visual))
                    .collect();
            }
            LinkData {
                name: Cow::Borrowed(l.name.as_str()),
                origin: origin(&l.inertial.origin),
                mass: l.inertial.mass.value,
                inertia: [i.ixx, i.ixy, i.ixz, i.iyy, i.iyz, i.izz],
                geometry,
            }
        })
        .collect();
    let joints = robot
        .joints
        .iter()
        .map(|j| {
            if let Some(m) = &j.mimic {
                warnings.push(LoadWarning::Mimic {
                    joint: j.name.clone(),
                    leader: m.joint.clone(),
                });
            }
            JointData {
                name: Cow::Borrowed(j.name.as_str()),
                kind: match j.joint_type {
                    u::JointType::Revolute => Ok(JointKind::Revolute),
                    u::JointType::Continuous => Ok(JointKind::Continuous),
                    u::JointType::Prismatic => Ok(JointKind::Prismatic),
                    u::JointType::Fixed => Ok(JointKind::Fixed),
                    u::JointType::Floating => Ok(JointKind::Floating),
                    u::JointType::Planar => Err("planar"),
                    u::JointType::Spherical => Err("spherical"),
                },
                origin: origin(&j.origin),
                parent: Cow::Borrowed(j.parent.link.as_str()),
                child: Cow::Borrowed(j.child.link.as_str()),
                axis: DVec3::from_array(j.axis.xyz.0),
                // As `read_limits`: finite with lower < upper, else none.
                limits: (j.limit.lower.is_finite()
                    && j.limit.upper.is_finite()
                    && j.limit.lower < j.limit.upper)
                    .then_some([j.limit.lower, j.limit.upper]),
                // As `read_dynamics` (the friction warning aside).
                damping: j.dynamics.as_ref().map_or(0.0, |d| d.damping).max(0.0),
            }
        })
        .collect();
    Ok(RobotData {
        name: Cow::Borrowed(robot.name.as_str()),
        links,
        joints,
        warnings,
    })
}
