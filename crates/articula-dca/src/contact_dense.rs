//! Dense factorisations of the contact solver's Newton systems ([`crate::contact_newton`]),
//! row-major `n × n` with `n` known only at run time: LU with partial pivoting for the
//! non-symmetric ones (a sliding contact's rows make the system non-symmetric). The symmetric
//! ones (every pushing contact sticking) use the Cholesky family's `cholesky_rows`.

use articula_spatial::numerics::dot_lanes as dot;

/// In place, the LU factorisation with partial pivoting `P A = L U` of the row-major `n × n`
/// `a` (unit lower `L` below the diagonal, `U` on and above it; `piv[j]` the row swapped with
/// row `j` at step `j`). `false` when a pivot is zero or not finite. O(n³/3).
pub(crate) fn lu(a: &mut [f64], n: usize, piv: &mut Vec<usize>) -> bool {
    piv.clear();
    for j in 0..n {
        let (mut p, mut big) = (j, a[j * n + j].abs());
        for i in (j + 1)..n {
            let x = a[i * n + j].abs();
            if x > big {
                (p, big) = (i, x);
            }
        }
        if !(big > 0.0 && big.is_finite()) {
            return false;
        }
        piv.push(p);
        if p != j {
            for c in 0..n {
                a.swap(j * n + c, p * n + c);
            }
        }
        let (top, below) = a.split_at_mut((j + 1) * n);
        let row_j = &top[j * n..];
        let r = 1.0 / row_j[j];
        for row_i in below.chunks_exact_mut(n) {
            let l = row_i[j] * r;
            row_i[j] = l;
            if l != 0.0 {
                for (x, u) in row_i[j + 1..].iter_mut().zip(&row_j[j + 1..]) {
                    *x -= l * u;
                }
            }
        }
    }
    true
}

/// `b ← x` with `A x = b`, `A` factored by [`lu`]: the row swaps, then forward and back
/// substitution, O(n²).
pub(crate) fn lu_solve(lu: &[f64], n: usize, piv: &[usize], b: &mut [f64]) {
    for (j, &p) in piv.iter().enumerate() {
        b.swap(j, p);
    }
    for i in 0..n {
        b[i] -= dot(&lu[i * n..i * n + i], &b[..i]);
    }
    for i in (0..n).rev() {
        let s = dot(&lu[i * n + i + 1..(i + 1) * n], &b[i + 1..n]);
        b[i] = (b[i] - s) / lu[i * n + i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use articula_spatial::numerics::{cholesky_rows, cholesky_rows_solve};

    /// `A x` for the row-major `n × n` `a`.
    fn product(a: &[f64], x: &[f64]) -> Vec<f64> {
        let n = x.len();
        (0..n)
            .map(|i| (0..n).map(|j| a[i * n + j] * x[j]).sum())
            .collect()
    }

    /// `lu` / `lu_solve` solve a non-symmetric system that needs row swaps (a zero diagonal),
    /// checked against its product; a singular matrix is refused.
    #[test]
    fn lu_solves_a_pivoted_system() {
        let n = 5;
        let a: Vec<f64> = (0..n * n)
            .map(|i| {
                if i % (n + 1) == 0 {
                    0.0
                } else {
                    ((i * 37 % 11) as f64 - 5.0) / 3.0
                }
            })
            .collect();
        let x: Vec<f64> = (0..n).map(|i| 1.0 + i as f64).collect();
        let mut b = product(&a, &x);
        let (mut f, mut piv) = (a.clone(), Vec::new());
        assert!(lu(&mut f, n, &mut piv));
        assert!(
            piv.iter().enumerate().any(|(j, &p)| p != j),
            "no swap tested"
        );
        lu_solve(&f, n, &piv, &mut b);
        for (got, want) in b.iter().zip(&x) {
            assert!((got - want).abs() < 1e-12, "{b:?}");
        }
        let mut z = vec![1.0; 4];
        assert!(!lu(&mut z, 2, &mut piv));
    }

    /// `cholesky_rows` / `cholesky_rows_solve` on `Bᵀ B + I` (symmetric positive definite), checked
    /// against its product and against `lu`'s solution; an indefinite matrix is refused.
    #[test]
    fn cholesky_solves_a_positive_definite_system() {
        let n = 7;
        let b: Vec<f64> = (0..n * n)
            .map(|i| ((i * 29 % 13) as f64 - 6.0) / 4.0)
            .collect();
        let mut a = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                a[i * n + j] = (0..n).map(|p| b[p * n + i] * b[p * n + j]).sum::<f64>()
                    + if i == j { 1.0 } else { 0.0 };
            }
        }
        let x: Vec<f64> = (0..n).map(|i| (i as f64 - 3.0) * 0.5).collect();
        let rhs = product(&a, &x);
        let (mut l, mut y) = (a.clone(), rhs.clone());
        assert!(cholesky_rows(&mut l, n));
        cholesky_rows_solve(&l, n, &mut y);
        let (mut f, mut piv, mut z) = (a.clone(), Vec::new(), rhs.clone());
        assert!(lu(&mut f, n, &mut piv));
        lu_solve(&f, n, &piv, &mut z);
        for i in 0..n {
            assert!((y[i] - x[i]).abs() < 1e-11, "{y:?} vs {x:?}");
            assert!((y[i] - z[i]).abs() < 1e-11, "{y:?} vs {z:?}");
        }
        let mut indefinite = vec![1.0, 2.0, 2.0, 1.0];
        assert!(!cholesky_rows(&mut indefinite, 2));
    }
}
