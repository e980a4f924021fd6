//! DCA at a gather node of the assembly tree (docs/design.md#assembly-tree): a hub with many
//! children absorbs their subassemblies in inertia form, as ABA absorbs a body's children, in
//! O(1) storage per child and one handle (the hub's own joint) for the result.
//!
//! Child c's subassembly has one handle, its joint to the hub, about whose point `P_c` it obeys
//! `a_c = Φ_c f_c + b_c` (`f_c` the force the hub exerts on it). With `K_c = Φ_c⁻¹`, the joint's
//! `S` and velocity product `c_j`, and the hub's acceleration `a` (about the hub's point `P`;
//! `X_c` moves it to `P_c`), `a_c = X_c a + S q̈ + c_j` and `Sᵀ f_c = τ` give
//!
//! ```text
//! u = X_c a + c_j − b_c,   D = Sᵀ K_c S,   q̈ = D⁻¹ (τ − Sᵀ K_c u),   f_c = K_c (u + S q̈)
//!   = P_c (X_c a) + K_c (c_j − b_c) + K_c S D⁻¹ (τ − Sᵀ K_c (c_j − b_c)),
//! P_c = K_c − K_c S D⁻¹ Sᵀ K_c.
//! ```
//!
//! The hub then obeys `Iᴬ a + pᴬ = f` (`f` the force at its own joint) with
//! `Iᴬ = I + Σ_c X_cᵀ P_c X_c` and `pᴬ = p + Σ_c X_cᵀ (f_c at a = 0)`, `I` and `p = v ×* I v −
//! f_ext − I a_g` the hub body's own: the gather node's `Φ = (Iᴬ)⁻¹`, `b = −(Iᴬ)⁻¹ pᴬ` at `P`.
//! The ground as a hub does not move (`a = 0`). The back-substitution takes `a = Φ f + b` and
//! gives each child's `q̈` and `f_c` by the first line.

use crate::small::{SmallSpd, SymT};
use crate::{Data, DynamicsError};
use articula_model::Model;
use articula_spatial::numerics::{
    cholesky_inv_diag, dot6, invert_factor_inv_diag, solve_lower_inv_diag, solve_lower_t_inv_diag,
    Portable,
};
use articula_spatial::{Mat6, SpatialForce, SpatialMotion};
use glam::{DMat3, DVec3};

use articula_spatial::numerics::M6;

/// What a gather node is made of: the hub's body (`None`: the ground) and where its children
/// are in `DcaData::gathered`.
#[derive(Clone, Copy)]
pub(crate) struct Gather {
    pub hub: Option<usize>,
    pub first: usize,
    pub count: usize,
}

impl Gather {
    /// From `DKind::Gather`'s fields.
    pub(crate) fn of(body: u32, first: u32, count: u32) -> Gather {
        Gather {
            hub: (body != u32::MAX).then_some(body as usize),
            first: first as usize,
            count: count as usize,
        }
    }
}

/// The main pass at gather node `n`: each child's `K_c`, `D⁻¹` and contribution, the hub's
/// `Iᴬ` and `pᴬ`, and the node's `Φ` and `b` in its slot (see the module's equations).
/// Without `bias` the hub's velocity products and external force are left out (as a leaf's).
pub(crate) fn main(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    bias: bool,
    data: &mut Data,
    n: usize,
    g: Gather,
) -> Result<(), DynamicsError> {
    let a_g = SpatialMotion::new(DVec3::ZERO, data.gravity);
    let p_hub = g.hub.map_or(DVec3::ZERO, |h| data.dca.bodies.point[h]);
    let (mut ia, mut pa) = match g.hub {
        Some(h) => hub_inertia(model, h, f_ext, a_g, bias, data)?,
        None => ([[0.0; 6]; 6], [0.0; 6]),
    };
    for k in g.first..g.first + g.count {
        let d = &mut data.dca;
        let nd = d.node[d.gather.gathered[k] as usize];
        let joint = d.hj[nd.hoff as usize] as usize;
        let slot = nd.slot as usize;
        let singular = |detail| DynamicsError::Singular {
            joint: model.bodies[joint].joint_name(),
            detail,
        };
        let l = cholesky_inv_diag(&dense(&d.slots.dg[slot]), 6).ok_or_else(|| {
            singular("Φ_jj of the subassembly on a gathered hub is not positive definite")
        })?;
        let km = invert_factor_inv_diag(&l);
        d.gather.gk[k] = Mat6(km);
        let pj = d.bodies.point[joint];
        let shift = |m: SpatialMotion| SpatialMotion::new(m.w, m.v + m.w.cross(pj));
        let (vo, nv) = (data.topo[joint].vo, data.topo[joint].nv);
        // S's columns at P_c, K S, and D = Sᵀ K S.
        let mut s = [[0.0; 6]; 6];
        let mut ks = [[0.0; 6]; 6];
        for p in 0..nv {
            s[p] = shift(data.s[vo + p]).to_array();
            ks[p] = mul(&km, &s[p]);
        }
        let mut dm = SmallSpd {
            k: nv,
            a: [[0.0; 6]; 6],
        };
        for p in 0..nv {
            for q in 0..nv {
                dm.a[p][q] = dot6::<Portable>(&s[p], &ks[q]);
            }
            // Armature: D = Sᵀ K S + A (in inertia form, as ABA).
            if let Some(a) = data.armature.get(vo + p) {
                dm.a[p][p] += a;
            }
        }
        if !dm.invert() {
            return Err(singular(
                "Sᵀ K S is not positive definite at a gathered hub",
            ));
        }
        d.bodies.dinv[joint] = dm;
        // f_c at a = 0: K u₀ + K S D⁻¹ (τ − (K S)ᵀ u₀), u₀ = c_j − b_c.
        let u0 = (shift(data.c[joint]) - d.slots.b[slot]).to_array();
        let mut r = [0.0; 6];
        for p in 0..nv {
            r[p] = tau[vo + p] - dot6::<Portable>(&ks[p], &u0);
        }
        let mut x = [0.0; 6];
        dm.mul(&r[..nv], &mut x[..nv]);
        let mut f0 = mul(&km, &u0);
        for p in 0..nv {
            for i in 0..6 {
                f0[i] += ks[p][i] * x[p];
            }
        }
        if g.hub.is_none() {
            continue;
        }
        // P_c = K − K S D⁻¹ (K S)ᵀ, moved to the hub's point.
        let mut pc = km;
        for p in 0..nv {
            for q in 0..nv {
                let dpq = dm.a[p][q];
                for i in 0..6 {
                    let a = ks[p][i] * dpq;
                    for j in 0..6 {
                        pc[i][j] -= a * ks[q][j];
                    }
                }
            }
        }
        let arm = pj - p_hub;
        add_moved(&mut ia, &pc, arm);
        // X_cᵀ f: n + arm × f.
        let mf = arm.cross(DVec3::new(f0[3], f0[4], f0[5]));
        for i in 0..3 {
            pa[i] += f0[i] + mf[i];
            pa[i + 3] += f0[i + 3];
        }
    }
    let Some(h) = g.hub else {
        return Ok(());
    };
    let l = cholesky_inv_diag(&ia, 6).ok_or_else(|| DynamicsError::Singular {
        joint: model.bodies[h].joint_name(),
        detail: "the articulated inertia of a gathered hub is not positive definite",
    })?;
    let phi = invert_factor_inv_diag(&l);
    let b = mul(&phi, &pa).map(|x| -x);
    let d = &mut data.dca;
    let slot = d.node[n].slot as usize;
    d.joins.l[n] = l;
    d.joins.beta[n] = SpatialMotion::from_array(b);
    d.slots.dg[slot] = sym_tiles(&phi);
    d.slots.b[slot] = SpatialMotion::from_array(b);
    Ok(())
}

/// The back-substitution at gather node `n`: the hub's acceleration `a = (Iᴬ)⁻¹ f + b` from
/// the force at its joint (zero for the ground), then each child's `q̈` and the force at its
/// handle.
pub(crate) fn back(tau: &[f64], data: &mut Data, n: usize, g: Gather) {
    let d = &mut data.dca;
    let (a, p_hub) = match g.hub {
        Some(h) => {
            let f = d.slots.f[d.node[n].slot as usize].to_array();
            let l = &d.joins.l[n];
            let a = solve_lower_t_inv_diag(l, &solve_lower_inv_diag(l, &f));
            let b = d.joins.beta[n].to_array();
            (std::array::from_fn(|i| a[i] + b[i]), d.bodies.point[h])
        }
        None => ([0.0; 6], DVec3::ZERO),
    };
    let (aw, av) = (DVec3::new(a[0], a[1], a[2]), DVec3::new(a[3], a[4], a[5]));
    for k in g.first..g.first + g.count {
        let nd = d.node[d.gather.gathered[k] as usize];
        let joint = d.hj[nd.hoff as usize] as usize;
        let slot = nd.slot as usize;
        let pj = d.bodies.point[joint];
        let shift = |m: SpatialMotion| SpatialMotion::new(m.w, m.v + m.w.cross(pj));
        // u = X_c a + c_j − b_c
        let at = SpatialMotion::new(aw, av + aw.cross(pj - p_hub));
        let u = (at + shift(data.c[joint]) - d.slots.b[slot]).to_array();
        let km = &d.gather.gk[k].0;
        let (vo, nv) = (data.topo[joint].vo, data.topo[joint].nv);
        let mut r = [0.0; 6];
        let mut ks = [[0.0; 6]; 6];
        for p in 0..nv {
            ks[p] = mul(km, &shift(data.s[vo + p]).to_array());
            r[p] = tau[vo + p] - dot6::<Portable>(&ks[p], &u);
        }
        d.bodies.dinv[joint].mul(&r[..nv], &mut data.qdd[vo..vo + nv]);
        let mut f = mul(km, &u);
        for p in 0..nv {
            let qdd = data.qdd[vo + p];
            for i in 0..6 {
                f[i] += ks[p][i] * qdd;
            }
        }
        d.slots.f[slot] = SpatialForce::from_array(f);
    }
}

/// The hub body's spatial inertia `I` and `p = v ×* I v − f_ext − I a_g` about its point `P`
/// (without `bias`: `−I a_g`), from its leaf constants; also sets its world inertia
/// `data.inertia[h]`, as a leaf does.
fn hub_inertia(
    model: &Model,
    h: usize,
    f_ext: &[SpatialForce],
    a_g: SpatialMotion,
    bias: bool,
    data: &mut Data,
) -> Result<(M6, [f64; 6]), DynamicsError> {
    let lc = data.dca.bodies.leaf[h];
    if lc.im.is_nan() {
        return Err(DynamicsError::Singular {
            joint: model.bodies[h].joint_name(),
            detail: "the body's spatial inertia is not positive definite",
        });
    }
    let x = &data.x[h];
    let icb = if lc.full == u32::MAX {
        DMat3::from_diagonal(DVec3::from_array(lc.ic))
    } else {
        let u = &data.dca.bodies.leaf_full[lc.full as usize][0];
        DMat3::from_cols_array(&[u[0], u[1], u[2], u[1], u[3], u[4], u[2], u[4], u[5]])
    };
    let ic = x.e * icb * x.e.transpose();
    let cv = x.apply_point(DVec3::from_array(lc.com));
    let m = data.inertia[h].mass;
    // The world inertia about the computation origin (as `dca::leaf` sets it).
    let wi = &mut data.inertia[h];
    wi.h = cv * m;
    wi.ibar = ic + (DMat3::from_diagonal(DVec3::splat(cv.dot(cv))) - outer(cv, cv)) * m;
    // About P: I = [I_c + m (c'·c' 1 − c' c'ᵀ), m c'×; −m c'×, m 1], c' = c − P.
    let p = data.dca.bodies.point[h];
    let cp = cv - p;
    let top = ic + (DMat3::from_diagonal(DVec3::splat(cp.dot(cp))) - outer(cp, cp)) * m;
    let cx = skew(cp) * m;
    let mut im = [[0.0; 6]; 6];
    for r in 0..3 {
        for c in 0..3 {
            im[r][c] = top.col(c)[r];
            im[r][c + 3] = cx.col(c)[r];
            im[r + 3][c] = -cx.col(c)[r];
        }
        im[r + 3][r + 3] = m;
    }
    // −I a_g, a_g = [0; g]: −[m c' × g; m g].
    let g = a_g.v;
    let (mut n0, mut f0) = (-(cp.cross(g) * m), -(g * m));
    if bias {
        let v = data.v[h];
        let w = v.w;
        let vp = v.v + w.cross(p);
        let lin = (vp + w.cross(cp)) * m;
        let ang = ic * w + cp.cross(lin);
        n0 += w.cross(ang) + vp.cross(lin);
        f0 += w.cross(lin);
        if let Some(fe) = f_ext.get(h) {
            n0 -= fe.n - p.cross(fe.f);
            f0 -= fe.f;
        }
    }
    Ok((im, [n0.x, n0.y, n0.z, f0.x, f0.y, f0.z]))
}

/// `M += Xᵀ P X` for `X` the motion transform by `arm` (`[ω; v] ↦ [ω; v + ω × arm]`, i.e.
/// `X = [1, 0; −R, 1]` with `R = arm×`): `Xᵀ P X = [A − B R + R Bᵀ − R C R, B + R C; Bᵀ − C R, C]`
/// for `P = [A, B; Bᵀ, C]`, written as the two products.
pub(crate) fn add_moved(m: &mut M6, p: &M6, arm: DVec3) {
    let x = transform(arm);
    let mut px = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..6 {
            px[i][j] = (0..6).map(|k| p[i][k] * x[k][j]).sum();
        }
    }
    for i in 0..6 {
        for j in 0..6 {
            m[i][j] += (0..6).map(|k| x[k][i] * px[k][j]).sum::<f64>();
        }
    }
}

/// `X = [1, 0; −arm×, 1]`.
pub(crate) fn transform(arm: DVec3) -> M6 {
    let mut x = [[0.0; 6]; 6];
    let r = skew(arm);
    for i in 0..6 {
        x[i][i] = 1.0;
    }
    for i in 0..3 {
        for j in 0..3 {
            x[i + 3][j] = -r.col(j)[i];
        }
    }
    x
}

/// `a×` as a matrix.
fn skew(a: DVec3) -> DMat3 {
    DMat3::from_cols(
        DVec3::new(0.0, a.z, -a.y),
        DVec3::new(-a.z, 0.0, a.x),
        DVec3::new(a.y, -a.x, 0.0),
    )
}

/// `a bᵀ`.
fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

fn mul(m: &M6, x: &[f64; 6]) -> [f64; 6] {
    std::array::from_fn(|r| dot6::<Portable>(&m[r], x))
}

/// A [`SymT`] as a dense matrix.
fn dense(t: &SymT) -> M6 {
    std::array::from_fn(|r| std::array::from_fn(|c| t.at(r, c)))
}

/// A symmetric dense matrix as a [`SymT`] (its upper tiles).
pub(crate) fn sym_tiles(m: &M6) -> SymT {
    let mut t = SymT::ZERO;
    for i in 0..3 {
        for j in i..3 {
            let (r, c) = (2 * i, 2 * j);
            t.set_tile(i, j, [m[r][c], m[r][c + 1], m[r + 1][c], m[r + 1][c + 1]]);
        }
    }
    t
}
