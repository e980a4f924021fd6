//! Kernels on raw arrays that the passes of articula-dca and articula-adaptive share
//! (docs/design.md#numerics): the dot family — the scalar products of 6-vectors in the
//! summation orders those passes are written with, of 3-vectors, and of run-time-sized slices
//! in vector lanes. The small Cholesky family is [`crate::cholesky`].
//!
//! A pass's results depend on the order of its sums to the last bit, so each order it uses
//! is one named function here rather than a private copy in the pass.

// Index loops mirror the equations (rows i, columns j, sums over p).
#![allow(clippy::needless_range_loop)]

use crate::arith::Arith;

/// `a · b` summed left to right, `(((a₀b₀ + a₁b₁) + a₂b₂) + …) + a₅b₅`, each step one
/// [`Arith::mul_add`]. With [`Portable`](crate::arith::Portable) it is the plain expression
/// `a₀b₀ + a₁b₁ + … + a₅b₅` (the rows of [`Mat6::mul_vec`](crate::Mat6::mul_vec), ABA's
/// `D = sᵀ U`).
#[inline(always)]
pub fn dot6<A: Arith>(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    let mut s = a[0] * b[0];
    for i in 1..6 {
        s = A::mul_add(a[i], b[i], s);
    }
    s
}

/// `a · b` as the sum of its even and its odd terms, `(a₀b₀ + a₂b₂ + a₄b₄) + (a₁b₁ + a₃b₃ +
/// a₅b₅)`: two-lane vector products and sums instead of one serial chain of six (the DCA
/// pass's).
#[inline(always)]
pub fn dot6_even_odd<A: Arith>(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    let even = A::mul_add(a[4], b[4], A::mul_add(a[2], b[2], a[0] * b[0]));
    let odd = A::mul_add(a[5], b[5], A::mul_add(a[3], b[3], a[1] * b[1]));
    even + odd
}

/// `a · b` as three pairs, `((a₀b₀ + a₁b₁) + (a₂b₂ + a₃b₃)) + (a₄b₄ + a₅b₅)`: a dependency
/// chain of a product, a multiply–add and two additions instead of six multiply–adds (for
/// passes whose `D = sᵀ U` and `Uᵀ a'` sit on the chain from joint to joint).
#[inline(always)]
pub fn dot6_pairs<A: Arith>(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    let p = [
        A::mul_add(a[1], b[1], a[0] * b[0]),
        A::mul_add(a[3], b[3], a[2] * b[2]),
        A::mul_add(a[5], b[5], a[4] * b[4]),
    ];
    (p[0] + p[1]) + p[2]
}

/// A 6×6 block as a plain row-major array: the storage of the hot kernels that stream rows
/// of blocks ([`crate::Mat6`] wraps the same array).
pub type M6 = [[f64; 6]; 6];

/// `a · b` over the shorter length, in four interleaved partial sums (`s_r = Σ_{p ≡ r mod 4}
/// a_p b_p`, each left to right, then `(s₀ + s₁) + (s₂ + s₃)`): independent chains the
/// compiler can run in vector lanes (the run-time-sized Cholesky members,
/// [`cholesky_rows`](crate::cholesky::cholesky_rows)).
#[inline(always)]
pub fn dot_lanes(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut s = [0.0f64; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for r in 0..4 {
            s[r] += x[r] * y[r];
        }
    }
    for (r, (x, y)) in ra.iter().zip(rb).enumerate() {
        s[r] += x * y;
    }
    (s[0] + s[1]) + (s[2] + s[3])
}

/// `a · x` for a 3-vector `a` and the first three entries of `x`, `(a₀x₀ + a₁x₁) + a₂x₂`, each
/// step one [`Arith::mul_add`] (DCA's one-axis joins).
#[inline(always)]
pub fn dot3<A: Arith>(a: &[f64; 3], x: &[f64]) -> f64 {
    A::mul_add(a[2], x[2], A::mul_add(a[1], x[1], a[0] * x[0]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arith::Portable;

    /// The three summation orders agree with the exact sum of small integers, and `dot6`
    /// with [`Portable`] is the plain left-to-right expression to the bit.
    #[test]
    fn dot_products_sum_the_same_terms() {
        let a = [1.0, -2.0, 3.0, 0.5, -7.0, 11.0];
        let b = [4.0, 6.0, -1.0, 8.0, 2.0, -3.0];
        let exact = 4.0 - 12.0 - 3.0 + 4.0 - 14.0 - 33.0;
        assert_eq!(dot6::<Portable>(&a, &b), exact);
        assert_eq!(dot6_even_odd::<Portable>(&a, &b), exact);
        assert_eq!(dot6_pairs::<Portable>(&a, &b), exact);
        let x = [0.1, 0.7, -0.3, 1e-9, 2.5, -1.3];
        let y = [0.3, -0.11, 0.9, 3e7, 0.17, 0.6];
        let plain =
            x[0] * y[0] + x[1] * y[1] + x[2] * y[2] + x[3] * y[3] + x[4] * y[4] + x[5] * y[5];
        assert_eq!(dot6::<Portable>(&x, &y).to_bits(), plain.to_bits());
    }

    /// `dot_lanes` and `dot3` against the exact sums of small integers, and `dot_lanes` over
    /// lengths with and without a remainder against its documented lane order.
    #[test]
    fn lane_and_three_vector_products() {
        let a = [1.0, -2.0, 3.0, 0.5, -7.0, 11.0, 4.0];
        let b = [4.0, 6.0, -1.0, 8.0, 2.0, -3.0, 0.25];
        assert_eq!(
            dot_lanes(&a, &b),
            4.0 - 12.0 - 3.0 + 4.0 - 14.0 - 33.0 + 1.0
        );
        assert_eq!(dot_lanes(&a[..6], &b), 4.0 - 12.0 - 3.0 + 4.0 - 14.0 - 33.0);
        assert_eq!(dot_lanes(&[], &b), 0.0);
        assert_eq!(dot3::<Portable>(&[1.0, -2.0, 3.0], &b), 4.0 - 12.0 - 3.0);
        let x = [0.1, 0.7, -0.3, 1e-9, 2.5, -1.3];
        let y = [0.3, -0.11, 0.9, 3e7, 0.17, 0.6];
        let lanes = ((x[0] * y[0] + x[4] * y[4]) + (x[1] * y[1] + x[5] * y[5]))
            + (x[2] * y[2] + x[3] * y[3]);
        assert_eq!(dot_lanes(&x, &y).to_bits(), lanes.to_bits());
    }
}
