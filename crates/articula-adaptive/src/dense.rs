//! Small dense kernels on flat row-major slices (dimensions ≤ 6 × handles): the handle-space
//! matrices of the acceleration metric (Ψ, K, N, M) are a few tens of rows at most.

/// `c = aᵀ b` with `a` (r × m), `b` (r × n), `c` (m × n), all row-major; `c` is overwritten.
#[inline]
pub(crate) fn at_b(a: &[f64], b: &[f64], r: usize, m: usize, n: usize, c: &mut [f64]) {
    c[..m * n].iter_mut().for_each(|x| *x = 0.0);
    for k in 0..r {
        let (ar, br) = (&a[k * m..k * m + m], &b[k * n..k * n + n]);
        for (i, &x) in ar.iter().enumerate() {
            if x == 0.0 {
                continue;
            }
            let ci = &mut c[i * n..i * n + n];
            for (cij, &y) in ci.iter_mut().zip(br) {
                *cij += x * y;
            }
        }
    }
}

/// `c = a b` with `a` (m × r), `b` (r × n), `c` (m × n); `c` is overwritten.
#[inline]
pub(crate) fn a_b(a: &[f64], b: &[f64], m: usize, r: usize, n: usize, c: &mut [f64]) {
    c[..m * n].iter_mut().for_each(|x| *x = 0.0);
    for i in 0..m {
        let ci = &mut c[i * n..i * n + n];
        for k in 0..r {
            let x = a[i * r + k];
            if x == 0.0 {
                continue;
            }
            for (cij, &y) in ci.iter_mut().zip(&b[k * n..k * n + n]) {
                *cij += x * y;
            }
        }
    }
}

/// `y = a x` with `a` (m × n).
pub(crate) fn a_x(a: &[f64], x: &[f64], m: usize, n: usize, y: &mut [f64]) {
    for i in 0..m {
        y[i] = a[i * n..i * n + n].iter().zip(x).map(|(p, q)| p * q).sum();
    }
}

/// `y = aᵀ x` with `a` (m × n), `x` (m), `y` (n).
pub(crate) fn at_x(a: &[f64], x: &[f64], m: usize, n: usize, y: &mut [f64]) {
    y[..n].iter_mut().for_each(|v| *v = 0.0);
    for i in 0..m {
        let xi = x[i];
        if xi == 0.0 {
            continue;
        }
        for (yj, &aij) in y.iter_mut().zip(&a[i * n..i * n + n]) {
            *yj += aij * xi;
        }
    }
}

/// `xᵀ a x` for a square `a` (n × n).
pub(crate) fn quad(a: &[f64], x: &[f64], n: usize) -> f64 {
    let mut s = 0.0;
    for i in 0..n {
        if x[i] == 0.0 {
            continue;
        }
        let row: f64 = a[i * n..i * n + n].iter().zip(x).map(|(p, q)| p * q).sum();
        s += x[i] * row;
    }
    s
}

/// Inverse of the leading k×k block of a symmetric positive definite matrix (k ≤ 6), through
/// its Cholesky factor: `A⁻¹ = L⁻ᵀ L⁻¹` (articula-spatial's `invert_spd_into`). `None` when not
/// positive definite.
pub(crate) fn spd_inverse(a: &[[f64; 6]; 6], k: usize) -> Option<[[f64; 6]; 6]> {
    let mut inv = [[0.0f64; 6]; 6];
    invert_spd_into(a, k, &mut inv).then_some(inv)
}

/// Cholesky factor `L` of a 6×6 symmetric positive definite matrix (see [`cholesky_k`]).
pub(crate) fn spd_cholesky(a: &[[f64; 6]; 6]) -> Option<[[f64; 6]; 6]> {
    cholesky_k(a, 6)
}

/// Cholesky factor (lower) of the leading k×k block of a symmetric positive definite matrix
/// (k ≤ 6); `None` when a pivot is not positive — articula-dca's. (A Jacobi-scaled variant
/// turned the join of a 40,000-link chain's halves indefinite where this one does not.)
pub(crate) use articula_spatial::internals::cholesky as cholesky_k;
use articula_spatial::internals::invert_spd_into;

/// `(L Lᵀ)⁻¹ u` for the leading k×k factor `L`.
#[inline(always)]
pub(crate) fn solve_llt_k(l: &[[f64; 6]; 6], u: &[f64; 5], k: usize) -> [f64; 5] {
    solve_lt_k(l, &solve_l_k(l, u, k), k)
}

/// `L⁻¹ u` for the leading k×k factor `L`.
#[inline(always)]
pub(crate) fn solve_l_k(l: &[[f64; 6]; 6], u: &[f64; 5], k: usize) -> [f64; 5] {
    let mut x = [0.0; 5];
    for i in 0..k {
        let mut v = u[i];
        for p in 0..i {
            v -= l[i][p] * x[p];
        }
        x[i] = v / l[i][i];
    }
    x
}

/// `L⁻ᵀ u` for the leading k×k factor `L`.
#[inline(always)]
pub(crate) fn solve_lt_k(l: &[[f64; 6]; 6], u: &[f64; 5], k: usize) -> [f64; 5] {
    let mut x = *u;
    for i in (0..k).rev() {
        let mut v = x[i];
        for p in (i + 1)..k {
            v -= l[p][i] * x[p];
        }
        x[i] = v / l[i][i];
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spd_inverse_times_matrix_is_identity() {
        // A badly scaled SPD matrix: B Bᵀ + diag, rows scaled by 1e-4 … 1e4.
        let mut a = [[0.0; 6]; 6];
        let s = [1e-4, 1e-2, 1.0, 1e2, 1e3, 1e4];
        for i in 0..6 {
            for j in 0..6 {
                let b = |r: usize, c: usize| ((r * 7 + c * 3) % 5) as f64 - 2.0;
                let mut x: f64 = (0..6).map(|p| b(i, p) * b(j, p)).sum();
                if i == j {
                    x += 1.0;
                }
                a[i][j] = x * s[i] * s[j];
            }
        }
        let inv = spd_inverse(&a, 6).unwrap();
        for i in 0..6 {
            for j in 0..6 {
                let x: f64 = (0..6).map(|p| a[i][p] * inv[p][j]).sum();
                let expect = if i == j { 1.0 } else { 0.0 };
                // Entry (i, j) carries the scale s_i / s_j.
                assert!((x - expect).abs() * s[j] / s[i] < 1e-12, "{i} {j} {x}");
            }
        }
        assert!(spd_inverse(&[[0.0; 6]; 6], 3).is_none());
    }

    #[test]
    fn products_match_index_formulas() {
        let a: Vec<f64> = (0..6).map(|x| x as f64 + 1.0).collect(); // 2 × 3
        let b: Vec<f64> = (0..6).map(|x| (x as f64) * 0.5 - 1.0).collect(); // 2 × 3 / 3 × 2
        let mut c = vec![0.0; 9];
        at_b(&a, &b, 2, 3, 3, &mut c); // aᵀ b: 3 × 3
        for i in 0..3 {
            for j in 0..3 {
                let x = a[i] * b[j] + a[3 + i] * b[3 + j];
                assert_eq!(c[i * 3 + j], x);
            }
        }
        let mut d = vec![0.0; 4];
        a_b(&a, &b, 2, 3, 2, &mut d); // a (2×3) b (3×2)
        for i in 0..2 {
            for j in 0..2 {
                let x: f64 = (0..3).map(|k| a[i * 3 + k] * b[k * 2 + j]).sum();
                assert_eq!(d[i * 2 + j], x);
            }
        }
        let x = [1.0, -2.0, 0.5];
        let mut y = [0.0; 2];
        a_x(&a, &x, 2, 3, &mut y);
        assert_eq!(y, [1.0 - 4.0 + 1.5, 4.0 - 10.0 + 3.0]);
        let mut z = [0.0; 3];
        at_x(&a, &[1.0, 2.0], 2, 3, &mut z);
        assert_eq!(z, [9.0, 12.0, 15.0]);
        let sq = [2.0, 1.0, 1.0, 3.0];
        assert_eq!(quad(&sq, &[1.0, 2.0], 2), 2.0 + 4.0 + 12.0);
    }
}
