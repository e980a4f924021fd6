//! Small dense Cholesky factorisations and SPD solves (k ≤ 6) on the stack: the joint-space
//! matrices `D = Sᵀ V S` and `D = Sᵀ Iᴬ S` of multi-DOF joints, and DCA's 6×6
//! `Φ^A_jj + Φ^B_jj`.

/// Cholesky factor `L` (lower) of the leading k×k block of a symmetric positive definite
/// matrix, `None` when a pivot is not positive.
#[inline]
pub fn cholesky(a: &[[f64; 6]; 6], k: usize) -> Option<[[f64; 6]; 6]> {
    let mut l = [[0.0f64; 6]; 6];
    for j in 0..k {
        let mut d = a[j][j];
        for p in 0..j {
            d -= l[j][p] * l[j][p];
        }
        if d.is_nan() || d <= 0.0 {
            return None;
        }
        let ljj = d.sqrt();
        l[j][j] = ljj;
        let inv = 1.0 / ljj;
        for i in (j + 1)..k {
            let mut x = a[i][j];
            for p in 0..j {
                x -= l[i][p] * l[j][p];
            }
            l[i][j] = x * inv;
        }
    }
    Some(l)
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
        let k = self.k;
        if k == 1 {
            let d = self.a[0][0];
            if d.is_nan() || d <= 0.0 {
                return false;
            }
            self.a[0][0] = 1.0 / d;
            return true;
        }
        let Some(l) = cholesky(&self.a, k) else {
            return false;
        };
        let mut li = [[0.0f64; 6]; 6];
        for i in 0..k {
            li[i][i] = 1.0 / l[i][i];
            for j in 0..i {
                let mut s = 0.0;
                for p in j..i {
                    s -= l[i][p] * li[p][j];
                }
                li[i][j] = s / l[i][i];
            }
        }
        for i in 0..k {
            for j in i..k {
                let mut s = 0.0;
                for p in j..k {
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
