//! Featherstone's divide-and-conquer algorithm (DESIGN §5), all quantities in world
//! coordinates.
//!
//! A subassembly with handles h obeys `a_h = Σ_k Φ_hk f_k + b_h` (handle forces `f_k` act on it;
//! `a_h` is the spatial acceleration of the body at handle h). The main pass computes Φ and b
//! bottom-up over the assembly tree; the back-substitution computes each principal joint's
//! `q̈` and constraint force top-down.

use crate::data::Side;
use crate::{Data, DynamicsError};
use articula_model::{Model, NodeKind};
use articula_spatial::{Mat6, SpatialForce, SpatialMotion};
use glam::DVec3;

/// Runs DCA on the kinematics already in `data` (see [`crate::forward_kinematics`]); writes
/// `data.qdd`.
pub(crate) fn dca(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
) -> Result<(), DynamicsError> {
    main_pass(model, tau, f_ext, data)?;
    back_substitution(model, tau, data);
    Ok(())
}

/// Φ_hk of node `n` (row-major nh × nh blocks).
#[inline]
fn phi(d: &crate::data::DcaData, n: usize, nh: usize, h: usize, k: usize) -> &Mat6 {
    &d.phi[d.boff[n] + h * nh + k]
}

fn main_pass(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
) -> Result<(), DynamicsError> {
    let tree = &model.assembly;
    let a_g = SpatialMotion::new(DVec3::ZERO, data.gravity);
    // Each handle (joint h) keeps its vectors about its own point P_h, the origin of body h:
    // far from the computation origin the blocks would otherwise lose digits (a 100,000-link
    // chain reaches 10 km).
    for (h, x) in data.x.iter().enumerate() {
        data.dca.point[h] = x.apply_point(DVec3::ZERO);
    }
    for (n, node) in tree.nodes.iter().enumerate() {
        let nh = node.handles.len();
        let (ho, bo) = (data.dca.hoff[n], data.dca.boff[n]);
        match node.kind {
            // Ground: Φ = 0, b = 0.
            NodeKind::Ground => {
                for k in 0..nh * nh {
                    data.dca.phi[bo + k] = Mat6::ZERO;
                }
                for k in 0..nh {
                    data.dca.b[ho + k] = SpatialMotion::ZERO;
                }
            }
            // Leaf: Φ_hk = I⁻¹ for every handle pair, b = a_g + I⁻¹ (f_ext − v ×* I v).
            // Leaf (DESIGN §5): Φ_hk = I⁻¹, b_h = a_g + I⁻¹ (f_ext − v ×* I v), each handle's
            // rows and columns taken at its own point P_h. About the centre of mass c, where
            // I = diag(I_c, m 1): with a = c − P_h, e = c − P_k, J = I_c⁻¹,
            // Φ_hk = [J, −J e×; a× J, −a× J e× + 1/m].
            NodeKind::Body(i) => {
                let body = &model.bodies[i];
                let (rot, _) = data.x[i].to_pose();
                let c = data.x[i].apply_point(body.inertia.com());
                let ic_body = body.inertia.inertia_about_com();
                let m = body.inertia.mass;
                if m.is_nan() || m <= 0.0 || ic_body.determinant() <= 0.0 {
                    return Err(DynamicsError::Singular {
                        joint: body.joint_name(),
                        detail: "the body's spatial inertia is not positive definite",
                    });
                }
                let j = rot * ic_body.inverse() * rot.transpose();
                let ic = rot * ic_body * rot.transpose();
                // Net force about c: f_ext − v ×* I v, with v_c the velocity of the point at c.
                let v = data.v[i];
                let v_c = v.v + v.w.cross(c);
                let fe = crate::f_ext_of(f_ext, i);
                let n_c = fe.n - c.cross(fe.f) - v.w.cross(ic * v.w);
                let f_c = fe.f - v.w.cross(v_c) * m;
                let acc_w = j * n_c;
                let acc_c = f_c / m;
                // With A_h = a_h× J: −J e_k× = A_kᵀ (J symmetric) and −a_h× J e_k× = a_h× A_kᵀ,
                // so Φ_hk = [J, A_kᵀ; A_h, a_h× A_kᵀ + 1/m]: three cross products per block.
                let node_handles = &tree.nodes[n].handles;
                let jrows = j.transpose(); // rows of J (= columns: J is symmetric)
                let im = 1.0 / m;
                for (h, &jh) in node_handles.iter().enumerate() {
                    let ah = c - data.dca.point[jh];
                    // b at P_h: [α; a_c + α × (P_h − c)] + a_g
                    data.dca.b[ho + h] = a_g + SpatialMotion::new(acc_w, acc_c + acc_w.cross(-ah));
                }
                for (h, &jh) in node_handles.iter().enumerate() {
                    let ah = c - data.dca.point[jh];
                    // Columns of A_h = a_h× J are a_h × (columns of J).
                    let ah_cols = [ah.cross(j.x_axis), ah.cross(j.y_axis), ah.cross(j.z_axis)];
                    for (k, &jk) in node_handles.iter().enumerate() {
                        let ak = c - data.dca.point[jk];
                        let ak_cols = [ak.cross(j.x_axis), ak.cross(j.y_axis), ak.cross(j.z_axis)];
                        // Row r of A_kᵀ is column r of A_k; column cc of A_kᵀ is row cc of A_k.
                        let ak_row =
                            |cc: usize| DVec3::new(ak_cols[0][cc], ak_cols[1][cc], ak_cols[2][cc]);
                        let br_cols = [
                            ah.cross(ak_row(0)),
                            ah.cross(ak_row(1)),
                            ah.cross(ak_row(2)),
                        ];
                        let out = &mut data.dca.phi[bo + h * nh + k].0;
                        for r in 0..3 {
                            let jr = jrows.col(r);
                            out[r] = [jr.x, jr.y, jr.z, ak_cols[r].x, ak_cols[r].y, ak_cols[r].z];
                            out[r + 3] = [
                                ah_cols[0][r],
                                ah_cols[1][r],
                                ah_cols[2][r],
                                br_cols[0][r],
                                br_cols[1][r],
                                br_cols[2][r],
                            ];
                            out[r + 3][r + 3] += im;
                        }
                    }
                }
            }
            NodeKind::Join {
                joint,
                parent_side: a,
                child_side: b,
            } => join(model, tau, data, n, joint, a, b)?,
        }
    }
    Ok(())
}

/// `L⁻¹ b` (forward substitution).
#[inline]
fn solve_l(l: &[[f64; 6]; 6], b: &[f64; 6]) -> [f64; 6] {
    let mut x = [0.0; 6];
    for i in 0..6 {
        let mut v = b[i];
        for p in 0..i {
            v -= l[i][p] * x[p];
        }
        x[i] = v / l[i][i];
    }
    x
}

/// `L⁻ᵀ b` (back substitution).
#[inline]
fn solve_lt(l: &[[f64; 6]; 6], b: &[f64; 6]) -> [f64; 6] {
    let mut x = [0.0; 6];
    for i in (0..6).rev() {
        let mut v = b[i];
        for p in (i + 1)..6 {
            v -= l[p][i] * x[p];
        }
        x[i] = v / l[i][i];
    }
    x
}

#[inline]
fn dot6(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]
}

/// Joins A and B at `joint` into node `n` (DESIGN §5, any handle count), through the
/// Cholesky factor of `Φ^A_jj + Φ^B_jj = L Lᵀ` so that V and W never appear explicitly:
/// with `Z = L⁻¹ S`, `D = ZᵀZ` and the orthogonal projector `Q = 1 − Z D⁻¹ Zᵀ`,
/// `W = L⁻ᵀ Q L⁻¹`, so `Φ_hj W Φ_jk = Ỹ_hᵀ Ỹ_k` with `Ỹ_h = Q L⁻¹ Φ_jh` (one Gram product per
/// block; `Q = QᵀQ`), and `γ = W β + V S D⁻¹ Q_τ = L⁻ᵀ (w − Z D⁻¹ (Zᵀw − τ))` with
/// `w = L⁻¹ β`.
#[inline(never)]
fn join(
    model: &Model,
    tau: &[f64],
    data: &mut Data,
    n: usize,
    joint: usize,
    a: usize,
    b: usize,
) -> Result<(), DynamicsError> {
    let tree = &model.assembly;
    let body = &model.bodies[joint];
    let (nha, nhb) = (tree.nodes[a].handles.len(), tree.nodes[b].handles.len());
    let nhc = tree.nodes[n].handles.len();
    let d = &mut data.dca;
    let (ja, jb) = (d.ja[n], d.jb[n]);
    // L Lᵀ = Φ^A_jj + Φ^B_jj
    let sum = (*phi(d, a, nha, ja, ja) + *phi(d, b, nhb, jb, jb)).0;
    let l = crate::small::cholesky6(&sum).ok_or_else(|| DynamicsError::Singular {
        joint: body.joint_name(),
        detail: "Φ_jj^A + Φ_jj^B is not positive definite",
    })?;
    // S and c at the joint's point P_j; Z = L⁻¹ S, D = Zᵀ Z.
    let pj = d.point[joint];
    let shift = |m: SpatialMotion| SpatialMotion::new(m.w, m.v + m.w.cross(pj));
    let (vo, k) = (body.v_offset, body.nv);
    let mut dm = crate::small::SmallSpd {
        k,
        a: [[0.0; 6]; 6],
    };
    for p in 0..k {
        let z = solve_l(&l, &shift(data.s[vo + p]).to_array());
        d.z[vo + p] = z;
        for q in 0..=p {
            let x = dot6(&d.z[vo + q], &z);
            dm.a[p][q] = x;
            dm.a[q][p] = x;
        }
    }
    if !dm.invert() {
        return Err(DynamicsError::Singular {
            joint: body.joint_name(),
            detail: "Sᵀ V S is not positive definite",
        });
    }
    d.dinv[joint] = dm;
    d.l[n] = l;
    // Z D⁻¹ (columns), for the projector Q = 1 − (Z D⁻¹) Zᵀ.
    let mut zd = [[0.0; 6]; 6];
    for p in 0..k {
        for q in 0..k {
            let x = dm.a[p][q];
            let zq = &d.z[vo + q];
            for i in 0..6 {
                zd[p][i] += x * zq[i];
            }
        }
    }
    // β = b_j^A − b_j^B + c;  γ = L⁻ᵀ (w − Z D⁻¹ (Zᵀw − Q)),  w = L⁻¹ β
    let beta = d.b[d.hoff[a] + ja] - d.b[d.hoff[b] + jb] + shift(data.c[joint]);
    d.beta[n] = beta;
    let mut w = solve_l(&l, &beta.to_array());
    for p in 0..k {
        let t = dot6(&d.z[vo + p], &w) - tau[vo + p];
        for i in 0..6 {
            w[i] -= zd[p][i] * t;
        }
    }
    let gamma = solve_lt(&l, &w);
    // Ỹ_h = Q L⁻¹ Φ_jh: forward substitution on whole rows of Φ_jh (vectorises), then the
    // projection Ỹ −= (Z D⁻¹)(Zᵀ Ỹ) (k rank-1 row updates).
    let (hc, bc) = (d.hoff[n], d.boff[n]);
    let (boa, bob) = (d.boff[a], d.boff[b]);
    for h in 0..nhc {
        let (side, i) = d.from[hc + h];
        let gt = match side {
            Side::A => &d.phi[boa + ja * nha + i].0,
            Side::B => &d.phi[bob + jb * nhb + i].0,
        };
        y_tilde(&mut d.y[h], gt, &l, &d.z[vo..vo + k], &zd);
    }
    // Φ^C blocks: same side Φ_hk − Ỹ_hᵀỸ_k; across +Ỹ_hᵀỸ_k. Then b^C.
    let (src, dst) = d.phi.split_at_mut(bc);
    for h in 0..nhc {
        let (sh, ih) = d.from[hc + h];
        for kk in h..nhc {
            let (sk, ik) = d.from[hc + kk];
            // Row r of Ỹ_hᵀ Ỹ_k is Σ_i Ỹ_h[i][r] · (row i of Ỹ_k): six accumulators per row.
            let (yh, yk) = (&d.y[h], &d.y[kk]);
            let old = match (sh, sk) {
                (Side::A, Side::A) => Some(&src[boa + ih * nha + ik].0),
                (Side::B, Side::B) => Some(&src[bob + ih * nhb + ik].0),
                _ => None,
            };
            let out = &mut dst[h * nhc + kk].0;
            if h == kk {
                gram_sym_into(out, yh, old);
            } else {
                gram_into(out, yh, yk, old);
            }
            if h == kk {
                // Symmetric: mirror the upper triangle (round-off would differ below).
                for r in 0..6 {
                    for c in 0..r {
                        out[r][c] = out[c][r];
                    }
                }
            } else {
                let t = Mat6(*out).transpose();
                dst[kk * nhc + h] = t;
            }
        }
        // b^C_h = b^A_h − Φ^A_hj γ  or  b^B_h + Φ^B_hj γ  (Φ_hj γ = Φ_jhᵀ γ)
        d.b[hc + h] = match sh {
            Side::A => {
                d.b[d.hoff[a] + ih]
                    - SpatialMotion::from_array(src[boa + ja * nha + ih].tr_mul_vec(&gamma))
            }
            Side::B => {
                d.b[d.hoff[b] + ih]
                    + SpatialMotion::from_array(src[bob + jb * nhb + ih].tr_mul_vec(&gamma))
            }
        };
    }
    Ok(())
}

/// `Ỹ = Q L⁻¹ G` for `G = Φ_jh`: forward substitution on whole rows (vectorises), then the
/// projection `Ỹ −= (Z D⁻¹)(Zᵀ Ỹ)` (one rank-1 row update per column of `Z`).
#[inline(never)]
fn y_tilde(
    yt: &mut [[f64; 6]; 6],
    gt: &[[f64; 6]; 6],
    l: &[[f64; 6]; 6],
    z: &[[f64; 6]],
    zd: &[[f64; 6]; 6],
) {
    for r in 0..6 {
        let mut v = gt[r];
        for q in 0..r {
            let lrq = l[r][q];
            for c in 0..6 {
                v[c] -= lrq * yt[q][c];
            }
        }
        let inv = 1.0 / l[r][r];
        for c in 0..6 {
            yt[r][c] = v[c] * inv;
        }
    }
    for (zp, zdp) in z.iter().zip(zd) {
        let mut zy = [0.0; 6];
        for r in 0..6 {
            for c in 0..6 {
                zy[c] += zp[r] * yt[r][c];
            }
        }
        for r in 0..6 {
            let x = zdp[r];
            for c in 0..6 {
                yt[r][c] -= x * zy[c];
            }
        }
    }
}

/// `out = old − Ỹ_hᵀ Ỹ_k` (or `+Ỹ_hᵀ Ỹ_k` without `old`): row r is
/// `Σ_i Ỹ_h[i][r] · (row i of Ỹ_k)`, six accumulators per row.
#[inline(never)]
fn gram_into(
    out: &mut [[f64; 6]; 6],
    yh: &[[f64; 6]; 6],
    yk: &[[f64; 6]; 6],
    old: Option<&[[f64; 6]; 6]>,
) {
    for r in 0..6 {
        let mut acc = [0.0; 6];
        for i in 0..6 {
            let x = yh[i][r];
            let yki = &yk[i];
            for c in 0..6 {
                acc[c] += x * yki[c];
            }
        }
        match old {
            Some(o) => {
                for c in 0..6 {
                    out[r][c] = o[r][c] - acc[c];
                }
            }
            None => out[r] = acc,
        }
    }
}

/// [`gram_into`] for a diagonal block (`Ỹ_k = Ỹ_h`, symmetric): only the entries on and above
/// the diagonal, in pairs of columns (rows 2p and 2p+1 start at column 2p); the caller mirrors.
#[inline(never)]
fn gram_sym_into(out: &mut [[f64; 6]; 6], y: &[[f64; 6]; 6], old: Option<&[[f64; 6]; 6]>) {
    gram_rows::<0>(out, y, old);
    gram_rows::<2>(out, y, old);
    gram_rows::<4>(out, y, old);
}

#[inline(always)]
fn gram_rows<const C0: usize>(
    out: &mut [[f64; 6]; 6],
    y: &[[f64; 6]; 6],
    old: Option<&[[f64; 6]; 6]>,
) {
    for r in C0..C0 + 2 {
        let mut acc = [0.0; 6];
        for i in 0..6 {
            let x = y[i][r];
            for c in C0..6 {
                acc[c] += x * y[i][c];
            }
        }
        match old {
            Some(o) => {
                for c in C0..6 {
                    out[r][c] = o[r][c] - acc[c];
                }
            }
            None => out[r][C0..6].copy_from_slice(&acc[C0..6]),
        }
    }
}

/// Top-down: with `y = β + Σ_{k∈A} Φ^A_jk f_k − Σ_{k∈B} Φ^B_jk f_k` over C's handle forces
/// and `w = L⁻¹ y`: `q̈ = D⁻¹ (Q − Zᵀ w)` (= `D⁻¹ (Q − Sᵀ V y)`) and the joint force
/// `f = L⁻ᵀ (w + Z q̈)` (= `W y + V S D⁻¹ Q`).
#[inline(never)]
fn back_substitution(model: &Model, tau: &[f64], data: &mut Data) {
    let tree = &model.assembly;
    for n in (0..tree.nodes.len()).rev() {
        let NodeKind::Join {
            joint,
            parent_side: a,
            child_side: b,
        } = tree.nodes[n].kind
        else {
            continue;
        };
        let d = &mut data.dca;
        let (nha, nhb, nhc) = (
            tree.nodes[a].handles.len(),
            tree.nodes[b].handles.len(),
            tree.nodes[n].handles.len(),
        );
        let (ja, jb, hc) = (d.ja[n], d.jb[n], d.hoff[n]);
        let mut y = d.beta[n];
        for h in 0..nhc {
            let f = d.f[hc + h];
            match d.from[hc + h] {
                (Side::A, i) => y += phi(d, a, nha, ja, i).force_to_motion(f),
                (Side::B, i) => y -= phi(d, b, nhb, jb, i).force_to_motion(f),
            }
        }
        let body = &model.bodies[joint];
        let (vo, k) = (body.v_offset, body.nv);
        let l = &d.l[n];
        let mut w = solve_l(l, &y.to_array());
        let mut r = [0.0; 6];
        for p in 0..k {
            r[p] = tau[vo + p] - dot6(&d.z[vo + p], &w);
        }
        d.dinv[joint].mul(&r[..k], &mut data.qdd[vo..vo + k]);
        for p in 0..k {
            let (z, qdd) = (d.z[vo + p], data.qdd[vo + p]);
            for i in 0..6 {
                w[i] += z[i] * qdd;
            }
        }
        let f = SpatialForce::from_array(solve_lt(l, &w));
        let (hoa, hob) = (d.hoff[a], d.hoff[b]);
        for h in 0..nhc {
            let fh = d.f[hc + h];
            match d.from[hc + h] {
                (Side::A, i) => d.f[hoa + i] = fh,
                (Side::B, i) => d.f[hob + i] = fh,
            }
        }
        d.f[hoa + ja] = -f;
        d.f[hob + jb] = f;
    }
}
