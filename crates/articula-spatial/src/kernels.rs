//! Kernels on raw arrays that the passes of articula-dca and articula-adaptive share
//! (docs/design.md#numerics): the scalar products of 6-vectors in the summation orders those
//! passes are written with, and the small Cholesky factorisation with the SPD inverse built
//! on it (which [`SymMat6::inverse_spd`](crate::SymMat6::inverse_spd) uses too).
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

/// The relative pivot at or below which a joint's own `k × k` block `Sᵀ X S` is singular
/// ([`joint_block_regular`]); `X` is the inertia the method eliminates with (ABA's articulated
/// inertia, CRBA's composite inertia, DCA's inverse compliance), `S` the joint's `k` axes.
/// Every method tests the same block the same way, so they agree on what is singular. At the
/// exact gimbal lock of a composed 3-DOF joint two axes coincide and the pivot is rounding
/// (~1e-16 of the diagonal); `1e-13` leaves three digits of margin above that and refuses a
/// configuration within about 3e-7 rad of the lock, where `q̈` would lose 13 digits.
pub const JOINT_PIVOT_REL: f64 = 1e-13;

/// Whether the leading `k × k` block of the symmetric `a` (its lower triangle is read) is
/// regular as a joint block: every pivot `d_j` of its `L D Lᵀ` factorisation (columns in
/// order) is above [`JOINT_PIVOT_REL`] times its diagonal entry `a_jj`. `false` for a NaN.
pub fn joint_block_regular<const N: usize>(a: &[[f64; N]], k: usize) -> bool {
    let mut l = [[0.0f64; 6]; 6];
    let mut d = [0.0f64; 6];
    for j in 0..k.min(6) {
        let mut dj = a[j][j];
        for p in 0..j {
            dj -= l[j][p] * l[j][p] * d[p];
        }
        // `!(x > y)` also refuses a NaN.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(dj > JOINT_PIVOT_REL * a[j][j].abs()) {
            return false;
        }
        d[j] = dj;
        for i in (j + 1)..k.min(6) {
            let mut x = a[i][j];
            for p in 0..j {
                x -= l[i][p] * l[j][p] * d[p];
            }
            l[i][j] = x / dj;
        }
    }
    true
}

/// Cholesky factorisation `L Lᵀ = A` of the leading `k × k` block of a symmetric positive
/// definite `a` (its lower triangle is read) into the caller's arrays: the lower triangle of
/// the leading block of `l` gets `L` (nothing else is written) and `inv[j]` the `1 / L_jj`
/// that column `j` is scaled by. Column by column: `L_jj = √(a_jj − Σ_{p<j} L_jp²)`,
/// `L_ij = (a_ij − Σ_{p<j} L_ip L_jp) · (1 / L_jj)`, the sums left to right; the same
/// operations in the same order wherever it is inlined, so the same bits. `false` when a
/// pivot is not positive (or NaN).
#[inline(always)]
pub fn cholesky_into<const N: usize, const M: usize>(
    a: &[[f64; N]],
    k: usize,
    l: &mut [[f64; M]],
    inv: &mut [f64],
) -> bool {
    for j in 0..k {
        let mut d = a[j][j];
        for p in 0..j {
            d -= l[j][p] * l[j][p];
        }
        if d.is_nan() || d <= 0.0 {
            return false;
        }
        let ljj = d.sqrt();
        l[j][j] = ljj;
        let r = 1.0 / ljj;
        inv[j] = r;
        for i in (j + 1)..k {
            let mut x = a[i][j];
            for p in 0..j {
                x -= l[i][p] * l[j][p];
            }
            l[i][j] = x * r;
        }
    }
    true
}

/// A 6×6 block as a plain row-major array: the storage of the hot kernels that stream rows
/// of blocks ([`crate::Mat6`] wraps the same array).
pub type M6 = [[f64; 6]; 6];

/// `L⁻¹ b` by forward substitution, for the lower-triangular factor `L` of [`cholesky`] (its
/// diagonal as is: each row divides by `L_ii`).
#[inline]
pub fn solve_lower(l: &[[f64; 6]; 6], b: &[f64; 6]) -> [f64; 6] {
    let mut x = [0.0; 6];
    for i in 0..6 {
        let mut v = b[i];
        for p in 0..i {
            v -= l[i][p] * x[p];
        }
        x[i] = v / l[i][i];
    }
    x
}

/// `L⁻ᵀ b` by back substitution, `L` as in [`solve_lower`].
#[inline]
pub fn solve_lower_t(l: &[[f64; 6]; 6], b: &[f64; 6]) -> [f64; 6] {
    let mut x = [0.0; 6];
    for i in (0..6).rev() {
        let mut v = b[i];
        for p in (i + 1)..6 {
            v -= l[p][i] * x[p];
        }
        x[i] = v / l[i][i];
    }
    x
}

/// `L⁻¹ b` by forward substitution, for a lower-triangular `L` whose diagonal is stored
/// inverted (`1 / L_ii`: each row multiplies by it), as DCA's joins keep their factor
/// (`cholesky6_inv_diag` in articula-dca).
#[inline]
pub fn solve_lower_inv_diag(l: &[[f64; 6]; 6], b: &[f64; 6]) -> [f64; 6] {
    let mut x = [0.0; 6];
    for i in 0..6 {
        let mut v = b[i];
        for p in 0..i {
            v -= l[i][p] * x[p];
        }
        x[i] = v * l[i][i];
    }
    x
}

/// `L⁻ᵀ b` by back substitution, `L` as in [`solve_lower_inv_diag`].
#[inline]
pub fn solve_lower_t_inv_diag(l: &[[f64; 6]; 6], b: &[f64; 6]) -> [f64; 6] {
    let mut x = [0.0; 6];
    for i in (0..6).rev() {
        let mut v = b[i];
        for p in (i + 1)..6 {
            v -= l[p][i] * x[p];
        }
        x[i] = v * l[i][i];
    }
    x
}

/// [`cholesky_into`]'s factor `L` of the leading `k × k` block of `a`, `None` when a pivot is
/// not positive.
#[inline]
pub fn cholesky(a: &[[f64; 6]; 6], k: usize) -> Option<[[f64; 6]; 6]> {
    let mut l = [[0.0f64; 6]; 6];
    let mut inv = [0.0f64; 6];
    cholesky_into(a, k, &mut l, &mut inv).then_some(l)
}

/// The inverse of the leading `k × k` block (`k ≤ M`) of a symmetric positive definite `a`
/// (its lower triangle is read) into the leading block of `out`, both triangles:
/// `A = L Lᵀ` ([`cholesky_into`]), `L⁻¹` by forward substitution (`(L⁻¹)_ii = 1 / L_ii`,
/// `(L⁻¹)_ij = −Σ_{j≤p<i} L_ip (L⁻¹)_pj / L_ii`), then `A⁻¹ = L⁻ᵀ L⁻¹` on the upper triangle,
/// mirrored (so exactly symmetric). `false` when `a` is not positive definite to working
/// precision.
#[inline(always)]
pub fn invert_spd_into<const N: usize, const M: usize>(
    a: &[[f64; N]],
    k: usize,
    out: &mut [[f64; M]],
) -> bool {
    let mut l = [[0.0f64; M]; M];
    let mut inv = [0.0f64; M];
    if !cholesky_into(a, k, &mut l, &mut inv) {
        return false;
    }
    let mut li = [[0.0f64; M]; M];
    for i in 0..k {
        li[i][i] = inv[i];
        for j in 0..i {
            let mut x = 0.0;
            for p in j..i {
                x -= l[i][p] * li[p][j];
            }
            li[i][j] = x / l[i][i];
        }
    }
    for i in 0..k {
        for j in i..k {
            let mut x = 0.0;
            for p in j..k {
                x += li[p][i] * li[p][j];
            }
            out[i][j] = x;
            out[j][i] = x;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arith::Portable;

    /// Both triangular-solve pairs solve `A x = b` through `A = L Lᵀ`: checked against the
    /// residual `A x − b` and against `x = A⁻¹ b` with the inverse of [`invert_spd_into`]
    /// (an independent route: the inverse's columns, then a matrix-vector product).
    #[test]
    fn triangular_solves_invert_the_factor() {
        // A = M Mᵀ + I for a fixed M: symmetric positive definite, condition ~1e2.
        let m: [[f64; 6]; 6] = std::array::from_fn(|i| {
            std::array::from_fn(|j| ((i * 7 + j * 3) % 11) as f64 / 5.0 - 1.0)
        });
        let a: [[f64; 6]; 6] = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                (0..6).map(|p| m[i][p] * m[j][p]).sum::<f64>() + if i == j { 1.0 } else { 0.0 }
            })
        });
        let b = [1.0, -2.0, 0.5, 3.0, -1.5, 2.5];
        let l = cholesky(&a, 6).expect("positive definite");
        let x = solve_lower_t(&l, &solve_lower(&l, &b));
        let mut l_inv_diag = l;
        for (i, row) in l_inv_diag.iter_mut().enumerate() {
            row[i] = 1.0 / l[i][i];
        }
        let y = solve_lower_t_inv_diag(&l_inv_diag, &solve_lower_inv_diag(&l_inv_diag, &b));
        let mut inv = [[0.0; 6]; 6];
        assert!(invert_spd_into(&a, 6, &mut inv));
        for i in 0..6 {
            let residual = (0..6).map(|j| a[i][j] * x[j]).sum::<f64>() - b[i];
            assert!(residual.abs() < 1e-12, "row {i}: residual {residual:e}");
            let by_inverse = (0..6).map(|j| inv[i][j] * b[j]).sum::<f64>();
            assert!(
                (x[i] - by_inverse).abs() < 1e-11,
                "{} vs {by_inverse}",
                x[i]
            );
            assert!((y[i] - x[i]).abs() < 1e-12, "{} vs {}", y[i], x[i]);
        }
    }

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

    /// `L Lᵀ` reproduces a 4×4 SPD block, `invert_spd_into` gives `A A⁻¹ = 1`, and a matrix
    /// with a non-positive pivot is rejected.
    #[test]
    fn cholesky_and_inverse_of_a_small_block() {
        let a = [
            [4.0, 2.0, 0.4, -1.0],
            [2.0, 5.0, 1.0, 0.3],
            [0.4, 1.0, 3.0, 0.2],
            [-1.0, 0.3, 0.2, 2.0],
        ];
        let mut l = [[0.0; 4]; 4];
        let mut inv = [0.0; 4];
        assert!(cholesky_into(&a, 4, &mut l, &mut inv));
        for i in 0..4 {
            assert_eq!(inv[i], 1.0 / l[i][i]);
            for j in 0..4 {
                let llt: f64 = (0..4).map(|p| l[i][p] * l[j][p]).sum();
                assert!((llt - a[i][j]).abs() < 1e-14, "({i}, {j})");
            }
        }
        let mut ai = [[0.0; 4]; 4];
        assert!(invert_spd_into(&a, 4, &mut ai));
        for i in 0..4 {
            for j in 0..4 {
                let e: f64 = (0..4).map(|p| a[i][p] * ai[p][j]).sum();
                assert!(
                    (e - f64::from(u8::from(i == j))).abs() < 1e-14,
                    "({i}, {j})"
                );
                assert_eq!(ai[i][j].to_bits(), ai[j][i].to_bits());
            }
        }
        let mut bad = a;
        bad[2][2] = 0.1;
        assert!(!invert_spd_into(&bad, 4, &mut ai));
        assert!(cholesky(&[[0.0; 6]; 6], 1).is_none());
    }
}
