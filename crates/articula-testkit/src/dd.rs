//! Double-double arithmetic: a value is the unevaluated sum `hi + lo` of two `f64` with
//! `|lo| ≤ ulp(hi)/2`, which carries about 106 significant bits (~32 decimal digits).
//! Error-free transformations (Knuth's two-sum, the FMA two-product) as in Hida, Li and
//! Bailey's QD library. It implements what the high-precision reference dynamics
//! ([`crate::reference`]) needs: `+ − × ÷`, `sqrt`, `sin`, `cos`.

use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// A double-double number `hi + lo`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Dd {
    pub hi: f64,
    pub lo: f64,
}

/// `a + b = s + e` exactly.
#[inline]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    let e = (a - (s - bb)) + (b - bb);
    (s, e)
}

/// `a + b = s + e` exactly, given `|a| ≥ |b|`.
#[inline]
fn quick_two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    (s, b - (s - a))
}

/// `a b = p + e` exactly (fused multiply–add).
#[inline]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

impl Dd {
    /// Zero.
    pub const ZERO: Dd = Dd { hi: 0.0, lo: 0.0 };
    /// One.
    pub const ONE: Dd = Dd { hi: 1.0, lo: 0.0 };
    /// π to double-double precision.
    pub const PI: Dd = Dd {
        hi: std::f64::consts::PI,
        lo: 1.224_646_799_147_353_2e-16,
    };

    /// The exact value of an `f64`.
    #[inline]
    pub const fn from_f64(x: f64) -> Dd {
        Dd { hi: x, lo: 0.0 }
    }

    /// Rounded to the nearest `f64`.
    #[inline]
    pub fn to_f64(self) -> f64 {
        self.hi + self.lo
    }

    /// The absolute value.
    #[inline]
    pub fn abs(self) -> Dd {
        if self.hi < 0.0 {
            -self
        } else {
            self
        }
    }

    /// Square root: one Newton step on the `f64` root (Karp's trick).
    pub fn sqrt(self) -> Dd {
        if self.hi <= 0.0 {
            return Dd::ZERO;
        }
        let x = 1.0 / self.hi.sqrt();
        let ax = self.hi * x;
        let diff = self - Dd::from_f64(ax) * Dd::from_f64(ax);
        let (s, e) = two_sum(ax, diff.hi * (x * 0.5));
        let (hi, lo) = quick_two_sum(s, e);
        Dd { hi, lo }
    }

    /// `(sin x, cos x)`: reduction by multiples of π/2 in double-double, then Taylor series on
    /// `|r| ≤ π/4` (27 terms reach 1e-33 there).
    pub fn sin_cos(self) -> (Dd, Dd) {
        let half_pi = Dd::PI * Dd::from_f64(0.5);
        let k = (self.to_f64() / std::f64::consts::FRAC_PI_2).round();
        let r = self - half_pi * Dd::from_f64(k);
        let r2 = r * r;
        // sin r = r − r³/3! + …, cos r = 1 − r²/2! + …
        let (mut s, mut c) = (r, Dd::ONE);
        let (mut ts, mut tc) = (r, Dd::ONE);
        for i in 1..=27 {
            let fi = i as f64;
            ts = -(ts * r2) / Dd::from_f64((2.0 * fi) * (2.0 * fi + 1.0));
            tc = -(tc * r2) / Dd::from_f64((2.0 * fi - 1.0) * (2.0 * fi));
            s += ts;
            c += tc;
            if ts.hi.abs() < 1e-40 && tc.hi.abs() < 1e-40 {
                break;
            }
        }
        match (k as i64).rem_euclid(4) {
            0 => (s, c),
            1 => (c, -s),
            2 => (-s, -c),
            _ => (-c, s),
        }
    }
}

impl From<f64> for Dd {
    fn from(x: f64) -> Dd {
        Dd::from_f64(x)
    }
}

impl Neg for Dd {
    type Output = Dd;
    #[inline]
    fn neg(self) -> Dd {
        Dd {
            hi: -self.hi,
            lo: -self.lo,
        }
    }
}

impl Add for Dd {
    type Output = Dd;
    /// The accurate ("IEEE") double-double sum.
    #[inline]
    fn add(self, b: Dd) -> Dd {
        let (s1, s2) = two_sum(self.hi, b.hi);
        let (t1, t2) = two_sum(self.lo, b.lo);
        let s2 = s2 + t1;
        let (s1, s2) = quick_two_sum(s1, s2);
        let s2 = s2 + t2;
        let (hi, lo) = quick_two_sum(s1, s2);
        Dd { hi, lo }
    }
}

impl Sub for Dd {
    type Output = Dd;
    #[inline]
    fn sub(self, b: Dd) -> Dd {
        self + (-b)
    }
}

impl Mul for Dd {
    type Output = Dd;
    #[inline]
    fn mul(self, b: Dd) -> Dd {
        let (p, e) = two_prod(self.hi, b.hi);
        let e = e + (self.hi * b.lo + self.lo * b.hi);
        let (hi, lo) = quick_two_sum(p, e);
        Dd { hi, lo }
    }
}

impl Div for Dd {
    type Output = Dd;
    /// Long division: three `f64` quotient digits.
    #[inline]
    fn div(self, b: Dd) -> Dd {
        let q1 = self.hi / b.hi;
        let r = self - b * Dd::from_f64(q1);
        let q2 = r.hi / b.hi;
        let r = r - b * Dd::from_f64(q2);
        let q3 = r.hi / b.hi;
        let (hi, lo) = quick_two_sum(q1, q2);
        Dd { hi, lo } + Dd::from_f64(q3)
    }
}

impl AddAssign for Dd {
    #[inline]
    fn add_assign(&mut self, b: Dd) {
        *self = *self + b;
    }
}

impl SubAssign for Dd {
    #[inline]
    fn sub_assign(&mut self, b: Dd) {
        *self = *self - b;
    }
}

impl MulAssign for Dd {
    #[inline]
    fn mul_assign(&mut self, b: Dd) {
        *self = *self * b;
    }
}

/// The scalar operations the reference dynamics is written in: `f64` (to check the code
/// against the library's f64 solvers) and [`Dd`] (the reference itself).
pub trait Real:
    Copy
    + Default
    + std::fmt::Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
{
    fn from_f64(x: f64) -> Self;
    fn to_f64(self) -> f64;
    fn sin_cos(self) -> (Self, Self);
    fn zero() -> Self {
        Self::from_f64(0.0)
    }
}

impl Real for f64 {
    fn from_f64(x: f64) -> f64 {
        x
    }
    fn to_f64(self) -> f64 {
        self
    }
    fn sin_cos(self) -> (f64, f64) {
        f64::sin_cos(self)
    }
}

impl Real for Dd {
    fn from_f64(x: f64) -> Dd {
        Dd::from_f64(x)
    }
    fn to_f64(self) -> f64 {
        Dd::to_f64(self)
    }
    fn sin_cos(self) -> (Dd, Dd) {
        Dd::sin_cos(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Relative difference in double-double.
    fn rel(a: Dd, b: Dd) -> f64 {
        ((a - b).abs().to_f64()) / b.abs().to_f64()
    }

    /// A double-double constant: `hi` the nearest f64 to a 50-digit decimal, `lo` the nearest
    /// f64 to the remainder (split with Python's `decimal` module).
    fn dd(hi: f64, lo: f64) -> Dd {
        Dd { hi, lo }
    }

    #[test]
    fn one_third_times_three_is_one_to_32_digits() {
        let third = Dd::ONE / Dd::from_f64(3.0);
        let back = third * Dd::from_f64(3.0);
        assert!((back - Dd::ONE).abs().to_f64() < 1e-32, "{back:?}");
        // In f64 the same computation leaves 1/3 with an error of 1.85e-17.
        assert_eq!(third.hi, 1.0 / 3.0);
        assert!(third.lo.abs() > 1e-17);
    }

    #[test]
    fn sums_keep_what_f64_loses() {
        let x = Dd::from_f64(1.0) + Dd::from_f64(1e-20);
        assert_eq!(x.hi, 1.0);
        assert_eq!(x.lo, 1e-20);
        let y = x - Dd::ONE;
        assert_eq!(y.to_f64(), 1e-20);
    }

    #[test]
    fn sqrt_two_matches_known_digits() {
        // √2 = 1.4142135623730950488016887242096980785696…
        let expected = dd(std::f64::consts::SQRT_2, -9.667_293_313_452_913e-17);
        let s = Dd::from_f64(2.0).sqrt();
        assert!(rel(s, expected) < 1e-31, "{s:?}");
        assert!(rel(s * s, Dd::from_f64(2.0)) < 1e-31);
    }

    #[test]
    fn pi_sin_cos_match_known_digits() {
        // sin 1 = 0.8414709848078965066525023216302989996226…
        // cos 1 = 0.5403023058681397174009366074429766037323…
        let (s, c) = Dd::ONE.sin_cos();
        let s_ref = dd(0.8414709848078965, 1.776_845_092_935_536e-18);
        let c_ref = dd(0.5403023058681398, -4.760_954_612_604_417e-17);
        assert!(rel(s, s_ref) < 1e-30, "{s:?}");
        assert!(rel(c, c_ref) < 1e-30, "{c:?}");
        // sin² + cos² = 1 and sin π = 0 (to double-double accuracy) for large arguments too.
        for x in [-7.3, -1.2, 0.0, 0.3, 2.0, 3.0, 10.0, 100.0] {
            let (s, c) = Dd::from_f64(x).sin_cos();
            assert!((s * s + c * c - Dd::ONE).abs().to_f64() < 1e-30, "x = {x}");
            assert!((s.to_f64() - x.sin()).abs() < 1e-15, "x = {x}");
        }
        let (s, c) = Dd::PI.sin_cos();
        assert!(s.abs().to_f64() < 1e-32);
        assert!((c + Dd::ONE).abs().to_f64() < 1e-32);
    }

    #[test]
    fn division_is_accurate() {
        let a = Dd::from_f64(2.0).sqrt();
        let b = Dd::from_f64(7.0);
        let q = a / b;
        assert!(rel(q * b, a) < 1e-31);
    }
}
