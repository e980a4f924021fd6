//! Reference 1: the articulated-body algorithm (Featherstone, RBDA ch. 7, Table 7.1) with the
//! world's axes about each body's own origin, so that the only transform between bodies is a
//! translation by the (short) arm from the parent's origin, and no quantity carries a lever arm
//! to a far point (docs/algorithms.md, ABA). Articulated inertias
//! are kept as [`SymMat6`] and 1-DOF joints take a rank-1 fast path.

use crate::data::AbaData;
use crate::kinematics::FkPlan;
use crate::{Data, DynamicsError};
use articula_model::Model;
use articula_spatial::numerics::{dot6, invert_spd_into, joint_block_regular, Arith, Portable};
use articula_spatial::{SpatialForce, SpatialMotion, SymMat6};
use glam::DVec3;

articula_spatial::fma_dispatch! {
    /// `forward_dynamics`' ABA call: the kinematics loop (pass 1) then [`aba_with`]. On an
    /// x86-64 CPU with AVX2 and FMA (`data.dca.fused`, as for the DCA pass) compiled for those
    /// features with the same arithmetic in the same order ([`Portable`]: no fused
    /// multiply–adds), so the same bits, with wider vectors and three-operand instructions.
    pub(crate) fn forward(
        model: &Model,
        q: &[f64],
        qd: &[f64],
        tau: &[f64],
        f_ext: &[SpatialForce],
        data: &mut Data,
    ) -> Result<(), DynamicsError>;
    avx2_fma: data.dca.fused, Portable;
    |A| {
        // Pass 2 sets the world inertias, from the rotated ones it needs itself.
        crate::kinematics::kinematics_with(model, q, qd, data, false, |_, _| {});
        aba_with::<A>(model, tau, f_ext, data)
    }
}

/// `m` (about the computation origin) about the point `p`: `[ω; v + ω × p]`.
#[inline(always)]
pub(crate) fn motion_at(m: SpatialMotion, p: DVec3) -> SpatialMotion {
    SpatialMotion::new(m.w, m.v + m.w.cross(p))
}

/// `f` (about one point) about the point `r` before it: `[n + r × f; f]`.
#[inline(always)]
pub(crate) fn force_back(f: SpatialForce, r: DVec3) -> SpatialForce {
    SpatialForce::new(f.n + r.cross(f.f), f.f)
}

/// Runs ABA on the kinematics in `data` (pass 1 is the kinematics loop); writes `data.qdd`.
///
/// Every body's quantities are taken about its own origin `pᵢ` (the computation frame's axes):
/// `Iᵢ` is the body inertia rotated, `S`, `vᵢ`, `cᵢ` are moved there from the computation
/// origin (`[ω; v + ω × pᵢ]`), and a child's `Iᵃ`, `pᵃ` are moved to its parent's origin by
/// the arm `rᵢ = pᵢ − p_parent` ([`SymMat6::shifted`]), as pass 3 moves `a_parent`
/// forward. About the world origin instead, `Iᴬ` of a body 1 km away holds entries ~`M·(1 km)²`
/// of which `D = Sᵀ Iᴬ S` is a tiny difference: a tilted 100,000-link chain lost 11 digits.
#[inline(always)]
fn aba_with<A: Arith>(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
) -> Result<(), DynamicsError> {
    let n = model.bodies.len();
    let aba = &mut data.aba;
    // Pass 2, leaves to root: Iᴬᵢ = Iᵢ + Σ_children Iᵃ, pᴬᵢ = vᵢ ×* Iᵢ vᵢ − f_ext,i + Σ pᵃ
    // (gravity enters as a_0 = −a_g); U = Iᴬ S, D = Sᵀ U, u = τ − Sᵀ pᴬ,
    // Iᵃ = Iᴬ − U D⁻¹ Uᵀ, pᵃ = pᴬ + Iᵃ c + U D⁻¹ u, moved to the parent's origin.
    // Pass 1's part (Iᵢ, vᵢ ×* Iᵢ vᵢ) is formed here, where it is first used: `ia`, `pa` hold
    // only the children's sums, set by the first child processed (`first`), so that no per-body
    // array is written in the kinematics loop and read back a whole chain later.
    let topo = &data.topo[..n];
    for i in (0..n).rev() {
        let t = topo[i];
        let (vo, k, doff) = (t.vo, t.nv, aba.doff[i]);
        let x = &data.x[i];
        let p = -(x.e * x.r);
        let parent = t.parent;
        let arm = crate::kinematics::arm(data.fk_plan[i], &data.x, parent, p);
        aba.arm[i] = arm;
        // The body inertia with the computation frame's axes about pᵢ (no lever arm to any far
        // point), and about the computation origin for `data.inertia`, from one `E Ī Eᵀ`.
        let (inertia, world) =
            crate::kinematics::rotated_and_world_inertia(x, &model.bodies[i].inertia);
        data.inertia[i] = world;
        let v = motion_at(data.v[i], p);
        let fe = crate::inputs::f_ext_of(f_ext, i);
        let mut ia = SymMat6::from_inertia(&inertia);
        let mut pa_i = v.cross_force(inertia.mul_motion(v)) - force_back(fe, -p);
        let slot = aba.acc[i] as usize;
        if slot != u32::MAX as usize {
            ia.add_assign(&aba.ia[slot]);
            pa_i += aba.pa[slot];
        }
        let c = motion_at(data.c[i], p);
        aba.cl[i] = c;
        let first = aba.first[i];
        let body = BodyJoint {
            ia,
            pa: pa_i,
            c,
            origin: Some(p),
            vo,
            k,
            doff,
            axis_through_origin: matches!(data.fk_plan[i], FkPlan::AxisRevolute { .. }),
        };
        let to_parent = parent != usize::MAX;
        let (mut ia_a, mut pa_a) = (SymMat6::ZERO, SpatialForce::ZERO);
        let sums = to_parent.then_some((&mut ia_a, &mut pa_a, true));
        if !articulate_joint::<A>(aba, &data.s, tau, &data.armature, body, sums) {
            return Err(DynamicsError::Singular {
                joint: model.bodies[i].joint_name(),
                detail: if k == 1 {
                    "Sᵀ Iᴬ S is not positive definite"
                } else {
                    crate::error::JOINT_BLOCK_SINGULAR
                },
            });
        };
        if !to_parent {
            continue;
        }
        let ps = aba.acc[parent] as usize;
        let pa = force_back(pa_a, arm);
        let ia_a = ia_a.shifted(arm.to_array());
        if first {
            aba.pa[ps] = pa;
            aba.ia[ps] = ia_a;
        } else {
            aba.pa[ps] += pa;
            aba.ia[ps].add_assign(&ia_a);
        }
    }
    let a0 = SpatialMotion::new(glam::DVec3::ZERO, -data.gravity);
    accelerations::<A>(topo, aba, true, a0, &mut data.qdd);
    Ok(())
}

/// Pass 3, root to leaves, about each body's origin: `a' = X a_parent + c` (`a_parent` moved
/// forward by the arm, `[α; a + α × r]`), `q̈ = D⁻¹ (u − Uᵀ a')`, `a = a' + S q̈`, on the
/// `U`, `u`, `D⁻¹`, local `S`, `c` and arms of `aba` (`with_c = false`: no velocity
/// products), writing `qdd`.
#[inline(always)]
fn accelerations<A: Arith>(
    topo: &[crate::data::Topo],
    aba: &mut crate::data::AbaData,
    with_c: bool,
    a0: SpatialMotion,
    qdd: &mut [f64],
) {
    for (i, t) in topo.iter().enumerate() {
        let (vo, k, doff) = (t.vo, t.nv, aba.doff[i]);
        let a_parent = if t.parent == usize::MAX {
            a0
        } else {
            aba.a[aba.aslot[t.parent] as usize]
        };
        let mut ap = motion_at(a_parent, aba.arm[i]);
        let slot = aba.aslot[i] as usize;
        if with_c {
            ap += aba.cl[i];
        }
        let apa = ap.to_array();
        let s = &aba.sl;
        if k == 1 {
            let x = aba.dinv[doff] * (aba.uu[vo] - dot6::<A>(&apa, &aba.u[vo]));
            qdd[vo] = x;
            aba.a[slot] = ap + s[vo] * x;
            continue;
        }
        let args = (
            &aba.uu[vo..vo + k],
            &aba.u[vo..vo + k],
            &aba.dinv[doff..doff + k * k],
            &s[vo..vo + k],
            &mut qdd[vo..vo + k],
        );
        aba.a[slot] = match k {
            0 => accelerate_multi::<A, 0>(args, ap),
            2 => accelerate_multi::<A, 2>(args, ap),
            3 => accelerate_multi::<A, 3>(args, ap),
            4 => accelerate_multi::<A, 4>(args, ap),
            5 => accelerate_multi::<A, 5>(args, ap),
            _ => accelerate_multi::<A, 6>(args, ap),
        };
    }
}

/// One body's joint as ABA's pass 2 meets it, everything about the body's own origin.
#[derive(Clone, Copy)]
pub(crate) struct BodyJoint {
    /// The body's articulated inertia `Iᴬ` and bias force `pᴬ` (its children's sums added).
    pub ia: SymMat6,
    pub pa: SpatialForce,
    /// Its velocity product `c`.
    pub c: SpatialMotion,
    /// The point its `S` (and `Iᴬ`, `pᴬ`, `c`) is taken about: its origin `pᵢ` in the
    /// computation frame, or `None` for the computation origin itself (`S` as the kinematics
    /// gives it; DCA's leaf clusters).
    pub origin: Option<DVec3>,
    /// Its joint's offset in `v`, degrees of freedom, and offset in `AbaData::dinv`.
    pub vo: usize,
    pub k: usize,
    pub doff: usize,
    /// One revolute axis through the origin ([`FkPlan::AxisRevolute`]): `S = [ω; 0]`.
    pub axis_through_origin: bool,
}

/// ABA's pass 2 at one joint (RBDA Table 7.1), shared by ABA and DCA's leaf clusters: the
/// local `S` into `aba.sl`, `U = Iᴬ S`, `D = Sᵀ U` plus the armature, `u = τ − Sᵀ pᴬ` and
/// `D⁻¹` into `aba`; with `to_parent` (sums and whether to set them, as
/// [`articulate_multi`] takes it), `Iᵃ = Iᴬ − U D⁻¹ Uᵀ` and `pᵃ = pᴬ + Iᵃ c + U D⁻¹ u`, about
/// the point `S` and `Iᴬ` are taken about, set into or added to the sums. `false`: `D` is not
/// positive definite. `s`, `tau` and `armature` are the model-wide arrays (`data.s`, `τ`,
/// `data.armature`, empty for none).
#[inline(always)]
pub(crate) fn articulate_joint<A: Arith>(
    aba: &mut AbaData,
    s: &[SpatialMotion],
    tau: &[f64],
    armature: &[f64],
    b: BodyJoint,
    to_parent: Option<(&mut SymMat6, &mut SpatialForce, bool)>,
) -> bool {
    if b.k == 1 {
        return articulate_hinge::<A>(aba, s, tau, armature, b, to_parent);
    }
    let (vo, k, doff, ia) = (b.vo, b.k, b.doff, b.ia);
    // Several DOF: the same equations with k×k `D`, its loops of fixed length.
    for p_ in 0..k {
        aba.sl[vo + p_] = b.origin.map_or(s[vo + p_], |p| motion_at(s[vo + p_], p));
    }
    let args = MultiArgs {
        s: &aba.sl[vo..vo + k],
        tau: &tau[vo..vo + k],
        c: b.c,
        ia,
        pa_i: b.pa,
        u: &mut aba.u[vo..vo + k],
        uu: &mut aba.uu[vo..vo + k],
        dinv: &mut aba.dinv[doff..doff + k * k],
        armature: armature.get(vo..vo + k).unwrap_or(&[]),
    };
    match k {
        0 => articulate_multi::<A, 0>(args, to_parent),
        2 => articulate_multi::<A, 2>(args, to_parent),
        3 => articulate_multi::<A, 3>(args, to_parent),
        4 => articulate_multi::<A, 4>(args, to_parent),
        5 => articulate_multi::<A, 5>(args, to_parent),
        _ => articulate_multi::<A, 6>(args, to_parent),
    }
}

/// [`articulate_joint`] at a joint of one degree of freedom (the common case): `U = Iᴬ s`,
/// `D = sᵀU` a scalar. DCA's leaf clusters call it directly for their one-axis joints: through
/// [`articulate_joint`], with the several-DOF widths inlined beside it, a fixed-base
/// quadruped's DCA (one cluster of hinges) took 3–5% longer (go1, solo12; seven alternated
/// rounds of `articula bench`).
#[inline(always)]
pub(crate) fn articulate_hinge<A: Arith>(
    aba: &mut AbaData,
    s: &[SpatialMotion],
    tau: &[f64],
    armature: &[f64],
    b: BodyJoint,
    to_parent: Option<(&mut SymMat6, &mut SpatialForce, bool)>,
) -> bool {
    let (vo, doff, ia) = (b.vo, b.doff, b.ia);
    // One DOF (the common case): U = Iᴬ s, D = sᵀU scalar.
    let (u, d, sm) = if b.axis_through_origin {
        // A revolute axis through pᵢ: s = [ω; 0] there (`motion_at` gives
        // `p × ω + ω × p`, exactly zero), so U takes Iᴬ's first three columns only and
        // D three products (the same values as the six with zeros).
        let w = s[vo].w;
        let u = ia.mul_angular(&w.to_array());
        let d = A::mul_add(w.z, u[2], A::mul_add(w.y, u[1], w.x * u[0]));
        (u, d, SpatialMotion::new(w, DVec3::ZERO))
    } else {
        let sm = b.origin.map_or(s[vo], |p| motion_at(s[vo], p));
        let s = sm.to_array();
        let u = ia.mul_vec(&s);
        (u, dot6::<A>(&s, &u), sm)
    };
    aba.sl[vo] = sm;
    // Armature: D = sᵀ Iᴬ s + a (docs/loading.md#armature-and-damping).
    let d = match armature.get(vo) {
        Some(a) => d + a,
        None => d,
    };
    if d.is_nan() || d <= 0.0 {
        return false;
    }
    let dinv = 1.0 / d;
    let uu = tau[vo] - sm.dot(b.pa);
    aba.u[vo] = u;
    aba.uu[vo] = uu;
    aba.dinv[doff] = dinv;
    let Some((ia_t, pa_t, first)) = to_parent else {
        return true;
    };
    // pᵃ = pᴬ + Iᵃ c + U D⁻¹ u with Iᵃ c = Iᴬ c − U (Uᵀc) / D
    let c = b.c.to_array();
    let ic = ia.mul_vec(&c);
    let g = dinv * (uu - dot6::<A>(&c, &u));
    let pa = b.pa + SpatialForce::from_array(std::array::from_fn(|r| ic[r] + u[r] * g));
    if first {
        *ia_t = ia.sub_outer(&u, dinv);
        *pa_t = pa;
    } else {
        ia_t.add_sub_outer(&ia, &u, dinv);
        *pa_t += pa;
    }
    true
}

/// What ABA's pass 2 reads and writes at a joint of `k` > 1 degrees of freedom (see
/// [`articulate_multi`]).
pub struct MultiArgs<'a> {
    /// The joint's subspace columns `S` (`k`).
    pub s: &'a [SpatialMotion],
    /// Its joint forces `τ` (`k`).
    pub tau: &'a [f64],
    /// The velocity product `c` of its body.
    pub c: SpatialMotion,
    /// The articulated inertia `Iᴬ` of its body.
    pub ia: SymMat6,
    /// The articulated bias force `pᴬ` of its body.
    pub pa_i: SpatialForce,
    /// Written: `U = Iᴬ S` (`k` columns).
    pub u: &'a mut [[f64; 6]],
    /// Written: `u = τ − Sᵀ pᴬ` (`k`).
    pub uu: &'a mut [f64],
    /// Written: `D⁻¹` (`k × k`, row-major).
    pub dinv: &'a mut [f64],
    /// The joint's armature (`k`, added to `D`'s diagonal), or empty for none.
    pub armature: &'a [f64],
}

/// ABA's pass 2 (RBDA Table 7.1) at a joint of `K` > 1 degrees of freedom (`K = 0`: none,
/// nothing is factored): `U = Iᴬ S`, `D = Sᵀ U`, `u = τ − Sᵀ pᴬ`, `D⁻¹` (Cholesky,
/// [`invert_spd_into`]); with a parent (`to_parent`: its articulated inertia and bias sums,
/// and whether this is its first child, whose terms set the sums instead of adding to them),
/// also `Iᵃ = Iᴬ − Σ_p U_p w_pᵀ` (`w_p = Σ_q D⁻¹_pq U_q`) and
/// `pᵃ = pᴬ + Iᵃ c + Σ_p U_p (D⁻¹u)_p`, set into or added to the parent's sums. On K×K
/// arrays, `Iᴬ S` on `Iᴬ` unpacked once ([`Mat6::sym_mul_vec`](articula_spatial::Mat6)), the
/// rank-K update entry by entry; `A` is the arithmetic of its dot products. `false`: `D` is
/// not positive definite.
#[inline(always)]
pub fn articulate_multi<A: Arith, const K: usize>(
    m: MultiArgs,
    to_parent: Option<(&mut SymMat6, &mut SpatialForce, bool)>,
) -> bool {
    let s: &[SpatialMotion; K] = m.s.try_into().expect("K columns");
    let tau: &[f64; K] = m.tau.try_into().expect("K torques");
    let u_out: &mut [[f64; 6]; K] = m.u.try_into().expect("K columns");
    let uu: &mut [f64; K] = m.uu.try_into().expect("K entries");
    let dinv: &mut [f64] = m.dinv;
    let (ia, pa_i) = (&m.ia, m.pa_i);
    let dense = ia.to_mat6();
    // D's lower triangle (all the factorisation reads): D_pq = s_qᵀ U_p, q ≤ p.
    let mut dm = [[0.0; K]; K];
    for p in 0..K {
        let u = dense.sym_mul_vec(&s[p].to_array());
        u_out[p] = u;
        for q in 0..=p {
            dm[p][q] = dot6::<A>(&s[q].to_array(), &u);
        }
        if let Some(a) = m.armature.get(p) {
            dm[p][p] += a;
        }
        uu[p] = tau[p] - s[p].dot(pa_i);
    }
    let mut di = [[0.0; K]; K];
    // The joint's own block, tested as every method tests it (`JOINT_PIVOT_REL`).
    if !joint_block_regular(&dm, K) || !invert_spd_into(&dm, K, &mut di) {
        return false;
    }
    for p in 0..K {
        for q in 0..K {
            dinv[p * K + q] = di[p][q];
        }
    }
    let Some((ia_t, pa_t, first)) = to_parent else {
        return true;
    };
    let mut du = [0.0; K];
    for p in 0..K {
        let mut x = 0.0;
        for q in 0..K {
            x += di[p][q] * uu[q];
        }
        du[p] = x;
    }
    let mut w = [[0.0; 6]; K];
    for p in 0..K {
        for q in 0..K {
            let x = di[p][q];
            for r in 0..6 {
                w[p][r] += x * u_out[q][r];
            }
        }
    }
    // Iᵃ = Iᴬ − Σ_p U_p w_pᵀ on the upper triangle, entry by entry (p in order).
    let mut ia_a = SymMat6::ZERO;
    for i in 0..6 {
        for j in i..6 {
            let mut x = ia.get(i, j);
            for p in 0..K {
                x -= u_out[p][i] * w[p][j];
            }
            ia_a.set(i, j, x);
        }
    }
    let mut pa = pa_i;
    for p in 0..K {
        pa += SpatialForce::from_array(u_out[p]) * du[p];
    }
    pa += SpatialForce::from_array(ia_a.mul_vec(&m.c.to_array()));
    if first {
        *ia_t = ia_a;
        *pa_t = pa;
    } else {
        ia_t.add_assign(&ia_a);
        *pa_t += pa;
    }
    true
}

/// What pass 3 reads and writes at a joint of several degrees of freedom: its `u`, `U`,
/// `D⁻¹` (k×k), `S`, and its `q̈` (written).
pub(crate) type AccelArgs<'a> = (
    &'a [f64],
    &'a [[f64; 6]],
    &'a [f64],
    &'a [SpatialMotion],
    &'a mut [f64],
);

/// Pass 3 at a joint of `K` > 1 degrees of freedom: `q̈ = D⁻¹ (u − Uᵀ a')`, returning
/// `a = a' + S q̈` (arguments: `u`, `U`, `D⁻¹`, `S`, and `q̈` written). Unrolled, the same
/// operations as the loops over `k` it replaces.
#[inline(always)]
pub(crate) fn accelerate_multi<A: Arith, const K: usize>(
    args: AccelArgs,
    ap: SpatialMotion,
) -> SpatialMotion {
    let (uu, u, dinv, s, qdd) = args;
    let uu: &[f64; K] = uu.try_into().expect("K entries");
    let u: &[[f64; 6]; K] = u.try_into().expect("K columns");
    let s: &[SpatialMotion; K] = s.try_into().expect("K columns");
    let qdd: &mut [f64; K] = qdd.try_into().expect("K accelerations");
    let apa = ap.to_array();
    let mut r = [0.0; K];
    for p in 0..K {
        r[p] = uu[p] - dot6::<A>(&apa, &u[p]);
    }
    let mut a = ap;
    for p in 0..K {
        let mut x = 0.0;
        for q in 0..K {
            x += dinv[p * K + q] * r[q];
        }
        qdd[p] = x;
        a += s[p] * x;
    }
    a
}

/// The residual, relative to the largest joint force, above which [`refine`] corrects q̈.
const ABA_TRIGGER: f64 = 1e-11;

/// One step of iterative refinement for a floating base (run after [`aba`]).
///
/// With a floating base, the base's 6×6 `D` is the articulated inertia of the whole body; on
/// a long floppy chain its entries are small differences of large terms, and its rounding
/// puts q̈ ~1e-9 relative off on a 1,000-link floating chain (a fixed base never solves with
/// it). The residual `r = τ − ID(q̈)` by the recursive Newton–Euler algorithm, which forms no
/// such differences, and the correction `Δ = H⁻¹ r` — ABA's passes 2 and 3 on the stored `U`,
/// `D⁻¹`, without velocity, gravity or external force — bring it to ~1e-11 (CRBA's agreement).
/// The residual costs about half an ABA, for floating bases only; the correction (as much
/// again) runs only when the residual is large ([`ABA_TRIGGER`]: never on the humanoid).
pub(crate) fn refine(model: &Model, tau: &[f64], f_ext: &[SpatialForce], data: &mut Data) {
    let n = model.bodies.len();
    let input = crate::residual::RneaInput {
        x: &data.x,
        fk_plan: &data.fk_plan,
        v: &data.v,
        c: &data.c,
        s: &data.s,
        gravity: data.gravity,
        tau,
        f_ext,
        qdd: Some(&data.qdd),
        armature: &data.armature,
    };
    // r = τ − ID(q̈) into uu (aba.a, aba.pa as scratch).
    let aba = &mut data.aba;
    let (scale, rmax) =
        crate::residual::rnea_residual(model, &input, &mut aba.a, &mut aba.pa, &mut aba.uu);
    // Small residual: q̈ kept. ABA's floating-base error shows in the residual at a lower
    // level than DCA's (1e-8 of the largest joint force would leave 2.2e-10 on chain300):
    // 1e-11, still above the humanoid's 1.6e-12.
    if rmax <= ABA_TRIGGER * scale {
        return;
    }
    let topo = &data.topo[..n];
    // ABA pass 2's bias on the residual: u = r − Sᵀ pᴬ, pᵃ = pᴬ + U D⁻¹ u (no velocity).
    aba.pa.fill(SpatialForce::ZERO);
    for i in (0..n).rev() {
        let t = topo[i];
        let (vo, k, doff) = (t.vo, t.nv, aba.doff[i]);
        let pa_i = aba.pa[i];
        for p in 0..k {
            aba.uu[vo + p] -= aba.sl[vo + p].dot(pa_i);
        }
        if t.parent == usize::MAX {
            continue;
        }
        let mut pa = pa_i;
        for p in 0..k {
            let mut du = 0.0;
            for q in 0..k {
                du += aba.dinv[doff + p * k + q] * aba.uu[vo + q];
            }
            pa += SpatialForce::from_array(aba.u[vo + p]) * du;
        }
        aba.pa[t.parent] += force_back(pa, aba.arm[i]);
    }
    // Pass 3 on the correction (a_0 = 0, no velocity products): Δq̈, then q̈ += Δq̈.
    data.refine.qdd.copy_from_slice(&data.qdd);
    accelerations::<Portable>(topo, aba, false, SpatialMotion::ZERO, &mut data.qdd);
    for (q, q0) in data.qdd.iter_mut().zip(&data.refine.qdd) {
        *q += q0;
    }
}

#[cfg(test)]
mod tests {
    use crate::{Data, Method};

    /// ABA compiled for AVX2 + FMA runs the same arithmetic as the portable build: the same
    /// q̈ to the bit on every bundled model, fixed and floating base, with and without forces.
    #[test]
    fn avx2_and_portable_aba_are_bit_identical() {
        for (name, floating_base, model) in crate::bundled_models() {
            let mut data = Data::new(&model);
            for seed in 0..4 {
                let (portable, avx2) =
                    crate::solve_portable_and_fused(&model, &mut data, seed, Method::Aba);
                assert!(portable.iter().all(|x| x.is_finite()));
                assert_eq!(
                    portable.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                    avx2.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                    "{name} floating={floating_base} seed {seed}"
                );
            }
        }
    }
}
