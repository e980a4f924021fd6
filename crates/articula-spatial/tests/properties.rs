//! Property tests: every spatial-algebra operation is checked against explicit 6×6 matrix
//! formulas (Featherstone, RBDA ch. 2) assembled here from plain arrays, independently of the
//! crate's own matrix builders.
//!
//! - motion transform  `X  = rot(E) xlt(r) = [E 0; -E r× E]`
//! - force transform   `X* = [E -E r×; 0 E] = X⁻ᵀ`
//! - cross products    `crm(v) = [w× 0; v× w×]`, `crf(v) = -crm(v)ᵀ`
//! - rigid-body inertia `I = [Ibar h×; h×ᵀ m·1]`, `Ibar = Ic + m c× c×ᵀ`, `h = m c`
//!
//! Tolerances are relative: every comparison is scaled by the magnitude of the quantities that
//! enter the computation.

// Dense index arithmetic reads clearer with explicit indices.
#![allow(clippy::needless_range_loop)]

use articula_spatial::{
    DMat3, DQuat, DVec3, Mat6, SpatialForce, SpatialInertia, SpatialMotion, SpatialTransform,
    SymMat6,
};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

// ---------------------------------------------------------------------------------------------
// Independent reference helpers (plain row-major arrays).
// ---------------------------------------------------------------------------------------------

type V3 = [f64; 3];
type M3 = [[f64; 3]; 3];
type V6 = [f64; 6];
type M6 = [[f64; 6]; 6];

/// Relative tolerance for direct formula comparisons (a handful of roundings each).
const TOL: f64 = 1e-12;

fn v3(v: DVec3) -> V3 {
    [v.x, v.y, v.z]
}

/// Row-major copy of a glam (column-major) matrix.
fn m3(m: DMat3) -> M3 {
    let c = m.to_cols_array_2d(); // c[col][row]
    let mut a = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            a[i][j] = c[j][i];
        }
    }
    a
}

fn m3_to_glam(a: &M3) -> DMat3 {
    DMat3::from_cols(
        DVec3::new(a[0][0], a[1][0], a[2][0]),
        DVec3::new(a[0][1], a[1][1], a[2][1]),
        DVec3::new(a[0][2], a[1][2], a[2][2]),
    )
}

fn motion6(m: SpatialMotion) -> V6 {
    [m.w.x, m.w.y, m.w.z, m.v.x, m.v.y, m.v.z]
}

fn force6(f: SpatialForce) -> V6 {
    [f.n.x, f.n.y, f.n.z, f.f.x, f.f.y, f.f.z]
}

/// `[a]×`, the 3×3 matrix with `[a]× b = a × b`.
fn skew3(a: V3) -> M3 {
    [[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]]
}

fn mul3(a: &M3, b: &M3) -> M3 {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            for k in 0..3 {
                c[i][j] += a[i][k] * b[k][j];
            }
        }
    }
    c
}

fn mv3(a: &M3, x: &V3) -> V3 {
    let mut y = [0.0; 3];
    for i in 0..3 {
        for k in 0..3 {
            y[i] += a[i][k] * x[k];
        }
    }
    y
}

fn tr3(a: &M3) -> M3 {
    let mut t = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            t[j][i] = a[i][j];
        }
    }
    t
}

fn add3(a: &M3, b: &M3) -> M3 {
    let mut c = *a;
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] += b[i][j];
        }
    }
    c
}

fn scale3(a: &M3, s: f64) -> M3 {
    let mut c = *a;
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] *= s;
        }
    }
    c
}

fn diag3(d: V3) -> M3 {
    [[d[0], 0.0, 0.0], [0.0, d[1], 0.0], [0.0, 0.0, d[2]]]
}

fn cross3(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

const Z3: M3 = [[0.0; 3]; 3];

/// The 6×6 block matrix `[a b; c d]`.
fn blocks(a: &M3, b: &M3, c: &M3, d: &M3) -> M6 {
    let mut m = [[0.0; 6]; 6];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = a[i][j];
            m[i][j + 3] = b[i][j];
            m[i + 3][j] = c[i][j];
            m[i + 3][j + 3] = d[i][j];
        }
    }
    m
}

fn mul6(a: &M6, b: &M6) -> M6 {
    let mut c = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..6 {
            for k in 0..6 {
                c[i][j] += a[i][k] * b[k][j];
            }
        }
    }
    c
}

fn mv6(a: &M6, x: &V6) -> V6 {
    let mut y = [0.0; 6];
    for i in 0..6 {
        for k in 0..6 {
            y[i] += a[i][k] * x[k];
        }
    }
    y
}

fn tr6(a: &M6) -> M6 {
    let mut t = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..6 {
            t[j][i] = a[i][j];
        }
    }
    t
}

fn neg6(a: &M6) -> M6 {
    let mut c = *a;
    for i in 0..6 {
        for j in 0..6 {
            c[i][j] = -c[i][j];
        }
    }
    c
}

fn eye6() -> M6 {
    let mut m = [[0.0; 6]; 6];
    for i in 0..6 {
        m[i][i] = 1.0;
    }
    m
}

fn dot6(a: &V6, b: &V6) -> f64 {
    (0..6).map(|i| a[i] * b[i]).sum()
}

fn max_abs6(a: &M6) -> f64 {
    a.iter().flatten().fold(0.0, |m, x| m.max(x.abs()))
}

fn max_abs_v6(a: &V6) -> f64 {
    a.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// Inverse by Gauss–Jordan elimination with partial pivoting; `None` if a pivot vanishes.
fn gauss_jordan_inv6(a: &M6) -> Option<M6> {
    let mut m = *a;
    let mut inv = eye6();
    for col in 0..6 {
        let mut p = col;
        for row in (col + 1)..6 {
            if m[row][col].abs() > m[p][col].abs() {
                p = row;
            }
        }
        if m[p][col].abs() < 1e-300 || !m[p][col].is_finite() {
            return None;
        }
        m.swap(col, p);
        inv.swap(col, p);
        let d = 1.0 / m[col][col];
        for j in 0..6 {
            m[col][j] *= d;
            inv[col][j] *= d;
        }
        for row in 0..6 {
            if row != col {
                let f = m[row][col];
                if f != 0.0 {
                    for j in 0..6 {
                        m[row][j] -= f * m[col][j];
                        inv[row][j] -= f * inv[col][j];
                    }
                }
            }
        }
    }
    Some(inv)
}

/// Explicit motion transform `[E 0; -E r× E]`.
fn motion_mat(e: &M3, r: V3) -> M6 {
    let er = scale3(&mul3(e, &skew3(r)), -1.0);
    blocks(e, &Z3, &er, e)
}

/// Explicit force transform `[E -E r×; 0 E]`.
fn force_mat(e: &M3, r: V3) -> M6 {
    let er = scale3(&mul3(e, &skew3(r)), -1.0);
    blocks(e, &er, &Z3, e)
}

fn x_motion(x: &SpatialTransform) -> M6 {
    motion_mat(&m3(x.e), v3(x.r))
}

fn x_force(x: &SpatialTransform) -> M6 {
    force_mat(&m3(x.e), v3(x.r))
}

/// Explicit `crm(v) = [w× 0; v× w×]`.
fn crm_mat(v: &V6) -> M6 {
    let wx = skew3([v[0], v[1], v[2]]);
    let vx = skew3([v[3], v[4], v[5]]);
    blocks(&wx, &Z3, &vx, &wx)
}

/// Explicit `crf(v) = [w× v×; 0 w×]`.
fn crf_mat(v: &V6) -> M6 {
    let wx = skew3([v[0], v[1], v[2]]);
    let vx = skew3([v[3], v[4], v[5]]);
    blocks(&wx, &vx, &Z3, &wx)
}

/// Explicit rigid-body inertia from mass, COM and rotational inertia about the COM:
/// `[Ibar h×; h×ᵀ m 1]` with `Ibar = Ic + m c× c×ᵀ`, `h = m c`.
fn inertia_mat(m: f64, c: V3, ic: &M3) -> M6 {
    let cx = skew3(c);
    let ibar = add3(ic, &scale3(&mul3(&cx, &tr3(&cx)), m));
    let hx = skew3([m * c[0], m * c[1], m * c[2]]);
    blocks(&ibar, &hx, &tr3(&hx), &diag3([m, m, m]))
}

/// Explicit matrix of a `SpatialInertia` from its stored fields.
fn inertia_fields_mat(i: &SpatialInertia) -> M6 {
    let hx = skew3(v3(i.h));
    let m = i.mass;
    blocks(&m3(i.ibar), &hx, &tr3(&hx), &diag3([m, m, m]))
}

fn mat6_arr(m: &Mat6) -> M6 {
    let mut a = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..6 {
            a[i][j] = m.get(i, j);
        }
    }
    a
}

fn sym6_arr(m: &SymMat6) -> M6 {
    let mut a = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..6 {
            a[i][j] = m.get(i, j);
        }
    }
    a
}

fn is_exactly_symmetric(a: &M6) -> bool {
    (0..6).all(|i| (0..6).all(|j| a[i][j] == a[j][i]))
}

fn check_m6(what: &str, got: &M6, want: &M6, scale: f64, tol: f64) -> Result<(), TestCaseError> {
    let mut err = 0.0f64;
    for i in 0..6 {
        for j in 0..6 {
            err = err.max((got[i][j] - want[i][j]).abs());
        }
    }
    prop_assert!(
        err <= tol * scale,
        "{}: max error {:e} > {:e} * {:e}\n got  {:?}\n want {:?}",
        what,
        err,
        tol,
        scale,
        got,
        want
    );
    Ok(())
}

fn check_v6(what: &str, got: &V6, want: &V6, scale: f64, tol: f64) -> Result<(), TestCaseError> {
    let err = (0..6).fold(0.0f64, |m, i| m.max((got[i] - want[i]).abs()));
    prop_assert!(
        err <= tol * scale,
        "{}: max error {:e} > {:e} * {:e}\n got  {:?}\n want {:?}",
        what,
        err,
        tol,
        scale,
        got,
        want
    );
    Ok(())
}

fn check_v3(what: &str, got: V3, want: V3, scale: f64, tol: f64) -> Result<(), TestCaseError> {
    let err = (0..3).fold(0.0f64, |m, i| m.max((got[i] - want[i]).abs()));
    prop_assert!(
        err <= tol * scale,
        "{}: max error {:e} > {:e} * {:e}\n got  {:?}\n want {:?}",
        what,
        err,
        tol,
        scale,
        got,
        want
    );
    Ok(())
}

fn check_s(what: &str, got: f64, want: f64, scale: f64, tol: f64) -> Result<(), TestCaseError> {
    let err = (got - want).abs();
    prop_assert!(
        err <= tol * scale,
        "{}: error {:e} > {:e} * {:e} (got {}, want {})",
        what,
        err,
        tol,
        scale,
        got,
        want
    );
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Strategies.
// ---------------------------------------------------------------------------------------------

fn coord() -> impl Strategy<Value = f64> {
    -10.0f64..=10.0
}

fn vec3() -> impl Strategy<Value = DVec3> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

fn motion() -> impl Strategy<Value = SpatialMotion> {
    (vec3(), vec3()).prop_map(|(w, v)| SpatialMotion::new(w, v))
}

fn force() -> impl Strategy<Value = SpatialForce> {
    (vec3(), vec3()).prop_map(|(n, f)| SpatialForce::new(n, f))
}

/// Rotations from random unit quaternions or from axis–angle pairs.
fn rotation() -> impl Strategy<Value = DMat3> {
    let quat = (-1.0f64..=1.0, -1.0f64..=1.0, -1.0f64..=1.0, -1.0f64..=1.0)
        .prop_filter("quaternion too short", |(x, y, z, w)| {
            x * x + y * y + z * z + w * w > 0.01
        })
        .prop_map(|(x, y, z, w)| DMat3::from_quat(DQuat::from_xyzw(x, y, z, w).normalize()));
    let axis_angle = (vec3(), -std::f64::consts::PI..=std::f64::consts::PI)
        .prop_filter("axis too short", |(a, _)| a.length() > 0.1)
        .prop_map(|(a, t)| DMat3::from_axis_angle(a.normalize(), t));
    prop_oneof![quat, axis_angle]
}

fn transform() -> impl Strategy<Value = SpatialTransform> {
    (rotation(), vec3()).prop_map(|(e, r)| SpatialTransform::new(e, r))
}

fn mass() -> impl Strategy<Value = f64> {
    (0.0f64..1.0).prop_map(|u| 100.0 - u * (100.0 - 0.01)) // (0.01, 100]
}

/// Parameters of a rigid body: mass, COM, and a positive-definite rotational inertia about the
/// COM, `R diag(a, b, c) Rᵀ` with the principal moments of a solid box (so they satisfy the
/// triangle inequality).
#[derive(Clone, Debug)]
struct Body {
    m: f64,
    c: DVec3,
    ic: DMat3,
}

fn body() -> impl Strategy<Value = Body> {
    (
        mass(),
        vec3(),
        (0.05f64..=2.0, 0.05f64..=2.0, 0.05f64..=2.0),
        rotation(),
    )
        .prop_map(|(m, c, (x, y, z), rot)| {
            let d = [
                m / 12.0 * (y * y + z * z),
                m / 12.0 * (x * x + z * z),
                m / 12.0 * (x * x + y * y),
            ];
            let r = m3(rot);
            let ic = mul3(&mul3(&r, &diag3(d)), &tr3(&r));
            Body {
                m,
                c,
                ic: m3_to_glam(&ic),
            }
        })
}

fn mat6() -> impl Strategy<Value = M6> {
    prop::array::uniform6(prop::array::uniform6(coord()))
}

fn vec6() -> impl Strategy<Value = V6> {
    prop::array::uniform6(coord())
}

/// Exactly symmetric `A Aᵀ + 0.1·1` (symmetric positive definite).
fn spd_from(a: &M6) -> M6 {
    let mut s = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in i..6 {
            let mut x = 0.0;
            for k in 0..6 {
                x += a[i][k] * a[j][k];
            }
            s[i][j] = x;
            s[j][i] = x;
        }
        s[i][i] += 0.1;
    }
    s
}

/// Exactly symmetric `A + Aᵀ`.
fn sym_from(a: &M6) -> M6 {
    let mut s = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..6 {
            s[i][j] = a[i][j] + a[j][i];
        }
    }
    s
}

/// An orthogonal 6×6 matrix: the Q of a Gram–Schmidt orthonormalisation of `a`'s rows.
fn orthonormal_rows(a: &M6) -> Option<M6> {
    let mut q = *a;
    for i in 0..6 {
        for _pass in 0..2 {
            for k in 0..i {
                let d = dot6(&q[i], &q[k]);
                for j in 0..6 {
                    q[i][j] -= d * q[k][j];
                }
            }
        }
        let n = dot6(&q[i], &q[i]).sqrt();
        if n < 1e-3 {
            return None;
        }
        for j in 0..6 {
            q[i][j] /= n;
        }
    }
    Some(q)
}

/// `Qᵀ diag(d) Q`, exactly symmetric.
fn sym_with_eigen(q: &M6, d: &V6) -> M6 {
    let mut s = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in i..6 {
            let x: f64 = (0..6).map(|k| q[k][i] * d[k] * q[k][j]).sum();
            s[i][j] = x;
            s[j][i] = x;
        }
    }
    s
}

fn cfg() -> ProptestConfig {
    ProptestConfig::with_cases(256)
}

// ---------------------------------------------------------------------------------------------
// Transforms.
// ---------------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(cfg())]

    /// `apply_motion`, `apply_force` and the crate's matrices match `[E 0; -E r× E]` and
    /// `[E -E r×; 0 E]`; the force matrix is the inverse transpose of the motion matrix.
    #[test]
    fn transform_apply_matches_explicit(x in transform(), m in motion(), f in force()) {
        let xm = x_motion(&x);
        let xf = x_force(&x);
        let s = 1.0 + x.r.length();
        check_m6("to_motion_mat6", &mat6_arr(&x.to_motion_mat6()), &xm, s, TOL)?;
        check_m6("to_force_mat6", &mat6_arr(&x.to_force_mat6()), &xf, s, TOL)?;
        check_v6("apply_motion", &motion6(x.apply_motion(m)), &mv6(&xm, &motion6(m)),
            s * m.norm(), TOL)?;
        check_v6("apply_force", &force6(x.apply_force(f)), &mv6(&xf, &force6(f)),
            s * f.norm(), TOL)?;
        // X* = X⁻ᵀ.
        let xinv = gauss_jordan_inv6(&xm).expect("motion transform is invertible");
        check_m6("X* = X^-T", &xf, &tr6(&xinv), s * s, TOL)?;
    }

    /// `inv_apply_motion` is `X⁻¹ m` (Gauss–Jordan inverse), `inv_apply_force` is `Xᵀ f`.
    #[test]
    fn transform_inv_apply_matches_explicit(x in transform(), m in motion(), f in force()) {
        let xm = x_motion(&x);
        let xinv = gauss_jordan_inv6(&xm).expect("motion transform is invertible");
        let s = 1.0 + x.r.length();
        check_v6("inv_apply_motion", &motion6(x.inv_apply_motion(m)),
            &mv6(&xinv, &motion6(m)), s * s * m.norm(), TOL)?;
        check_v6("inv_apply_force", &force6(x.inv_apply_force(f)),
            &mv6(&tr6(&xm), &force6(f)), s * f.norm(), TOL)?;
    }

    /// Round trips `X⁻¹ X`, `X X⁻¹` for motions and forces, also through `inverse()`.
    #[test]
    fn transform_round_trips(x in transform(), m in motion(), f in force()) {
        let s = (1.0 + x.r.length()).powi(2);
        let (mm, ff) = (motion6(m), force6(f));
        check_v6("X^-1 X m", &motion6(x.inv_apply_motion(x.apply_motion(m))), &mm,
            s * m.norm(), TOL)?;
        check_v6("X X^-1 m", &motion6(x.apply_motion(x.inv_apply_motion(m))), &mm,
            s * m.norm(), TOL)?;
        check_v6("X^-* X* f", &force6(x.inv_apply_force(x.apply_force(f))), &ff,
            s * f.norm(), TOL)?;
        check_v6("X* X^-* f", &force6(x.apply_force(x.inv_apply_force(f))), &ff,
            s * f.norm(), TOL)?;
        let xi = x.inverse();
        check_v6("inverse().apply_motion X m", &motion6(xi.apply_motion(x.apply_motion(m))),
            &mm, s * m.norm(), TOL)?;
        check_v6("inverse().apply_force X* f", &force6(xi.apply_force(x.apply_force(f))),
            &ff, s * f.norm(), TOL)?;
        // Both at once, ~1e-9 relative as a coarse sanity bound independent of |r|.
        let back = x.inv_apply_motion(x.apply_motion(m));
        prop_assert!((back - m).norm() <= 1e-9 * m.norm().max(1e-300) || m.norm() == 0.0);
    }

    /// `inverse()` matches the Gauss–Jordan inverse of the explicit motion matrix, and its
    /// force matrix is the transpose of the motion matrix.
    #[test]
    fn transform_inverse_matches_gauss_jordan(x in transform()) {
        let xm = x_motion(&x);
        let xinv = gauss_jordan_inv6(&xm).expect("motion transform is invertible");
        let s = 1.0 + x.r.length();
        let xi = x.inverse();
        check_m6("inverse motion", &x_motion(&xi), &xinv, s * s, TOL)?;
        check_m6("inverse force = X^T", &x_force(&xi), &tr6(&xm), s, TOL)?;
        let xii = xi.inverse();
        check_m6("inverse().inverse()", &x_motion(&xii), &xm, s * s, TOL)?;
    }

    /// Composition `a * b` is the matrix product `Xa Xb` (motion and force).
    #[test]
    fn transform_composition_is_matrix_product(a in transform(), b in transform(),
                                               m in motion()) {
        let ab = a * b;
        let s = (1.0 + a.r.length()) * (1.0 + b.r.length());
        check_m6("(a*b) motion", &x_motion(&ab), &mul6(&x_motion(&a), &x_motion(&b)), s, TOL)?;
        check_m6("(a*b) force", &x_force(&ab), &mul6(&x_force(&a), &x_force(&b)), s, TOL)?;
        check_v6("(a*b) m = a(b m)", &motion6(ab.apply_motion(m)),
            &motion6(a.apply_motion(b.apply_motion(m))), s * m.norm(), TOL)?;
    }

    /// `from_pose` / `to_pose` round trip both ways.
    #[test]
    fn pose_round_trip(rot in rotation(), p in vec3(), x in transform()) {
        let (r2, p2) = SpatialTransform::from_pose(rot, p).to_pose();
        check_m6("to_pose rotation",
            &blocks(&m3(r2), &Z3, &Z3, &Z3), &blocks(&m3(rot), &Z3, &Z3, &Z3), 1.0, TOL)?;
        check_v3("to_pose translation", v3(p2), v3(p), 1.0 + p.length(), TOL)?;
        let (e, t) = x.to_pose();
        let y = SpatialTransform::from_pose(e, t);
        check_m6("from_pose(to_pose(X))", &x_motion(&y), &x_motion(&x),
            1.0 + x.r.length(), TOL)?;
    }

    /// `from_pose(R, p)` maps the child frame to the parent: a child point `q` lands at
    /// `R q + p`; a child motion `[ω; v]` (v at the child origin) becomes
    /// `[R ω; R v + p × R ω]` (a pure spin about the child origin has linear part `p × ω`);
    /// a child force `[n; f]` becomes `[R n + p × R f; R f]`. Composition of poses matches.
    #[test]
    fn from_pose_maps_child_to_parent(rot in rotation(), p in vec3(), q in vec3(),
                                      m in motion(), f in force(),
                                      rot2 in rotation(), p2 in vec3()) {
        let x = SpatialTransform::from_pose(rot, p);
        let r = m3(rot);
        let (pp, qq) = (v3(p), v3(q));
        let rq = mv3(&r, &qq);
        let want_pt = [rq[0] + pp[0], rq[1] + pp[1], rq[2] + pp[2]];
        let s = 1.0 + p.length();
        check_v3("apply_point", v3(x.apply_point(q)), want_pt, s + q.length(), TOL)?;
        check_v3("inv_apply_point", v3(x.inv_apply_point(DVec3::from_array(want_pt))), qq,
            s + q.length(), TOL)?;
        // The parent origin, seen from the child, is r.
        check_v3("apply_point(r) = 0", v3(x.apply_point(x.r)), [0.0; 3], s, TOL)?;

        // Pure spin about the child origin.
        let spin = SpatialMotion::new(m.w, DVec3::ZERO);
        let rw = mv3(&r, &v3(m.w));
        let pxw = cross3(pp, rw);
        check_v6("pure spin", &motion6(x.apply_motion(spin)),
            &[rw[0], rw[1], rw[2], pxw[0], pxw[1], pxw[2]], s * m.w.length(), TOL)?;
        // General motion.
        let rv = mv3(&r, &v3(m.v));
        check_v6("child motion", &motion6(x.apply_motion(m)),
            &[rw[0], rw[1], rw[2], rv[0] + pxw[0], rv[1] + pxw[1], rv[2] + pxw[2]],
            s * m.norm(), TOL)?;
        // Force.
        let (rn, rf) = (mv3(&r, &v3(f.n)), mv3(&r, &v3(f.f)));
        let pxf = cross3(pp, rf);
        check_v6("child force", &force6(x.apply_force(f)),
            &[rn[0] + pxf[0], rn[1] + pxf[1], rn[2] + pxf[2], rf[0], rf[1], rf[2]],
            s * f.norm(), TOL)?;
        // Pose composition: grandchild (rot2, p2) in child, child (rot, p) in parent.
        let r2 = m3(rot2);
        let rp2 = mv3(&r, &v3(p2));
        let composed = SpatialTransform::from_pose(
            m3_to_glam(&mul3(&r, &r2)),
            DVec3::new(rp2[0] + pp[0], rp2[1] + pp[1], rp2[2] + pp[2]),
        );
        let prod = x * SpatialTransform::from_pose(rot2, p2);
        check_m6("pose composition", &x_motion(&prod), &x_motion(&composed),
            (s + p2.length()).powi(2), TOL)?;
    }

    /// Power `<v, f>` is invariant under any transform (and its inverse).
    #[test]
    fn power_is_frame_invariant(x in transform(), m in motion(), f in force()) {
        let p0 = dot6(&motion6(m), &force6(f));
        check_s("dot vs explicit", m.dot(f), p0, m.norm() * f.norm(), TOL)?;
        check_s("force dot", f.dot(m), p0, m.norm() * f.norm(), TOL)?;
        let s = (1.0 + x.r.length()).powi(2) * m.norm() * f.norm();
        check_s("<Xv, X*f>", x.apply_motion(m).dot(x.apply_force(f)), p0, s, TOL)?;
        check_s("<X^-1 v, X^-* f>", x.inv_apply_motion(m).dot(x.inv_apply_force(f)), p0, s,
            TOL)?;
    }
}

// ---------------------------------------------------------------------------------------------
// Inertia.
// ---------------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(cfg())]

    /// `SpatialInertia::new` (and `to_mat6`) match `[Ic + m c× c×ᵀ, h×; h×ᵀ, m 1]`.
    #[test]
    fn inertia_new_matches_explicit(b in body()) {
        let i = SpatialInertia::new(b.m, b.c, b.ic);
        let want = inertia_mat(b.m, v3(b.c), &m3(b.ic));
        let s = max_abs6(&want);
        check_m6("new (fields)", &inertia_fields_mat(&i), &want, s, TOL)?;
        let got = sym6_arr(&i.to_mat6());
        check_m6("to_mat6", &got, &want, s, TOL)?;
        prop_assert!(is_exactly_symmetric(&got));
        prop_assert_eq!(i.mass, b.m);
    }

    /// `mul_motion` is the matrix–vector product; kinetic energy is `½ vᵀ I v`.
    #[test]
    fn inertia_mul_motion_matches_explicit(b in body(), m in motion()) {
        let i = SpatialInertia::new(b.m, b.c, b.ic);
        let im = inertia_mat(b.m, v3(b.c), &m3(b.ic));
        let s = max_abs6(&im) * m.norm();
        let want = mv6(&im, &motion6(m));
        check_v6("mul_motion", &force6(i.mul_motion(m)), &want, s, TOL)?;
        check_s("kinetic_energy", i.kinetic_energy(m), 0.5 * dot6(&motion6(m), &want),
            s * m.norm(), TOL)?;
        prop_assert!(i.kinetic_energy(m) >= -TOL * s * m.norm());
    }

    /// `apply_inertia` is `X* I X⁻¹` with the explicit matrices; momentum is covariant:
    /// `X*(I v) = (X I X⁻¹)(X v)`.
    #[test]
    fn inertia_apply_matches_congruence(b in body(), x in transform(), m in motion()) {
        let i = SpatialInertia::new(b.m, b.c, b.ic);
        let im = inertia_mat(b.m, v3(b.c), &m3(b.ic));
        let xm = x_motion(&x);
        let xinv = gauss_jordan_inv6(&xm).expect("invertible");
        let want = mul6(&mul6(&x_force(&x), &im), &xinv);
        let got_i = x.apply_inertia(&i);
        let got = inertia_fields_mat(&got_i);
        let s = (1.0 + x.r.length()).powi(2) * max_abs6(&im);
        check_m6("apply_inertia", &got, &want, s, TOL)?;
        prop_assert_eq!(got_i.mass, i.mass);
        // The stored ibar stays symmetric to round-off.
        let ib = m3(got_i.ibar);
        for r in 0..3 {
            for c in 0..3 {
                prop_assert!((ib[r][c] - ib[c][r]).abs() <= TOL * s);
            }
        }
        let lhs = force6(x.apply_force(i.mul_motion(m)));
        let rhs = force6(got_i.mul_motion(x.apply_motion(m)));
        check_v6("momentum covariance", &lhs, &rhs, s * (1.0 + x.r.length()) * m.norm(), TOL)?;
        // COM moves like a point.
        check_v3("com transforms as a point", v3(got_i.com()), v3(x.apply_point(b.c)),
            1.0 + b.c.length() + x.r.length(), 1e-10)?;
    }

    /// `com()` and `inertia_about_com()` recover the constructor arguments.
    #[test]
    fn inertia_com_round_trip(b in body()) {
        let i = SpatialInertia::new(b.m, b.c, b.ic);
        check_v3("com", v3(i.com()), v3(b.c), 1.0 + b.c.length(), TOL)?;
        let ic = m3(i.inertia_about_com());
        let want = m3(b.ic);
        // ibar is ~ m |c|² large; the recovered Ic loses absolute accuracy at that scale.
        let s = b.m * (1.0 + b.c.length_squared());
        check_m6("inertia_about_com", &blocks(&ic, &Z3, &Z3, &Z3),
            &blocks(&want, &Z3, &Z3, &Z3), s, TOL)?;
        let j = SpatialInertia::new(i.mass, i.com(), i.inertia_about_com());
        check_m6("rebuilt", &inertia_fields_mat(&j), &inertia_fields_mat(&i),
            max_abs6(&inertia_fields_mat(&i)), TOL)?;
    }

    /// The sum of two inertias is the sum of their matrices, and acts additively.
    #[test]
    fn inertia_sum_is_additive(b1 in body(), b2 in body(), m in motion()) {
        let i1 = SpatialInertia::new(b1.m, b1.c, b1.ic);
        let i2 = SpatialInertia::new(b2.m, b2.c, b2.ic);
        let a1 = inertia_mat(b1.m, v3(b1.c), &m3(b1.ic));
        let a2 = inertia_mat(b2.m, v3(b2.c), &m3(b2.ic));
        let mut want = a1;
        for r in 0..6 {
            for c in 0..6 {
                want[r][c] += a2[r][c];
            }
        }
        let s = max_abs6(&a1) + max_abs6(&a2);
        let sum = i1 + i2;
        check_m6("I1 + I2", &inertia_fields_mat(&sum), &want, s, TOL)?;
        let mut acc = i1;
        acc += i2;
        check_m6("I1 += I2", &inertia_fields_mat(&acc), &want, s, TOL)?;
        let lhs = force6(sum.mul_motion(m));
        let r1 = force6(i1.mul_motion(m));
        let r2 = force6(i2.mul_motion(m));
        let rhs = [r1[0] + r2[0], r1[1] + r2[1], r1[2] + r2[2],
                   r1[3] + r2[3], r1[4] + r2[4], r1[5] + r2[5]];
        check_v6("(I1+I2) v", &lhs, &rhs, s * m.norm(), TOL)?;
        // The combined COM is the mass-weighted mean.
        let mt = b1.m + b2.m;
        let wc = (b1.c * b1.m + b2.c * b2.m) / mt;
        check_v3("combined com", v3(sum.com()), v3(wc), 1.0 + b1.c.length() + b2.c.length(),
            TOL)?;
    }

    /// `inverse()` is a two-sided inverse of `to_mat6` and matches Gauss–Jordan.
    #[test]
    fn inertia_inverse(b in body()) {
        let i = SpatialInertia::new(b.m, b.c, b.ic);
        let im = inertia_mat(b.m, v3(b.c), &m3(b.ic));
        let inv = i.inverse().expect("a body with positive-definite Ic is invertible");
        let inv = sym6_arr(&inv);
        let (na, ni) = (max_abs6(&im), max_abs6(&inv));
        check_m6("I I^-1", &mul6(&im, &inv), &eye6(), na * ni, 1e-11)?;
        check_m6("I^-1 I", &mul6(&inv, &im), &eye6(), na * ni, 1e-11)?;
        let gj = gauss_jordan_inv6(&im).expect("invertible");
        check_m6("vs Gauss-Jordan", &inv, &gj, na * ni * ni, 1e-11)?;
    }

    /// Massless and point-mass-at-origin inertias are singular: `inverse()` is `None`.
    #[test]
    fn inertia_inverse_singular(m in mass(), b in body()) {
        prop_assert!(SpatialInertia::ZERO.inverse().is_none());
        prop_assert!(SpatialInertia::new(m, DVec3::ZERO, DMat3::ZERO).inverse().is_none());
        // A body without mass but with rotational inertia is singular too.
        let massless = SpatialInertia { mass: 0.0, h: DVec3::ZERO, ibar: b.ic };
        prop_assert!(massless.inverse().is_none());
    }
}

// ---------------------------------------------------------------------------------------------
// Cross products.
// ---------------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(cfg())]

    /// `crm`/`crf` match the explicit matrices and `cross_motion`/`cross_force` match the
    /// matrix–vector products.
    #[test]
    fn cross_matrices_match_explicit(v in motion(), m in motion(), f in force()) {
        let vv = motion6(v);
        let (cm, cf) = (crm_mat(&vv), crf_mat(&vv));
        check_m6("crm", &mat6_arr(&v.crm()), &cm, v.norm(), TOL)?;
        check_m6("crf", &mat6_arr(&v.crf()), &cf, v.norm(), TOL)?;
        check_v6("cross_motion", &motion6(v.cross_motion(m)), &mv6(&cm, &motion6(m)),
            v.norm() * m.norm(), TOL)?;
        check_v6("cross_force", &force6(v.cross_force(f)), &mv6(&cf, &force6(f)),
            v.norm() * f.norm(), TOL)?;
    }

    /// `v × v = 0` and `crf(v) = -crm(v)ᵀ`.
    #[test]
    fn cross_self_and_duality(v in motion()) {
        let vxv = motion6(v.cross_motion(v));
        check_v6("v x v", &vxv, &[0.0; 6], v.norm() * v.norm(), TOL)?;
        let crm = mat6_arr(&v.crm());
        check_m6("crf = -crm^T", &mat6_arr(&v.crf()), &neg6(&tr6(&crm)), v.norm(), TOL)?;
        let vv = motion6(v);
        check_m6("explicit crf = -crm^T", &crf_mat(&vv), &neg6(&tr6(&crm_mat(&vv))),
            v.norm(), TOL)?;
    }

    /// `<v × m, f> = -<m, v ×* f>`.
    #[test]
    fn cross_adjoint(v in motion(), m in motion(), f in force()) {
        let lhs = v.cross_motion(m).dot(f);
        let rhs = -m.dot(v.cross_force(f));
        check_s("<v x m, f> = -<m, v x* f>", lhs, rhs, v.norm() * m.norm() * f.norm(), TOL)?;
    }

    /// Cross products are frame covariant: `X(v × m) = (Xv) × (Xm)` and
    /// `X*(v ×* f) = (Xv) ×* (X* f)`.
    #[test]
    fn cross_transform_covariance(x in transform(), v in motion(), m in motion(),
                                  f in force()) {
        let s = (1.0 + x.r.length()).powi(2) * v.norm();
        let lhs = motion6(x.apply_motion(v.cross_motion(m)));
        let rhs = motion6(x.apply_motion(v).cross_motion(x.apply_motion(m)));
        check_v6("X(v x m)", &lhs, &rhs, s * m.norm(), TOL)?;
        let lhs = force6(x.apply_force(v.cross_force(f)));
        let rhs = force6(x.apply_motion(v).cross_force(x.apply_force(f)));
        check_v6("X*(v x* f)", &lhs, &rhs, s * f.norm(), TOL)?;
    }
}

// ---------------------------------------------------------------------------------------------
// SymMat6 and Mat6.
// ---------------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(cfg())]

    /// `inverse_spd` on `A Aᵀ + 0.1·1` matches Gauss–Jordan, is exactly symmetric and is a
    /// two-sided inverse.
    #[test]
    fn sym_inverse_spd_matches_gauss_jordan(a in mat6()) {
        let s = spd_from(&a);
        let inv = SymMat6::from_mat6(&Mat6(s)).inverse_spd().expect("SPD");
        let inv = sym6_arr(&inv);
        prop_assert!(is_exactly_symmetric(&inv));
        let gj = gauss_jordan_inv6(&s).expect("invertible");
        let (ns, ni) = (max_abs6(&s), max_abs6(&gj));
        check_m6("inverse_spd vs GJ", &inv, &gj, ns * ni * ni, 1e-11)?;
        check_m6("S S^-1", &mul6(&s, &inv), &eye6(), ns * ni, 1e-11)?;
    }

    /// `inverse_spd` rejects singular and indefinite matrices. The singular cases have an
    /// exactly zero pivot; a matrix that is singular only in exact arithmetic (e.g. a rank-5
    /// `B Bᵀ`) may leave a round-off-sized positive pivot, which unpivoted Cholesky cannot
    /// tell from a tiny genuine one, so such inputs are deliberately not asserted on.
    #[test]
    fn sym_inverse_spd_rejects_non_spd(a in mat6(), k in 0usize..6, neg in 1.0f64..=10.0,
                                       d in prop::array::uniform6(1.0f64..=10.0)) {
        let s = spd_from(&a);
        // Singular: zero row and column k.
        let mut z = s;
        for j in 0..6 {
            z[k][j] = 0.0;
            z[j][k] = 0.0;
        }
        prop_assert!(SymMat6::from_mat6(&Mat6(z)).inverse_spd().is_none(), "zero row {}", k);
        // Indefinite: a negative diagonal entry.
        let mut n = s;
        n[k][k] = -neg;
        prop_assert!(SymMat6::from_mat6(&Mat6(n)).inverse_spd().is_none(), "neg diag {}", k);
        // Indefinite with all-positive diagonal: Qᵀ diag(d) Q with one eigenvalue ≤ -1.
        if let Some(q) = orthonormal_rows(&a) {
            let mut dd = d;
            dd[k] = -neg;
            let m = sym_with_eigen(&q, &dd);
            prop_assert!(SymMat6::from_mat6(&Mat6(m)).inverse_spd().is_none(),
                "indefinite eigenvalues {:?}", dd);
            // The same with all eigenvalues positive is accepted.
            let p = sym_with_eigen(&q, &d);
            prop_assert!(SymMat6::from_mat6(&Mat6(p)).inverse_spd().is_some());
        }
        // Non-finite entries are rejected.
        let mut nan = s;
        nan[k][(k + 1) % 6] = f64::NAN;
        nan[(k + 1) % 6][k] = f64::NAN;
        prop_assert!(SymMat6::from_mat6(&Mat6(nan)).inverse_spd().is_none());
    }

    /// `congruence` is `A S Aᵀ` and exactly symmetric.
    #[test]
    fn sym_congruence(a in mat6(), b in mat6()) {
        let s = sym_from(&b);
        let want = mul6(&mul6(&a, &s), &tr6(&a));
        let got = sym6_arr(&SymMat6::from_mat6(&Mat6(s)).congruence(&Mat6(a)));
        prop_assert!(is_exactly_symmetric(&got));
        check_m6("congruence", &got, &want, max_abs6(&a).powi(2) * max_abs6(&s) * 36.0, TOL)?;
    }

    /// `SymMat6`'s articulated-body operations: `sub_outer` is `S − α u uᵀ`, `add_sub_outer`
    /// is `T + S − α u uᵀ`, both exactly symmetric, and `mul_vec` (and `Mat6::sym_mul_vec` on
    /// the whole matrix, to the bit) is `S x`.
    #[test]
    fn sym_aba_operations(b in mat6(), c in mat6(), u in vec6(), x in vec6(), alpha in -10.0f64..=10.0) {
        let (s, t) = (sym_from(&b), sym_from(&c));
        let mut want = s;
        for i in 0..6 {
            for j in 0..6 {
                want[i][j] -= alpha * u[i] * u[j];
            }
        }
        let ps = SymMat6::from_mat6(&Mat6(s));
        let got = ps.sub_outer(&u, alpha).to_mat6().0;
        prop_assert!(is_exactly_symmetric(&got), "sub_outer broke symmetry: {:?}", got);
        let scale = max_abs6(&s) + alpha.abs() * max_abs_v6(&u).powi(2);
        check_m6("sub_outer", &got, &want, scale, TOL)?;
        let mut acc = SymMat6::from_mat6(&Mat6(t));
        acc.add_sub_outer(&ps, &u, alpha);
        let want2: M6 = std::array::from_fn(|i| std::array::from_fn(|j| want[i][j] + t[i][j]));
        check_m6("add_sub_outer", &acc.to_mat6().0, &want2, scale + max_abs6(&t), TOL)?;
        prop_assert!(is_exactly_symmetric(&acc.to_mat6().0));
        for i in 0..6 {
            for j in 0..6 {
                prop_assert_eq!(acc.get(i, j), acc.to_mat6().0[i][j]);
            }
        }
        let y = mv6(&s, &x);
        let sc = max_abs6(&s) * max_abs_v6(&x) * 6.0;
        check_v6("packed mul_vec", &ps.mul_vec(&x), &y, sc, TOL)?;
        let dense = ps.to_mat6().sym_mul_vec(&x);
        for (a, b) in ps.mul_vec(&x).iter().zip(&dense) {
            prop_assert!(a == b, "sym_mul_vec {} vs mul_vec {}", b, a);
        }
    }

    /// `from_mat6` is the symmetric part; `mul_vec`, `force_to_motion`, `motion_to_force`
    /// match the explicit product.
    #[test]
    fn sym_basics(b in mat6(), x in vec6()) {
        let got = sym6_arr(&SymMat6::from_mat6(&Mat6(b)));
        let mut want = [[0.0; 6]; 6];
        for i in 0..6 {
            for j in 0..6 {
                want[i][j] = 0.5 * (b[i][j] + b[j][i]);
            }
        }
        prop_assert!(is_exactly_symmetric(&got));
        check_m6("from_mat6", &got, &want, max_abs6(&b), TOL)?;
        let sm = SymMat6::from_mat6(&Mat6(b));
        let y = mv6(&want, &x);
        let sc = max_abs6(&want) * max_abs_v6(&x) * 6.0;
        check_v6("sym mul_vec", &sm.mul_vec(&x), &y, sc, TOL)?;
        check_v6("sym force_to_motion",
            &motion6(sm.force_to_motion(SpatialForce::from_array(x))), &y, sc, TOL)?;
        check_v6("sym motion_to_force",
            &force6(sm.motion_to_force(SpatialMotion::from_array(x))), &y, sc, TOL)?;
    }

    /// `Mat6` products and transposes match explicit loops.
    #[test]
    fn mat6_products(a in mat6(), b in mat6(), x in vec6()) {
        let (ma, mb) = (Mat6(a), Mat6(b));
        let sc = max_abs6(&a) * max_abs6(&b) * 6.0;
        check_m6("mul_mat", &mat6_arr(&ma.mul_mat(&mb)), &mul6(&a, &b), sc, TOL)?;
        check_m6("Mul", &mat6_arr(&(ma * mb)), &mul6(&a, &b), sc, TOL)?;
        check_m6("mul_tr", &mat6_arr(&ma.mul_tr(&mb)), &mul6(&a, &tr6(&b)), sc, TOL)?;
        prop_assert_eq!(mat6_arr(&ma.transpose()), tr6(&a));
        let sv = max_abs6(&a) * max_abs_v6(&x) * 6.0;
        check_v6("mul_vec", &ma.mul_vec(&x), &mv6(&a, &x), sv, TOL)?;
        check_v6("tr_mul_vec", &ma.tr_mul_vec(&x), &mv6(&tr6(&a), &x), sv, TOL)?;
        check_v6("force_to_motion", &motion6(ma.force_to_motion(SpatialForce::from_array(x))),
            &mv6(&a, &x), sv, TOL)?;
        check_v6("motion_to_force", &force6(ma.motion_to_force(SpatialMotion::from_array(x))),
            &mv6(&a, &x), sv, TOL)?;
        check_v6("tr_force_to_motion",
            &motion6(ma.tr_force_to_motion(SpatialForce::from_array(x))),
            &mv6(&tr6(&a), &x), sv, TOL)?;
        let mut outer = [[0.0; 6]; 6];
        for i in 0..6 {
            for j in 0..6 {
                outer[i][j] = x[i] * b[0][j];
            }
        }
        prop_assert_eq!(mat6_arr(&Mat6::outer(&x, &b[0])), outer);
        prop_assert_eq!(mat6_arr(&ma.symmetric_part().into()), sym6_arr(&ma.symmetric_part()));
    }
}

proptest! {
    #![proptest_config(cfg())]

    /// Linear-space operations and constructors: vector `+ - neg * += -=`, `norm`,
    /// `Mat6`/`SymMat6` `+ - neg *`, `xlt`/`rot`/`new` composing to the explicit matrix.
    #[test]
    fn linear_ops_and_constructors(m1 in motion(), m2 in motion(), f1 in force(),
                                   f2 in force(), s in coord(), a in mat6(), b in mat6(),
                                   rot in rotation(), r in vec3()) {
        let (a1, a2) = (motion6(m1), motion6(m2));
        let mut want = [0.0; 6];
        for i in 0..6 {
            want[i] = a1[i] + s * a2[i];
        }
        let sc = m1.norm() + s.abs() * m2.norm();
        check_v6("m1 + s m2", &motion6(m1 + m2 * s), &want, sc, TOL)?;
        check_v6("m1 + s m2 (f64 * m)", &motion6(m1 + s * m2), &want, sc, TOL)?;
        let mut acc = m1;
        acc -= -(m2 * s);
        check_v6("-= neg", &motion6(acc), &want, sc, TOL)?;
        let mut acc = m1;
        acc += m2;
        acc -= m2;
        check_v6("+= -=", &motion6(acc), &a1, m1.norm() + m2.norm(), TOL)?;
        check_v6("m1 - m2", &motion6(m1 - m2), &[a1[0] - a2[0], a1[1] - a2[1], a1[2] - a2[2],
            a1[3] - a2[3], a1[4] - a2[4], a1[5] - a2[5]], sc, TOL)?;
        check_s("norm", m1.norm(), dot6(&a1, &a1).sqrt(), m1.norm(), TOL)?;
        let (b1, b2) = (force6(f1), force6(f2));
        check_v6("f1 - f2", &force6(f1 - f2), &[b1[0] - b2[0], b1[1] - b2[1], b1[2] - b2[2],
            b1[3] - b2[3], b1[4] - b2[4], b1[5] - b2[5]], f1.norm() + f2.norm(), TOL)?;
        check_v6("f1 + s f2", &force6(f1 + s * f2), &[b1[0] + s * b2[0], b1[1] + s * b2[1],
            b1[2] + s * b2[2], b1[3] + s * b2[3], b1[4] + s * b2[4], b1[5] + s * b2[5]],
            f1.norm() + s.abs() * f2.norm(), TOL)?;

        let (ma, mb) = (Mat6(a), Mat6(b));
        let mut want = [[0.0; 6]; 6];
        for i in 0..6 {
            for j in 0..6 {
                want[i][j] = a[i][j] - s * b[i][j];
            }
        }
        let sc = max_abs6(&a) + s.abs() * max_abs6(&b);
        check_m6("A - s B", &mat6_arr(&(ma - mb * s)), &want, sc, TOL)?;
        check_m6("A + -(s B)", &mat6_arr(&(ma + -(mb * s))), &want, sc, TOL)?;
        let mut acc = ma;
        acc -= mb * s;
        check_m6("A -= s B", &mat6_arr(&acc), &want, sc, TOL)?;
        let (sa, sb) = (sym_from(&a), sym_from(&b));
        let (ssa, ssb) = (SymMat6::from_mat6(&Mat6(sa)), SymMat6::from_mat6(&Mat6(sb)));
        let got = sym6_arr(&(ssa - ssb * s));
        let got2 = sym6_arr(&(ssa + -(ssb * s)));
        let mut want = [[0.0; 6]; 6];
        for i in 0..6 {
            for j in 0..6 {
                want[i][j] = sa[i][j] - s * sb[i][j];
            }
        }
        prop_assert!(is_exactly_symmetric(&got) && is_exactly_symmetric(&got2));
        let sc = max_abs6(&sa) + s.abs() * max_abs6(&sb);
        check_m6("SA - s SB", &got, &want, sc, TOL)?;
        check_m6("SA + -(s SB)", &got2, &want, sc, TOL)?;
        prop_assert_eq!(ssa.as_mat6().max_abs(), max_abs6(&sa));
        prop_assert!(ssa.is_finite() && ma.is_finite());

        // new(E, r) = rot(E) * xlt(r), all three equal to the explicit matrix.
        let x = SpatialTransform::rot(rot) * SpatialTransform::xlt(r);
        let want = motion_mat(&m3(rot), v3(r));
        check_m6("rot * xlt", &x_motion(&x), &want, 1.0 + r.length(), TOL)?;
        check_m6("new", &x_motion(&SpatialTransform::new(rot, r)), &want, 1.0 + r.length(),
            TOL)?;
        check_m6("identity", &x_motion(&SpatialTransform::IDENTITY), &eye6(), 1.0, 0.0)?;
        check_m6("xlt", &x_motion(&SpatialTransform::xlt(r)), &motion_mat(&m3(DMat3::IDENTITY),
            v3(r)), 1.0 + r.length(), TOL)?;
    }
}

/// Fixed examples: a known transform and the to_array layout (angular part first).
#[test]
fn fixed_examples() {
    let m = SpatialMotion::new(DVec3::new(1.0, 2.0, 3.0), DVec3::new(4.0, 5.0, 6.0));
    assert_eq!(m.to_array(), [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    let f = SpatialForce::new(DVec3::new(1.0, 2.0, 3.0), DVec3::new(4.0, 5.0, 6.0));
    assert_eq!(f.to_array(), [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    // Child 1 m along parent x, rotated 90° about z; spinning about z at 2 rad/s about its
    // origin: in the parent the linear velocity at the parent origin is p × ω = (0, -2, 0).
    let x = SpatialTransform::from_pose(
        DMat3::from_rotation_z(std::f64::consts::FRAC_PI_2),
        DVec3::X,
    );
    let v = x.apply_motion(SpatialMotion::new(DVec3::new(0.0, 0.0, 2.0), DVec3::ZERO));
    assert!((v.w - DVec3::new(0.0, 0.0, 2.0)).length() < 1e-15);
    assert!((v.v - DVec3::new(0.0, -2.0, 0.0)).length() < 1e-15);
    // The child's x axis is the parent's y axis.
    assert!((x.apply_point(DVec3::X) - DVec3::new(1.0, 1.0, 0.0)).length() < 1e-15);
}
