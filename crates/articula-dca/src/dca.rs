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
use articula_spatial::{skew, Mat6, SpatialForce, SpatialMotion, SymMat6};
use glam::{DMat3, DVec3};

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
                let node_handles = &tree.nodes[n].handles;
                for (h, &jh) in node_handles.iter().enumerate() {
                    let ah = c - data.dca.point[jh];
                    let axj = skew(ah) * j;
                    for (k, &jk) in node_handles.iter().enumerate() {
                        let ek = skew(c - data.dca.point[jk]);
                        let tl = j;
                        let tr = -(j * ek);
                        let bl = axj;
                        let br = -(axj * ek) + DMat3::from_diagonal(DVec3::splat(1.0 / m));
                        data.dca.phi[bo + h * nh + k] = Mat6::from_blocks(tl, tr, bl, br);
                    }
                    // b at P_h: [α; a_c + α × (P_h − c)] + a_g
                    data.dca.b[ho + h] = a_g + SpatialMotion::new(acc_w, acc_c + acc_w.cross(-ah));
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

/// Cholesky factor of `M` computed on the Jacobi-scaled `E M E` (`E = diag(M_ii^-½)`), then
/// unscaled (`L = E⁻¹ L'`): rotational and translational entries differ by the square of the
/// lever arms (a 100,000-link chain is 10 km long), and the scaled pivots do not.
#[inline]
fn scaled_cholesky(m: &[[f64; 6]; 6]) -> Option<[[f64; 6]; 6]> {
    let mut e = [0.0; 6];
    for i in 0..6 {
        if m[i][i].is_nan() || m[i][i] <= 0.0 {
            return None;
        }
        e[i] = 1.0 / m[i][i].sqrt();
    }
    let mut ms = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..6 {
            ms[i][j] = m[i][j] * e[i] * e[j];
        }
    }
    let mut l = crate::small::cholesky(&ms, 6)?;
    for i in 0..6 {
        for j in 0..=i {
            l[i][j] /= e[i];
        }
    }
    Some(l)
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
/// with `Z = L⁻¹ S`, `D = ZᵀZ`, `Y_h = Φ_hj L⁻ᵀ` and `P_h = Y_h Z`,
/// `Φ_hj W Φ_jk = Y_h Y_kᵀ − P_h D⁻¹ P_kᵀ`, and `γ = W β + V S D⁻¹ Q
/// = L⁻ᵀ (w − Z D⁻¹ (Zᵀw − Q))` with `w = L⁻¹ β`.
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
    let l = scaled_cholesky(&sum).ok_or_else(|| DynamicsError::Singular {
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
    // β = b_j^A − b_j^B + c;  γ = L⁻ᵀ (w − Z D⁻¹ (Zᵀw − Q)),  w = L⁻¹ β
    let beta = d.b[d.hoff[a] + ja] - d.b[d.hoff[b] + jb] + shift(data.c[joint]);
    d.beta[n] = beta;
    let mut w = solve_l(&l, &beta.to_array());
    let mut t = [0.0; 6];
    for p in 0..k {
        t[p] = dot6(&d.z[vo + p], &w) - tau[vo + p];
    }
    let mut r = [0.0; 6];
    dm.mul(&t[..k], &mut r[..k]);
    for p in 0..k {
        let z = d.z[vo + p];
        for i in 0..6 {
            w[i] -= z[i] * r[p];
        }
    }
    let gamma = SpatialForce::from_array(solve_lt(&l, &w));
    // Yᵀ_h = L⁻¹ Φ_jh (Φ_jh = Φ_hjᵀ is stored; forward substitution on whole rows, which
    // vectorises), P_h = Y_h Z, R_h = P_h D⁻¹. Row i of `d.y[h]` is column i of Y_h.
    let (hc, bc) = (d.hoff[n], d.boff[n]);
    for h in 0..nhc {
        let (side, i) = d.from[hc + h];
        let gt = match side {
            Side::A => phi(d, a, nha, ja, i),
            Side::B => phi(d, b, nhb, jb, i),
        };
        let mut yt = [[0.0; 6]; 6];
        for r in 0..6 {
            let mut v = gt.0[r];
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
        let mut pm = [[0.0; 6]; 6];
        let mut rm = [[0.0; 6]; 6];
        for p in 0..k {
            let z = d.z[vo + p];
            let mut col = [0.0; 6];
            for r in 0..6 {
                for c in 0..6 {
                    col[c] += yt[r][c] * z[r];
                }
            }
            for row in 0..6 {
                pm[row][p] = col[row];
            }
        }
        for row in 0..6 {
            dm.mul(&pm[row][..k], &mut rm[row][..k]);
        }
        d.y[h] = Mat6(yt);
        d.pz[h] = Mat6(pm);
        d.rz[h] = Mat6(rm);
    }
    // Φ^C blocks: same side Φ_hk − (Y_h Y_kᵀ − R_h P_kᵀ); across +(Y_h Y_kᵀ − R_h P_kᵀ).
    for h in 0..nhc {
        let (sh, ih) = d.from[hc + h];
        for kk in h..nhc {
            let (sk, ik) = d.from[hc + kk];
            // m = Y_h Y_kᵀ − R_h P_kᵀ = Σ_i (column i of Y_h)(column i of Y_k)ᵀ − R_h P_kᵀ
            let mut m = Mat6::ZERO;
            let (yh, yk, rh, pk) = (&d.y[h].0, &d.y[kk].0, &d.rz[h].0, &d.pz[kk].0);
            for i in 0..6 {
                for row in 0..6 {
                    let x = yh[i][row];
                    for col in 0..6 {
                        m.0[row][col] += x * yk[i][col];
                    }
                }
            }
            for p in 0..k {
                for row in 0..6 {
                    let x = rh[row][p];
                    for col in 0..6 {
                        m.0[row][col] -= x * pk[col][p];
                    }
                }
            }
            let blk = match (sh, sk) {
                (Side::A, Side::A) => *phi(d, a, nha, ih, ik) - m,
                (Side::B, Side::B) => *phi(d, b, nhb, ih, ik) - m,
                _ => m,
            };
            if h == kk {
                d.phi[bc + h * nhc + h] = *SymMat6::from_mat6(&blk).as_mat6();
            } else {
                d.phi[bc + h * nhc + kk] = blk;
                d.phi[bc + kk * nhc + h] = blk.transpose();
            }
        }
        // b^C_h = b^A_h − Φ^A_hj γ  or  b^B_h + Φ^B_hj γ
        d.b[hc + h] = match sh {
            Side::A => d.b[d.hoff[a] + ih] - phi(d, a, nha, ih, ja).force_to_motion(gamma),
            Side::B => d.b[d.hoff[b] + ih] + phi(d, b, nhb, ih, jb).force_to_motion(gamma),
        };
    }
    Ok(())
}

/// Top-down: with `y = β + Σ_{k∈A} Φ^A_jk f_k − Σ_{k∈B} Φ^B_jk f_k` over C's handle forces
/// and `w = L⁻¹ y`: `q̈ = D⁻¹ (Q − Zᵀ w)` (= `D⁻¹ (Q − Sᵀ V y)`) and the joint force
/// `f = L⁻ᵀ (w + Z q̈)` (= `W y + V S D⁻¹ Q`).
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
