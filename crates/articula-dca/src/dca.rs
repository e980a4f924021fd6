//! Featherstone's divide-and-conquer algorithm (docs/design.md#dca), all quantities in world
//! coordinates.
//!
//! A subassembly with handles h obeys `a_h = Σ_k Φ_hk f_k + b_h` (handle forces `f_k` act on it;
//! `a_h` is the spatial acceleration of the body at handle h). The main pass computes Φ and b
//! bottom-up over the assembly tree; the back-substitution computes each principal joint's
//! `q̈` and constraint force top-down.

use crate::data::ub;
use crate::data::{DKind, LeafK, RevJoin, Side};
use crate::small::SymT;
use crate::{Data, DynamicsError};
use articula_model::Model;
use articula_spatial::numerics::{
    cholesky_inv_diag, dot3, dot6_even_odd as dot6, ldl5, psd_root, Arith,
};
use articula_spatial::numerics::{solve_lower_inv_diag, solve_lower_t_inv_diag};
use articula_spatial::{Mat6, SpatialForce, SpatialMotion};
use glam::DVec3;

/// Per body i, in the kinematics loop right after its pose: the point P_i, origin of body i,
/// about which every vector of handle (joint) i is taken (far from the computation origin the
/// blocks would otherwise lose digits: a 100,000-link chain reaches 10 km).
#[inline(always)]
pub(crate) fn init_body(i: usize, data: &mut Data) {
    let p = data.x[i].apply_point(DVec3::ZERO);
    data.dca.bodies.point[i] = p;
    data.dca.bodies.arm[i] =
        crate::kinematics::arm(data.fk_plan[i], &data.x, data.topo[i].parent, p);
}

/// `P_h − P_i` for a handle `h` of leaf body `i`: 0 for its own joint, else the arm of the
/// child joint `h` (whose parent is `i`).
#[inline(always)]
fn handle_offset(d: &crate::data::DcaData, i: usize, h: usize) -> [f64; 3] {
    if h == i {
        [0.0; 3]
    } else {
        d.bodies.arm[h].to_array()
    }
}

articula_spatial::fma_dispatch! {
    /// `forward_dynamics`' DCA call: the kinematics (at the leaves, or in a loop of its own with
    /// [`init_body`]) and [`dca`]'s pass with the leaves' bias accelerations, in the compilation
    /// `data.dca.fused` picks (see [`dca`]).
    pub(crate) fn forward(
        model: &Model,
        q: &[f64],
        qd: &[f64],
        tau: &[f64],
        f_ext: &[SpatialForce],
        data: &mut Data,
    ) -> Result<(), DynamicsError>;
    avx2_fma: data.dca.fused, Fused;
    |A| {
        data.ensure_dca(model)?;
        forward_with::<A>(model, q, qd, tau, f_ext, data)
    }
}

#[inline(always)]
fn forward_with<A: Arith>(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
) -> Result<(), DynamicsError> {
    if data.dca.leaf_kinematics {
        // Each body's kinematics at its leaf (see `DcaData::leaf_kinematics`).
        let nodes = 0..data.dca.node.len();
        main_pass::<A>(model, tau, f_ext, data, true, Some((q, qd)), nodes.clone())?;
        back_substitution::<A>(tau, data, nodes);
        return Ok(());
    }
    // DCA's leaves set the world inertias themselves.
    crate::kinematics::kinematics_with(model, q, qd, data, false, init_body);
    dca_with::<A>(model, tau, f_ext, data, true)
}

articula_spatial::fma_dispatch! {
    /// Runs DCA on the kinematics already in `data` (see [`crate::forward_kinematics`], with
    /// [`init_body`] run per body) and the external forces `f_ext` (computation frame, empty for
    /// none); writes `data.qdd`. Without `bias` the leaves' accelerations (velocity products,
    /// external forces) are left out, and with `data.gravity` and `data.c` zero this solves
    /// `H q̈ = τ`.
    ///
    /// The pass runs in one of two compilations of the same code: with fused multiply–adds
    /// (`Fused`, on an x86-64 CPU with AVX2 and FMA, chosen once in `Data::new`: see
    /// `DcaData::fused`) or the portable one (`Portable`); everything below is inlined into
    /// each.
    pub(crate) fn dca(
        model: &Model,
        tau: &[f64],
        f_ext: &[SpatialForce],
        data: &mut Data,
        bias: bool,
    ) -> Result<(), DynamicsError>;
    avx2_fma: data.dca.fused, Fused;
    |A| {
        data.ensure_dca(model)?;
        dca_with::<A>(model, tau, f_ext, data, bias)
    }
}

#[inline(always)]
fn dca_with<A: Arith>(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
    bias: bool,
) -> Result<(), DynamicsError> {
    let nodes = 0..data.dca.node.len();
    main_pass::<A>(model, tau, f_ext, data, bias, None, nodes.clone())?;
    back_substitution::<A>(tau, data, nodes);
    Ok(())
}

articula_spatial::fma_dispatch! {
    /// The kinematics loop of [`forward`] without the leaves' (the kinematics in a loop of
    /// its own, with [`init_body`]), in the compilation `data.dca.fused` picks: what the
    /// parallel driver (`parallel_dca.rs`) runs before its passes.
    pub(crate) fn kinematics_loop(model: &Model, q: &[f64], qd: &[f64], data: &mut Data);
    avx2_fma: data.dca.fused, Fused;
    |A| crate::kinematics::kinematics_with(model, q, qd, data, false, init_body)
}

articula_spatial::fma_dispatch! {
    /// The per-body part of the parallel driver's kinematics after its pose chain, for the
    /// bodies `bodies`: [`crate::kinematics::kinematics_bias`] and [`init_body`]. Each body
    /// reads only poses and velocities and writes only its own entries.
    pub(crate) fn bias_range(qd: &[f64], data: &mut Data, bodies: std::ops::Range<usize>);
    avx2_fma: data.dca.fused, Fused;
    |A| {
        for i in bodies {
            crate::kinematics::kinematics_bias(i, qd, data);
            init_body(i, data);
        }
    }
}

articula_spatial::fma_dispatch! {
    /// [`dca`]'s main pass over the nodes `nodes` only (a post-order range whose children
    /// outside it are done), on the kinematics already in `data` and with the buffers built:
    /// the parallel driver's unit of work (`parallel_dca.rs`). Each node's arithmetic is the
    /// same as in the whole pass.
    pub(crate) fn main_range(
        model: &Model,
        tau: &[f64],
        f_ext: &[SpatialForce],
        data: &mut Data,
        bias: bool,
        nodes: std::ops::Range<usize>,
    ) -> Result<(), DynamicsError>;
    avx2_fma: data.dca.fused, Fused;
    |A| main_pass::<A>(model, tau, f_ext, data, bias, None, nodes)
}

articula_spatial::fma_dispatch! {
    /// [`dca`]'s back-substitution over the nodes `nodes` only, last to first (their parents
    /// outside the range done): the parallel driver's unit of work (`parallel_dca.rs`).
    pub(crate) fn back_range(tau: &[f64], data: &mut Data, nodes: std::ops::Range<usize>);
    avx2_fma: data.dca.fused, Fused;
    |A| back_substitution::<A>(tau, data, nodes)
}

/// `Φ_jh f` (j ≠ h) of node `n` (nh × nh blocks, those with j ≤ h stored, `Φ_hj = Φ_jhᵀ`).
#[inline(always)]
fn phi_jh_mul<A: Arith>(
    d: &crate::data::DcaData,
    n: usize,
    nh: usize,
    j: usize,
    h: usize,
    f: SpatialForce,
) -> SpatialMotion {
    let bo = d.node[n].boff as usize;
    match d.node[n].kind {
        DKind::Join { .. } => {}
        DKind::Body(i) => return leaf_mul::<A>(d, i as usize, n, j, h, f),
        DKind::Ground => return SpatialMotion::ZERO,
        DKind::Gather { .. } => unreachable!("a gather node has one handle: no cross block"),
        DKind::Cluster { body, .. } => {
            let ho = d.node[n].hoff as usize;
            return crate::cluster::phi_mul(d, body, n, ho, j, h, f);
        }
    }
    let f = f.to_array();
    SpatialMotion::from_array(if j < h {
        mat_vec::<A>(&d.joins.phi[bo + ub(nh, j, h)].0, &f)
    } else {
        mat_tr_vec::<A>(&d.joins.phi[bo + ub(nh, h, j)].0, &f)
    })
}

/// `Φ_jh f` of leaf node `n` (body `i`), in closed form (see [`leaf`]): with `a_h = c − P_h` (from the body origin and the arms),
/// the moment about c `n_c = n − a_h × f`, `α = J n_c`, and at P_j `[α; f/m + a_j × α]`.
#[inline(always)]
fn leaf_mul<A: Arith>(
    d: &crate::data::DcaData,
    i: usize,
    n: usize,
    j: usize,
    h: usize,
    f: SpatialForce,
) -> SpatialMotion {
    let lk = &d.bodies.leafk[i];
    let ho = d.node[n].hoff as usize;
    let c = lk.c;
    let (ph, pj) = (
        handle_offset(d, i, d.hj[ho + h] as usize),
        handle_offset(d, i, d.hj[ho + j] as usize),
    );
    let (fn_, ff) = (f.n.to_array(), f.f.to_array());
    let nc = sub3(fn_, cross3::<A>(sub3(c, ph), ff));
    let m = &lk.j;
    let alpha = [
        dot3::<A>(&[m[0], m[1], m[2]], &nc),
        dot3::<A>(&[m[1], m[3], m[4]], &nc),
        dot3::<A>(&[m[2], m[4], m[5]], &nc),
    ];
    let lin = cross3::<A>(sub3(c, pj), alpha);
    let v: [f64; 3] = std::array::from_fn(|r| A::mul_add(ff[r], lk.im, lin[r]));
    SpatialMotion::from_array(cat3(alpha, v))
}

#[inline(always)]
fn main_pass<A: Arith>(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
    bias: bool,
    kinematics: Option<(&[f64], &[f64])>,
    nodes: std::ops::Range<usize>,
) -> Result<(), DynamicsError> {
    if nodes.start == 0 && nodes.end == data.dca.node.len() {
        // A whole pass (the parallel driver resets the count before its split passes).
        data.dca.clamped = 0;
    }
    let a_g = SpatialMotion::new(DVec3::ZERO, data.gravity);
    // X_{C←W} = xlt(origin), for the kinematics at the leaves.
    let x_cw = articula_spatial::SpatialTransform::xlt(data.origin);
    // DCA's own tree (`DcaData::tree`: the model's, with leaf clusters), one record per node.
    for n in nodes {
        // Φ's diagonal blocks and b, read only by the parent join, go to the node's slot.
        let nd = data.dca.node[n];
        let (ho, nh) = (nd.hoff as usize, nd.nh as usize);
        let (bo, top) = (nd.boff as usize, nd.slot as usize);
        match nd.kind {
            // Ground: Φ = 0, b = 0.
            DKind::Ground => {
                if let Some((q, qd)) = kinematics {
                    // The root bodies' kinematics (its handles).
                    for h in ho..ho + nh {
                        let c = data.dca.hj[h] as usize;
                        crate::kinematics::kinematics_body(model, c, q, qd, data, x_cw, false);
                        init_body(c, data);
                    }
                }
                for k in 0..nh * nh.saturating_sub(1) / 2 {
                    data.dca.joins.phi[bo + k] = Mat6::ZERO;
                }
                for h in 0..nh {
                    data.dca.slots.dg[top + h] = SymT::ZERO;
                    data.dca.slots.b[top + h] = SpatialMotion::ZERO;
                }
            }
            DKind::Body(i) => {
                let i = i as usize;
                if let Some((q, qd)) = kinematics {
                    // The kinematics of the body's children (its handles but its own joint,
                    // whose point the leaf needs), the body's done (see
                    // `DcaData::leaf_kinematics`).
                    for h in ho..ho + nh {
                        let c = data.dca.hj[h] as usize;
                        if c != i {
                            crate::kinematics::kinematics_body(model, c, q, qd, data, x_cw, false);
                            init_body(c, data);
                        }
                    }
                }
                leaf::<A>(model, i, (ho, nh, bo, top), f_ext, a_g, bias, data)?
            }
            DKind::Join { joint, a, b } => {
                join::<A>(model, tau, data, n, joint as usize, a as usize, b as usize)?
            }
            DKind::Gather { .. } | DKind::Cluster { .. } => {
                rare_main(model, tau, f_ext, bias, data, n, (ho, nh, bo, top))?
            }
        }
    }
    Ok(())
}

articula_spatial::fma_dispatch! {
    /// The main pass at a gather or cluster node `n` (handle offset, handle count, cross-block
    /// offset and slot `at`), out of line: inlined, their code would share the chain's hot
    /// loop (its registers and its unrolling) with the leaves and joins.
    #[inline(never)]
    fn rare_main(
        model: &Model,
        tau: &[f64],
        f_ext: &[SpatialForce],
        bias: bool,
        data: &mut Data,
        n: usize,
        at: (usize, usize, usize, usize),
    ) -> Result<(), DynamicsError>;
    avx2_fma: data.dca.fused, Fused;
    |A| match data.dca.node[n].kind {
        DKind::Gather { body, first, count } => {
            let g = crate::gather::Gather::of(body, first, count);
            crate::gather::main(model, tau, f_ext, bias, data, n, g)
        }
        DKind::Cluster { body, first, count } => {
            let g = crate::cluster::Cluster::of(body, first, count);
            crate::cluster::main::<A>(model, tau, f_ext, bias, data, n, g, at)
        }
        _ => unreachable!("rare_main runs at gather and cluster nodes only"),
    }
}

articula_spatial::fma_dispatch! {
    /// The back-substitution at a gather or cluster node `n`, out of line (see [`rare_main`]).
    #[inline(never)]
    fn rare_back(tau: &[f64], data: &mut Data, n: usize);
    avx2_fma: data.dca.fused, Fused;
    |A| {
        let nc = data.dca.node[n];
        match nc.kind {
            DKind::Gather { body, first, count } => {
                let g = crate::gather::Gather::of(body, first, count);
                crate::gather::back(tau, data, n, g)
            }
            DKind::Cluster { body, first, count } => {
                let g = crate::cluster::Cluster::of(body, first, count);
                let at = (nc.hoff as usize, nc.nh as usize, nc.slot as usize);
                crate::cluster::back::<A>(data, n, g, at)
            }
            _ => unreachable!("rare_back runs at gather and cluster nodes only"),
        }
    }
}

/// Leaf (docs/design.md#dca): `Φ_hk = I⁻¹` for all handle pairs, `b_h = a_g + I⁻¹ (f_ext − v ×* I v)`,
/// each handle's rows and columns taken at its own point P_h. About the centre of mass c, where
/// `I = diag(I_c, m 1)`: with `I_c = R I_c,body Rᵀ`, `J = I_c⁻¹ = R I_c,body⁻¹ Rᵀ`,
/// `a_h = c − P_h` and `A_h = a_h× J`,
/// `Φ_hk = [J, A_kᵀ; A_h, a_h× A_kᵀ + 1/m]` (`−J e× = A_eᵀ` as J is symmetric), and
/// `b_h = a_g + [α; a_c + a_h × α]` with the body's acceleration for no handle forces and no
/// gravity `α = J (n_c − ω × I_c ω)`, `a_c = f/m − ω × v_c` (`f_ext = [n; f]` about the
/// origin, `n_c = n − c × f`, `v_c` the velocity of the point at c). Only the blocks with
/// `h ≤ k` are computed and stored (`Φ_kh = Φ_hkᵀ`). J, c and 1/m are kept for the
/// back-substitution ([`LeafK`]), and the world inertia `data.inertia[i]` is set here.
#[inline(always)]
fn leaf<A: Arith>(
    model: &Model,
    i: usize,
    (ho, nh, bo, top): (usize, usize, usize, usize),
    f_ext: &[SpatialForce],
    a_g: SpatialMotion,
    bias: bool,
    data: &mut Data,
) -> Result<(), DynamicsError> {
    let lc = &data.dca.bodies.leaf[i];
    let im = lc.im;
    // NaN marks an inertia that is not positive definite.
    if im.is_nan() {
        return Err(DynamicsError::Singular {
            joint: model.bodies[i].joint_name(),
            detail: "the body's spatial inertia is not positive definite",
        });
    }
    let x = &data.x[i];
    // R: body → computation-frame axes, by columns (e[k] = R e_k).
    let e = x.e.to_cols_array_2d();
    let cv = x.apply_point(DVec3::from_array(lc.com));
    let (ic, jc) = if lc.full == u32::MAX {
        // Principal axes along the body's (the common case): R diag(d) Rᵀ = Σ_k d_k e_k e_kᵀ,
        // and the inverse's with 1/d_k.
        let d = lc.ic;
        rotate_diagonal_pair::<A>(&e, d, [1.0 / d[0], 1.0 / d[1], 1.0 / d[2]])
    } else {
        let [u, u_inv] = &data.dca.bodies.leaf_full[lc.full as usize];
        (
            rotate_sym::<A>(&e, &sym3(u)),
            rotate_sym::<A>(&e, &sym3(u_inv)),
        )
    };
    let (alpha, acc_c) = if bias {
        let v = data.v[i];
        let w = v.w.to_array();
        let icw = DVec3::new(
            dot3::<A>(&ic[0], &w),
            dot3::<A>(&ic[1], &w),
            dot3::<A>(&ic[2], &w),
        );
        let (mut n_c, mut acc_c) = (-v.w.cross(icw), -v.w.cross(v.v + v.w.cross(cv)));
        // An empty `f_ext` means no external forces.
        if let Some(fe) = f_ext.get(i) {
            n_c += fe.n - cv.cross(fe.f);
            acc_c += fe.f * im;
        }
        let n_c = n_c.to_array();
        let alpha = [
            dot3::<A>(&jc[0], &n_c),
            dot3::<A>(&jc[1], &n_c),
            dot3::<A>(&jc[2], &n_c),
        ];
        (alpha, acc_c.to_array())
    } else {
        ([0.0; 3], [0.0; 3])
    };
    let c = cv.to_array();
    // The centre of mass from the body's origin, `E c_body`: the handles' arms start there.
    let c_rel = (x.e * DVec3::from_array(lc.com)).to_array();
    // The body's world inertia by parallel axes: `Ī_O = I_c + m (c·c 1 − c cᵀ)`, `h = m c`
    // (its mass set once, in `Data::new`).
    let wi = &mut data.inertia[i];
    let m = wi.mass;
    let cc = cv.dot(cv);
    let pa = |r: usize, s: usize| A::neg_mul_add(m * c[r], c[s], ic[r][s]);
    let (xx, yy, zz) = (pa(0, 0) + m * cc, pa(1, 1) + m * cc, pa(2, 2) + m * cc);
    let (xy, xz, yz) = (pa(0, 1), pa(0, 2), pa(1, 2));
    wi.h = cv * m;
    wi.ibar = glam::DMat3::from_cols(
        DVec3::new(xx, xy, xz),
        DVec3::new(xy, yy, yz),
        DVec3::new(xz, yz, zz),
    );
    let d = &mut data.dca;
    d.bodies.leafk[i] = LeafK {
        j: [jc[0][0], jc[0][1], jc[0][2], jc[1][1], jc[1][2], jc[2][2]],
        c: c_rel,
        im,
    };
    let acc = add3(acc_c, a_g.v.to_array());
    let alpha_g = add3(alpha, a_g.w.to_array());
    let lh = LeafHandles {
        c: c_rel,
        jc: &jc,
        im,
        alpha,
        alpha_g,
        acc,
    };
    // Two handles (a chain's bodies) unrolled.
    if nh == 2 {
        leaf_handles::<A, 2>(d, &lh, i, ho, bo, top, 2);
    } else {
        leaf_handles::<A, 0>(d, &lh, i, ho, bo, top, nh);
    }
    Ok(())
}

/// What [`leaf_handles`] needs of its leaf: the centre of mass `c` (from the body origin), `J`, `1/m`, α, and the
/// bias acceleration's parts `α + a_g^ω` and `a_c + a_g^v`.
struct LeafHandles<'a> {
    c: [f64; 3],
    jc: &'a [[f64; 3]; 3],
    im: f64,
    alpha: [f64; 3],
    alpha_g: [f64; 3],
    acc: [f64; 3],
}

/// A leaf's per-handle outputs (see [`leaf`]): `b_h`, the diagonal blocks `Φ_hh` and the cross
/// blocks `Φ_hk`, `h < k`, for its `nh` handles (`N = nh` when `N > 0`, unrolled). Handle k's
/// `A_k` columns `a_k × (column r of J)` are computed once and serve both `Φ_kk` and the upper
/// right of every `Φ_hk`.
#[inline(always)]
fn leaf_handles<A: Arith, const N: usize>(
    d: &mut crate::data::DcaData,
    lh: &LeafHandles,
    i: usize,
    ho: usize,
    bo: usize,
    top: usize,
    nh: usize,
) {
    let nh = if N > 0 { N } else { nh };
    if nh == 0 {
        return;
    }
    let (c, jc, im) = (lh.c, lh.jc, lh.im);
    // The leaf's slots and handles, bounds checked once.
    let (hj, arms) = (&d.hj[ho..ho + nh], &d.bodies.arm);
    let (bs, dgs) = (
        &mut d.slots.b[top..top + nh],
        &mut d.slots.dg[top..top + nh],
    );
    let phi = &mut d.joins.phi;
    // Handle h's a_h and A_h's columns a_h × (column r of J).
    let arm = |h: usize| {
        let hh = hj[h] as usize;
        let ah = if hh == i {
            c
        } else {
            sub3(c, arms[hh].to_array())
        };
        let col = [
            cross3::<A>(ah, jc[0]),
            cross3::<A>(ah, jc[1]),
            cross3::<A>(ah, jc[2]),
        ];
        (ah, col)
    };
    let mut next = arm(0);
    for h in 0..nh {
        let (ah, col) = next;
        // b at P_h: [α; a_c + a_h × α] + a_g
        bs[h] =
            SpatialMotion::from_array(cat3(lh.alpha_g, add3(lh.acc, cross3::<A>(ah, lh.alpha))));
        // A_h's rows.
        let row: [[f64; 3]; 3] = std::array::from_fn(|r| [col[0][r], col[1][r], col[2][r]]);
        // Φ_hh's lower-right block a_h× A_hᵀ + 1/m: row r is a_h × (row r of A_h); its upper
        // triangle.
        let b0 = cross3::<A>(ah, row[0]);
        let b11 = A::neg_mul_add(ah[0], row[1][2], ah[2] * row[1][0]);
        let b12 = A::neg_mul_add(ah[1], row[1][0], ah[0] * row[1][1]);
        let b22 = A::neg_mul_add(ah[1], row[2][0], ah[0] * row[2][1]);
        // By tiles (`SymT`): rows 0-1, 2-3, 4-5 against columns 0-1, 2-3, 4-5; the upper
        // right block is A_hᵀ (row r = column r of A_h).
        dgs[h] = SymT::from_tiles([
            [jc[0][0], jc[0][1], jc[0][1], jc[1][1]],
            [jc[0][2], col[0][0], jc[1][2], col[1][0]],
            [col[0][1], col[0][2], col[1][1], col[1][2]],
            [jc[2][2], col[2][0], col[2][0], b0[0] + im],
            [col[2][1], col[2][2], b0[1], b0[2]],
            [b11 + im, b12, b12, b22 + im],
        ]);
        for k in h + 1..nh {
            let (ak, colk) = if k == h + 1 {
                next = arm(k);
                next
            } else {
                arm(k)
            };
            // Φ_hk = [J, A_kᵀ; A_h, A_h a_k×ᵀ + 1/m]: row r of the lower right is
            // a_k × (row r of A_h); row r of A_kᵀ is column r of A_k.
            let out = &mut phi[bo + ub(nh, h, k)].0;
            for r in 0..3 {
                out[r] = cat3(jc[r], colk[r]);
                let mut x = cross3::<A>(ak, row[r]);
                x[r] += im;
                out[r + 3] = cat3(row[r], x);
            }
        }
    }
}

#[inline(always)]
fn cross3<A: Arith>(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        A::neg_mul_add(a[2], b[1], a[1] * b[2]),
        A::neg_mul_add(a[0], b[2], a[2] * b[0]),
        A::neg_mul_add(a[1], b[0], a[0] * b[1]),
    ]
}

#[inline(always)]
fn add3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline(always)]
fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
fn cat3(a: [f64; 3], b: [f64; 3]) -> [f64; 6] {
    [a[0], a[1], a[2], b[0], b[1], b[2]]
}

/// `R S Rᵀ` for a symmetric 3×3 `S` and a rotation given by its columns `e` (`e[k] = R e_k`);
/// the product's rows.
#[inline(always)]
fn rotate_sym<A: Arith>(e: &[[f64; 3]; 3], s: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    // T = R S: row i is Σ_k R_ik (row k of S).
    let t: [[f64; 3]; 3] = std::array::from_fn(|i| {
        std::array::from_fn(|q| {
            dot3::<A>(&[e[0][i], e[1][i], e[2][i]], &[s[0][q], s[1][q], s[2][q]])
        })
    });
    // (T Rᵀ)_il = row i of T · row l of R, upper triangle, mirrored.
    let row = |l: usize| [e[0][l], e[1][l], e[2][l]];
    let (r0, r1, r2) = (row(0), row(1), row(2));
    let dot = |a: &[f64; 3], b: &[f64; 3]| dot3::<A>(a, b);
    let (a00, a01, a02) = (dot(&t[0], &r0), dot(&t[0], &r1), dot(&t[0], &r2));
    let (a11, a12, a22) = (dot(&t[1], &r1), dot(&t[1], &r2), dot(&t[2], &r2));
    [[a00, a01, a02], [a01, a11, a12], [a02, a12, a22]]
}

/// `(R diag(d) Rᵀ, R diag(d') Rᵀ) = (Σ_k d_k e_k e_kᵀ, Σ_k d'_k e_k e_kᵀ)` for a rotation given by
/// its columns `e` (`e[k] = R e_k`); the products' rows.
#[inline(always)]
fn rotate_diagonal_pair<A: Arith>(
    e: &[[f64; 3]; 3],
    d: [f64; 3],
    d2: [f64; 3],
) -> ([[f64; 3]; 3], [[f64; 3]; 3]) {
    // Entry (r, s) is Σ_k (d_k e_k[r]) e_k[s]: the upper triangle, mirrored. (Written out:
    // `array::map` over the index pairs is not inlined there.)
    let sum = |d: [f64; 3]| -> [[f64; 3]; 3] {
        let u: [[f64; 3]; 3] =
            std::array::from_fn(|k| [d[k] * e[k][0], d[k] * e[k][1], d[k] * e[k][2]]);
        let at = |r: usize, s: usize| {
            A::mul_add(
                u[2][r],
                e[2][s],
                A::mul_add(u[1][r], e[1][s], u[0][r] * e[0][s]),
            )
        };
        sym3(&[at(0, 0), at(0, 1), at(0, 2), at(1, 1), at(1, 2), at(2, 2)])
    };
    (sum(d), sum(d2))
}

/// A symmetric 3×3 from its upper triangle (`xx, xy, xz, yy, yz, zz`), by rows.
#[inline(always)]
fn sym3(u: &[f64; 6]) -> [[f64; 3]; 3] {
    [[u[0], u[1], u[2]], [u[1], u[3], u[4]], [u[2], u[4], u[5]]]
}

/// Joins A and B at `joint` into node `n` (docs/design.md#dca, any handle count); V and W never
/// appear explicitly. With `K = Φ^A_jj + Φ^B_jj = V⁻¹`, W is the same for every basis `T` of
/// the forces that do no work along S: `W = V − V S (SᵀVS)⁻¹ SᵀV = T (TᵀKT)⁻¹ Tᵀ`.
/// - One revolute axis (the common case): the basis of [`RevJoin`] (fixed positions), the
///   `L D Lᵀ` factors of the 5×5 `TᵀKT` ([`ldl5`]),
///   `Z_h = L⁻¹ Tᵀ Φ_jh` and `U_h = D⁻¹ Z_h` (5 rows each), and the joint terms of
///   [`joint_terms`]: `Φ_hj W Φ_jk = U_hᵀ Z_k` (no square root on the way).
/// - Otherwise: the Cholesky factor of `K = L Lᵀ`, `Z = L⁻¹ S`, `D = ZᵀZ` and the orthogonal
///   projector `Q = 1 − Z D⁻¹ Zᵀ`: `W = L⁻ᵀ Q L⁻¹`, `Ỹ_h = Q L⁻¹ Φ_jh` (`Q = QᵀQ`), and
///   `γ = W β + V S D⁻¹ Q_τ = L⁻ᵀ (w − Z D⁻¹ (Zᵀw − τ))` with `w = L⁻¹ β`.
///
/// Either way one Gram product per stored block of C (`h ≤ k`; the diagonal ones on their
/// upper 2×2 tiles, [`SymT`]): `Φ_hj W Φ_jk = Ỹ_hᵀ Ỹ_k` or `U_hᵀ Z_k`.
///
/// A's, B's and C's diagonal blocks and b are in their nodes' slots (see `DcaData::dg`).
#[inline(always)]
fn join<A: Arith>(
    model: &Model,
    tau: &[f64],
    data: &mut Data,
    n: usize,
    joint: usize,
    a: usize,
    b: usize,
) -> Result<(), DynamicsError> {
    let d = &data.dca;
    let (na, nb, nc) = (d.node[a], d.node[b], d.node[n]);
    let hc = nc.hoff as usize;
    let (nha, nhb, nhc) = (na.nh as usize, nb.nh as usize, nc.nh as usize);
    let (hoa, hob, top) = (na.slot as usize, nb.slot as usize, nc.slot as usize);
    let (ja, jb) = (nc.ja as usize, nc.jb as usize);
    let (boa, bob, bc) = (na.boff as usize, nb.boff as usize, nc.boff as usize);
    let at = JoinAt {
        ys: nc.ys as usize * d.max_h,
        hc,
        nha,
        nhb,
        hoa,
        hob,
        top,
        ja,
        jb,
        boa,
        bob,
        bc,
    };
    // K = Φ^A_jj + Φ^B_jj, tiled.
    let ks = SymT::sum(&d.slots.dg[hoa + ja], &d.slots.dg[hob + jb]);
    // S and c at the joint's point P_j.
    let pj = d.bodies.point[joint];
    // β = b_j^A − b_j^B + c
    let beta = d.slots.b[hoa + ja] - d.slots.b[hob + jb] + shift(pj, data.c[joint]);
    let (gamma, rows) = if one_axis(data, &nc, joint) {
        let gamma = join_one_axis::<A>(model, tau, data, &at, (n, joint), &ks, beta)?;
        (gamma, 5)
    } else {
        let gamma = join_general::<A>(model, tau, data, &at, (n, joint), &ks, beta)?;
        (gamma, 6)
    };
    let d = &mut data.dca;
    // Two handles (a chain's joins) unrolled.
    match (nhc, rows) {
        (2, 5) => c_blocks::<A, 5>(d, &at, 2, &gamma),
        (_, 5) => c_blocks::<A, 5>(d, &at, nhc, &gamma),
        _ => c_blocks::<A, 6>(d, &at, nhc, &gamma),
    }
    Ok(())
}

/// Whether join `nc` (principal joint `joint`) takes the one-axis join: a hinge without
/// armature of its own (`DNode::one_dof`) whose armature in this solve is zero too (a step
/// integrating its damping implicitly adds `dt b`, which the general join takes).
#[inline(always)]
fn one_axis(data: &Data, nc: &crate::data::DNode, joint: usize) -> bool {
    nc.one_dof
        && (!nc.damped
            || data
                .armature
                .get(data.topo[joint].vo)
                .is_none_or(|&a| a == 0.0))
}

/// [`join`]'s one revolute axis: the 5×5 constraint system of [`RevJoin`], its `L D Lᵀ`
/// factors ([`ldl5`]), the joint terms, `q̈` and `Y`; returns `γ`.
#[inline(always)]
fn join_one_axis<A: Arith>(
    model: &Model,
    tau: &[f64],
    data: &mut Data,
    at: &JoinAt,
    (n, joint): (usize, usize),
    ks: &SymT,
    beta: SpatialMotion,
) -> Result<[f64; 6], DynamicsError> {
    let vo = data.topo[joint].vo;
    let d = &mut data.dca;
    let nc = d.node[n];
    let nhc = nc.nh as usize;
    let kf = |r: usize, c: usize| ks.at(r, c);
    // One revolute axis: the 5×5 constraint system (see `RevJoin`).
    let w = data.s[vo].w.to_array(); // s = [ω; 0] at P_j
    let (p, q) = perpendicular_pair(w);
    // K's blocks: the symmetric angular one K_ω (rows and columns 0..3) and the coupling
    // K_c (rows 0..3, columns 3..6): K_ω x and K_cᵀ x for x = p, q, ω.
    let kw = |x: &[f64; 3]| -> [f64; 3] {
        let row = |r: usize| dot3::<A>(&[kf(r, 0), kf(r, 1), kf(r, 2)], x);
        [row(0), row(1), row(2)]
    };
    let kc = |x: &[f64; 3]| -> [f64; 3] {
        let col = |c: usize| dot3::<A>(x, &[kf(0, c), kf(1, c), kf(2, c)]);
        [col(3), col(4), col(5)]
    };
    let (kwp, kwq, kww) = (kw(&p), kw(&q), kw(&w));
    let (kcp, kcq, kcw) = (kc(&p), kc(&q), kc(&w));
    // Tᵀ K T (lower triangle): [pᵀK_ω p, ·; qᵀK_ω p, qᵀK_ω q; K_cᵀp, K_cᵀq, K_v].
    let (t00, t10, t11) = (
        dot3::<A>(&p, &kwp),
        dot3::<A>(&q, &kwp),
        dot3::<A>(&q, &kwq),
    );
    let tkt = |r: usize, c: usize| match (r, c) {
        (0, 0) => t00,
        (1, 0) => t10,
        (1, 1) => t11,
        (_, 0) => kcp[r - 2],
        (_, 1) => kcq[r - 2],
        _ => kf(r + 1, c + 1),
    };
    // Its L D Lᵀ factors (L packed by rows, 1/d on the diagonal).
    let Some((l, clamped)) = ldl5::<A>(tkt) else {
        return Err(DynamicsError::Singular {
            joint: model.bodies[joint].joint_name(),
            detail: "Φ_jj^A + Φ_jj^B is not a number on the constraint forces",
        });
    };
    // A pivot lost to rounding: this solve is refined (`refine::refine_dca`).
    d.clamped += u32::from(clamped);
    let rj = &mut d.joins.rev[nc.jix as usize];
    rj.p = p;
    rj.q = q;
    rj.l = l;
    // K s = [K_ω ω; K_cᵀ ω]
    let ks = [kww[0], kww[1], kww[2], kcw[0], kcw[1], kcw[2]];
    let ba = beta.to_array();
    // W K s and W β side by side (two lanes).
    let wkb = w_apply::<A, P2>(rj, &std::array::from_fn(|i| P2([ks[i], ba[i]])));
    let qt = joint_terms::<A>(&w, &ks, &wkb.map(|x| x.0[0]), rj);
    // γ = W β + f_τ τ, f_τ = −g: the joint force without handle forces; and q̈ then.
    let wb = wkb.map(|x| x.0[1]);
    let t = tau[vo];
    let gamma: [f64; 6] = std::array::from_fn(|i| A::neg_mul_add(rj.g[i], t, wb[i]));
    rj.gamma = gamma;
    rj.qdd = A::mul_add(qt, t, dot6::<A>(&rj.g, &ba));
    let rj = &d.joins.rev[nc.jix as usize];
    let pq = (rj.p, rj.q);
    // Two handles (a chain's joins) unrolled.
    if nhc == 2 {
        y_all::<A>(d, at, 2, pq, &l)
    } else {
        y_all::<A>(d, at, nhc, pq, &l)
    }
    Ok(gamma)
}

/// [`join`]'s other joints: `K = L Lᵀ`, `Z = L⁻¹ S`, `D = ZᵀZ` (plus armature) inverted, `γ`
/// and `Ỹ_h = Q L⁻¹ Φ_jh`; returns `γ`.
#[inline(always)]
fn join_general<A: Arith>(
    model: &Model,
    tau: &[f64],
    data: &mut Data,
    at: &JoinAt,
    (n, joint): (usize, usize),
    ks: &SymT,
    beta: SpatialMotion,
) -> Result<[f64; 6], DynamicsError> {
    let (vo, k) = (data.topo[joint].vo, data.topo[joint].nv);
    let d = &mut data.dca;
    let nhc = d.node[n].nh as usize;
    let kf = |r: usize, c: usize| ks.at(r, c);
    let pj = d.bodies.point[joint];
    let mut sum = [[0.0; 6]; 6];
    for r in 0..6 {
        for c in r..6 {
            let x = kf(r, c);
            sum[r][c] = x;
            sum[c][r] = x;
        }
    }
    d.joins.beta[n] = beta;
    // Armature A (docs/loading.md#armature-and-damping): D = SᵀVS + A.
    let arm = data
        .armature
        .get(vo..vo + k)
        .filter(|a| a.iter().any(|&x| x != 0.0));
    let identity = k == 6 && d.free_identity && arm.is_none();
    // L Lᵀ = Φ^A_jj + Φ^B_jj; a free joint's W is zero for any K (`mass_ratio.rs`).
    let l = if identity {
        crate::mass_ratio::IDENTITY
    } else {
        cholesky_inv_diag(&sum, 6).ok_or_else(|| DynamicsError::Singular {
            joint: model.bodies[joint].joint_name(),
            detail: "Φ_jj^A + Φ_jj^B is not positive definite",
        })?
    };
    // Z = L⁻¹ S, D = Zᵀ Z.
    let mut dm = crate::small::SmallSpd {
        k,
        a: [[0.0; 6]; 6],
    };
    for p in 0..k {
        let z = solve_lower_inv_diag(&l, &shift(pj, data.s[vo + p]).to_array());
        d.bodies.z[vo + p] = z;
        for q in 0..=p {
            let x = dot6::<A>(&d.bodies.z[vo + q], &z);
            dm.a[p][q] = x;
            dm.a[q][p] = x;
        }
    }
    if let Some(arm) = arm {
        for p in 0..k {
            dm.a[p][p] += arm[p];
        }
    }
    if !dm.invert() {
        return Err(DynamicsError::Singular {
            joint: model.bodies[joint].joint_name(),
            detail: crate::error::JOINT_BLOCK_SINGULAR,
        });
    }
    d.bodies.dinv[joint] = dm;
    d.joins.l[n] = l;
    // Z D⁻¹ (columns), for the projector Q = 1 − (Z D⁻¹) Zᵀ.
    let mut zd = [[0.0; 6]; 6];
    for p in 0..k {
        for q in 0..k {
            let x = dm.a[p][q];
            let zq = &d.bodies.z[vo + q];
            for i in 0..6 {
                zd[p][i] += x * zq[i];
            }
        }
    }
    if identity {
        // The back-substitution's q̈ with L = 1 (`mass_ratio.rs`).
        d.joins.beta[n] = crate::mass_ratio::free_beta(&sum, &zd, &tau[vo..vo + 6], beta);
    }
    // γ = L⁻ᵀ (w − Z D⁻¹ (Zᵀw − Q)),  w = L⁻¹ β
    let mut w = solve_lower_inv_diag(&l, &beta.to_array());
    if arm.is_none() {
        // Zᵀ Z D⁻¹ = 1: each update leaves the other columns' Zᵀw as they were.
        for p in 0..k {
            let t = dot6::<A>(&d.bodies.z[vo + p], &w) - tau[vo + p];
            for i in 0..6 {
                w[i] -= zd[p][i] * t;
            }
        }
    } else {
        armature_w_update::<A>(&mut w, &d.bodies.z[vo..vo + k], &zd, &tau[vo..vo + k]);
    }
    let gamma = solve_lower_t_inv_diag(&l, &w);
    // Ỹ_h = Q L⁻¹ Φ_jh: forward substitution on whole rows of Φ_jh (vectorises), then the
    // projection Ỹ −= (Z D⁻¹)(Zᵀ Ỹ) (k rank-1 row updates).
    // With armature Q = 1 − Z D⁻¹ Zᵀ is no projector: Ỹ_h = R L⁻¹ Φ_jh, RᵀR = Q.
    let zs = &d.bodies.z[vo..vo + k];
    let root = arm.map(|_| armature_projector_root(zs, &zd));
    for h in 0..nhc {
        let (bo, nh, j, i) = at.from(d, h);
        let g = cross_rows(&d.joins.phi, bo, nh, j, i);
        match &root {
            None => y_tilde(&mut d.joins.y[at.ys + h], &g, &l, zs, &zd),
            Some(root) => y_tilde_rooted(&mut d.joins.y[at.ys + h], &g, &l, &zd, root),
        }
    }
    Ok(gamma)
}

/// `m` (a joint's `S` or `c` at the body's origin) at the joint's point `pj`.
#[inline(always)]
fn shift(pj: DVec3, m: SpatialMotion) -> SpatialMotion {
    SpatialMotion::new(m.w, m.v + m.w.cross(pj))
}

/// Where a join's nodes keep their handles and blocks (see [`DNode`](crate::data::DNode)): C's
/// handle offset `hc`, A's and B's handle counts, the slots of A, B and C, the principal
/// joint's index among A's and B's handles, and the block offsets of A, B and C.
struct JoinAt {
    /// Where its scratch starts in `y` and `u` (see `DNode::ys`).
    ys: usize,
    hc: usize,
    nha: usize,
    nhb: usize,
    hoa: usize,
    hob: usize,
    top: usize,
    ja: usize,
    jb: usize,
    boa: usize,
    bob: usize,
    bc: usize,
}

impl JoinAt {
    /// Where Φ_jh of C's handle h is: its side's block offset and handle count, the joint's
    /// and the handle's index there.
    #[inline(always)]
    fn from(&self, d: &crate::data::DcaData, h: usize) -> (usize, usize, usize, usize) {
        match d.from[self.hc + h] {
            (Side::A, i) => (self.boa, self.nha, self.ja, i as usize),
            (Side::B, i) => (self.bob, self.nhb, self.jb, i as usize),
        }
    }
}

/// C's blocks and bias from `Ỹ` (R rows each, in `d.y`; with R = 5, one axis, `Ỹ_hᵀỸ_k` reads
/// `U_hᵀ Z_k`, `U_h` in `d.u` and `Z_k` in `d.y`) and γ: Φ^C_hk for `h ≤ k` (a diagonal
/// block's upper 2×2 tiles only): same side `Φ_hk − Ỹ_hᵀỸ_k`, across `+Ỹ_hᵀỸ_k` (a side's
/// handles keep their order in C, so a same-side pair `h ≤ k` is a stored block of that side
/// too); then `b^C_h = b^A_h − Φ^A_hj γ` or `b^B_h + Φ^B_hj γ`.
#[inline(always)]
fn c_blocks<A: Arith, const R: usize>(
    d: &mut crate::data::DcaData,
    at: &JoinAt,
    nhc: usize,
    gamma: &[f64; 6],
) {
    let (hoa, hob, top) = (at.hoa, at.hob, at.top);
    let (src, dst) = d.joins.phi.split_at_mut(at.bc);
    // C's slot lies below its children's (one level up the tree).
    let mid = hoa.min(hob);
    let (ddst, dsrc) = d.slots.dg.split_at_mut(mid);
    for h in 0..nhc {
        let (sh, ih) = d.from[at.hc + h];
        let ih = ih as usize;
        // The Gram products' left factor: U_h (one axis) or Ỹ_h.
        let xh = if R == 5 {
            &d.joins.u[at.ys + h]
        } else {
            &d.joins.y[at.ys + h]
        };
        let old = match sh {
            Side::A => &dsrc[hoa - mid + ih],
            Side::B => &dsrc[hob - mid + ih],
        };
        gram_sym_into::<A, R>(&mut ddst[top + h], xh, &d.joins.y[at.ys + h], old);
        for kk in h + 1..nhc {
            let (sk, ik) = d.from[at.hc + kk];
            let ik = ik as usize;
            let yk = &d.joins.y[at.ys + kk];
            let old = match (sh, sk) {
                (Side::A, Side::A) => Some(&src[at.boa + ub(at.nha, ih, ik)].0),
                (Side::B, Side::B) => Some(&src[at.bob + ub(at.nhb, ih, ik)].0),
                _ => None,
            };
            gram_into::<A, R>(&mut dst[ub(nhc, h, kk)].0, xh, yk, old);
        }
        let (bo, nh, j, i) = match sh {
            Side::A => (at.boa, at.nha, at.ja, ih),
            Side::B => (at.bob, at.nhb, at.jb, ih),
        };
        let phj_gamma = SpatialMotion::from_array(if j < i {
            mat_tr_vec::<A>(&src[bo + ub(nh, j, i)].0, gamma)
        } else {
            mat_vec::<A>(&src[bo + ub(nh, i, j)].0, gamma)
        });
        d.slots.b[top + h] = match sh {
            Side::A => d.slots.b[hoa + ih] - phj_gamma,
            Side::B => d.slots.b[hob + ih] + phj_gamma,
        };
    }
}

/// Φ_jh (j ≠ h) of a node with `nh` handles and blocks at `bo`, as rows: only the blocks on
/// and above the diagonal are stored (`Φ_hj = Φ_jhᵀ`).
#[inline(always)]
fn cross_rows(phi: &[Mat6], bo: usize, nh: usize, j: usize, h: usize) -> [[f64; 6]; 6] {
    if j < h {
        phi[bo + ub(nh, j, h)].0
    } else {
        phi[bo + ub(nh, h, j)].transpose().0
    }
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
        let inv = l[r][r];
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

/// `w −= Z D⁻¹ (Zᵀw − Q)` for a joint with armature, where `Zᵀ Z D⁻¹ ≠ 1`: every column's
/// `Zᵀw` is read before any update (`zd` = Z D⁻¹, one row per column of the joint).
fn armature_w_update<A: Arith>(w: &mut [f64; 6], z: &[[f64; 6]], zd: &[[f64; 6]; 6], tau: &[f64]) {
    let t: [f64; 6] = std::array::from_fn(|p| z.get(p).map_or(0.0, |zp| dot6::<A>(zp, w) - tau[p]));
    for (p, tp) in t.iter().enumerate().take(z.len()) {
        for i in 0..6 {
            w[i] -= zd[p][i] * tp;
        }
    }
}

/// With armature `Q = 1 − Z D⁻¹ Zᵀ` is no projector; its square root `R` (`RᵀR = Q`,
/// [`psd_root`]) carries `Ỹ_h = R L⁻¹ Φ_jh`.
fn armature_projector_root(z: &[[f64; 6]], zd: &[[f64; 6]; 6]) -> [[f64; 6]; 6] {
    let mut q = [[0.0; 6]; 6];
    for r in 0..6 {
        for c in 0..6 {
            let zz: f64 = (0..z.len()).map(|p| zd[p][r] * z[p][c]).sum();
            q[r][c] = f64::from(u8::from(r == c)) - zz;
        }
    }
    psd_root(q)
}

/// `Ỹ_h = R L⁻¹ Φ_jh` (the armature form of [`y_tilde`]'s projection).
fn y_tilde_rooted(
    y: &mut [[f64; 6]; 6],
    g: &[[f64; 6]; 6],
    l: &[[f64; 6]; 6],
    zd: &[[f64; 6]; 6],
    root: &[[f64; 6]; 6],
) {
    let mut yt = [[0.0; 6]; 6];
    y_tilde(&mut yt, g, l, &[], zd);
    *y = std::array::from_fn(|r| {
        std::array::from_fn(|c| (0..6).map(|s| root[r][s] * yt[s][c]).sum())
    });
}

/// A pair `p`, `q` completing ω to an orthogonal basis: `p = ω × e` with `e` the coordinate
/// axis least aligned with ω (`|p| ≥ √(2/3) |ω|`), `q = ω × p`. T need not be orthonormal (W
/// does not depend on the basis), so no square root or division enters.
#[inline(always)]
fn perpendicular_pair(w: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let w = DVec3::from_array(w);
    let a = w.abs();
    let e = if a.x <= a.y && a.x <= a.z {
        DVec3::X
    } else if a.y <= a.z {
        DVec3::Y
    } else {
        DVec3::Z
    };
    let p = w.cross(e);
    let q = w.cross(p);
    (p.to_array(), q.to_array())
}

/// `G x`, inlined (a result returned through memory in pieces stalls the vector loads that
/// read it).
#[inline(always)]
fn mat_vec<A: Arith>(g: &[[f64; 6]; 6], x: &[f64; 6]) -> [f64; 6] {
    std::array::from_fn(|r| dot6::<A>(&g[r], x))
}

/// `Gᵀ x = Σ_r x_r (row r of G)`, inlined.
#[inline(always)]
fn mat_tr_vec<A: Arith>(g: &[[f64; 6]; 6], x: &[f64; 6]) -> [f64; 6] {
    let mut y: [f64; 6] = std::array::from_fn(|c| g[0][c] * x[0]);
    for r in 1..6 {
        for c in 0..6 {
            y[c] = A::mul_add(g[r][c], x[r], y[c]);
        }
    }
    y
}

/// `Tᵀ x = [p·x_ω, q·x_ω, x_v]`.
#[inline(always)]
fn t_tr<A: Arith, X: Lane>(x: &[X; 6], rj: &RevJoin) -> [X; 5] {
    let (p, q) = (&rj.p, &rj.q);
    [
        sum_products::<A, X, 3>([(x[0], p[0]), (x[1], p[1]), (x[2], p[2])]),
        sum_products::<A, X, 3>([(x[0], q[0]), (x[1], q[1]), (x[2], q[2])]),
        x[3],
        x[4],
        x[5],
    ]
}

/// `T λ = [λ_0 p + λ_1 q; λ_2, λ_3, λ_4]`.
#[inline(always)]
fn t_mul<A: Arith, X: Lane>(rj: &RevJoin, l: [X; 5]) -> [X; 6] {
    let (p, q) = (&rj.p, &rj.q);
    [
        sum_products::<A, X, 2>([(l[0], p[0]), (l[1], q[0])]),
        sum_products::<A, X, 2>([(l[0], p[1]), (l[1], q[1])]),
        sum_products::<A, X, 2>([(l[0], p[2]), (l[1], q[2])]),
        l[2],
        l[3],
        l[4],
    ]
}

/// What [`w_apply`] and [`y_reduced`] compute on: `f64`, or [`P2`].
trait Lane:
    Copy
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<f64, Output = Self>
{
    /// `self·x + c`.
    fn mul_add<A: Arith>(self, x: f64, c: Self) -> Self;
    /// `c − self·x`.
    fn neg_mul_add<A: Arith>(self, x: f64, c: Self) -> Self;
}

impl Lane for f64 {
    #[inline(always)]
    fn mul_add<A: Arith>(self, x: f64, c: f64) -> f64 {
        A::mul_add(self, x, c)
    }
    #[inline(always)]
    fn neg_mul_add<A: Arith>(self, x: f64, c: f64) -> f64 {
        A::neg_mul_add(self, x, c)
    }
}

/// `Σ_k x_k m_k`, left to right.
#[inline(always)]
fn sum_products<A: Arith, X: Lane, const N: usize>(t: [(X, f64); N]) -> X {
    let mut s = t[0].0 * t[0].1;
    for &(x, m) in &t[1..] {
        s = x.mul_add::<A>(m, s);
    }
    s
}

/// `c − Σ_k x_k m_k`, left to right.
#[inline(always)]
fn sub_products<A: Arith, X: Lane, const N: usize>(c: X, t: [(X, f64); N]) -> X {
    let mut s = c;
    for &(x, m) in &t {
        s = x.neg_mul_add::<A>(m, s);
    }
    s
}

/// Two `f64` lanes (a pair of columns, or two right-hand sides) that the compiler keeps in one
/// SSE2 register: the 5-row solves run on pairs.
#[derive(Clone, Copy, Debug)]
struct P2([f64; 2]);

impl Lane for P2 {
    #[inline(always)]
    fn mul_add<A: Arith>(self, x: f64, c: P2) -> P2 {
        P2([
            A::mul_add(self.0[0], x, c.0[0]),
            A::mul_add(self.0[1], x, c.0[1]),
        ])
    }
    #[inline(always)]
    fn neg_mul_add<A: Arith>(self, x: f64, c: P2) -> P2 {
        P2([
            A::neg_mul_add(self.0[0], x, c.0[0]),
            A::neg_mul_add(self.0[1], x, c.0[1]),
        ])
    }
}

impl std::ops::Add for P2 {
    type Output = P2;
    #[inline(always)]
    fn add(self, o: P2) -> P2 {
        P2([self.0[0] + o.0[0], self.0[1] + o.0[1]])
    }
}

impl std::ops::Sub for P2 {
    type Output = P2;
    #[inline(always)]
    fn sub(self, o: P2) -> P2 {
        P2([self.0[0] - o.0[0], self.0[1] - o.0[1]])
    }
}

impl std::ops::Mul<f64> for P2 {
    type Output = P2;
    #[inline(always)]
    fn mul(self, x: f64) -> P2 {
        P2([self.0[0] * x, self.0[1] * x])
    }
}

/// A row of six `f64` (six columns side by side): [`y_reduced`]'s lanes.
#[derive(Clone, Copy, Debug)]
struct R6([f64; 6]);

impl Lane for R6 {
    #[inline(always)]
    fn mul_add<A: Arith>(self, x: f64, c: R6) -> R6 {
        R6(std::array::from_fn(|k| A::mul_add(self.0[k], x, c.0[k])))
    }
    #[inline(always)]
    fn neg_mul_add<A: Arith>(self, x: f64, c: R6) -> R6 {
        R6(std::array::from_fn(|k| {
            A::neg_mul_add(self.0[k], x, c.0[k])
        }))
    }
}

impl std::ops::Add for R6 {
    type Output = R6;
    #[inline(always)]
    fn add(self, o: R6) -> R6 {
        R6(std::array::from_fn(|k| self.0[k] + o.0[k]))
    }
}

impl std::ops::Sub for R6 {
    type Output = R6;
    #[inline(always)]
    fn sub(self, o: R6) -> R6 {
        R6(std::array::from_fn(|k| self.0[k] - o.0[k]))
    }
}

impl std::ops::Mul<f64> for R6 {
    type Output = R6;
    #[inline(always)]
    fn mul(self, x: f64) -> R6 {
        R6(self.0.map(|v| v * x))
    }
}

/// `T (TᵀKT)⁻¹ Tᵀ y` (the packed `L D Lᵀ` factors of `TᵀKT` in `rj.l`, see [`RevJoin`]), the
/// two unit triangular solves written out; for one vector (`f64`) or two side by side ([`P2`]).
#[inline(always)]
fn w_apply<A: Arith, X: Lane>(rj: &RevJoin, y: &[X; 6]) -> [X; 6] {
    let u = t_tr::<A, X>(y, rj);
    let m = &rj.l;
    // L x = u: x_i = u_i − Σ_{p<i} L_ip x_p
    let x0 = u[0];
    let x1 = sub_products::<A, X, 1>(u[1], [(x0, m[1])]);
    let x2 = sub_products::<A, X, 2>(u[2], [(x0, m[3]), (x1, m[4])]);
    let x3 = sub_products::<A, X, 3>(u[3], [(x0, m[6]), (x1, m[7]), (x2, m[8])]);
    let x4 = sub_products::<A, X, 4>(u[4], [(x0, m[10]), (x1, m[11]), (x2, m[12]), (x3, m[13])]);
    // Lᵀ λ = D⁻¹ x: λ_i = x_i / d_i − Σ_{p>i} L_pi λ_p
    let l4 = x4 * m[14];
    let l3 = sub_products::<A, X, 1>(x3 * m[9], [(l4, m[13])]);
    let l2 = sub_products::<A, X, 2>(x2 * m[5], [(l3, m[8]), (l4, m[12])]);
    let l1 = sub_products::<A, X, 3>(x1 * m[2], [(l2, m[4]), (l3, m[7]), (l4, m[11])]);
    let l0 = sub_products::<A, X, 4>(x0 * m[0], [(l1, m[1]), (l2, m[3]), (l3, m[6]), (l4, m[10])]);
    t_mul::<A, X>(rj, [l0, l1, l2, l3, l4])
}

/// What the back-substitution needs besides `W`: `g = (W K s − s) / sᵀs`, which gives
/// `q̈ = gᵀ y + q̈_τ τ` for `K f = y + s q̈` (`sᵀ (K W y − y) = (W K s − s)ᵀ y`, `W`
/// symmetric), and with the unit-torque force `f₀ = s / sᵀs` (`sᵀ f₀ = 1`) the joint force per
/// unit torque `f_τ = f₀ − W K f₀ = −g` (`sᵀ f_τ = 1`, `Tᵀ K f_τ = 0`) and
/// `q̈_τ = sᵀ K f_τ / sᵀs = −gᵀ K s / sᵀs`. Joint torques enter linearly, so a huge τ cannot
/// overflow an intermediate product. `ks = K s`, `s = [ω; 0]`; sets `g`, returns `q̈_τ`.
/// `wks = W K s`.
#[inline(always)]
fn joint_terms<A: Arith>(w: &[f64; 3], ks: &[f64; 6], wks: &[f64; 6], rj: &mut RevJoin) -> f64 {
    let iss = 1.0 / dot3::<A>(w, w);
    let g = [
        (wks[0] - w[0]) * iss,
        (wks[1] - w[1]) * iss,
        (wks[2] - w[2]) * iss,
        wks[3] * iss,
        wks[4] * iss,
        wks[5] * iss,
    ];
    rj.g = g;
    -dot6::<A>(&g, ks) * iss
}

/// [`y_reduced`] for each of C's `nhc` handles, into `d.y` (Z) and `d.u` (D⁻¹ Z).
#[inline(always)]
fn y_all<A: Arith>(
    d: &mut crate::data::DcaData,
    at: &JoinAt,
    nhc: usize,
    pq: ([f64; 3], [f64; 3]),
    l: &[f64; 15],
) {
    for h in 0..nhc {
        let (bo, nh, j, i) = at.from(d, h);
        // Φ_jh by rows: the stored block's, or the stored Φ_hj's columns (a transpose).
        if j < i {
            let g = &d.joins.phi[bo + ub(nh, j, i)].0;
            let s = at.ys + h;
            y_reduced::<A>(&mut d.joins.y[s], &mut d.joins.u[s], g, pq, l);
        } else {
            let g = d.joins.phi[bo + ub(nh, i, j)].transpose().0;
            let s = at.ys + h;
            y_reduced::<A>(&mut d.joins.y[s], &mut d.joins.u[s], &g, pq, l);
        }
    }
}

/// `Z = L⁻¹ Tᵀ G` and `U = D⁻¹ Z` (5 rows each; `L D Lᵀ = TᵀKT` packed by rows in `l`, `1/d`
/// on the diagonal) for `G = Φ_jh` given by rows: `Tᵀ G` (`[p·g_ω; q·g_ω; g_v]`) then the unit
/// forward substitution, on whole rows of six ([`R6`]: every column's own arithmetic, in the
/// same order as column by column). Then `Φ_hj W Φ_jk = Z_hᵀ D⁻¹ Z_k = U_hᵀ Z_k`. (Not
/// `Ỹ = D^{-1/2} Z`: its square roots and scalings sat on the path from one join's factors to
/// the next join's.)
#[inline(always)]
fn y_reduced<A: Arith>(
    zt: &mut [[f64; 6]; 6],
    ut: &mut [[f64; 6]; 6],
    g: &[[f64; 6]; 6],
    (p, q): ([f64; 3], [f64; 3]),
    l: &[f64; 15],
) {
    let (g0, g1, g2) = (R6(g[0]), R6(g[1]), R6(g[2]));
    // L Z = Tᵀ G, row by row (L unit lower: z_i = (TᵀG)_i − Σ_{p<i} L_ip z_p).
    let z0 = sum_products::<A, R6, 3>([(g0, p[0]), (g1, p[1]), (g2, p[2])]);
    let tq = sum_products::<A, R6, 3>([(g0, q[0]), (g1, q[1]), (g2, q[2])]);
    let z1 = sub_products::<A, R6, 1>(tq, [(z0, l[1])]);
    let z2 = sub_products::<A, R6, 2>(R6(g[3]), [(z0, l[3]), (z1, l[4])]);
    let z3 = sub_products::<A, R6, 3>(R6(g[4]), [(z0, l[6]), (z1, l[7]), (z2, l[8])]);
    let z4 = sub_products::<A, R6, 4>(
        R6(g[5]),
        [(z0, l[10]), (z1, l[11]), (z2, l[12]), (z3, l[13])],
    );
    let z = [z0, z1, z2, z3, z4];
    // U = D⁻¹ Z.
    let inv_d = [l[0], l[2], l[5], l[9], l[14]];
    for r in 0..5 {
        zt[r] = z[r].0;
        ut[r] = (z[r] * inv_d[r]).0;
    }
}

/// `out = old − X_hᵀ Ỹ_k` (or `+X_hᵀ Ỹ_k` without `old`; `X_h` is `Ỹ_h` or `U_h`, see
/// [`c_blocks`]): row r is `Σ_i X_h[i][r] · (row i of Ỹ_k)`, six accumulators per row.
#[inline(always)]
fn gram_into<A: Arith, const R: usize>(
    out: &mut [[f64; 6]; 6],
    xh: &[[f64; 6]; 6],
    yk: &[[f64; 6]; 6],
    old: Option<&[[f64; 6]; 6]>,
) {
    // Two rows at a time: each row of Ỹ_k is loaded once for both; the sums start with their
    // first product.
    for r in (0..6).step_by(2) {
        let mut acc = [[0.0; 6]; 2];
        for dr in 0..2 {
            for c in 0..6 {
                acc[dr][c] = xh[0][r + dr] * yk[0][c];
            }
        }
        for i in 1..R {
            let (x0, x1) = (xh[i][r], xh[i][r + 1]);
            let yki = &yk[i];
            for c in 0..6 {
                acc[0][c] = A::mul_add(x0, yki[c], acc[0][c]);
                acc[1][c] = A::mul_add(x1, yki[c], acc[1][c]);
            }
        }
        for (dr, acc) in acc.iter().enumerate() {
            match old {
                Some(o) => {
                    for c in 0..6 {
                        out[r + dr][c] = o[r + dr][c] - acc[c];
                    }
                }
                None => out[r + dr] = *acc,
            }
        }
    }
}

/// [`gram_into`] for a diagonal block (`X_hᵀ Ỹ_h`, symmetric): only its upper 2×2 tiles
/// ([`SymT`]), a row pair of tiles at a time.
#[inline(always)]
fn gram_sym_into<A: Arith, const R: usize>(
    out: &mut SymT,
    x: &[[f64; 6]; 6],
    y: &[[f64; 6]; 6],
    old: &SymT,
) {
    gram_tiles::<A, 0, R>(out, x, y, old);
    gram_tiles::<A, 1, R>(out, x, y, old);
    gram_tiles::<A, 2, R>(out, x, y, old);
}

/// Tiles `(I, J)`, `J ≥ I`, of `old − XᵀỸ`: rows `2I`, `2I+1` from column `2I` on, the sums
/// started with their first product.
#[inline(always)]
fn gram_tiles<A: Arith, const I: usize, const R: usize>(
    out: &mut SymT,
    xs: &[[f64; 6]; 6],
    y: &[[f64; 6]; 6],
    old: &SymT,
) {
    let mut acc = [[0.0; 6]; 2];
    for dr in 0..2 {
        let x = xs[0][2 * I + dr];
        for c in 2 * I..6 {
            acc[dr][c] = x * y[0][c];
        }
    }
    for (xi, yi) in xs[1..R].iter().zip(&y[1..R]) {
        for dr in 0..2 {
            let x = xi[2 * I + dr];
            for c in 2 * I..6 {
                acc[dr][c] = A::mul_add(x, yi[c], acc[dr][c]);
            }
        }
    }
    for j in I..3 {
        let (o, c) = (old.tile(I, j), 2 * j);
        out.set_tile(
            I,
            j,
            [
                o[0] - acc[0][c],
                o[1] - acc[0][c + 1],
                o[2] - acc[1][c],
                o[3] - acc[1][c + 1],
            ],
        );
    }
}

/// How many nodes ahead the passes prefetch.
const PREFETCH: usize = 8;

/// Asks for the cache line holding address `p` (a hint: no effect on results).
#[inline(always)]
fn prefetch_ptr(p: *const u8) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch only hints the cache: it never faults, whatever the address, and
    // reads nothing into the program.
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>(p.cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// [`prefetch_ptr`] for every line of a 6×6 block (or a record as large) starting at `x`.
#[inline(always)]
fn prefetch_span<T: ?Sized>(x: &T) {
    let p = (x as *const T).cast::<u8>();
    for off in (0..std::mem::size_of::<Mat6>()).step_by(64) {
        prefetch_ptr(p.wrapping_add(off));
    }
}

/// Top-down: with `y = β + Σ_{k∈A} Φ^A_jk f_k − Σ_{k∈B} Φ^B_jk f_k` over C's handle forces
/// and `w = L⁻¹ y`: `q̈ = D⁻¹ (Q − Zᵀ w)` (= `D⁻¹ (Q − Sᵀ V y)`) and the joint force
/// `f = L⁻ᵀ (w + Z q̈)` (= `W y + V S D⁻¹ Q`).
#[inline(always)]
fn back_substitution<A: Arith>(tau: &[f64], data: &mut Data, nodes: std::ops::Range<usize>) {
    for n in nodes.rev() {
        // What the join PREFETCH nodes ahead reads, on its way from memory meanwhile (only
        // where those streams outgrow the caches: `DcaData::prefetch`). Its node record and
        // its children's are read here to find the rest, so they are asked for PREFETCH nodes
        // earlier still: a miss on them would stall this join.
        if data.dca.prefetch {
            let d = &data.dca;
            prefetch_ptr(
                d.node
                    .as_ptr()
                    .wrapping_sub(2 * PREFETCH)
                    .wrapping_add(n)
                    .cast(),
            );
            if let Some(m) = n.checked_sub(PREFETCH) {
                let nm = &d.node[m];
                prefetch_ptr(d.hj.as_ptr().wrapping_add(nm.hoff as usize).cast());
                prefetch_ptr(d.from.as_ptr().wrapping_add(nm.hoff as usize).cast());
                if let DKind::Join { joint, a, b } = nm.kind {
                    prefetch_span(&d.joins.rev[nm.jix as usize]);
                    for c in [a, b] {
                        let nd = &d.node[c as usize];
                        match nd.kind {
                            DKind::Join { .. } => prefetch_span(&d.joins.phi[nd.boff as usize..]),
                            // A leaf's closed-form Φ (`leaf_mul`): its `LeafK` (80 bytes: two
                            // lines at most) and its own point.
                            DKind::Body(i) => {
                                let lk = (&d.bodies.leafk[i as usize] as *const LeafK).cast::<u8>();
                                prefetch_ptr(lk);
                                prefetch_ptr(lk.wrapping_add(std::mem::size_of::<LeafK>() - 1));
                                prefetch_ptr((&d.bodies.point[i as usize] as *const DVec3).cast());
                            }
                            DKind::Ground | DKind::Gather { .. } | DKind::Cluster { .. } => {}
                        }
                    }
                    prefetch_ptr((&data.topo[joint as usize] as *const crate::data::Topo).cast());
                }
            }
        }
        let nc = data.dca.node[n];
        let DKind::Join { joint, a, b } = nc.kind else {
            if let DKind::Gather { .. } | DKind::Cluster { .. } = nc.kind {
                rare_back(tau, data, n);
            }
            continue;
        };
        let (joint, a, b) = (joint as usize, a as usize, b as usize);
        // Two handles (a chain's joins) unrolled.
        if nc.nh == 2 {
            back_node::<A, 2>(tau, data, n, &nc, (joint, a, b));
        } else {
            back_node::<A, 0>(tau, data, n, &nc, (joint, a, b));
        }
    }
}

/// [`back_substitution`] at join `n` (`nc`, principal joint `joint`, sides `a` and `b`), with
/// `N` handles when `N > 0` (unrolled), `nc.nh` otherwise.
#[inline(always)]
fn back_node<A: Arith, const N: usize>(
    tau: &[f64],
    data: &mut Data,
    n: usize,
    nc: &crate::data::DNode,
    (joint, a, b): (usize, usize, usize),
) {
    let nhc = if N > 0 { N } else { nc.nh as usize };
    let (nha, nhb) = (data.dca.node[a].nh as usize, data.dca.node[b].nh as usize);
    let (ja, jb) = (nc.ja as usize, nc.jb as usize);
    let (hc, sc) = (nc.hoff as usize, nc.slot as usize);
    // y without β (one axis: the join's γ and q̈ hold it) or with it.
    let one = one_axis(data, nc, joint);
    let d = &mut data.dca;
    let mut y = if one {
        SpatialMotion::ZERO
    } else {
        d.joins.beta[n]
    };
    for h in 0..nhc {
        let f = d.slots.f[sc + h];
        match d.from[hc + h] {
            (Side::A, i) => y += phi_jh_mul::<A>(d, a, nha, ja, i as usize, f),
            (Side::B, i) => y -= phi_jh_mul::<A>(d, b, nhb, jb, i as usize, f),
        }
    }
    let (vo, k) = (data.topo[joint].vo, data.topo[joint].nv);
    let f = if one {
        // f = W (β + y) + f_τ τ = γ + W y (so K f = β + y + s q̈);
        // q̈ = gᵀ (β + y) + q̈_τ τ (`joint_terms`).
        let rj = &d.joins.rev[nc.jix as usize];
        let ya = y.to_array();
        let fy = w_apply::<A, f64>(rj, &ya);
        data.qdd[vo] = rj.qdd + dot6::<A>(&rj.g, &ya);
        SpatialForce::from_array(std::array::from_fn(|i| rj.gamma[i] + fy[i]))
    } else {
        let l = &d.joins.l[n];
        let mut w = solve_lower_inv_diag(l, &y.to_array());
        let mut r = [0.0; 6];
        for p in 0..k {
            r[p] = tau[vo + p] - dot6::<A>(&d.bodies.z[vo + p], &w);
        }
        d.bodies.dinv[joint].mul(&r[..k], &mut data.qdd[vo..vo + k]);
        for p in 0..k {
            let (z, qdd) = (d.bodies.z[vo + p], data.qdd[vo + p]);
            for i in 0..6 {
                w[i] += z[i] * qdd;
            }
        }
        SpatialForce::from_array(solve_lower_t_inv_diag(l, &w))
    };
    let (hoa, hob) = (d.node[a].slot as usize, d.node[b].slot as usize);
    for h in 0..nhc {
        let fh = d.slots.f[sc + h];
        match d.from[hc + h] {
            (Side::A, i) => d.slots.f[hoa + i as usize] = fh,
            (Side::B, i) => d.slots.f[hob + i as usize] = fh,
        }
    }
    d.slots.f[hoa + ja] = -f;
    d.slots.f[hob + jb] = f;
}

#[cfg(test)]
mod tests {
    use crate::{forward_dynamics_slices, Data, Method, State};

    /// The fused (AVX2 + FMA) and portable compilations of the pass agree to 1e-12 relative
    /// (max |difference| / max |q̈|) on every bundled model, fixed and floating base, with and
    /// without external forces; where the CPU has FMA the two must also differ somewhere (the
    /// fused one rounds once per multiply–add), which shows that it ran. The floating 300-link
    /// chain is the exception, at 1e-11: its solve is ill-conditioned enough to take the
    /// Newton–Euler refinement (`refine.rs`), and there the two roundings differed by up to
    /// 5.4e-12, each as far from CRBA and ABA as the other (1.7–6.2e-12).
    #[test]
    fn fused_and_portable_agree() {
        let mut differ = false;
        for (name, floating_base, model) in crate::bundled_models() {
            let tol = if floating_base && name == "chain300" {
                1e-11
            } else {
                1e-12
            };
            let mut data = Data::new(&model);
            assert_eq!(
                data.dca.fused,
                articula_spatial::numerics::fused_available()
            );
            for seed in 0..6 {
                let (portable, fused) =
                    crate::solve_portable_and_fused(&model, &mut data, seed, Method::Dca);
                let scale = portable.iter().fold(1.0f64, |m, x| m.max(x.abs()));
                let diff = portable
                    .iter()
                    .zip(&fused)
                    .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
                assert!(
                    diff <= tol * scale,
                    "{name} floating={floating_base} seed {seed}: {:e}",
                    diff / scale
                );
                differ |= portable != fused;
            }
        }
        assert_eq!(differ, articula_spatial::numerics::fused_available());
    }

    /// The kinematics at the leaves (`DcaData::leaf_kinematics`, set on every bundled model's
    /// tree without leaf clusters) and in a loop of its own give the same q̈ to rounding: the
    /// handle points differ only in rounding (a child's origin from its own pose instead of its
    /// parent's), fixed and floating base, with and without external forces.
    #[test]
    fn leaf_kinematics_agrees() {
        for (name, floating_base, model) in crate::bundled_models() {
            let tol = if floating_base && name == "chain300" {
                1e-11
            } else {
                1e-12
            };
            let mut data = Data::new(&model);
            data.set_leaf_clusters(&model, false);
            data.ensure_dca(&model).unwrap();
            assert!(data.dca.leaf_kinematics, "{name}");
            for seed in 0..4 {
                let mut s = State::random(&model, seed, 1.0);
                if seed % 2 == 1 {
                    s.randomize_forces(seed, 0.5);
                }
                let mut solve = |at_leaves: bool| {
                    data.dca.leaf_kinematics = at_leaves;
                    let qdd = forward_dynamics_slices(
                        &model,
                        &mut data,
                        &s.q,
                        &s.qd,
                        &s.tau,
                        &s.f_ext,
                        Method::Dca,
                    )
                    .unwrap()
                    .to_vec();
                    (qdd, data.x.clone(), data.v.clone())
                };
                let (loop_, leaves) = (solve(false), solve(true));
                let scale = loop_.0.iter().fold(1.0f64, |m, x| m.max(x.abs()));
                let diff = loop_
                    .0
                    .iter()
                    .zip(&leaves.0)
                    .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
                assert!(
                    diff <= tol * scale,
                    "{name} floating={floating_base} seed {seed}: {:e}",
                    diff / scale
                );
                // The same kinematics, bit for bit.
                assert_eq!(loop_.1, leaves.1);
                assert_eq!(loop_.2, leaves.2);
            }
        }
    }
}
