//! Rigid-body spatial inertia.

use crate::{Mat6, SpatialForce, SpatialMotion, SymMat6};
use glam::{DMat3, DVec3};
use std::ops::{Add, AddAssign};

/// The spatial inertia of a rigid body (RBDA eq. 2.62), stored as mass `m`, first moment
/// `h = m c` and rotational inertia `ibar` about the frame origin:
/// `I = [ibar, h×; h×ᵀ, m 1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpatialInertia {
    /// Mass (kg).
    pub mass: f64,
    /// First moment of mass `m c` (kg·m), `c` the centre of mass.
    pub h: DVec3,
    /// Rotational inertia about the frame origin (kg·m²), symmetric.
    pub ibar: DMat3,
}

impl Default for SpatialInertia {
    fn default() -> Self {
        Self::ZERO
    }
}

/// `-[c]× [c]×` = `(c·c) 1 - c cᵀ`.
#[inline]
fn neg_skew_sq(c: DVec3) -> DMat3 {
    DMat3::from_diagonal(DVec3::splat(c.length_squared())) - outer3(c, c)
}

#[inline]
pub(crate) fn outer3(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// The skew-symmetric matrix `[a]×` with `[a]× b = a × b`.
#[inline]
pub fn skew(a: DVec3) -> DMat3 {
    DMat3::from_cols(
        DVec3::new(0.0, a.z, -a.y),
        DVec3::new(-a.z, 0.0, a.x),
        DVec3::new(a.y, -a.x, 0.0),
    )
}

impl SpatialInertia {
    /// The zero inertia (a massless body).
    pub const ZERO: Self = Self {
        mass: 0.0,
        h: DVec3::ZERO,
        ibar: DMat3::ZERO,
    };

    /// From mass, centre of mass and rotational inertia about the centre of mass, all in the
    /// frame the inertia is expressed in (RBDA eq. 2.63).
    pub fn new(mass: f64, com: DVec3, inertia_about_com: DMat3) -> Self {
        Self {
            mass,
            h: com * mass,
            ibar: inertia_about_com + neg_skew_sq(com) * mass,
        }
    }

    /// Centre of mass (the origin for a massless body).
    #[inline]
    pub fn com(&self) -> DVec3 {
        if self.mass > 0.0 {
            self.h / self.mass
        } else {
            DVec3::ZERO
        }
    }

    /// Rotational inertia about the centre of mass.
    #[inline]
    pub fn inertia_about_com(&self) -> DMat3 {
        if self.mass > 0.0 {
            let c = self.com();
            self.ibar - neg_skew_sq(c) * self.mass
        } else {
            self.ibar
        }
    }

    /// `I v`: the momentum of a body moving with spatial velocity `v`.
    #[inline]
    pub fn mul_motion(&self, v: SpatialMotion) -> SpatialForce {
        SpatialForce {
            n: self.ibar * v.w + self.h.cross(v.v),
            f: v.v * self.mass - self.h.cross(v.w),
        }
    }

    /// Kinetic energy `½ vᵀ I v`.
    #[inline]
    pub fn kinetic_energy(&self, v: SpatialMotion) -> f64 {
        0.5 * v.dot(self.mul_motion(v))
    }

    /// The explicit 6×6 matrix.
    #[inline]
    pub fn to_mat6(&self) -> SymMat6 {
        let hx = skew(self.h);
        let m1 = DMat3::from_diagonal(DVec3::splat(self.mass));
        SymMat6::from_mat6(&Mat6::from_blocks(self.ibar, hx, hx.transpose(), m1))
    }

    /// The inverse `I⁻¹` (a force→motion map), or `None` when the inertia is singular
    /// (massless, or a point/rod mass with a singular rotational inertia).
    ///
    /// Computed about the centre of mass, where `I` is block diagonal, then shifted:
    /// with `J = I_c⁻¹` and `c` the centre of mass,
    /// `I⁻¹ = [J, −J c×; c× J, −c× J c× + 1/m]` — better conditioned than inverting the 6×6
    /// matrix about a distant origin.
    pub fn inverse(&self) -> Option<SymMat6> {
        if self.mass.is_nan() || self.mass <= 0.0 {
            return None;
        }
        let c = self.com();
        let ic = self.inertia_about_com();
        if ic.determinant() <= 0.0 {
            return None;
        }
        let j = ic.inverse();
        let cx = skew(c);
        let tl = j;
        let tr = -(j * cx);
        let bl = cx * j;
        let br = -(cx * j * cx) + DMat3::from_diagonal(DVec3::splat(1.0 / self.mass));
        let inv = SymMat6::from_mat6(&Mat6::from_blocks(tl, tr, bl, br));
        inv.is_finite().then_some(inv)
    }

    /// True when all entries are finite.
    pub fn is_finite(&self) -> bool {
        self.mass.is_finite() && self.h.is_finite() && self.ibar.is_finite()
    }
}

impl Add for SpatialInertia {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        Self {
            mass: self.mass + o.mass,
            h: self.h + o.h,
            ibar: self.ibar + o.ibar,
        }
    }
}
impl AddAssign for SpatialInertia {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}
