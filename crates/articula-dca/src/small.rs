//! DCA's and ABA's small storage types: a joint's `k × k` joint-space inverse ([`SmallSpd`])
//! and the tiled storage of DCA's diagonal blocks ([`SymT`]). The factorisations they are
//! built with (the small dense Cholesky / `L D Lᵀ` family), the dot family and the symmetric
//! 6×6 value type live in articula-spatial (docs/design.md#numerics).

use articula_spatial::numerics::invert_joint_block;

/// A joint's `k × k` symmetric positive definite block (`D` or `D⁻¹`, k ≤ 6), row-major in a
/// fixed array with its size: storage only, inverted by the Cholesky family's
/// [`invert_joint_block`].
#[derive(Clone, Copy, Debug, Default)]
pub struct SmallSpd {
    /// Dimension.
    pub k: usize,
    /// Entries; only the leading k×k block is used.
    pub a: [[f64; 6]; 6],
}

impl SmallSpd {
    /// Inverts in place ([`invert_joint_block`]); `false` when not positive definite or, for
    /// k ≥ 2, not a regular joint block (`joint_block_regular`: a gimbal lock).
    pub fn invert(&mut self) -> bool {
        invert_joint_block(&mut self.a, self.k)
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
/// run on whole pairs of columns. Read and written only through [`SymT::at`], [`SymT::tile`],
/// [`SymT::set_tile`] and [`SymT::from_tiles`]; `gather.rs` converts to and from a whole
/// row-major 6×6 (`dense`, `sym_tiles`).
///
/// Measured against the whole row-major layout (the same accessors over `[[f64; 6]; 6]`, the
/// off-diagonal tiles mirrored; the same bits), `cargo xtask time dca 300 200 100` and
/// `… humanoid-floating 1000 100`, three alternated rounds on a loaded machine, December 2026:
/// chain300 medians 66.27 66.46 66.71 µs tiled against 68.21 69.46 67.93 whole (2–4%), the
/// floating humanoid 3.83 3.84 3.85 against 3.90 3.91 3.86 (1–2%). Below the 5% that a second
/// layout is to show; kept because DCA on chain300 is the figure held against Pinocchio, and
/// moving Φ_hh onto `SymMat6` itself would also change its bits (a diagonal tile's two
/// off-diagonal entries are separate Gram sums, equal only to rounding).
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

    /// Tile `(i, j)`, `i ≤ j`: `[a_{2i,2j}, a_{2i,2j+1}, a_{2i+1,2j}, a_{2i+1,2j+1}]`.
    #[inline(always)]
    pub fn tile(&self, i: usize, j: usize) -> [f64; 4] {
        self.0[TILE[i][j]]
    }

    /// Sets tile `(i, j)`, `i ≤ j` (entries as [`SymT::tile`] returns them).
    #[inline(always)]
    pub fn set_tile(&mut self, i: usize, j: usize, t: [f64; 4]) {
        self.0[TILE[i][j]] = t;
    }

    /// The matrix from its six upper tiles in the order of [`TILE`] (`(0,0), (0,1), (0,2),
    /// (1,1), (1,2), (2,2)`).
    #[inline(always)]
    pub fn from_tiles(t: [[f64; 4]; 6]) -> SymT {
        SymT(t)
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

    /// `SymT::at` reads the entry of the matrix it was tiled from.
    #[test]
    fn tiled_layout_matches_the_whole_matrix() {
        let mut dense = [[0.0; 6]; 6];
        for i in 0..6 {
            for j in i..6 {
                let x = 1.0 + (i * 7 + j * 3) as f64 * 0.37;
                dense[i][j] = x;
                dense[j][i] = x;
            }
        }
        let mut t = SymT::ZERO;
        for (i, j) in [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)] {
            t.set_tile(
                i,
                j,
                std::array::from_fn(|k| dense[2 * i + k / 2][2 * j + k % 2]),
            );
        }
        for i in 0..6 {
            for j in 0..6 {
                assert_eq!(t.at(i, j), dense[i][j], "({i}, {j})");
            }
        }
    }
}
