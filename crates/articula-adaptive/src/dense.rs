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

#[cfg(test)]
mod tests {
    use super::*;

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
