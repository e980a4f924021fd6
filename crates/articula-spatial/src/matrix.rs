//! Dense 6×6 matrices: [`Mat6`] (general, e.g. cross-inertia blocks Φ12) and [`SymMat6`]
//! (symmetric, e.g. inverse-inertia blocks Φ11, Φ22 and the DCA matrices V and W).
//!
//! A matrix that maps forces to motions (an inverse inertia) is applied with
//! [`Mat6::force_to_motion`]; one that maps motions to forces (an inertia) with
//! [`Mat6::motion_to_force`]. Both are plain row-major `[[f64; 6]; 6]` underneath.

// Dense index arithmetic reads clearer with explicit indices.
#![allow(clippy::needless_range_loop)]

use crate::{SpatialForce, SpatialMotion};
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

#[inline]
fn mv(m: &[[f64; 6]; 6], x: &[f64; 6]) -> [f64; 6] {
    let mut y = [0.0; 6];
    for i in 0..6 {
        let r = &m[i];
        y[i] = r[0] * x[0] + r[1] * x[1] + r[2] * x[2] + r[3] * x[3] + r[4] * x[4] + r[5] * x[5];
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
    #[inline]
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
                let (a, bb) = (&self.0[i], &b.0[j]);
                c[i][j] = a[0] * bb[0]
                    + a[1] * bb[1]
                    + a[2] * bb[2]
                    + a[3] * bb[3]
                    + a[4] * bb[4]
                    + a[5] * bb[5];
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
                let (x, y) = (&t.0[i], &a.0[j]);
                let s = x[0] * y[0]
                    + x[1] * y[1]
                    + x[2] * y[2]
                    + x[3] * y[3]
                    + x[4] * y[4]
                    + x[5] * y[5];
                c[i][j] = s;
                c[j][i] = s;
            }
        }
        SymMat6(Mat6(c))
    }

    /// `self - alpha · u uᵀ` (a symmetric rank-1 update).
    #[inline]
    pub fn sub_outer(&self, u: &[f64; 6], alpha: f64) -> SymMat6 {
        let mut m = self.0 .0;
        for i in 0..6 {
            let aui = alpha * u[i];
            // Upper triangle only, mirrored: `(α u_i) u_j` and `(α u_j) u_i` round differently.
            for j in i..6 {
                let s = m[i][j] - aui * u[j];
                m[i][j] = s;
                m[j][i] = s;
            }
        }
        SymMat6(Mat6(m))
    }

    /// `self += a − alpha · u uᵀ` in place (the articulated-inertia update of a 1-DOF joint).
    #[inline]
    pub fn add_sub_outer(&mut self, a: &SymMat6, u: &[f64; 6], alpha: f64) {
        let (s, a) = (&mut self.0 .0, &a.0 .0);
        for i in 0..6 {
            let aui = alpha * u[i];
            for j in i..6 {
                let x = s[i][j] + a[i][j] - aui * u[j];
                s[i][j] = x;
                s[j][i] = x;
            }
        }
    }

    /// `self += a` in place.
    #[inline]
    pub fn add_assign(&mut self, a: &SymMat6) {
        self.0 += a.0;
    }

    /// Inverse of a symmetric positive definite matrix by Cholesky factorisation.
    /// Returns `None` when a pivot is not positive (the matrix is not SPD to working precision).
    pub fn inverse_spd(&self) -> Option<SymMat6> {
        let a = &self.0 .0;
        // L Lᵀ = A.
        let mut l = [[0.0f64; 6]; 6];
        for j in 0..6 {
            let mut d = a[j][j];
            for k in 0..j {
                d -= l[j][k] * l[j][k];
            }
            if d.is_nan() || d <= 0.0 {
                return None;
            }
            let djj = d.sqrt();
            l[j][j] = djj;
            let inv = 1.0 / djj;
            for i in (j + 1)..6 {
                let mut s = a[i][j];
                for k in 0..j {
                    s -= l[i][k] * l[j][k];
                }
                l[i][j] = s * inv;
            }
        }
        // Linv = L⁻¹ (lower triangular).
        let mut li = [[0.0f64; 6]; 6];
        for i in 0..6 {
            li[i][i] = 1.0 / l[i][i];
            for j in 0..i {
                let mut s = 0.0;
                for k in j..i {
                    s -= l[i][k] * li[k][j];
                }
                li[i][j] = s / l[i][i];
            }
        }
        // A⁻¹ = L⁻ᵀ L⁻¹.
        let mut inv = [[0.0f64; 6]; 6];
        for i in 0..6 {
            for j in i..6 {
                let mut s = 0.0;
                for k in j..6 {
                    s += li[k][i] * li[k][j];
                }
                inv[i][j] = s;
                inv[j][i] = s;
            }
        }
        Some(SymMat6(Mat6(inv)))
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
