//! Small dense Cholesky factorisations and SPD solves (k ≤ 6) on the stack: the joint-space
//! matrices `D = Sᵀ V S` and `D = Sᵀ Iᴬ S` of multi-DOF joints, and DCA's 6×6
//! `Φ^A_jj + Φ^B_jj`.

use crate::arith::Arith;

/// Cholesky factor `L` (lower) of the leading k×k block of a symmetric positive definite
/// matrix, `None` when a pivot is not positive.
#[inline]
pub fn cholesky(a: &[[f64; 6]; 6], k: usize) -> Option<[[f64; 6]; 6]> {
    let mut l = [[0.0f64; 6]; 6];
    let mut inv = [0.0f64; 6];
    cholesky_into(a, k, &mut l, &mut inv).then_some(l)
}

/// [`cholesky`]'s factorisation of the leading `k × k` block of `a` (its lower triangle is
/// read) into the caller's arrays: the lower triangle of the leading block of `l` gets `L`
/// (nothing else is written, nothing else is read) and `inv[j]` the `1 / L_jj` column `j` is
/// scaled by — the same operations in the same order, so the same bits wherever it is inlined.
/// `false` when a pivot is not positive (or NaN).
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

/// Cholesky factor `L` (lower, `L Lᵀ = A`) of a 6×6 symmetric positive definite matrix
/// (its lower triangle is read), `None` when a pivot is not positive. Fully unrolled.
/// **The diagonal holds `1 / L_jj`**, so that the triangular solves multiply instead of
/// dividing (a division's latency is on their critical path).
#[inline(always)]
pub fn cholesky6(a: &[[f64; 6]; 6]) -> Option<[[f64; 6]; 6]> {
    let mut l = [[0.0f64; 6]; 6];
    let mut ok = true;
    col::<0, 6>(a, &mut l, &mut ok);
    col::<1, 6>(a, &mut l, &mut ok);
    col::<2, 6>(a, &mut l, &mut ok);
    col::<3, 6>(a, &mut l, &mut ok);
    col::<4, 6>(a, &mut l, &mut ok);
    col::<5, 6>(a, &mut l, &mut ok);
    ok.then_some(l)
}

/// `L D Lᵀ` of a 5×5 symmetric positive definite matrix given by its lower-triangle entries
/// `a(i, j)`, `i ≥ j`; `None` when a pivot is not positive. Returns L packed by rows (`(i, j)`
/// at `i (i + 1) / 2 + j`: `L_ij` below the diagonal, `1 / d_i` on it). The recursion's
/// critical path holds one division and one multiply–add per column and no square root; its
/// multiply–subtracts go through `A` (fused in DCA's fused compilation, which halves their
/// latency).
#[inline(always)]
pub(crate) fn ldl5<A: Arith>(a: impl Fn(usize, usize) -> f64) -> Option<[f64; 15]> {
    // l: L below the diagonal, 1/d_j on it; c_ij = L_ij d_j (i > j).
    let mut l = [[0.0f64; 5]; 5];
    let mut c = [[0.0f64; 5]; 5];
    let mut ok = true;
    ldl_col::<A, 0>(&a, &mut l, &mut c, &mut ok);
    ldl_col::<A, 1>(&a, &mut l, &mut c, &mut ok);
    ldl_col::<A, 2>(&a, &mut l, &mut c, &mut ok);
    ldl_col::<A, 3>(&a, &mut l, &mut c, &mut ok);
    ldl_col::<A, 4>(&a, &mut l, &mut c, &mut ok);
    ok.then_some([
        l[0][0], l[1][0], l[1][1], l[2][0], l[2][1], l[2][2], l[3][0], l[3][1], l[3][2], l[3][3],
        l[4][0], l[4][1], l[4][2], l[4][3], l[4][4],
    ])
}

/// Column `J` of [`ldl5`]: `d_J = a_JJ − Σ_p c_Jp² (1/d_p)`, `c_iJ = a_iJ − Σ_p L_ip c_Jp`,
/// `L_iJ = c_iJ / d_J`. (`c_Jp² · 1/d_p` rather than `L_Jp c_Jp`: the square is ready before
/// the division `1/d_p`, so from one pivot's division to the next there is one multiply–add,
/// not a multiply and then a multiply–add.)
#[inline(always)]
fn ldl_col<A: Arith, const J: usize>(
    a: &impl Fn(usize, usize) -> f64,
    l: &mut [[f64; 5]; 5],
    c: &mut [[f64; 5]; 5],
    ok: &mut bool,
) {
    let mut d = a(J, J);
    for p in 0..J {
        d = A::neg_mul_add(c[J][p] * c[J][p], l[p][p], d);
    }
    // `!(d > 0)` also catches NaN.
    *ok &= d > 0.0;
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

/// Column `J` of the Cholesky factor of the leading N×N block (rows J..N), from the columns
/// before it.
#[inline(always)]
fn col<const J: usize, const N: usize>(a: &[[f64; 6]; 6], l: &mut [[f64; 6]; 6], ok: &mut bool) {
    let mut d = a[J][J];
    for p in 0..J {
        d -= l[J][p] * l[J][p];
    }
    // `!(d > 0)` also catches NaN.
    *ok &= d > 0.0;
    let inv = 1.0 / d.sqrt();
    l[J][J] = inv;
    for i in (J + 1)..N {
        let mut x = a[i][J];
        for p in 0..J {
            x -= l[i][p] * l[J][p];
        }
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
    /// Inverts in place by Cholesky; `false` when not positive definite.
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
    /// `A⁻¹ = L⁻ᵀ L⁻¹`.
    #[inline(always)]
    pub fn invert_fixed<const K: usize>(&mut self) -> bool {
        debug_assert_eq!(self.k, K);
        let Some(l) = cholesky(&self.a, K) else {
            return false;
        };
        let mut li = [[0.0f64; 6]; 6];
        for i in 0..K {
            li[i][i] = 1.0 / l[i][i];
            for j in 0..i {
                let mut s = 0.0;
                for p in j..i {
                    s -= l[i][p] * li[p][j];
                }
                li[i][j] = s / l[i][i];
            }
        }
        for i in 0..K {
            for j in i..K {
                let mut s = 0.0;
                for p in j..K {
                    s += li[p][i] * li[p][j];
                }
                self.a[i][j] = s;
                self.a[j][i] = s;
            }
        }
        true
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

/// The packed index of every `(i, j)` (both triangles).
#[cfg(test)]
const PIDX: [[usize; 6]; 6] = {
    let mut t = [[0; 6]; 6];
    let mut k = 0;
    let mut i = 0;
    while i < 6 {
        let mut j = i;
        while j < 6 {
            t[i][j] = k;
            t[j][i] = k;
            k += 1;
            j += 1;
        }
        i += 1;
    }
    t
};

/// A symmetric 6×6 matrix stored as its 21 upper-triangle entries (row by row): the
/// articulated inertias of ABA take 168 bytes instead of 288.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sym6(pub [f64; 21]);

impl Sym6 {
    pub const ZERO: Sym6 = Sym6([0.0; 21]);

    /// Entry `(i, j)`.
    #[cfg(test)]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.0[PIDX[i][j]]
    }

    /// The spatial inertia `[Ī, h×; h×ᵀ, m 1]`.
    #[inline]
    pub fn from_inertia(i: &articula_spatial::SpatialInertia) -> Sym6 {
        let (b, h, m) = (&i.ibar, i.h, i.mass);
        // Ī is symmetric: take its upper triangle (column-major glam: b.col(j)[i] = Ī_ij).
        Sym6([
            b.x_axis.x, b.y_axis.x, b.z_axis.x, 0.0, -h.z, h.y, // row 0
            b.y_axis.y, b.z_axis.y, h.z, 0.0, -h.x, // row 1
            b.z_axis.z, -h.y, h.x, 0.0, // row 2
            m, 0.0, 0.0, // row 3
            m, 0.0, // row 4
            m,   // row 5
        ])
    }

    /// `self · x`.
    #[inline(always)]
    pub fn mul_vec(&self, x: &[f64; 6]) -> [f64; 6] {
        let a = &self.0;
        [
            a[0] * x[0] + a[1] * x[1] + a[2] * x[2] + a[3] * x[3] + a[4] * x[4] + a[5] * x[5],
            a[1] * x[0] + a[6] * x[1] + a[7] * x[2] + a[8] * x[3] + a[9] * x[4] + a[10] * x[5],
            a[2] * x[0] + a[7] * x[1] + a[11] * x[2] + a[12] * x[3] + a[13] * x[4] + a[14] * x[5],
            a[3] * x[0] + a[8] * x[1] + a[12] * x[2] + a[15] * x[3] + a[16] * x[4] + a[17] * x[5],
            a[4] * x[0] + a[9] * x[1] + a[13] * x[2] + a[16] * x[3] + a[18] * x[4] + a[19] * x[5],
            a[5] * x[0] + a[10] * x[1] + a[14] * x[2] + a[17] * x[3] + a[19] * x[4] + a[20] * x[5],
        ]
    }

    /// The full matrix, by rows (which are its columns).
    #[inline(always)]
    pub fn dense(&self) -> [[f64; 6]; 6] {
        let a = &self.0;
        [
            [a[0], a[1], a[2], a[3], a[4], a[5]],
            [a[1], a[6], a[7], a[8], a[9], a[10]],
            [a[2], a[7], a[11], a[12], a[13], a[14]],
            [a[3], a[8], a[12], a[15], a[16], a[17]],
            [a[4], a[9], a[13], a[16], a[18], a[19]],
            [a[5], a[10], a[14], a[17], a[19], a[20]],
        ]
    }

    /// [`Sym6::mul_vec`] on the matrix unpacked by [`Sym6::dense`]: the columns scaled and
    /// summed in turn, which is each row's sum in [`Sym6::mul_vec`]'s order (the same bits),
    /// on whole columns.
    #[inline(always)]
    pub fn dense_mul(d: &[[f64; 6]; 6], x: &[f64; 6]) -> [f64; 6] {
        // Rows 0–3 and 4–5 apart: one 4-wide and one 2-wide vector per column.
        let mut lo: [f64; 4] = std::array::from_fn(|r| d[0][r] * x[0]);
        let mut hi: [f64; 2] = std::array::from_fn(|r| d[0][4 + r] * x[0]);
        for j in 1..6 {
            for r in 0..4 {
                lo[r] += d[j][r] * x[j];
            }
            for r in 0..2 {
                hi[r] += d[j][4 + r] * x[j];
            }
        }
        [lo[0], lo[1], lo[2], lo[3], hi[0], hi[1]]
    }

    /// `self += a − alpha · u uᵀ`.
    #[inline(always)]
    pub fn add_sub_outer(&mut self, a: &Sym6, u: &[f64; 6], alpha: f64) {
        let (s, a) = (&mut self.0, &a.0);
        let au = u.map(|x| alpha * x);
        s[0] += a[0] - au[0] * u[0];
        s[1] += a[1] - au[0] * u[1];
        s[2] += a[2] - au[0] * u[2];
        s[3] += a[3] - au[0] * u[3];
        s[4] += a[4] - au[0] * u[4];
        s[5] += a[5] - au[0] * u[5];
        s[6] += a[6] - au[1] * u[1];
        s[7] += a[7] - au[1] * u[2];
        s[8] += a[8] - au[1] * u[3];
        s[9] += a[9] - au[1] * u[4];
        s[10] += a[10] - au[1] * u[5];
        s[11] += a[11] - au[2] * u[2];
        s[12] += a[12] - au[2] * u[3];
        s[13] += a[13] - au[2] * u[4];
        s[14] += a[14] - au[2] * u[5];
        s[15] += a[15] - au[3] * u[3];
        s[16] += a[16] - au[3] * u[4];
        s[17] += a[17] - au[3] * u[5];
        s[18] += a[18] - au[4] * u[4];
        s[19] += a[19] - au[4] * u[5];
        s[20] += a[20] - au[5] * u[5];
    }

    /// `self − alpha · u uᵀ`.
    #[inline(always)]
    pub fn sub_outer(&self, u: &[f64; 6], alpha: f64) -> Sym6 {
        let au = u.map(|x| alpha * x);
        let mut s = Sym6::ZERO;
        let mut k = 0;
        for i in 0..6 {
            for j in i..6 {
                s.0[k] = self.0[k] - au[i] * u[j];
                k += 1;
            }
        }
        s
    }

    /// `self += a`.
    #[inline(always)]
    pub fn add_assign(&mut self, a: &Sym6) {
        for k in 0..21 {
            self.0[k] += a.0[k];
        }
    }
}

/// Tile of the 2×2 block `(I, J)` (`I ≤ J`, blocks of rows and columns `2I, 2I+1`) in [`SymT`].
pub(crate) const TILE: [[usize; 3]; 3] = [[0, 1, 2], [1, 3, 4], [2, 4, 5]];

/// A symmetric 6×6 matrix stored as its six upper 2×2 tiles `(I, J)`, `I ≤ J` (in the order
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_layout_and_products_match_the_dense_matrix() {
        let mut dense = [[0.0; 6]; 6];
        let mut s = Sym6::ZERO;
        for i in 0..6 {
            for j in i..6 {
                let x = 1.0 + (i * 7 + j * 3) as f64 * 0.37;
                dense[i][j] = x;
                dense[j][i] = x;
                s.0[PIDX[i][j]] = x;
            }
        }
        let x = [0.3, -1.0, 2.0, 0.5, -0.7, 1.1];
        let y = s.mul_vec(&x);
        for i in 0..6 {
            let e: f64 = (0..6).map(|j| dense[i][j] * x[j]).sum();
            assert!((y[i] - e).abs() < 1e-12);
            for j in 0..6 {
                assert_eq!(s.get(i, j), dense[i][j]);
            }
        }
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
        let inertia = articula_spatial::SpatialInertia::new(
            2.0,
            glam::DVec3::new(0.1, -0.2, 0.3),
            glam::DMat3::from_diagonal(glam::DVec3::new(1.0, 2.0, 3.0)),
        );
        let p = Sym6::from_inertia(&inertia);
        let full = inertia.to_mat6();
        for i in 0..6 {
            for j in 0..6 {
                assert_eq!(p.get(i, j), full.get(i, j), "({i}, {j})");
            }
        }
    }
}
