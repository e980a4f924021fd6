//! Per-body bounding volumes, in the body frame.
//!
//! Each body of a model (a URDF link plus the links welded to it) gets:
//! - its **primitives**: the URDF collision (else visual) boxes, spheres and cylinders (a
//!   cylinder is bounded by the capsule of the same radius whose segment spans its length);
//!   a body with no primitive, or with a mesh, gets the **equivalent box of its inertia** instead
//!   — the solid box of the body's mass with the same central inertia, on its principal axes
//!   (half extents `aᵢ = √(3 (Iⱼ + Iₖ − Iᵢ) / (2m))`);
//! - its **skeleton**: capsules from the body's origin to each child's joint origin (a leaf body
//!   gets one from its origin through its centre of mass, twice as far), of radius
//!   [`BodyVolumes::radius`]. These are what the renderer draws.
//!
//! A bounding sphere of the whole body (primitives and skeleton) is kept for quick tests.

use articula_model::{Model, Shape};
use glam::{DMat3, DVec3};

/// A convex volume.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Volume {
    /// A ball.
    Sphere {
        /// Centre.
        center: DVec3,
        /// Radius.
        radius: f64,
    },
    /// A segment swept by a ball.
    Capsule {
        /// One end of the segment.
        a: DVec3,
        /// The other end.
        b: DVec3,
        /// Radius.
        radius: f64,
    },
    /// An oriented box.
    Box {
        /// Centre.
        center: DVec3,
        /// Axes as columns (orthonormal).
        axes: DMat3,
        /// Half extents along the axes.
        half: DVec3,
    },
}

impl Volume {
    /// The volume moved by the rigid motion `p ↦ rot p + pos`.
    pub fn transformed(&self, rot: DMat3, pos: DVec3) -> Volume {
        match *self {
            Volume::Sphere { center, radius } => Volume::Sphere {
                center: rot * center + pos,
                radius,
            },
            Volume::Capsule { a, b, radius } => Volume::Capsule {
                a: rot * a + pos,
                b: rot * b + pos,
                radius,
            },
            Volume::Box { center, axes, half } => Volume::Box {
                center: rot * center + pos,
                axes: rot * axes,
                half,
            },
        }
    }

    /// The radius of the balls [`Volume::inner_spheres`] makes (the volume's thickness / 2).
    pub fn inner_radius(&self) -> f64 {
        match *self {
            Volume::Sphere { radius, .. } | Volume::Capsule { radius, .. } => radius,
            Volume::Box { half, .. } => half.min_element(),
        }
    }

    /// A bounding sphere (centre, radius).
    pub fn bounding_sphere(&self) -> (DVec3, f64) {
        match *self {
            Volume::Sphere { center, radius } => (center, radius),
            Volume::Capsule { a, b, radius } => ((a + b) * 0.5, 0.5 * (b - a).length() + radius),
            Volume::Box { center, half, .. } => (center, half.length()),
        }
    }

    /// Spheres inside the volume that roughly fill it (the occluder approximation of the depth
    /// buffer): one for a sphere; balls along a capsule's segment, spaced by their radius; balls
    /// of the box's smallest half extent along its longest axis, on its middle plane grid.
    pub fn inner_spheres(&self, out: &mut Vec<(DVec3, f64)>) {
        match *self {
            Volume::Sphere { center, radius } => out.push((center, radius)),
            Volume::Capsule { a, b, radius } => {
                let len = (b - a).length();
                let n = if radius > 0.0 {
                    ((len / radius).ceil() as usize).min(16)
                } else {
                    0
                };
                for i in 0..=n {
                    let s = if n == 0 { 0.5 } else { i as f64 / n as f64 };
                    out.push((a.lerp(b, s), radius));
                }
            }
            Volume::Box { center, axes, half } => {
                let h = half.to_array();
                let cols = [axes.x_axis, axes.y_axis, axes.z_axis];
                let mut idx = [0, 1, 2];
                idx.sort_by(|&i, &j| h[i].total_cmp(&h[j]));
                let r = h[idx[0]];
                if r <= 0.0 {
                    return;
                }
                // A grid over the two larger extents, balls of the smallest half extent.
                let (m, l) = (idx[1], idx[2]);
                let count = |e: f64| (((e - r) / r).ceil().max(0.0) as usize).min(8);
                let (nm, nl) = (count(h[m]), count(h[l]));
                for i in 0..=nm {
                    for j in 0..=nl {
                        let sm = if nm == 0 {
                            0.0
                        } else {
                            -1.0 + 2.0 * i as f64 / nm as f64
                        };
                        let sl = if nl == 0 {
                            0.0
                        } else {
                            -1.0 + 2.0 * j as f64 / nl as f64
                        };
                        out.push((
                            center + cols[m] * (sm * (h[m] - r)) + cols[l] * (sl * (h[l] - r)),
                            r,
                        ));
                    }
                }
            }
        }
    }
}

/// The volumes of one body, in its frame.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyVolumes {
    /// URDF primitives, or the equivalent box of the inertia.
    pub primitives: Vec<Volume>,
    /// Whether `primitives` came from the inertia (no usable URDF geometry).
    pub from_inertia: bool,
    /// Capsules from the body's origin to its children's joint origins.
    pub skeleton: Vec<Volume>,
    /// Radius of the skeleton capsules.
    pub radius: f64,
    /// Bounding sphere of everything above: centre (body frame) and radius.
    pub bound: (DVec3, f64),
    /// The occluder balls ([`Volume::inner_spheres`], body frame) of `primitives` then
    /// `skeleton`, in `balls`, one group per volume: `(its inner radius, its balls' range)`.
    /// Made once: a classification only moves their centres.
    pub inner: Vec<(f64, std::ops::Range<usize>)>,
    /// See `inner`.
    pub balls: Vec<(DVec3, f64)>,
}

/// The equivalent box of a body's inertia: centre (the centre of mass), principal axes and half
/// extents of the uniform solid box with the same mass and central inertia. `None` for a
/// massless body.
pub(crate) fn inertia_box(inertia: &articula_spatial::SpatialInertia) -> Option<Volume> {
    // The same box as the contact spheres' fallback (`articula_model::inertia_box`).
    let (pose, size) = articula_model::inertia_box(inertia)?;
    let (axes, center) = pose.to_pose();
    Some(Volume::Box {
        center,
        axes,
        half: 0.5 * size,
    })
}

/// The bounding volumes of every body of `model` (indexed like `model.bodies`).
pub(crate) fn body_volumes(model: &Model) -> Vec<BodyVolumes> {
    model
        .bodies
        .iter()
        .map(|body| {
            let mut primitives = Vec::new();
            let mut has_mesh = false;
            for g in &body.geometry {
                let (rot, pos) = g.origin.to_pose();
                let v = match g.shape {
                    Shape::Box { size } => Volume::Box {
                        center: DVec3::ZERO,
                        axes: DMat3::IDENTITY,
                        half: size * 0.5,
                    },
                    Shape::Sphere { radius } => Volume::Sphere {
                        center: DVec3::ZERO,
                        radius,
                    },
                    Shape::Cylinder { radius, length } | Shape::Capsule { radius, length } => {
                        Volume::Capsule {
                            a: DVec3::new(0.0, 0.0, -0.5 * length),
                            b: DVec3::new(0.0, 0.0, 0.5 * length),
                            radius,
                        }
                    }
                    Shape::Mesh => {
                        has_mesh = true;
                        continue;
                    }
                };
                primitives.push(v.transformed(rot, pos));
            }
            let from_inertia = primitives.is_empty() || has_mesh;
            if from_inertia {
                primitives.extend(inertia_box(&body.inertia));
            }
            // Skeleton radius: the smaller half extents of the inertia box, bounded to a
            // sensible range relative to the body's size.
            let radius = match inertia_box(&body.inertia) {
                Some(Volume::Box { half, .. }) => {
                    let mut h = half.to_array();
                    h.sort_by(f64::total_cmp);
                    (0.5 * (h[0] + h[1])).max(0.01)
                }
                _ => 0.02,
            };
            let mut skeleton = Vec::new();
            for &c in &body.children {
                let (_, p) = model.bodies[c].joint[0].origin.to_pose();
                skeleton.push(Volume::Capsule {
                    a: DVec3::ZERO,
                    b: p,
                    radius,
                });
            }
            if body.children.is_empty() {
                let com = body.inertia.com();
                skeleton.push(Volume::Capsule {
                    a: DVec3::ZERO,
                    b: com * 2.0,
                    radius,
                });
            }
            // Bounding sphere: centred on the mean of the volumes' centres.
            let all: Vec<(DVec3, f64)> = primitives
                .iter()
                .chain(&skeleton)
                .map(Volume::bounding_sphere)
                .collect();
            let center = all.iter().map(|s| s.0).sum::<DVec3>() / all.len().max(1) as f64;
            let r = all
                .iter()
                .map(|(c, r)| (*c - center).length() + r)
                .fold(0.0, f64::max);
            let (mut inner, mut balls) = (Vec::new(), Vec::new());
            for v in primitives.iter().chain(&skeleton) {
                let first = balls.len();
                v.inner_spheres(&mut balls);
                inner.push((v.inner_radius(), first..balls.len()));
            }
            BodyVolumes {
                primitives,
                from_inertia,
                skeleton,
                radius,
                bound: (center, r),
                inner,
                balls,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests;
