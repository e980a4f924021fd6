//! Spatial motion and force vectors (Featherstone order: angular part first).

use glam::DVec3;
use std::ops::{Add, AddAssign, Mul, Neg, Sub, SubAssign};

/// A spatial motion vector `[w; v]`: angular velocity `w` and the linear velocity `v` of the
/// body-fixed point that coincides with the frame origin (Plücker coordinates).
/// Accelerations are motion vectors too.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpatialMotion {
    /// Angular part.
    pub w: DVec3,
    /// Linear part (at the frame origin).
    pub v: DVec3,
}

/// A spatial force vector `[n; f]`: the moment `n` about the frame origin and the force `f`.
/// Momenta and impulses are force vectors too.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpatialForce {
    /// Moment about the frame origin.
    pub n: DVec3,
    /// Linear force.
    pub f: DVec3,
}

macro_rules! vector_ops {
    ($t:ident, $a:ident, $b:ident) => {
        impl $t {
            /// The zero vector.
            pub const ZERO: Self = Self {
                $a: DVec3::ZERO,
                $b: DVec3::ZERO,
            };

            /// Builds the vector from its angular and linear parts.
            #[inline]
            pub const fn new($a: DVec3, $b: DVec3) -> Self {
                Self { $a, $b }
            }

            /// The six coordinates, angular part first.
            #[inline]
            pub fn to_array(self) -> [f64; 6] {
                [
                    self.$a.x, self.$a.y, self.$a.z, self.$b.x, self.$b.y, self.$b.z,
                ]
            }

            /// Builds the vector from six coordinates, angular part first.
            #[inline]
            pub fn from_array(a: [f64; 6]) -> Self {
                Self {
                    $a: DVec3::new(a[0], a[1], a[2]),
                    $b: DVec3::new(a[3], a[4], a[5]),
                }
            }

            /// True when all six coordinates are finite.
            #[inline]
            pub fn is_finite(self) -> bool {
                self.$a.is_finite() && self.$b.is_finite()
            }

            /// Euclidean norm of the six coordinates (not frame invariant; for tolerances only).
            #[inline]
            pub fn norm(self) -> f64 {
                (self.$a.length_squared() + self.$b.length_squared()).sqrt()
            }
        }

        impl Add for $t {
            type Output = Self;
            #[inline]
            fn add(self, o: Self) -> Self {
                Self {
                    $a: self.$a + o.$a,
                    $b: self.$b + o.$b,
                }
            }
        }
        impl Sub for $t {
            type Output = Self;
            #[inline]
            fn sub(self, o: Self) -> Self {
                Self {
                    $a: self.$a - o.$a,
                    $b: self.$b - o.$b,
                }
            }
        }
        impl AddAssign for $t {
            #[inline]
            fn add_assign(&mut self, o: Self) {
                self.$a += o.$a;
                self.$b += o.$b;
            }
        }
        impl SubAssign for $t {
            #[inline]
            fn sub_assign(&mut self, o: Self) {
                self.$a -= o.$a;
                self.$b -= o.$b;
            }
        }
        impl Neg for $t {
            type Output = Self;
            #[inline]
            fn neg(self) -> Self {
                Self {
                    $a: -self.$a,
                    $b: -self.$b,
                }
            }
        }
        impl Mul<f64> for $t {
            type Output = Self;
            #[inline]
            fn mul(self, s: f64) -> Self {
                Self {
                    $a: self.$a * s,
                    $b: self.$b * s,
                }
            }
        }
        impl Mul<$t> for f64 {
            type Output = $t;
            #[inline]
            fn mul(self, m: $t) -> $t {
                m * self
            }
        }
    };
}

vector_ops!(SpatialMotion, w, v);
vector_ops!(SpatialForce, n, f);

impl SpatialMotion {
    /// Motion cross product `self × m` (RBDA eq. 2.31): `[w × mw; w × mv + v × mw]`.
    #[inline]
    pub fn cross_motion(self, m: SpatialMotion) -> SpatialMotion {
        SpatialMotion {
            w: self.w.cross(m.w),
            v: self.w.cross(m.v) + self.v.cross(m.w),
        }
    }

    /// The Runge–Kutta–Munthe-Kaas slope of a pose `q0 exp(Θ)` moving with body twist `xi`,
    /// `Θ = self`: `Θ̇ = dexp⁻¹_{−Θ}(ξ) = ξ + ½ [Θ, ξ] + ¹⁄₁₂ [Θ, [Θ, ξ]]`, truncated where a
    /// fourth-order integrator needs it (`[Θ, ξ]` is the se(3) bracket, [`Self::cross_motion`]).
    #[inline]
    pub fn dexp_inv_slope(self, xi: SpatialMotion) -> SpatialMotion {
        let b1 = self.cross_motion(xi);
        let b2 = self.cross_motion(b1);
        xi + b1 * 0.5 + b2 * (1.0 / 12.0)
    }

    /// Force cross product `self ×* f` (RBDA eq. 2.32): `[w × n + v × f; w × f]`.
    #[inline]
    pub fn cross_force(self, f: SpatialForce) -> SpatialForce {
        SpatialForce {
            n: self.w.cross(f.n) + self.v.cross(f.f),
            f: self.w.cross(f.f),
        }
    }

    /// Scalar (power) product `<self, f>` = `w·n + v·f`.
    #[inline]
    pub fn dot(self, f: SpatialForce) -> f64 {
        self.w.dot(f.n) + self.v.dot(f.f)
    }
}

impl SpatialForce {
    /// Scalar (power) product `<m, self>`.
    #[inline]
    pub fn dot(self, m: SpatialMotion) -> f64 {
        m.dot(self)
    }
}
