//! The small dense Cholesky and `L D Lᵀ` family that every pass of the workspace factors its
//! symmetric systems with (docs/design.md#numerics): one naming scheme, one contract.
//!
//! **Contract.** Every factorisation reads the **lower triangle** of the symmetric `A` (entries
//! `a_ij`, `i ≥ j`) and nothing above it. A Cholesky factor `L` (`L Lᵀ = A`) is lower
//! triangular: its strict lower part holds `L_ij`, its diagonal holds `L_jj`, or `1 / L_jj` for
//! the members named `…_inv_diag` (their triangular solves multiply instead of dividing: a
//! division's latency is on the critical path of DCA's joins); entries above the diagonal are
//! not written. Sums run left to right (`a_ij − Σ_{p<j} L_ip L_jp` term by term), but for the
//! run-time-sized `…_rows` members, which sum in four lanes ([`dot_lanes`]). A pivot that is
//! not positive, or NaN, is a failure: `false` or `None`, nothing to read in the output — but
//! for [`cholesky_rows_skip`], which drops that row instead (and fails only on a NaN), and
//! [`ldl5`], which clamps it (and says so).
//!
//! **Members** by size:
//! - leading `k × k` of a 6×6 (or of any `N × N` array): [`cholesky_into`] (the one
//!   recursion), [`cholesky`] and [`cholesky_inv_diag`] (its factor with either diagonal), the
//!   solves [`solve_lower`], [`solve_lower_t`] (`k = 6`), [`solve_llt_k`], and for the inverted
//!   diagonal [`solve_lower_inv_diag`], [`solve_lower_t_inv_diag`] and
//!   [`invert_factor_inv_diag`] (DCA's joins, gathers and leaf clusters); the SPD inverse
//!   [`invert_spd_into`], and [`invert_joint_block`] (a joint's `D⁻¹`, refusing a gimbal lock
//!   through [`joint_block_regular`]);
//! - run-time `n × n`, row-major: [`cholesky_rows`], [`cholesky_rows_skip`] (dropping dependent
//!   rows) and their one solve [`cholesky_rows_solve`];
//! - `L D Lᵀ`: [`joint_block_regular`] (a test, no factor kept), [`ldl5`] (DCA's one-axis
//!   join, 5×5, pivots clamped) and [`psd_root`] (a square root of a semidefinite 6×6).

// Index loops mirror the equations (rows i, columns j, sums over p).
#![allow(clippy::needless_range_loop)]

use crate::arith::Arith;
use crate::kernels::{dot_lanes, M6};

/// Cholesky factorisation `L Lᵀ = A` of the leading `k × k` block of a symmetric positive
/// definite `a` into the caller's arrays: the lower triangle of the leading block of `l` gets
/// `L` (nothing else is written) and `inv[j]` the `1 / L_jj` that column `j` is scaled by.
/// Column by column: `L_jj = √(a_jj − Σ_{p<j} L_jp²)`, `L_ij = (a_ij − Σ_{p<j} L_ip L_jp) ·
/// (1 / L_jj)`, the sums left to right; the same operations in the same order wherever it is
/// inlined, so the same bits. `false` when a pivot is not positive (or NaN).
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

/// [`cholesky_into`]'s factor `L` of the leading `k × k` block of `a`, `None` when a pivot is
/// not positive.
#[inline]
pub fn cholesky(a: &M6, k: usize) -> Option<M6> {
    let mut l = [[0.0f64; 6]; 6];
    let mut inv = [0.0f64; 6];
    cholesky_into(a, k, &mut l, &mut inv).then_some(l)
}

/// [`cholesky_into`]'s factor `L` of the leading `k × k` block of `a`, **the diagonal holding
/// `1 / L_jj`** (its `inv[j]`: the same operations, so the same bits), for the triangular
/// solves that multiply instead of dividing ([`solve_lower_inv_diag`]: a division's latency is
/// on the critical path of DCA's joins); `None` when a pivot is not positive. (An unrolled 6×6
/// copy, `cholesky6_inv_diag`, was 5% of DCA on the floating humanoid in November 2026. Against
/// this one, December 2026, `cargo xtask time dca humanoid-floating 1000 100` alternated four
/// times on a loaded machine: medians 3.66–3.73 µs with the copy, 3.73–3.81 without (minima
/// 3.50–3.68, 3.62–3.74): about 2%, under the 5% a hand-written kernel has to show, so it went.)
#[inline(always)]
pub fn cholesky_inv_diag(a: &M6, k: usize) -> Option<M6> {
    let mut l = [[0.0f64; 6]; 6];
    let mut inv = [0.0f64; 6];
    if !cholesky_into(a, k, &mut l, &mut inv) {
        return None;
    }
    for j in 0..k {
        l[j][j] = inv[j];
    }
    Some(l)
}

/// `L⁻¹ b` by forward substitution, for the 6×6 factor `L` of [`cholesky`] (each row divides
/// by `L_ii`).
#[inline]
pub fn solve_lower(l: &M6, b: &[f64; 6]) -> [f64; 6] {
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
pub fn solve_lower_t(l: &M6, b: &[f64; 6]) -> [f64; 6] {
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

/// `x ← (L Lᵀ)⁻¹ x` on its leading `k` entries, for the factor `L` of the leading `k × k`
/// block of [`cholesky`] or [`cholesky_into`]: forward then back substitution in place, each
/// row dividing by `L_ii` (the operations of [`solve_lower`] then [`solve_lower_t`] when
/// `k = 6`).
#[inline(always)]
pub fn solve_llt_k(l: &M6, k: usize, x: &mut [f64]) {
    for i in 0..k {
        let mut v = x[i];
        for p in 0..i {
            v -= l[i][p] * x[p];
        }
        x[i] = v / l[i][i];
    }
    for i in (0..k).rev() {
        let mut v = x[i];
        for p in (i + 1)..k {
            v -= l[p][i] * x[p];
        }
        x[i] = v / l[i][i];
    }
}

/// `L⁻¹ b` by forward substitution, for the factor of [`cholesky_inv_diag`] (its diagonal
/// `1 / L_ii`: each row multiplies by it).
#[inline]
pub fn solve_lower_inv_diag(l: &M6, b: &[f64; 6]) -> [f64; 6] {
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
pub fn solve_lower_t_inv_diag(l: &M6, b: &[f64; 6]) -> [f64; 6] {
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

/// `A⁻¹ = L⁻ᵀ L⁻¹` from the factor of [`cholesky_inv_diag`]: column `c` by
/// [`solve_lower_inv_diag`] then [`solve_lower_t_inv_diag`] of `e_c`, then made exactly
/// symmetric (each pair `(r, c)`, `(c, r)` replaced by its mean).
#[inline]
pub fn invert_factor_inv_diag(l: &M6) -> M6 {
    let mut inv = [[0.0; 6]; 6];
    for c in 0..6 {
        let mut e = [0.0; 6];
        e[c] = 1.0;
        let col = solve_lower_t_inv_diag(l, &solve_lower_inv_diag(l, &e));
        for r in 0..6 {
            inv[r][c] = col[r];
        }
    }
    for r in 0..6 {
        for c in r + 1..6 {
            let x = 0.5 * (inv[r][c] + inv[c][r]);
            inv[r][c] = x;
            inv[c][r] = x;
        }
    }
    inv
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

/// In place, the inverse `D⁻¹` of a joint's `k × k` block `D = Sᵀ X S` (`k ≤ 6`, the leading
/// block of `a`; lower triangle read, both written): `1 / d` for `k = 1`, else
/// [`invert_spd_into`] with loops of fixed length, after [`joint_block_regular`] (so every
/// method refuses the same gimbal locks). `false` when not positive definite or not regular;
/// `a` is then left as it was for `k ≥ 2`.
#[inline]
pub fn invert_joint_block(a: &mut M6, k: usize) -> bool {
    match k {
        0 => true,
        1 => {
            let d = a[0][0];
            if d.is_nan() || d <= 0.0 {
                return false;
            }
            a[0][0] = 1.0 / d;
            true
        }
        2 => invert_fixed::<2>(a),
        3 => invert_fixed::<3>(a),
        4 => invert_fixed::<4>(a),
        5 => invert_fixed::<5>(a),
        _ => invert_fixed::<6>(a),
    }
}

/// [`invert_joint_block`] for `k = K > 1`.
#[inline(always)]
fn invert_fixed<const K: usize>(a: &mut M6) -> bool {
    let m = *a;
    joint_block_regular(&m, K) && invert_spd_into(&m, K, a)
}

/// In place, the Cholesky factor `L` (`L Lᵀ = A`) of the row-major symmetric positive
/// definite `n × n` `a` (row stride `n`), in its lower triangle (the upper one is left
/// alone): [`cholesky_into`]'s recursion for a size known only at run time, its sums in four
/// lanes ([`dot_lanes`]). `false` when a pivot is not positive or not finite. O(n³/6).
#[inline]
pub fn cholesky_rows(a: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        // Row j left of the diagonal already holds L_jp (p < j), from the steps before.
        let row_j = &mut a[j * n..(j + 1) * n];
        let d = row_j[j] - dot_lanes(&row_j[..j], &row_j[..j]);
        if !(d > 0.0 && d.is_finite()) {
            return false;
        }
        row_j[j] = d.sqrt();
        rows_column(a, n, j);
    }
    true
}

/// [`cholesky_rows`] of a symmetric positive **semi**definite `a`, **skipping dependent
/// rows**: a pivot `a_jj − Σ L_jp² ≤ skip · |a_jj|` (or `≤ 0`: row `j` a combination of the
/// rows before it, to that relative precision) drops row and column `j` (`L_jj = 0` marks it,
/// its column below is 0). [`cholesky_rows_solve`] then solves the equations of the kept rows
/// with `x_j = 0` on the dropped ones: the exact solution when the system is consistent.
/// Returns the number of dropped rows, `None` for a NaN.
#[inline]
pub fn cholesky_rows_skip(a: &mut [f64], n: usize, skip: f64) -> Option<usize> {
    let mut dropped = 0;
    for j in 0..n {
        let row_j = &mut a[j * n..(j + 1) * n];
        let ajj = row_j[j];
        let d = ajj - dot_lanes(&row_j[..j], &row_j[..j]);
        if d.is_nan() {
            return None;
        }
        if d <= skip * ajj.abs() || d <= 0.0 {
            dropped += 1;
            row_j[j] = 0.0;
            for i in (j + 1)..n {
                a[i * n + j] = 0.0;
            }
            continue;
        }
        row_j[j] = d.sqrt();
        rows_column(a, n, j);
    }
    Some(dropped)
}

/// Column `j` of [`cholesky_rows`] below its diagonal `L_jj` (already in place):
/// `L_ij = (a_ij − Σ_{p<j} L_ip L_jp) · (1 / L_jj)`.
#[inline(always)]
fn rows_column(a: &mut [f64], n: usize, j: usize) {
    let r = 1.0 / a[j * n + j];
    for i in (j + 1)..n {
        let (upper, lower) = a.split_at_mut(i * n);
        let lj = &upper[j * n..j * n + j];
        let li = &mut lower[..n];
        li[j] = (li[j] - dot_lanes(&li[..j], lj)) * r;
    }
}

/// `b ← x` with `L Lᵀ x = b`, for the factor of [`cholesky_rows`] or [`cholesky_rows_skip`]
/// (the lower triangle of the row-major `n × n` `l`), with `x_j = 0` on the rows the latter
/// dropped (`L_jj = 0`): forward then back substitution, O(n²).
#[inline]
pub fn cholesky_rows_solve(l: &[f64], n: usize, b: &mut [f64]) {
    for i in 0..n {
        let lii = l[i * n + i];
        if lii == 0.0 {
            b[i] = 0.0;
            continue;
        }
        b[i] = (b[i] - dot_lanes(&l[i * n..i * n + i], &b[..i])) / lii;
    }
    // Lᵀ x = y by rows of L: x_i = y_i / L_ii, then y_p −= L_ip x_i for p < i.
    for i in (0..n).rev() {
        let lii = l[i * n + i];
        if lii == 0.0 {
            b[i] = 0.0;
            continue;
        }
        let x = b[i] / lii;
        b[i] = x;
        for (bp, lp) in b[..i].iter_mut().zip(&l[i * n..i * n + i]) {
            *bp -= lp * x;
        }
    }
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

/// A square root `R` of a symmetric positive semidefinite 6×6 `Q`: `RᵀR = Q`, from
/// `Q = L D Lᵀ` (unit lower `L`, `D ≥ 0`) as `R = D^½ Lᵀ`. A pivot at rounding level (the
/// directions of joints without armature, where `Q` is singular) is taken as 0 with its
/// column. For DCA's joins of joints with armature.
#[inline]
pub fn psd_root(q: M6) -> M6 {
    let scale = (0..6).map(|i| q[i][i].abs()).fold(0.0, f64::max);
    let tiny = 1e-14 * scale;
    let mut l = [[0.0; 6]; 6];
    let mut d = [0.0; 6];
    for j in 0..6 {
        let mut dj = q[j][j];
        for p in 0..j {
            dj -= l[j][p] * l[j][p] * d[p];
        }
        if dj <= tiny {
            d[j] = 0.0;
            l[j][j] = 1.0;
            continue;
        }
        d[j] = dj;
        l[j][j] = 1.0;
        for i in j + 1..6 {
            let mut x = q[i][j];
            for p in 0..j {
                x -= l[i][p] * l[j][p] * d[p];
            }
            l[i][j] = x / dj;
        }
    }
    std::array::from_fn(|r| {
        let s = d[r].sqrt();
        std::array::from_fn(|c| s * l[c][r])
    })
}

/// `L D Lᵀ` of a 5×5 symmetric positive definite matrix given by its lower-triangle entries
/// `a(i, j)`, `i ≥ j`: DCA's one-axis join. Returns L packed by rows (`(i, j)` at
/// `i (i + 1) / 2 + j`: `L_ij` below the diagonal, `1 / d_i` on it). The recursion's critical
/// path holds one division and one multiply–add per column and no square root; its
/// multiply–subtracts go through `A` (fused in DCA's fused compilation, which halves their
/// latency).
///
/// A pivot that rounding has made zero or negative (the matrix is positive semidefinite in
/// exact arithmetic; its smallest eigenvalues can drown in the rounding of the largest) is
/// replaced by its magnitude (at least ε times its diagonal entry): the factors are then those
/// of a nearby positive definite matrix, and the second value is `true` — the caller must
/// refine the solution against the exact equations. `None`: a NaN.
#[inline(always)]
pub fn ldl5<A: Arith>(a: impl Fn(usize, usize) -> f64) -> Option<([f64; 15], bool)> {
    // l: L below the diagonal, 1/d_j on it; c_ij = L_ij d_j (i > j).
    let mut l = [[0.0f64; 5]; 5];
    let mut c = [[0.0f64; 5]; 5];
    let mut ok = true;
    let mut clamped = false;
    ldl_col::<A, 0>(&a, &mut l, &mut c, &mut ok, &mut clamped);
    ldl_col::<A, 1>(&a, &mut l, &mut c, &mut ok, &mut clamped);
    ldl_col::<A, 2>(&a, &mut l, &mut c, &mut ok, &mut clamped);
    ldl_col::<A, 3>(&a, &mut l, &mut c, &mut ok, &mut clamped);
    ldl_col::<A, 4>(&a, &mut l, &mut c, &mut ok, &mut clamped);
    ok.then_some((
        [
            l[0][0], l[1][0], l[1][1], l[2][0], l[2][1], l[2][2], l[3][0], l[3][1], l[3][2],
            l[3][3], l[4][0], l[4][1], l[4][2], l[4][3], l[4][4],
        ],
        clamped,
    ))
}

/// [`ldl5`]'s replacement for a pivot `d` that is not positive (`a_jj` its diagonal entry):
/// `|d|`, at least `ε |a_jj|` and the smallest normal number; marks the factorisation clamped,
/// and failed for a NaN.
#[cold]
#[inline(never)]
fn clamp_pivot(d: f64, a_jj: f64, ok: &mut bool, clamped: &mut bool) -> f64 {
    *ok &= !d.is_nan();
    *clamped = true;
    d.abs()
        .max(f64::EPSILON * a_jj.abs())
        .max(f64::MIN_POSITIVE)
}

/// Column `J` of [`ldl5`]: `d_J = a_JJ − Σ_p c_Jp² (1/d_p)`, `c_iJ = a_iJ − Σ_p L_ip c_Jp`,
/// `L_iJ = c_iJ / d_J`. (`c_Jp² · 1/d_p` rather than `L_Jp c_Jp`: the square is ready before
/// the division `1/d_p`, so from one pivot's division to the next there is one multiply–add,
/// not a multiply and then a multiply–add.)
#[inline(always)]
// `!(d > 0.0)`: one comparison that also catches NaN.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn ldl_col<A: Arith, const J: usize>(
    a: &impl Fn(usize, usize) -> f64,
    l: &mut [[f64; 5]; 5],
    c: &mut [[f64; 5]; 5],
    ok: &mut bool,
    clamped: &mut bool,
) {
    let mut d = a(J, J);
    for p in 0..J {
        d = A::neg_mul_add(c[J][p] * c[J][p], l[p][p], d);
    }
    // Not positive (or NaN, which fails): one comparison on the common path.
    if !(d > 0.0) {
        d = clamp_pivot(d, a(J, J), ok, clamped);
    }
    let inv = 1.0 / d;
    l[J][J] = inv;
    for i in (J + 1)..5 {
        let mut x = a(i, J);
        for p in 0..J {
            x = A::neg_mul_add(l[i][p], c[J][p], x);
        }
        c[i][J] = x;
        l[i][J] = x * inv;
    }
}

#[cfg(test)]
mod tests;
