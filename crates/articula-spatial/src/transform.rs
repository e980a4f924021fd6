//! Plücker coordinate transforms.

use crate::inertia::{outer3, skew};
use crate::{Mat6, SpatialForce, SpatialInertia, SpatialMotion};
use glam::{DMat3, DVec3};
use std::ops::Mul;

/// A Plücker coordinate transform `X = rot(E) xlt(r)` from frame A coordinates to frame B
/// coordinates (RBDA §2.8): `E` rotates A coordinates into B coordinates and `r` is the
/// position of B's origin expressed in A coordinates.
///
/// Most code builds transforms from a pose with [`SpatialTransform::from_pose`], which gives
/// the map from a child frame's coordinates to its parent's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpatialTransform {
    /// Rotation from A coordinates to B coordinates.
    pub e: DMat3,
    /// Origin of B in A coordinates.
    pub r: DVec3,
}

impl Default for SpatialTransform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl SpatialTransform {
    /// The identity.
    pub const IDENTITY: Self = Self {
        e: DMat3::IDENTITY,
        r: DVec3::ZERO,
    };

    /// Featherstone's `rot(E) xlt(r)`.
    #[inline]
    pub const fn new(e: DMat3, r: DVec3) -> Self {
        Self { e, r }
    }

    /// A pure rotation `rot(E)`.
    #[inline]
    pub const fn rot(e: DMat3) -> Self {
        Self { e, r: DVec3::ZERO }
    }

    /// A pure translation `xlt(r)`.
    #[inline]
    pub const fn xlt(r: DVec3) -> Self {
        Self {
            e: DMat3::IDENTITY,
            r,
        }
    }

    /// The map from a child frame's coordinates to its parent's, given the child's pose in
    /// the parent: its axes `rotation` (columns, in parent coordinates) and its origin
    /// `translation` (parent coordinates).
    #[inline]
    pub fn from_pose(rotation: DMat3, translation: DVec3) -> Self {
        Self {
            e: rotation,
            r: -(rotation.transpose() * translation),
        }
    }

    /// The inverse of [`SpatialTransform::from_pose`]: `(rotation, translation)` of frame A's
    /// pose in frame B, for a transform from A coordinates to B coordinates.
    #[inline]
    pub fn to_pose(&self) -> (DMat3, DVec3) {
        (self.e, -(self.e * self.r))
    }

    /// The inverse transform (B coordinates to A coordinates).
    #[inline]
    pub fn inverse(&self) -> Self {
        Self {
            e: self.e.transpose(),
            r: -(self.e * self.r),
        }
    }

    /// `X m` for a motion vector.
    #[inline]
    pub fn apply_motion(&self, m: SpatialMotion) -> SpatialMotion {
        SpatialMotion {
            w: self.e * m.w,
            v: self.e * (m.v - self.r.cross(m.w)),
        }
    }

    /// `X* f` for a force vector.
    #[inline]
    pub fn apply_force(&self, f: SpatialForce) -> SpatialForce {
        SpatialForce {
            n: self.e * (f.n - self.r.cross(f.f)),
            f: self.e * f.f,
        }
    }

    /// `X⁻¹ m` without forming the inverse.
    #[inline]
    pub fn inv_apply_motion(&self, m: SpatialMotion) -> SpatialMotion {
        let w = self.e.transpose() * m.w;
        SpatialMotion {
            w,
            v: self.e.transpose() * m.v + self.r.cross(w),
        }
    }

    /// `X⁻* f` = `Xᵀ f` without forming the inverse.
    #[inline]
    pub fn inv_apply_force(&self, f: SpatialForce) -> SpatialForce {
        let ff = self.e.transpose() * f.f;
        SpatialForce {
            n: self.e.transpose() * f.n + self.r.cross(ff),
            f: ff,
        }
    }

    /// The inertia expressed in B coordinates: `X* I X⁻¹` (RBDA eq. 2.66, in the
    /// `rot(E) xlt(r)` form): with `hr = h − m r`, `h' = E hr` and
    /// `Ī' = E (Ī + r× h× + hr× r×) Eᵀ`, the middle term expanded with
    /// `a× b× = b aᵀ − (a·b) 1` into `h rᵀ + r hrᵀ − (r·h + hr·r) 1` (no `m r·r` product, so a
    /// massless inertia stays zero however far it is moved).
    #[inline]
    pub fn apply_inertia(&self, i: &SpatialInertia) -> SpatialInertia {
        let (r, h) = (self.r, i.h);
        let hr = h - r * i.mass;
        let mid = i.ibar + outer3(h, r) + outer3(r, hr)
            - DMat3::from_diagonal(DVec3::splat(r.dot(h) + hr.dot(r)));
        SpatialInertia {
            mass: i.mass,
            h: self.e * hr,
            ibar: self.e * mid * self.e.transpose(),
        }
    }

    /// A point's coordinates in B given its coordinates in A.
    #[inline]
    pub fn apply_point(&self, p: DVec3) -> DVec3 {
        self.e * (p - self.r)
    }

    /// A point's coordinates in A given its coordinates in B.
    #[inline]
    pub fn inv_apply_point(&self, p: DVec3) -> DVec3 {
        self.e.transpose() * p + self.r
    }

    /// The 6×6 motion transform matrix `[E 0; -E r× E]`.
    pub fn to_motion_mat6(&self) -> Mat6 {
        let er = -(self.e * skew(self.r));
        Mat6::from_blocks(self.e, DMat3::ZERO, er, self.e)
    }

    /// The 6×6 force transform matrix `[E -E r×; 0 E]`.
    pub fn to_force_mat6(&self) -> Mat6 {
        let er = -(self.e * skew(self.r));
        Mat6::from_blocks(self.e, er, DMat3::ZERO, self.e)
    }
}

/// Composition: `(a * b) m = a (b m)`.
impl Mul for SpatialTransform {
    type Output = SpatialTransform;
    #[inline]
    fn mul(self, b: SpatialTransform) -> SpatialTransform {
        SpatialTransform {
            e: self.e * b.e,
            r: b.r + b.e.transpose() * self.r,
        }
    }
}

impl SpatialMotion {
    /// The 6×6 matrix `crm(v)` of `v ×` (RBDA eq. 2.31).
    pub fn crm(self) -> Mat6 {
        let (wx, vx) = (skew(self.w), skew(self.v));
        Mat6::from_blocks(wx, DMat3::ZERO, vx, wx)
    }

    /// The 6×6 matrix `crf(v)` of `v ×*` = `-crm(v)ᵀ` (RBDA eq. 2.32).
    pub fn crf(self) -> Mat6 {
        let (wx, vx) = (skew(self.w), skew(self.v));
        Mat6::from_blocks(wx, vx, DMat3::ZERO, wx)
    }
}
