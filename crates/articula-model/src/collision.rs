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
//! | cylinder (radius r, length l) | 8: 4 [`Rim`] points on each cap's rim, placed by the plane: the rim's lowest point and the points 90°, 180° and 270° round from it, radius 0 |
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

/// One contact sphere of a body: `center` in the body frame, `radius` (0 for a corner), or a
/// point of a cylinder's rim placed by the plane it meets (`rim`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactSphere {
    /// The body (index into `model.bodies`).
    pub body: usize,
    /// Centre in the body frame (m); for a rim point, the centre of its cap.
    pub center: DVec3,
    /// Radius (m); 0 for a box corner or a cylinder rim point.
    pub radius: f64,
    /// For a cylinder's rim point: where on the rim ([`ContactSphere::center_facing`]).
    pub rim: Option<Rim>,
}

/// A point on a cylinder cap's rim (circle of `radius` about `axis` through the sphere's
/// `center`), `angle` round from the rim's point nearest a plane (about `axis`): angle 0 is
/// the lowest point of the rim over the plane, whatever the cylinder's orientation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rim {
    /// The cylinder's axis (unit, body frame).
    pub axis: DVec3,
    /// The rim's radius (m).
    pub radius: f64,
    /// Radians round the axis from the lowest point.
    pub angle: f64,
}

impl ContactSphere {
    /// The sphere's centre (body frame) against a plane whose normal, in the body frame, is
    /// `normal` (unit, pointing away from the plane): `center`, or for a rim point its place
    /// on the rim — the lowest (`angle` 0: `center − r d`, `d` the normal's direction across
    /// the axis) turned by `angle` about the axis. With the axis along the normal (a cylinder
    /// standing on a cap) any direction across it serves: every rim point is equally low.
    pub fn center_facing(&self, normal: DVec3) -> DVec3 {
        let Some(rim) = self.rim else {
            return self.center;
        };
        let across = normal - rim.axis * rim.axis.dot(normal);
        let len = across.length();
        let d = if len > 1e-12 {
            across / len
        } else {
            rim.axis.any_orthonormal_vector()
        };
        let e = rim.axis.cross(d);
        self.center - rim.radius * (rim.angle.cos() * d + rim.angle.sin() * e)
    }

    /// The largest distance from `center` of any point of the sphere, wherever a rim point
    /// sits: `radius` plus the rim's radius.
    pub fn extent(&self) -> f64 {
        self.radius + self.rim.map_or(0.0, |r| r.radius)
    }
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
                if g.shape == Shape::Mesh {
                    has_mesh = true;
                    continue;
                }
                any = true;
                out.urdf_shapes += 1;
                // The shape's frame in the body's: its points and its axis.
                let axis = g.origin.apply_point(DVec3::Z) - g.origin.apply_point(DVec3::ZERO);
                out.spheres
                    .extend(shape_spheres(&g.shape).into_iter().map(|(c, radius, rim)| {
                        ContactSphere {
                            body: b,
                            center: g.origin.apply_point(c),
                            radius,
                            rim: rim.map(|r| Rim { axis, ..r }),
                        }
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
                            rim: None,
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

/// Rim points per cylinder cap.
pub const RIM_POINTS: usize = 4;

/// The contact spheres `(centre, radius, rim)` of one shape in its own frame (module table;
/// a rim's axis is the shape's z); none for a mesh.
pub fn shape_spheres(shape: &Shape) -> Vec<(DVec3, f64, Option<Rim>)> {
    match *shape {
        Shape::Cylinder { radius, length } => {
            let mut v = Vec::with_capacity(2 * RIM_POINTS);
            for z in [-0.5 * length, 0.5 * length] {
                for k in 0..RIM_POINTS {
                    let rim = Rim {
                        axis: DVec3::Z,
                        radius,
                        angle: k as f64 * std::f64::consts::TAU / RIM_POINTS as f64,
                    };
                    v.push((DVec3::new(0.0, 0.0, z), 0.0, Some(rim)));
                }
            }
            v
        }
        _ => shape_points(shape)
            .into_iter()
            .map(|(c, r)| (c, r, None))
            .collect(),
    }
}

/// The fixed contact spheres `(centre, radius)` of one shape in its own frame: a sphere's
/// centre, a capsule's end spheres, a box's corners; none for a cylinder (its rim points
/// move with the plane: [`shape_spheres`]) or a mesh.
pub fn shape_points(shape: &Shape) -> Vec<(DVec3, f64)> {
    match *shape {
        Shape::Sphere { radius } => vec![(DVec3::ZERO, radius)],
        Shape::Capsule { radius, length } => vec![
            (DVec3::new(0.0, 0.0, -0.5 * length), radius),
            (DVec3::new(0.0, 0.0, 0.5 * length), radius),
        ],
        Shape::Box { size } => box_corners(size).into_iter().map(|c| (c, 0.0)).collect(),
        Shape::Cylinder { .. } | Shape::Mesh => Vec::new(),
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

    /// A cylinder's rim points are its lowest rim points over any plane: tilted, the lowest
    /// is the support point `c − r d` (checked against the minimum over 3,600 rim points), and
    /// standing on a cap its 4 points span the cap (a square of side `r √2`); capsule ends at
    /// ±l/2 with the radius.
    #[test]
    fn shape_points_lie_on_the_shapes() {
        let cyl = Shape::Cylinder {
            radius: 0.3,
            length: 1.0,
        };
        let pts = shape_spheres(&cyl);
        assert_eq!(pts.len(), 2 * RIM_POINTS);
        let spheres: Vec<ContactSphere> = pts
            .iter()
            .map(|&(center, radius, rim)| ContactSphere {
                body: 0,
                center,
                radius,
                rim,
            })
            .collect();
        for normal in [
            DVec3::new(0.3, -0.2, 0.9).normalize(),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, -1.0),
        ] {
            // The lowest point of the whole rim, sampled finely, along `normal`.
            let sampled = (0..3600)
                .flat_map(|k| {
                    let a = k as f64 * std::f64::consts::TAU / 3600.0;
                    [-0.5, 0.5].map(|z| DVec3::new(0.3 * a.cos(), 0.3 * a.sin(), z).dot(normal))
                })
                .fold(f64::INFINITY, f64::min);
            let ours = spheres
                .iter()
                .map(|s| s.center_facing(normal).dot(normal))
                .fold(f64::INFINITY, f64::min);
            assert!(
                ours <= sampled + 1e-12 && ours > sampled - 1e-6,
                "{ours} {sampled}"
            );
            for s in &spheres {
                let p = s.center_facing(normal);
                assert!(((p.x * p.x + p.y * p.y).sqrt() - 0.3).abs() < 1e-15);
                assert!((p.z.abs() - 0.5).abs() < 1e-15);
                assert_eq!(s.extent(), 0.3);
            }
        }
        // Standing on its lower cap (normal +z): that cap's 4 points, a square on the rim.
        let low: Vec<DVec3> = spheres[..RIM_POINTS]
            .iter()
            .map(|s| s.center_facing(DVec3::Z))
            .collect();
        for k in 0..RIM_POINTS {
            let side = (low[k] - low[(k + 1) % RIM_POINTS]).length();
            assert!((side - 0.3 * 2f64.sqrt()).abs() < 1e-14, "{side}");
        }
        assert_eq!(shape_points(&cyl), vec![]);
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
