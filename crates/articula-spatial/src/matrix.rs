//! Dense 6×6 matrices: [`Mat6`] (general, e.g. cross-inertia blocks Φ12) and [`SymMat6`]
//! (symmetric, e.g. inverse-inertia blocks Φ11, Φ22, the DCA matrices V and W and ABA's
//! articulated inertias, with the operations of the articulated-body recursion).
//!
//! A matrix that maps forces to motions (an inverse inertia) is applied with
//! [`Mat6::force_to_motion`]; one that maps motions to forces (an inertia) with
//! [`Mat6::motion_to_force`]. Both are plain row-major `[[f64; 6]; 6]` underneath.

// Dense index arithmetic reads clearer with explicit indices.
#![allow(clippy::needless_range_loop)]

use crate::arith::Portable;
use crate::cholesky::invert_spd_into;
use crate::kernels::dot6;
use crate::{SpatialForce, SpatialInertia, SpatialMotion};
use glam::DMat3;
use std::ops::{Add, AddAssign, Mul, Neg, Sub, SubAssign};

/// A general 6×6 matrix, row-major.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mat6(pub [[f64; 6]; 6]);

/// A symmetric 6×6 matrix. The full array is stored; every constructor keeps it symmetric.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SymMat6(Mat6);

impl Default for Mat6 {
    fn default() -> Self {
        Self::ZERO
    }
}
impl Default for SymMat6 {
    fn default() -> Self {
        Self::ZERO
    }
}

/// `m · x`: each row's scalar product with `x`, left to right.
#[inline]
fn mv(m: &[[f64; 6]; 6], x: &[f64; 6]) -> [f64; 6] {
    let mut y = [0.0; 6];
    for i in 0..6 {
        y[i] = dot6::<Portable>(&m[i], x);
    }
    y
}

impl Mat6 {
    /// The zero matrix.
    pub const ZERO: Self = Mat6([[0.0; 6]; 6]);
    /// The identity.
    pub const IDENTITY: Self = Mat6([
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
    ]);

    /// Entry `(i, j)`.
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.0[i][j]
    }

    /// The matrix `[tl tr; bl br]` from four 3×3 blocks.
    #[inline]
    pub fn from_blocks(tl: DMat3, tr: DMat3, bl: DMat3, br: DMat3) -> Mat6 {
        let mut m = [[0.0; 6]; 6];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] = tl.col(j)[i];
                m[i][j + 3] = tr.col(j)[i];
                m[i + 3][j] = bl.col(j)[i];
                m[i + 3][j + 3] = br.col(j)[i];
            }
        }
        Mat6(m)
    }

    /// The transpose.
    #[inline(always)]
    pub fn transpose(&self) -> Mat6 {
        let mut t = [[0.0; 6]; 6];
        for (i, row) in self.0.iter().enumerate() {
            for (j, x) in row.iter().enumerate() {
                t[j][i] = *x;
            }
        }
        Mat6(t)
    }

    /// The outer product `a bᵀ`.
    #[inline]
    pub fn outer(a: &[f64; 6], b: &[f64; 6]) -> Mat6 {
        let mut m = [[0.0; 6]; 6];
        for i in 0..6 {
            for j in 0..6 {
                m[i][j] = a[i] * b[j];
            }
        }
        Mat6(m)
    }

    /// `self · x` for a raw 6-vector.
    #[inline]
    pub fn mul_vec(&self, x: &[f64; 6]) -> [f64; 6] {
        mv(&self.0, x)
    }

    /// `selfᵀ · x` for a raw 6-vector.
    #[inline]
    pub fn tr_mul_vec(&self, x: &[f64; 6]) -> [f64; 6] {
        let mut y = [0.0; 6];
        for (i, r) in self.0.iter().enumerate() {
            let xi = x[i];
            for j in 0..6 {
                y[j] += r[j] * xi;
            }
        }
        y
    }

    /// `self · x` for a symmetric `self` stored whole, as `Σ_j x_j (row j)` (its rows are its
    /// columns): whole rows, which vectorise, the sums started with their first term. Each
    /// entry is the same sum in the same order as [`Mat6::mul_vec`]'s and
    /// [`SymMat6::mul_vec`]'s, so the same bits (but for the sign of a zero).
    #[inline(always)]
    pub fn sym_mul_vec(&self, x: &[f64; 6]) -> [f64; 6] {
        let d = &self.0;
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

    /// Applies a force→motion matrix (an inverse inertia or cross-inertia block).
    #[inline]
    pub fn force_to_motion(&self, f: SpatialForce) -> SpatialMotion {
        SpatialMotion::from_array(self.mul_vec(&f.to_array()))
    }

    /// Applies a motion→force matrix (an inertia).
    #[inline]
    pub fn motion_to_force(&self, m: SpatialMotion) -> SpatialForce {
        SpatialForce::from_array(self.mul_vec(&m.to_array()))
    }

    /// Applies the transpose of a force→motion matrix: `Φ12ᵀ f` = `Φ21 f`.
    #[inline]
    pub fn tr_force_to_motion(&self, f: SpatialForce) -> SpatialMotion {
        SpatialMotion::from_array(self.tr_mul_vec(&f.to_array()))
    }

    /// `self · b`.
    #[inline]
    pub fn mul_mat(&self, b: &Mat6) -> Mat6 {
        let mut c = [[0.0; 6]; 6];
        for i in 0..6 {
            let a = &self.0[i];
            let ci = &mut c[i];
            for k in 0..6 {
                let aik = a[k];
                let bk = &b.0[k];
                for j in 0..6 {
                    ci[j] += aik * bk[j];
                }
            }
        }
        Mat6(c)
    }

    /// `self · bᵀ`.
    #[inline]
    pub fn mul_tr(&self, b: &Mat6) -> Mat6 {
        let mut c = [[0.0; 6]; 6];
        for i in 0..6 {
            for j in 0..6 {
                c[i][j] = dot6::<Portable>(&self.0[i], &b.0[j]);
            }
        }
        Mat6(c)
    }

    /// Largest absolute entry.
    pub fn max_abs(&self) -> f64 {
        self.0.iter().flatten().fold(0.0, |m, x| m.max(x.abs()))
    }

    /// True when every entry is finite.
    pub fn is_finite(&self) -> bool {
        self.0.iter().flatten().all(|x| x.is_finite())
    }

    /// The symmetric part `(self + selfᵀ) / 2`.
    #[inline]
    pub fn symmetric_part(&self) -> SymMat6 {
        let mut m = self.0;
        for i in 0..6 {
            for j in (i + 1)..6 {
                let s = 0.5 * (m[i][j] + m[j][i]);
                m[i][j] = s;
                m[j][i] = s;
            }
        }
        SymMat6(Mat6(m))
    }
}

impl Add for Mat6 {
    type Output = Mat6;
    #[inline]
    fn add(mut self, o: Mat6) -> Mat6 {
        self += o;
        self
    }
}
impl Sub for Mat6 {
    type Output = Mat6;
    #[inline]
    fn sub(mut self, o: Mat6) -> Mat6 {
        self -= o;
        self
    }
}
impl AddAssign for Mat6 {
    #[inline]
    fn add_assign(&mut self, o: Mat6) {
        for i in 0..6 {
            for j in 0..6 {
                self.0[i][j] += o.0[i][j];
            }
        }
    }
}
impl SubAssign for Mat6 {
    #[inline]
    fn sub_assign(&mut self, o: Mat6) {
        for i in 0..6 {
            for j in 0..6 {
                self.0[i][j] -= o.0[i][j];
            }
        }
    }
}
impl Neg for Mat6 {
    type Output = Mat6;
    #[inline]
    fn neg(self) -> Mat6 {
        let mut m = self.0;
        m.iter_mut().flatten().for_each(|x| *x = -*x);
        Mat6(m)
    }
}
impl Mul for Mat6 {
    type Output = Mat6;
    #[inline]
    fn mul(self, b: Mat6) -> Mat6 {
        self.mul_mat(&b)
    }
}
impl Mul<f64> for Mat6 {
    type Output = Mat6;
    #[inline]
    fn mul(self, s: f64) -> Mat6 {
        let mut m = self.0;
        m.iter_mut().flatten().for_each(|x| *x *= s);
        Mat6(m)
    }
}

impl SymMat6 {
    /// The zero matrix.
    pub const ZERO: Self = SymMat6(Mat6::ZERO);
    /// The identity.
    pub const IDENTITY: Self = SymMat6(Mat6::IDENTITY);

    /// Wraps a matrix the caller knows to be symmetric; it is symmetrised to remove round-off.
    #[inline]
    pub fn from_mat6(m: &Mat6) -> SymMat6 {
        m.symmetric_part()
    }

    /// The full matrix.
    #[inline]
    pub fn as_mat6(&self) -> &Mat6 {
        &self.0
    }

    /// Entry `(i, j)`.
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.0 .0[i][j]
    }

    /// `self · x` for a raw 6-vector.
    #[inline]
    pub fn mul_vec(&self, x: &[f64; 6]) -> [f64; 6] {
        mv(&self.0 .0, x)
    }

    /// Applies a force→motion symmetric matrix (an inverse inertia block).
    #[inline]
    pub fn force_to_motion(&self, f: SpatialForce) -> SpatialMotion {
        self.0.force_to_motion(f)
    }

    /// Applies a motion→force symmetric matrix (V or W of the DCA).
    #[inline]
    pub fn motion_to_force(&self, m: SpatialMotion) -> SpatialForce {
        self.0.motion_to_force(m)
    }

    /// The congruence `A · self · Aᵀ`, symmetric by construction (only the upper triangle is
    /// computed).
    #[inline]
    pub fn congruence(&self, a: &Mat6) -> SymMat6 {
        let t = a.mul_mat(&self.0); // A S
        let mut c = [[0.0; 6]; 6];
        for i in 0..6 {
            for j in i..6 {
                let s = dot6::<Portable>(&t.0[i], &a.0[j]);
                c[i][j] = s;
                c[j][i] = s;
            }
        }
        SymMat6(Mat6(c))
    }

    /// Inverse of a symmetric positive definite matrix by Cholesky factorisation
    /// ([`invert_spd_into`]), exactly symmetric. Returns `None` when a pivot is not positive
    /// (the matrix is not SPD to working precision).
    pub fn inverse_spd(&self) -> Option<SymMat6> {
        let mut inv = [[0.0f64; 6]; 6];
        invert_spd_into(&self.0 .0, 6, &mut inv).then_some(SymMat6(Mat6(inv)))
    }

    /// True when every entry is finite.
    pub fn is_finite(&self) -> bool {
        self.0.is_finite()
    }
}

impl Add for SymMat6 {
    type Output = SymMat6;
    #[inline]
    fn add(self, o: SymMat6) -> SymMat6 {
        SymMat6(self.0 + o.0)
    }
}
impl Sub for SymMat6 {
    type Output = SymMat6;
    #[inline]
    fn sub(self, o: SymMat6) -> SymMat6 {
        SymMat6(self.0 - o.0)
    }
}
impl Neg for SymMat6 {
    type Output = SymMat6;
    #[inline]
    fn neg(self) -> SymMat6 {
        SymMat6(-self.0)
    }
}
impl Mul<f64> for SymMat6 {
    type Output = SymMat6;
    #[inline]
    fn mul(self, s: f64) -> SymMat6 {
        SymMat6(self.0 * s)
    }
}
impl From<SymMat6> for Mat6 {
    fn from(s: SymMat6) -> Mat6 {
        s.0
    }
}

/// The articulated-body recursion's operations on a symmetric 6×6 (ABA's articulated
/// inertias `Iᴬ`, DCA's leaf clusters). Each writes an entry of the upper triangle and its
/// mirror, so the matrix stays exactly symmetric; the sums are those of the 21-entry packed
/// layout ABA kept before (December 2026: the same bits). That layout went: with it ABA ran
/// 3–4% faster on chain300 (`cargo xtask time aba 300 200 100`, medians 28.48–28.68 µs against
/// 29.59–29.77, three alternated rounds on a loaded machine), 1–2% on the floating humanoid and
/// on a 10,000-link chain — under the 5% a second layout has to show.
impl SymMat6 {
    /// Sets entry `(i, j)` and its mirror `(j, i)` to `x`.
    #[inline(always)]
    pub fn set(&mut self, i: usize, j: usize, x: f64) {
        self.0 .0[i][j] = x;
        self.0 .0[j][i] = x;
    }

    /// The spatial inertia `[Ī, h×; h×ᵀ, m 1]` (`Ī`'s upper triangle, mirrored).
    #[inline]
    pub fn from_inertia(i: &SpatialInertia) -> SymMat6 {
        let (b, h, m) = (&i.ibar, i.h, i.mass);
        // Column-major glam: b.col(j)[i] = Ī_ij.
        let upper = [
            b.x_axis.x, b.y_axis.x, b.z_axis.x, 0.0, -h.z, h.y, // row 0
            b.y_axis.y, b.z_axis.y, h.z, 0.0, -h.x, // row 1
            b.z_axis.z, -h.y, h.x, 0.0, // row 2
            m, 0.0, 0.0, // row 3
            m, 0.0, // row 4
            m,   // row 5
        ];
        let mut s = SymMat6::ZERO;
        let mut k = 0;
        for i in 0..6 {
            for j in i..6 {
                s.set(i, j, upper[k]);
                k += 1;
            }
        }
        s
    }

    /// `self · [w; 0]`: [`SymMat6::mul_vec`] of a vector whose last three entries are zero,
    /// without them (the same sums to their last nonzero term, so the same values).
    #[inline(always)]
    pub fn mul_angular(&self, w: &[f64; 3]) -> [f64; 6] {
        let a = &self.0 .0;
        std::array::from_fn(|r| a[r][0] * w[0] + a[r][1] * w[1] + a[r][2] * w[2])
    }

    /// A copy of the whole matrix (for [`Mat6::sym_mul_vec`] on several vectors).
    #[inline(always)]
    pub fn to_mat6(&self) -> Mat6 {
        self.0
    }

    /// `self += a − alpha · u uᵀ` (the articulated-inertia update of a 1-DOF joint): entry
    /// `(i, j)` is `s_ij + (a_ij − (α u_i) u_j)`.
    #[inline(always)]
    pub fn add_sub_outer(&mut self, a: &SymMat6, u: &[f64; 6], alpha: f64) {
        let au = u.map(|x| alpha * x);
        for i in 0..6 {
            for j in i..6 {
                let x = self.0 .0[i][j] + (a.0 .0[i][j] - au[i] * u[j]);
                self.set(i, j, x);
            }
        }
    }

    /// `self − alpha · u uᵀ`: entry `(i, j)` is `s_ij − (α u_i) u_j`.
    #[inline(always)]
    pub fn sub_outer(&self, u: &[f64; 6], alpha: f64) -> SymMat6 {
        let au = u.map(|x| alpha * x);
        let mut s = SymMat6::ZERO;
        for i in 0..6 {
            for j in i..6 {
                s.set(i, j, self.0 .0[i][j] - au[i] * u[j]);
            }
        }
        s
    }

    /// The same inertia about a point `r` behind this one (`Xᵀ I X` with
    /// `X = [1, 0; −r×, 1]`, the motion transform from the new point to this one): with
    /// `I = [A, B; Bᵀ, C]` (angular rows first), `C' = C`, `B' = B + r× C` and
    /// `A' = A + Tᵀ + r× B'ᵀ` where `T = r× Bᵀ` (so `A' = A + T + Tᵀ − r× C r×`, the parallel
    /// axis theorem of a general symmetric 6×6). ABA moves a child's articulated inertia from
    /// its joint to its parent's with it (`r` = child origin − parent origin).
    #[inline(always)]
    pub fn shifted(&self, r: [f64; 3]) -> SymMat6 {
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let g = |i: usize, j: usize| self.get(i, j);
        // Columns of C and rows of B.
        let ccol: [[f64; 3]; 3] = std::array::from_fn(|j| [g(3, 3 + j), g(4, 3 + j), g(5, 3 + j)]);
        let brow: [[f64; 3]; 3] = std::array::from_fn(|i| [g(i, 3), g(i, 4), g(i, 5)]);
        // Column j of r× C, and of T = r× Bᵀ (column j of Bᵀ is row j of B).
        let rc: [[f64; 3]; 3] = std::array::from_fn(|j| cross(r, ccol[j]));
        let t: [[f64; 3]; 3] = std::array::from_fn(|j| cross(r, brow[j]));
        // B' = B + r× C, by rows: B'_ij = B_ij + (r× C)_ij = brow[i][j] + rc[j][i].
        let b2: [[f64; 3]; 3] =
            std::array::from_fn(|i| std::array::from_fn(|j| brow[i][j] + rc[j][i]));
        // Column j of r× B'ᵀ.
        let rb: [[f64; 3]; 3] = std::array::from_fn(|j| cross(r, b2[j]));
        let mut out = *self;
        for i in 0..3 {
            for j in i..3 {
                // A'_ij = A_ij + T_ji + (r× B'ᵀ)_ij
                out.set(i, j, g(i, j) + t[i][j] + rb[j][i]);
            }
            for j in 0..3 {
                out.set(i, 3 + j, b2[i][j]);
            }
        }
        out
    }

    /// `self += a`.
    #[inline(always)]
    pub fn add_assign(&mut self, a: &SymMat6) {
        self.0 += a.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// `shifted(r)` moves an inertia to the point `r` behind: a rigid body's is its inertia
    /// about that point (centre of mass `c + r`), and as the shift is a congruence
    /// `Xᵀ I X`, an articulated-like `I − u uᵀ` goes to `shifted(I) − (Xᵀu)(Xᵀu)ᵀ` with
    /// `Xᵀ [n; f] = [n + r × f; f]`.
    #[test]
    fn shifted_is_the_parallel_axis_theorem() {
        let ic = DMat3::from_cols(
            DVec3::new(0.3, 0.01, -0.02),
            DVec3::new(0.01, 0.2, 0.03),
            DVec3::new(-0.02, 0.03, 0.4),
        );
        let (m, c, r) = (2.5, DVec3::new(0.1, -0.2, 0.3), DVec3::new(-0.7, 0.4, 1.1));
        let here = SymMat6::from_inertia(&SpatialInertia::new(m, c, ic));
        let there = SymMat6::from_inertia(&SpatialInertia::new(m, c + r, ic));
        let u = [0.3, -1.2, 0.5, 2.0, -0.4, 0.9];
        let f = DVec3::new(u[3], u[4], u[5]);
        let n = DVec3::new(u[0], u[1], u[2]) + r.cross(f);
        let xu = [n.x, n.y, n.z, f.x, f.y, f.z];
        let got = [
            here.shifted(r.to_array()),
            here.sub_outer(&u, 0.7).shifted(r.to_array()),
        ];
        let want = [there, there.sub_outer(&xu, 0.7)];
        for (g, w) in got.iter().zip(&want) {
            for i in 0..6 {
                for j in 0..6 {
                    let (a, b) = (g.get(i, j), w.get(i, j));
                    assert!((a - b).abs() < 1e-13, "({i}, {j}): {a} vs {b}");
                    assert_eq!(a.to_bits(), g.get(j, i).to_bits());
                }
            }
        }
    }

    /// `mul_angular(w)` is `mul_vec([w; 0])` to the bit.
    #[test]
    fn mul_angular_is_mul_vec_with_zero_linear_part() {
        let mut p = SymMat6::ZERO;
        for i in 0..6 {
            for j in i..6 {
                p.set(i, j, ((i * 6 + j) as f64 * 0.731).sin() * 3.0 + 0.1);
            }
        }
        for w in [[0.3, -1.2, 0.5], [1e-9, 2.0, -7.5], [0.0, 0.0, 1.0]] {
            let full = p.mul_vec(&[w[0], w[1], w[2], 0.0, 0.0, 0.0]);
            assert_eq!(p.mul_angular(&w).map(f64::to_bits), full.map(f64::to_bits));
        }
    }

    /// `from_inertia` is `SpatialInertia::to_mat6` entry for entry; `set` keeps the matrix
    /// symmetric.
    #[test]
    fn from_inertia_matches_the_whole_matrix() {
        let mut m = SymMat6::ZERO;
        m.set(1, 4, 2.5);
        assert_eq!((m.get(1, 4), m.get(4, 1)), (2.5, 2.5));
        let inertia = SpatialInertia::new(
            2.0,
            DVec3::new(0.1, -0.2, 0.3),
            DMat3::from_diagonal(DVec3::new(1.0, 2.0, 3.0)),
        );
        let p = SymMat6::from_inertia(&inertia);
        let full = inertia.to_mat6();
        for i in 0..6 {
            for j in 0..6 {
                assert_eq!(p.get(i, j), full.get(i, j), "({i}, {j})");
            }
        }
    }
}
