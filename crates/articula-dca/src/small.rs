//! The DCA and ABA passes' small dense pieces: the `L D Lᵀ` factorisation of a one-axis
//! join's 5×5 constraint system ([`ldl5`]), the 6×6 Cholesky factor of a general join
//! ([`cholesky6_inv_diag`]) and, for joints with armature, the square root of its
//! semidefinite projector ([`psd_root`]), the `k × k` joint-space inverses of multi-DOF joints
//! ([`SmallSpd`]), the tiled storage of DCA's diagonal blocks ([`SymT`]), and the Cholesky
//! factorisation of a row-major `n × n` matrix whose size is only known at run time
//! ([`cholesky_rows`], the contact solver's subspace systems). The fixed-size Cholesky
//! factorisation, and the symmetric 6×6 types, live in articula-spatial
//! (docs/design.md#numerics).

#[cfg(doc)]
use articula_spatial::internals::cholesky_into;
use articula_spatial::internals::{invert_spd_into, joint_block_regular, Arith};

/// A square root `R` of a symmetric positive semidefinite 6×6 `Q`: `RᵀR = Q`, from
/// `Q = L D Lᵀ` (unit lower `L`, `D ≥ 0`) as `R = D^½ Lᵀ`. A pivot at rounding level (the
/// directions of joints without armature, where `Q` is singular) is taken as 0 with its
/// column. For DCA's joins of joints with armature (`dca.rs`).
pub(crate) fn psd_root(q: [[f64; 6]; 6]) -> [[f64; 6]; 6] {
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

/// Cholesky factor `L` (lower, `L Lᵀ = A`) of a 6×6 symmetric positive definite matrix (its
/// lower triangle is read; [`cholesky_into`]'s operations, the same bits), `None` when a pivot
/// is not positive. **The diagonal holds `1 / L_jj`**, so that the triangular solves multiply
/// instead of dividing (a division's latency is on their critical path). Unrolled column by
/// column and without early exits: 5% of DCA on the floating humanoid over [`cholesky_into`].
#[inline(always)]
pub(crate) fn cholesky6_inv_diag(a: &[[f64; 6]; 6]) -> Option<[[f64; 6]; 6]> {
    let mut l = [[0.0f64; 6]; 6];
    let mut ok = true;
    col::<0>(a, &mut l, &mut ok);
    col::<1>(a, &mut l, &mut ok);
    col::<2>(a, &mut l, &mut ok);
    col::<3>(a, &mut l, &mut ok);
    col::<4>(a, &mut l, &mut ok);
    col::<5>(a, &mut l, &mut ok);
    ok.then_some(l)
}

/// Column `J` of [`cholesky6_inv_diag`] (rows J..6), from the columns before it.
#[inline(always)]
fn col<const J: usize>(a: &[[f64; 6]; 6], l: &mut [[f64; 6]; 6], ok: &mut bool) {
    let mut d = a[J][J];
    for p in 0..J {
        d -= l[J][p] * l[J][p];
    }
    // `!(d > 0)` also catches NaN.
    *ok &= d > 0.0;
    let inv = 1.0 / d.sqrt();
    l[J][J] = inv;
    for i in (J + 1)..6 {
        let mut x = a[i][J];
        for p in 0..J {
            x -= l[i][p] * l[J][p];
        }
        l[i][J] = x * inv;
    }
}

/// `L D Lᵀ` of a 5×5 symmetric positive definite matrix given by its lower-triangle entries
/// `a(i, j)`, `i ≥ j`; `None` when a pivot is not positive. Returns L packed by rows (`(i, j)`
/// at `i (i + 1) / 2 + j`: `L_ij` below the diagonal, `1 / d_i` on it). The recursion's
/// critical path holds one division and one multiply–add per column and no square root; its
/// multiply–subtracts go through `A` (fused in DCA's fused compilation, which halves their
/// latency).
#[inline(always)]
///
/// A pivot that rounding has made zero or negative (the matrix is positive semidefinite in
/// exact arithmetic; its smallest eigenvalues can drown in the rounding of the largest) is
/// replaced by its magnitude (at least ε times its diagonal entry): the factors are then those
/// of a nearby positive definite matrix, and the second value is `true` — the caller must
/// refine the solution against the exact equations. `None`: a NaN.
pub(crate) fn ldl5<A: Arith>(a: impl Fn(usize, usize) -> f64) -> Option<([f64; 15], bool)> {
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

/// A k×k symmetric positive definite matrix, k ≤ 6, row-major in a fixed array.
#[derive(Clone, Copy, Debug, Default)]
pub struct SmallSpd {
    /// Dimension.
    pub k: usize,
    /// Entries; only the leading k×k block is used.
    pub a: [[f64; 6]; 6],
}

impl SmallSpd {
    /// Inverts in place by Cholesky; `false` when not positive definite or, for k ≥ 2, not a
    /// regular joint block (`joint_block_regular`: a gimbal lock).
    pub fn invert(&mut self) -> bool {
        match self.k {
            0 => true,
            1 => {
                let d = self.a[0][0];
                if d.is_nan() || d <= 0.0 {
                    return false;
                }
                self.a[0][0] = 1.0 / d;
                true
            }
            2 => self.invert_fixed::<2>(),
            3 => self.invert_fixed::<3>(),
            4 => self.invert_fixed::<4>(),
            5 => self.invert_fixed::<5>(),
            _ => self.invert_fixed::<6>(),
        }
    }

    /// [`SmallSpd::invert`] for `k = K` > 1, with loops of fixed length: `A = L Lᵀ`,
    /// `A⁻¹ = L⁻ᵀ L⁻¹` ([`invert_spd_into`]).
    #[inline(always)]
    fn invert_fixed<const K: usize>(&mut self) -> bool {
        debug_assert_eq!(self.k, K);
        let a = self.a;
        joint_block_regular(&a, K) && invert_spd_into(&a, K, &mut self.a)
    }

    /// `y = self · x` on the leading k entries.
    #[inline]
    pub fn mul(&self, x: &[f64], y: &mut [f64]) {
        for i in 0..self.k {
            let mut s = 0.0;
            for j in 0..self.k {
                s += self.a[i][j] * x[j];
            }
            y[i] = s;
        }
    }
}

/// Tile of the 2×2 block `(I, J)` (`I ≤ J`, blocks of rows and columns `2I, 2I+1`) in [`SymT`].
pub(crate) const TILE: [[usize; 3]; 3] = [[0, 1, 2], [1, 3, 4], [2, 4, 5]];

/// A symmetric 6×6 matrix (the value type is `articula_spatial::SymMat6`) in the storage of
/// DCA's Gram updates: its six upper 2×2 tiles `(I, J)`, `I ≤ J` (in the order
/// of [`TILE`]), each by rows `[a_{2I,2J}, a_{2I,2J+1}, a_{2I+1,2J}, a_{2I+1,2J+1}]` (a diagonal
/// tile holds its mirrored entry too): DCA's diagonal blocks Φ_hh, whose Gram updates then
/// run on whole pairs of columns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SymT(pub [[f64; 4]; 6]);

impl SymT {
    pub const ZERO: SymT = SymT([[0.0; 4]; 6]);

    /// Entry `(r, c)`.
    #[inline(always)]
    pub fn at(&self, r: usize, c: usize) -> f64 {
        let (r, c) = if r / 2 > c / 2 { (c, r) } else { (r, c) };
        self.0[TILE[r / 2][c / 2]][2 * (r % 2) + c % 2]
    }

    /// `a + b`.
    #[inline(always)]
    pub fn sum(a: &SymT, b: &SymT) -> SymT {
        let mut s = *a;
        for (st, bt) in s.0.iter_mut().zip(&b.0) {
            for k in 0..4 {
                st[k] += bt[k];
            }
        }
        s
    }
}

/// In place, the Cholesky factor `L` (`L Lᵀ = A`) of the leading `n × n` block of the
/// row-major symmetric positive semidefinite `a` (row stride `n`; its lower triangle is read
/// and overwritten with `L`, the upper one is left alone): [`cholesky_into`]'s recursion,
/// `L_jj = √(a_jj − Σ_{p<j} L_jp²)`, `L_ij = (a_ij − Σ_{p<j} L_ip L_jp) / L_jj`, for a size
/// known only at run time, **skipping dependent rows**: a pivot `a_jj − Σ L_jp² ≤ skip · a_jj`
/// (row `j` a combination of the rows before it, to that relative precision) drops row and
/// column `j` (`L_jj = 0` marks it, its column below is 0). [`cholesky_rows_solve`] then
/// solves the equations of the kept rows with `x_j = 0` on the dropped ones: the exact
/// solution when the system is consistent. Returns the number of dropped rows, `None` for a
/// NaN. O(n³/6).
pub(crate) fn cholesky_rows(a: &mut [f64], n: usize, skip: f64) -> Option<usize> {
    let mut dropped = 0;
    for j in 0..n {
        let row_j = &mut a[j * n..(j + 1) * n];
        let ajj = row_j[j];
        let d = ajj - dot(&row_j[..j], &row_j[..j]);
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
        let r = 1.0 / row_j[j];
        for i in (j + 1)..n {
            let (upper, lower) = a.split_at_mut(i * n);
            let lj = &upper[j * n..j * n + j];
            let li = &mut lower[..n];
            li[j] = (li[j] - dot(&li[..j], lj)) * r;
        }
    }
    Some(dropped)
}

/// `a · b` in four interleaved partial sums (`Σ_{p ≡ r mod 4}`, r = 0..3, then
/// `(s₀ + s₁) + (s₂ + s₃)`): independent chains the compiler can run in vector lanes.
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
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

/// `b ← x` with `L Lᵀ x = b` on the rows [`cholesky_rows`] kept (its factor in the lower
/// triangle of the row-major `n × n` `l`) and `x_j = 0` on the rows it dropped: forward then
/// back substitution, O(n²).
pub(crate) fn cholesky_rows_solve(l: &[f64], n: usize, b: &mut [f64]) {
    for i in 0..n {
        let lii = l[i * n + i];
        if lii == 0.0 {
            b[i] = 0.0;
            continue;
        }
        b[i] = (b[i] - dot(&l[i * n..i * n + i], &b[..i])) / lii;
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

#[cfg(test)]
mod tests {
    use super::*;
    use articula_spatial::PackedSymMat6;

    /// `SymT::at` reads the entry of the matrix it was tiled from.
    #[test]
    fn tiled_layout_matches_the_whole_matrix() {
        let dense = PackedSymMat6(std::array::from_fn(|k| 1.0 + k as f64 * 0.37))
            .to_mat6()
            .0;
        let mut t = SymT::ZERO;
        for (i, j) in [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)] {
            for k in 0..4 {
                t.0[TILE[i][j]][k] = dense[2 * i + k / 2][2 * j + k % 2];
            }
        }
        for i in 0..6 {
            for j in 0..6 {
                assert_eq!(t.at(i, j), dense[i][j], "({i}, {j})");
            }
        }
    }

    /// `cholesky6_inv_diag`'s factor with its diagonal inverted back is `L` with `L Lᵀ = A`,
    /// and `SmallSpd::invert` gives `A A⁻¹ = 1` for every size.
    #[test]
    fn factor_and_inverses() {
        let mut a = [[0.0; 6]; 6];
        for i in 0..6 {
            for j in 0..6 {
                a[i][j] = 1.0 / (1.0 + i as f64 + j as f64) + if i == j { 1.0 } else { 0.0 };
            }
        }
        let mut l = cholesky6_inv_diag(&a).expect("SPD");
        for j in 0..6 {
            l[j][j] = 1.0 / l[j][j];
        }
        for i in 0..6 {
            for j in 0..6 {
                let llt: f64 = (0..6).map(|p| l[i][p] * l[j][p]).sum();
                assert!((llt - a[i][j]).abs() < 1e-14, "({i}, {j})");
            }
        }
        for k in 1..=6 {
            let mut m = SmallSpd { k, a };
            assert!(m.invert(), "k = {k}");
            for i in 0..k {
                for j in 0..k {
                    let e: f64 = (0..k).map(|p| a[i][p] * m.a[p][j]).sum();
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((e - want).abs() < 1e-13, "k = {k} ({i}, {j}): {e}");
                }
            }
        }
        // The run-time-sized factor solves A x = b; with a dependent row (A's row 6 the sum of
        // rows 0 and 1: a singular 7 × 7) it drops that row and solves the consistent system
        // exactly; an indefinite matrix fails.
        let want = [1.0, -2.0, 0.5, 3.0, -1.5, 0.25];
        let flat: Vec<f64> = a.iter().flatten().copied().collect();
        let mut l = flat.clone();
        assert_eq!(cholesky_rows(&mut l, 6, 1e-12), Some(0));
        let mut b: Vec<f64> = (0..6)
            .map(|i| (0..6).map(|j| flat[i * 6 + j] * want[j]).sum::<f64>())
            .collect();
        cholesky_rows_solve(&l, 6, &mut b);
        for (x, w) in b.iter().zip(want) {
            assert!((x - w).abs() < 1e-13, "{b:?}");
        }
        // B = Cᵀ A C with C (6 × 7) = [1 | e₀ + e₁]: B's last row and column are the sums of
        // its first two.
        let c = |i: usize, j: usize| match j {
            6 => (i < 2) as u8 as f64,
            _ => (i == j) as u8 as f64,
        };
        let mut big = vec![0.0; 49];
        for i in 0..7 {
            for j in 0..7 {
                big[i * 7 + j] = (0..6)
                    .flat_map(|p| (0..6).map(move |q| (p, q)))
                    .map(|(p, q)| c(p, i) * a[p][q] * c(q, j))
                    .sum();
            }
        }
        // Right-hand side B y for y = (want, 0): consistent.
        let y: Vec<f64> = want.iter().copied().chain([0.0]).collect();
        let rhs: Vec<f64> = (0..7)
            .map(|i| (0..7).map(|j| big[i * 7 + j] * y[j]).sum::<f64>())
            .collect();
        let mut l = big.clone();
        assert_eq!(cholesky_rows(&mut l, 7, 1e-12), Some(1));
        let mut x = rhs.clone();
        cholesky_rows_solve(&l, 7, &mut x);
        for i in 0..7 {
            let bx: f64 = (0..7).map(|j| big[i * 7 + j] * x[j]).sum();
            assert!((bx - rhs[i]).abs() < 1e-13, "row {i}: {bx} vs {}", rhs[i]);
        }
        assert_eq!(x[6], 0.0);
        a[3][3] = -1.0;
        let mut bad: Vec<f64> = a.iter().flatten().copied().collect();
        // (A negative pivot is dropped, not factored.)
        assert_eq!(cholesky_rows(&mut bad, 6, 1e-12), Some(1));
        assert!(cholesky6_inv_diag(&a).is_none());
        assert!(!SmallSpd { k: 6, a }.invert());
    }
}
