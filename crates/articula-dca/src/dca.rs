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

/// The 6×6 matrix `[tl tr; bl br]`.
fn block6(tl: DMat3, tr: DMat3, bl: DMat3, br: DMat3) -> Mat6 {
    let mut m = [[0.0; 6]; 6];
    for i in 0..3 {
        for k in 0..3 {
            m[i][k] = tl.col(k)[i];
            m[i][k + 3] = tr.col(k)[i];
            m[i + 3][k] = bl.col(k)[i];
            m[i + 3][k + 3] = br.col(k)[i];
        }
    }
    Mat6(m)
}

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
                        data.dca.phi[bo + h * nh + k] = block6(tl, tr, bl, br);
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

/// Joins A and B at `joint` into node `n` (DESIGN §5, general handle count).
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
    // V = (Φ_jj^A + Φ_jj^B)⁻¹
    let sum = SymMat6::from_mat6(&(*phi(d, a, nha, ja, ja) + *phi(d, b, nhb, jb, jb)));
    let v = sum.inverse_spd().ok_or_else(|| DynamicsError::Singular {
        joint: body.joint_name(),
        detail: "Φ_jj^A + Φ_jj^B is not positive definite",
    })?;
    let v = refine(&sum, &v);
    // S and c at the joint's point P_j.
    let pj = d.point[joint];
    let shift = |m: SpatialMotion| SpatialMotion::new(m.w, m.v + m.w.cross(pj));
    let (vo, k) = (body.v_offset, body.nv);
    let mut sj = [SpatialMotion::ZERO; 6];
    for p in 0..k {
        sj[p] = shift(data.s[vo + p]);
    }
    // V S, D = Sᵀ V S, D⁻¹
    let mut dm = crate::small::SmallSpd {
        k,
        a: [[0.0; 6]; 6],
    };
    for p in 0..k {
        let vs = v.motion_to_force(sj[p]);
        d.vs[vo + p] = vs;
        for q in 0..=p {
            let x = sj[q].dot(vs);
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
    // W = V − V S D⁻¹ Sᵀ V
    let mut w = v;
    for p in 0..k {
        for q in 0..k {
            let x = dm.a[p][q];
            if x != 0.0 {
                let (u, z) = (d.vs[vo + p].to_array(), d.vs[vo + q].to_array());
                w = if p == q {
                    w.sub_outer(&u, x)
                } else {
                    SymMat6::from_mat6(&(*w.as_mat6() - Mat6::outer(&u, &z) * x))
                };
            }
        }
    }
    // β = b_j^A − b_j^B + c,  γ = W β + V S D⁻¹ Q
    let beta = d.b[d.hoff[a] + ja] - d.b[d.hoff[b] + jb] + shift(data.c[joint]);
    let mut gamma = w.motion_to_force(beta);
    let mut dq = [0.0; 6];
    dm.mul(&tau[vo..vo + k], &mut dq);
    for p in 0..k {
        gamma += d.vs[vo + p] * dq[p];
    }
    d.w[n] = w;
    d.beta[n] = beta;
    d.gamma[n] = gamma;
    // T_h = Φ_hj W for each handle h of C (from A or B).
    let (hc, bc) = (d.hoff[n], d.boff[n]);
    for h in 0..nhc {
        let (side, i) = d.from[hc + h];
        let p = match side {
            Side::A => phi(d, a, nha, i, ja),
            Side::B => phi(d, b, nhb, i, jb),
        };
        d.t[h] = p.mul_mat(w.as_mat6());
    }
    // Φ^C blocks: same side  Φ_hk − T_h Φ_jk ; across  T_h Φ_jk (of the other side).
    for h in 0..nhc {
        let (sh, ih) = d.from[hc + h];
        for kk in h..nhc {
            let (sk, ik) = d.from[hc + kk];
            let blk = match (sh, sk) {
                (Side::A, Side::A) => {
                    *phi(d, a, nha, ih, ik) - d.t[h].mul_mat(phi(d, a, nha, ja, ik))
                }
                (Side::B, Side::B) => {
                    *phi(d, b, nhb, ih, ik) - d.t[h].mul_mat(phi(d, b, nhb, jb, ik))
                }
                (Side::A, Side::B) => d.t[h].mul_mat(phi(d, b, nhb, jb, ik)),
                (Side::B, Side::A) => d.t[h].mul_mat(phi(d, a, nha, ja, ik)),
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

/// Top-down: `q̈ = D⁻¹ (Q − Sᵀ V y)`, `f = W (y − β) + γ` with
/// `y = β + Σ_{k∈A} Φ^A_jk f_k − Σ_{k∈B} Φ^B_jk f_k` over C's handle forces.
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
        let mut r = [0.0; 6];
        for p in 0..k {
            r[p] = tau[vo + p] - y.dot(d.vs[vo + p]);
        }
        d.dinv[joint].mul(&r[..k], &mut data.qdd[vo..vo + k]);
        let f = d.w[n].motion_to_force(y - d.beta[n]) + d.gamma[n];
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

/// One step of iterative refinement of an inverse: `X ← X + X (1 − M X)`.
fn refine(m: &SymMat6, x: &SymMat6) -> SymMat6 {
    let r = Mat6::IDENTITY - m.as_mat6().mul_mat(x.as_mat6());
    SymMat6::from_mat6(&(*x.as_mat6() + x.as_mat6().mul_mat(&r)))
}
