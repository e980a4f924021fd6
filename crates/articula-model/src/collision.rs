//! Collision geometry for ground contact: every body's shapes reduced to **contact spheres**
//! (a centre in the body frame and a radius, 0 for a corner), the points a plane is tested
//! against (`docs/contact.md`, `docs/design.md#contact`).
//!
//! Per shape (its `<origin>` applied, then the body's fixed-joint merging, so shapes of merged
//! links are in the merged body's frame):
//!
//! | shape | contact spheres |
//! |---|---|
//! | sphere (radius r) | 1: its centre, radius r (the closest point to any plane) |
//! | capsule (radius r, length l) | 2: the end spheres' centres `±l/2 z`, radius r |
//! | box (size a × b × c) | 8: the corners, radius 0 |
//! | cylinder (radius r, length l) | 16: 8 points on each cap's rim (every 45°), radius 0 |
//! | mesh | the body's inertia box, once per body (meshes are not read) |
//!
//! A body with no readable shape gets its **inertia box**: the box of uniform density with
//! the body's mass and principal moments (`a² = 6 (I₂ + I₃ − I₁)/m`, …), centred on its centre
//! of mass along its principal axes — 8 corners. A point mass (zero moments) gives 1 point.
//! The cylinder's rim points undercut the true rim by `r (1 − cos 22.5°) ≈ 0.076 r` at worst
//! (a cylinder rolling on its rim sinks by at most that).

use crate::body_inertia::principal_moments;
use crate::{Model, Shape};
use articula_spatial::{SpatialInertia, SpatialTransform};
use glam::DVec3;

/// One contact sphere of a body: `center` in the body frame, `radius` (0 for a corner).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactSphere {
    /// The body (index into `model.bodies`).
    pub body: usize,
    /// Centre in the body frame (m).
    pub center: DVec3,
    /// Radius (m); 0 for a box corner or a cylinder rim point.
    pub radius: f64,
}

/// The contact spheres of every body of a model, built once ([`CollisionModel::new`]),
/// ordered by body, then shape, then point (a stable index for warm starts).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CollisionModel {
    /// Every contact sphere, grouped by body in body order.
    pub spheres: Vec<ContactSphere>,
    /// Shapes read from the URDF (sphere, capsule, box, cylinder).
    pub urdf_shapes: usize,
    /// Inertia boxes used: one per body without a readable shape or with a mesh.
    pub inertia_boxes: usize,
    /// Bodies with a `<mesh>` (replaced by their inertia box).
    pub mesh_bodies: usize,
}

impl CollisionModel {
    /// The contact spheres of `model`'s bodies (see the module documentation).
    pub fn new(model: &Model) -> CollisionModel {
        let mut out = CollisionModel::default();
        for (b, body) in model.bodies.iter().enumerate() {
            let mut has_mesh = false;
            let mut any = false;
            for g in &body.geometry {
                let local = shape_points(&g.shape);
                if g.shape == Shape::Mesh {
                    has_mesh = true;
                    continue;
                }
                any = true;
                out.urdf_shapes += 1;
                out.spheres
                    .extend(local.into_iter().map(|(c, radius)| ContactSphere {
                        body: b,
                        center: g.origin.apply_point(c),
                        radius,
                    }));
            }
            if has_mesh {
                out.mesh_bodies += 1;
            }
            if !any || has_mesh {
                if let Some((pose, size)) = inertia_box(&body.inertia) {
                    out.inertia_boxes += 1;
                    out.spheres
                        .extend(box_corners(size).into_iter().map(|c| ContactSphere {
                            body: b,
                            center: pose.apply_point(c),
                            radius: 0.0,
                        }));
                }
            }
        }
        out
    }

    /// One line for `articula info`: `N shapes from URDF, M inertia boxes` (and the meshes).
    pub fn summary(&self) -> String {
        let mut s = format!(
            "{} shapes from URDF, {} inertia boxes, {} contact points",
            self.urdf_shapes,
            self.inertia_boxes,
            self.spheres.len()
        );
        if self.mesh_bodies > 0 {
            s += &format!(
                " ({} bodies with meshes use their inertia box)",
                self.mesh_bodies
            );
        }
        s
    }
}

/// The contact spheres `(centre, radius)` of one shape in its own frame (module table); none
/// for a mesh.
pub fn shape_points(shape: &Shape) -> Vec<(DVec3, f64)> {
    match *shape {
        Shape::Sphere { radius } => vec![(DVec3::ZERO, radius)],
        Shape::Capsule { radius, length } => vec![
            (DVec3::new(0.0, 0.0, -0.5 * length), radius),
            (DVec3::new(0.0, 0.0, 0.5 * length), radius),
        ],
        Shape::Box { size } => box_corners(size).into_iter().map(|c| (c, 0.0)).collect(),
        Shape::Cylinder { radius, length } => {
            let mut v = Vec::with_capacity(16);
            for z in [-0.5 * length, 0.5 * length] {
                for k in 0..8 {
                    let a = k as f64 * std::f64::consts::FRAC_PI_4;
                    v.push((DVec3::new(radius * a.cos(), radius * a.sin(), z), 0.0));
                }
            }
            v
        }
        Shape::Mesh => Vec::new(),
    }
}

/// The 8 corners of a box of edge lengths `size` centred on the origin (1 point when all the
/// edges are 0).
fn box_corners(size: DVec3) -> Vec<DVec3> {
    if size == DVec3::ZERO {
        return vec![DVec3::ZERO];
    }
    let h = size * 0.5;
    (0..8)
        .map(|k| {
            let s = |bit: usize| if k >> bit & 1 == 1 { 1.0 } else { -1.0 };
            DVec3::new(s(0) * h.x, s(1) * h.y, s(2) * h.z)
        })
        .collect()
}

/// The inertia box of a body: `(pose, size)`, the box frame → body frame (centre of mass,
/// principal axes) and the edge lengths of the uniform box with the same mass and principal
/// moments, `a_i² = 6 (I_j + I_k − I_i)/m` (clamped at 0). `None` without mass.
pub fn inertia_box(inertia: &SpatialInertia) -> Option<(SpatialTransform, DVec3)> {
    let m = inertia.mass;
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    let (l, axes) = principal_moments(inertia.inertia_about_com());
    let edge = |i: f64, j: f64, k: f64| (6.0 * (j + k - i) / m).max(0.0).sqrt();
    let size = DVec3::new(
        edge(l[0], l[1], l[2]),
        edge(l[1], l[2], l[0]),
        edge(l[2], l[0], l[1]),
    );
    // A proper rotation (principal axes may come out left-handed).
    let mut axes = axes;
    if axes.determinant() < 0.0 {
        axes.z_axis = -axes.z_axis;
    }
    Some((SpatialTransform::from_pose(axes, inertia.com()), size))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DMat3;

    /// The inertia box of a uniform box is that box: a 2 kg box 0.2 × 0.4 × 0.6 m has
    /// `I_x = m (b² + c²)/12`, … and its inertia box has the same edges.
    #[test]
    fn inertia_box_of_a_box_is_the_box() {
        let (m, a, b, c) = (2.0, 0.2, 0.4, 0.6);
        let i = DMat3::from_diagonal(DVec3::new(
            m * (b * b + c * c) / 12.0,
            m * (a * a + c * c) / 12.0,
            m * (a * a + b * b) / 12.0,
        ));
        let com = DVec3::new(0.1, -0.2, 0.3);
        let inertia = SpatialInertia::new(m, com, i);
        let (pose, size) = inertia_box(&inertia).unwrap();
        let (r, p) = pose.to_pose();
        assert!((p - com).length() < 1e-14);
        // Edges along the principal axes: the world extent of the box is (a, b, c).
        let extent = (r * DVec3::X * size.x).abs()
            + (r * DVec3::Y * size.y).abs()
            + (r * DVec3::Z * size.z).abs();
        assert!(
            (extent - DVec3::new(a, b, c)).abs().max_element() < 1e-12,
            "{extent}"
        );
    }

    /// Cylinder rim points lie on the rim; capsule ends at ±l/2 with the radius.
    #[test]
    fn shape_points_lie_on_the_shapes() {
        let pts = shape_points(&Shape::Cylinder {
            radius: 0.3,
            length: 1.0,
        });
        assert_eq!(pts.len(), 16);
        for (p, r) in pts {
            assert_eq!(r, 0.0);
            assert!(((p.x * p.x + p.y * p.y).sqrt() - 0.3).abs() < 1e-15);
            assert!((p.z.abs() - 0.5).abs() < 1e-15);
        }
        let caps = shape_points(&Shape::Capsule {
            radius: 0.1,
            length: 0.4,
        });
        assert_eq!(
            caps,
            vec![
                (DVec3::new(0.0, 0.0, -0.2), 0.1),
                (DVec3::new(0.0, 0.0, 0.2), 0.1)
            ]
        );
        assert_eq!(shape_points(&Shape::Mesh), vec![]);
        assert_eq!(box_corners(DVec3::ZERO), vec![DVec3::ZERO]);
    }
}
