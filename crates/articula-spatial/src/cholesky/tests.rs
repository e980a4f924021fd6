// Index loops mirror the equations.
#![allow(clippy::needless_range_loop)]

use super::*;
use crate::arith::Portable;

/// `A = M Mᵀ + 1` for a fixed `M`: symmetric positive definite, condition ~1e2.
fn spd6() -> M6 {
    let m: M6 =
        std::array::from_fn(|i| std::array::from_fn(|j| ((i * 7 + j * 3) % 11) as f64 / 5.0 - 1.0));
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            (0..6).map(|p| m[i][p] * m[j][p]).sum::<f64>() + if i == j { 1.0 } else { 0.0 }
        })
    })
}

/// The Hilbert-like `1 / (1 + i + j) + δ_ij`, symmetric positive definite.
fn hilbert6() -> M6 {
    std::array::from_fn(|i| {
        std::array::from_fn(|j| 1.0 / (1.0 + i as f64 + j as f64) + if i == j { 1.0 } else { 0.0 })
    })
}

/// `Σ_p a_ip b_jp` over the first `k` columns.
fn a_bt(a: &M6, b: &M6, i: usize, j: usize, k: usize) -> f64 {
    (0..k).map(|p| a[i][p] * b[j][p]).sum()
}

/// Both triangular-solve pairs solve `A x = b` through `A = L Lᵀ`: checked against the
/// residual `A x − b` and against `x = A⁻¹ b` with the inverse of [`invert_spd_into`]
/// (an independent route: the inverse's columns, then a matrix-vector product).
#[test]
fn triangular_solves_invert_the_factor() {
    let a = spd6();
    let b = [1.0, -2.0, 0.5, 3.0, -1.5, 2.5];
    let l = cholesky(&a, 6).expect("positive definite");
    let x = solve_lower_t(&l, &solve_lower(&l, &b));
    let mut l_inv_diag = l;
    for (i, row) in l_inv_diag.iter_mut().enumerate() {
        row[i] = 1.0 / l[i][i];
    }
    let y = solve_lower_t_inv_diag(&l_inv_diag, &solve_lower_inv_diag(&l_inv_diag, &b));
    let mut z = b;
    solve_llt_k(&l, 6, &mut z);
    let mut inv = [[0.0; 6]; 6];
    assert!(invert_spd_into(&a, 6, &mut inv));
    for i in 0..6 {
        let residual = (0..6).map(|j| a[i][j] * x[j]).sum::<f64>() - b[i];
        assert!(residual.abs() < 1e-12, "row {i}: residual {residual:e}");
        let by_inverse = (0..6).map(|j| inv[i][j] * b[j]).sum::<f64>();
        assert!(
            (x[i] - by_inverse).abs() < 1e-11,
            "{} vs {by_inverse}",
            x[i]
        );
        assert!((y[i] - x[i]).abs() < 1e-12, "{} vs {}", y[i], x[i]);
        // The in-place solve is the same operations as the pair.
        assert_eq!(z[i].to_bits(), x[i].to_bits());
    }
}

/// `solve_llt_k` on a leading block: `A x` gives back `b` on the first `k` entries, and the
/// entries past `k` are left alone.
#[test]
fn leading_block_solve_gives_back_the_right_hand_side() {
    let a = hilbert6();
    for k in 1..=6 {
        let l = cholesky(&a, k).expect("positive definite");
        let b = [0.3, -1.0, 2.0, 0.7, -0.2, 1.1];
        let mut x = b;
        solve_llt_k(&l, k, &mut x);
        for i in 0..k {
            let ax: f64 = (0..k).map(|j| a[i][j] * x[j]).sum();
            assert!(
                (ax - b[i]).abs() < 1e-13,
                "k = {k}, row {i}: {ax} vs {}",
                b[i]
            );
        }
        assert_eq!(x[k..], b[k..]);
    }
}

/// `L Lᵀ` reproduces a 4×4 SPD block, `invert_spd_into` gives `A A⁻¹ = 1`, and a matrix
/// with a non-positive pivot is rejected.
#[test]
fn cholesky_and_inverse_of_a_small_block() {
    let a = [
        [4.0, 2.0, 0.4, -1.0],
        [2.0, 5.0, 1.0, 0.3],
        [0.4, 1.0, 3.0, 0.2],
        [-1.0, 0.3, 0.2, 2.0],
    ];
    let mut l = [[0.0; 4]; 4];
    let mut inv = [0.0; 4];
    assert!(cholesky_into(&a, 4, &mut l, &mut inv));
    for i in 0..4 {
        assert_eq!(inv[i], 1.0 / l[i][i]);
        for j in 0..4 {
            let llt: f64 = (0..4).map(|p| l[i][p] * l[j][p]).sum();
            assert!((llt - a[i][j]).abs() < 1e-14, "({i}, {j})");
        }
    }
    let mut ai = [[0.0; 4]; 4];
    assert!(invert_spd_into(&a, 4, &mut ai));
    for i in 0..4 {
        for j in 0..4 {
            let e: f64 = (0..4).map(|p| a[i][p] * ai[p][j]).sum();
            assert!(
                (e - f64::from(u8::from(i == j))).abs() < 1e-14,
                "({i}, {j})"
            );
            assert_eq!(ai[i][j].to_bits(), ai[j][i].to_bits());
        }
    }
    let mut bad = a;
    bad[2][2] = 0.1;
    assert!(!invert_spd_into(&bad, 4, &mut ai));
    assert!(cholesky(&[[0.0; 6]; 6], 1).is_none());
}

/// `cholesky_inv_diag`'s factor with its diagonal inverted back reconstructs `A` (whole and
/// leading blocks); `invert_factor_inv_diag` gives `A A⁻¹ = 1`, exactly symmetric; an
/// indefinite matrix and a NaN fail.
#[test]
fn factor_with_inverted_diagonal_and_its_inverse() {
    for k in 1..=6 {
        let a = spd6();
        let mut l = cholesky_inv_diag(&a, k).expect("SPD");
        for j in 0..k {
            l[j][j] = 1.0 / l[j][j];
        }
        for i in 0..k {
            for j in 0..k {
                assert!(
                    (a_bt(&l, &l, i, j, k) - a[i][j]).abs() < 1e-13,
                    "k = {k} ({i}, {j})"
                );
            }
        }
    }
    for a in [spd6(), hilbert6()] {
        let f = cholesky_inv_diag(&a, 6).expect("SPD");
        let ai = invert_factor_inv_diag(&f);
        for i in 0..6 {
            for j in 0..6 {
                let e: f64 = (0..6).map(|p| a[i][p] * ai[p][j]).sum();
                assert!(
                    (e - f64::from(u8::from(i == j))).abs() < 1e-12,
                    "({i}, {j}): {e}"
                );
                assert_eq!(ai[i][j].to_bits(), ai[j][i].to_bits());
            }
        }
    }
    let mut bad = hilbert6();
    bad[3][3] = -1.0;
    assert!(cholesky_inv_diag(&bad, 6).is_none());
    let mut nan = hilbert6();
    nan[5][5] = f64::NAN;
    assert!(cholesky_inv_diag(&nan, 6).is_none());
}

/// `invert_joint_block` gives `A A⁻¹ = 1` for every size, refuses an indefinite block, and
/// refuses a gimbal lock (two equal axes: a singular block whose Cholesky pivot is rounding).
#[test]
fn joint_block_inverses() {
    let a = hilbert6();
    for k in 1..=6 {
        let mut m = a;
        assert!(invert_joint_block(&mut m, k), "k = {k}");
        for i in 0..k {
            for j in 0..k {
                let e: f64 = (0..k).map(|p| a[i][p] * m[p][j]).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((e - want).abs() < 1e-13, "k = {k} ({i}, {j}): {e}");
            }
        }
    }
    let mut bad = a;
    bad[3][3] = -1.0;
    assert!(!invert_joint_block(&mut bad, 6));
    // D = Sᵀ S for axes s₀ = s₁ (exactly): its second pivot is 0.
    let s = [[1.0, 2.0, 0.5], [1.0, 2.0, 0.5], [0.0, 1.0, -1.0]];
    let mut d = [[0.0; 6]; 6];
    for i in 0..3 {
        for j in 0..3 {
            d[i][j] = (0..3).map(|p| s[i][p] * s[j][p]).sum();
        }
    }
    assert!(!joint_block_regular(&d, 3));
    assert!(!invert_joint_block(&mut d, 3));
    let mut one = [[0.0; 6]; 6];
    one[0][0] = 4.0;
    assert!(invert_joint_block(&mut one, 1));
    assert_eq!(one[0][0], 0.25);
}

/// The run-time-sized factor reconstructs `A` and solves `A x = b`; with a dependent row (a
/// 7 × 7 whose last row and column are the sums of its first two) the skipping variant drops
/// that row and finds the consistent solution, while the strict one fails; an indefinite
/// matrix fails (strict) or is dropped (skipping).
#[test]
fn run_time_sized_factor_skips_dependent_rows() {
    let a = hilbert6();
    let want = [1.0, -2.0, 0.5, 3.0, -1.5, 0.25];
    let flat: Vec<f64> = a.iter().flatten().copied().collect();
    let mut l = flat.clone();
    assert!(cholesky_rows(&mut l, 6));
    for i in 0..6 {
        for j in 0..=i {
            let llt: f64 = (0..=j).map(|p| l[i * 6 + p] * l[j * 6 + p]).sum();
            assert!((llt - a[i][j]).abs() < 1e-14, "({i}, {j})");
        }
        // The upper triangle is left alone.
        for j in i + 1..6 {
            assert_eq!(l[i * 6 + j], flat[i * 6 + j]);
        }
    }
    let mut skip = flat.clone();
    assert_eq!(cholesky_rows_skip(&mut skip, 6, 1e-12), Some(0));
    assert_eq!(skip, l);
    let mut b: Vec<f64> = (0..6)
        .map(|i| (0..6).map(|j| flat[i * 6 + j] * want[j]).sum::<f64>())
        .collect();
    cholesky_rows_solve(&l, 6, &mut b);
    for (x, w) in b.iter().zip(want) {
        assert!((x - w).abs() < 1e-13, "{b:?}");
    }
    // B = Cᵀ A C with C (6 × 7) = [1 | e₀ + e₁].
    let c = |i: usize, j: usize| match j {
        6 => f64::from(u8::from(i < 2)),
        _ => f64::from(u8::from(i == j)),
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
    assert_eq!(cholesky_rows_skip(&mut l, 7, 1e-12), Some(1));
    let mut x = rhs.clone();
    cholesky_rows_solve(&l, 7, &mut x);
    for i in 0..7 {
        let bx: f64 = (0..7).map(|j| big[i * 7 + j] * x[j]).sum();
        assert!((bx - rhs[i]).abs() < 1e-13, "row {i}: {bx} vs {}", rhs[i]);
    }
    assert_eq!(x[6], 0.0);
    assert!(!cholesky_rows(&mut big.clone(), 7));
    let mut bad = flat.clone();
    bad[3 * 6 + 3] = -1.0;
    assert!(!cholesky_rows(&mut bad.clone(), 6));
    assert_eq!(cholesky_rows_skip(&mut bad, 6, 1e-12), Some(1));
    let mut nan = flat;
    nan[0] = f64::NAN;
    assert_eq!(cholesky_rows_skip(&mut nan, 6, 1e-12), None);
}

/// `ldl5`'s `L D Lᵀ` reconstructs a 5×5 SPD matrix, unclamped; a semidefinite one is clamped
/// and flagged; a NaN fails. `psd_root`'s `R` gives `RᵀR = Q` for a semidefinite `Q` of
/// rank 4.
#[test]
fn ldlt_members() {
    let a = hilbert6();
    let (p, clamped) = ldl5::<Portable>(|i, j| a[i][j]).expect("SPD");
    assert!(!clamped);
    // Unpack: L unit lower, d from 1/d on the diagonal.
    let at = |i: usize, j: usize| p[i * (i + 1) / 2 + j];
    for i in 0..5 {
        for j in 0..=i {
            let x: f64 = (0..=j)
                .map(|q| {
                    let li = if q == i { 1.0 } else { at(i, q) };
                    let lj = if q == j { 1.0 } else { at(j, q) };
                    li * lj / at(q, q)
                })
                .sum();
            assert!(
                (x - a[i][j]).abs() < 1e-14,
                "({i}, {j}): {x} vs {}",
                a[i][j]
            );
        }
    }
    // Rank 1: every pivot after the first is (rounded) zero.
    let v = [1.0, 0.5, -0.25, 2.0, 0.125];
    let (_, clamped) = ldl5::<Portable>(|i, j| v[i] * v[j]).expect("no NaN");
    assert!(clamped);
    assert!(ldl5::<Portable>(|i, j| if i == 2 && j == 2 { f64::NAN } else { a[i][j] }).is_none());
    // Q = Mᵀ M for a 4 × 6 M: rank 4.
    let m: [[f64; 6]; 4] =
        std::array::from_fn(|i| std::array::from_fn(|j| ((i * 5 + j * 3) % 7) as f64 / 3.0 - 1.0));
    let q: M6 =
        std::array::from_fn(|i| std::array::from_fn(|j| (0..4).map(|p| m[p][i] * m[p][j]).sum()));
    let r = psd_root(q);
    for i in 0..6 {
        for j in 0..6 {
            let rtr: f64 = (0..6).map(|p| r[p][i] * r[p][j]).sum();
            assert!(
                (rtr - q[i][j]).abs() < 1e-12,
                "({i}, {j}): {rtr} vs {}",
                q[i][j]
            );
        }
    }
}

/// `invert_spd_into` of a badly scaled matrix: `A A⁻¹ = 1` to the scale of each entry.
#[test]
fn inverse_of_a_badly_scaled_matrix() {
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
    let mut inv = [[0.0; 6]; 6];
    assert!(invert_spd_into(&a, 6, &mut inv));
    for i in 0..6 {
        for j in 0..6 {
            let x: f64 = (0..6).map(|p| a[i][p] * inv[p][j]).sum();
            let expect = if i == j { 1.0 } else { 0.0 };
            // Entry (i, j) carries the scale s_i / s_j.
            assert!((x - expect).abs() * s[j] / s[i] < 1e-12, "{i} {j} {x}");
        }
    }
    assert!(!invert_spd_into(&[[0.0; 6]; 6], 3, &mut inv));
}
