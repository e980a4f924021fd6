//! Reference 1: the articulated-body algorithm (Featherstone, RBDA ch. 7, Table 7.1), run in
//! world coordinates, so no coordinate transforms appear between bodies. Articulated inertias
//! are kept packed (21 entries, [`Sym6`]) and 1-DOF joints take a rank-1 fast path.

use crate::small::{SmallSpd, Sym6};
use crate::{Data, DynamicsError};
use articula_model::Model;
use articula_spatial::{SpatialForce, SpatialMotion};

/// Runs ABA on the kinematics in `data` (pass 1 is the kinematics loop); writes `data.qdd`.
pub(crate) fn aba(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
) -> Result<(), DynamicsError> {
    let n = model.bodies.len();
    let aba = &mut data.aba;
    // Pass 2, leaves to root: Iᴬᵢ = Iᵢ + Σ_children Iᵃ, pᴬᵢ = vᵢ ×* Iᵢ vᵢ − f_ext,i + Σ pᵃ
    // (gravity enters as a_0 = −a_g); U = Iᴬ S, D = Sᵀ U, u = τ − Sᵀ pᴬ,
    // Iᵃ = Iᴬ − U D⁻¹ Uᵀ, pᵃ = pᴬ + Iᵃ c + U D⁻¹ u, passed to the parent (same frame).
    // Pass 1's part (Iᵢ, vᵢ ×* Iᵢ vᵢ) is formed here, where it is first used: `ia`, `pa` hold
    // only the children's sums, set by the first child processed (`first`), so that no per-body
    // array is written in the kinematics loop and read back a whole chain later.
    let topo = &data.topo[..n];
    for i in (0..n).rev() {
        let t = topo[i];
        let (vo, k, doff) = (t.vo, t.nv, aba.doff[i]);
        let inertia = &data.inertia[i];
        let v = data.v[i];
        let mut ia = Sym6::from_inertia(inertia);
        let mut pa_i = v.cross_force(inertia.mul_motion(v)) - crate::f_ext_of(f_ext, i);
        let slot = aba.acc[i] as usize;
        if slot != u32::MAX as usize {
            ia.add_assign(&aba.ia[slot]);
            pa_i += aba.pa[slot];
        }
        let first = aba.first[i];
        if k == 1 {
            // One DOF (the common case): U = Iᴬ s, D = sᵀU scalar.
            let s = data.s[vo].to_array();
            let u = ia.mul_vec(&s);
            let d = dot6(&s, &u);
            if d.is_nan() || d <= 0.0 {
                return Err(DynamicsError::Singular {
                    joint: model.bodies[i].joint_name(),
                    detail: "Sᵀ Iᴬ S is not positive definite",
                });
            }
            let dinv = 1.0 / d;
            let uu = tau[vo] - data.s[vo].dot(pa_i);
            aba.u[vo] = u;
            aba.uu[vo] = uu;
            aba.dinv[doff] = dinv;
            let parent = t.parent;
            if parent == usize::MAX {
                continue;
            }
            let ps = aba.acc[parent] as usize;
            // pᵃ = pᴬ + Iᵃ c + U D⁻¹ u with Iᵃ c = Iᴬ c − U (Uᵀc) / D
            let c = data.c[i].to_array();
            let ic = ia.mul_vec(&c);
            let g = dinv * (uu - dot6(&c, &u));
            let add = SpatialForce::from_array(std::array::from_fn(|r| ic[r] + u[r] * g));
            if first {
                aba.pa[ps] = pa_i + add;
                aba.ia[ps] = ia.sub_outer(&u, dinv);
            } else {
                aba.pa[ps] += pa_i + add;
                aba.ia[ps].add_sub_outer(&ia, &u, dinv);
            }
            continue;
        }
        let mut dm = SmallSpd {
            k,
            a: [[0.0; 6]; 6],
        };
        for p in 0..k {
            let u = ia.mul_vec(&data.s[vo + p].to_array());
            aba.u[vo + p] = u;
            for q in 0..=p {
                let x = dot6(&data.s[vo + q].to_array(), &u);
                dm.a[p][q] = x;
                dm.a[q][p] = x;
            }
            aba.uu[vo + p] = tau[vo + p] - data.s[vo + p].dot(pa_i);
        }
        if !dm.invert() {
            return Err(DynamicsError::Singular {
                joint: model.bodies[i].joint_name(),
                detail: "Sᵀ Iᴬ S is not positive definite",
            });
        }
        for p in 0..k {
            for q in 0..k {
                aba.dinv[doff + p * k + q] = dm.a[p][q];
            }
        }
        let parent = t.parent;
        if parent == usize::MAX {
            continue;
        }
        // Iᵃ = Iᴬ − Σ_p U_p w_pᵀ with w_p = Σ_q D⁻¹_pq U_q;  pᵃ = pᴬ + Iᵃ c + Σ_p U_p (D⁻¹u)_p.
        let mut ia_a = ia;
        let mut du = [0.0; 6];
        dm.mul(&aba.uu[vo..vo + k], &mut du);
        let mut pa = pa_i;
        for p in 0..k {
            let mut w = [0.0; 6];
            for q in 0..k {
                let x = dm.a[p][q];
                let uq = &aba.u[vo + q];
                for r in 0..6 {
                    w[r] += x * uq[r];
                }
            }
            ia_a.sub_upper_outer(&aba.u[vo + p], &w);
            pa += SpatialForce::from_array(aba.u[vo + p]) * du[p];
        }
        pa += SpatialForce::from_array(ia_a.mul_vec(&data.c[i].to_array()));
        let ps = aba.acc[parent] as usize;
        if first {
            aba.ia[ps] = ia_a;
            aba.pa[ps] = pa;
        } else {
            aba.ia[ps].add_assign(&ia_a);
            aba.pa[ps] += pa;
        }
    }
    let a0 = SpatialMotion::new(glam::DVec3::ZERO, -data.gravity);
    accelerations(topo, aba, &data.s, Some(&data.c), a0, &mut data.qdd);
    Ok(())
}

/// Pass 3, root to leaves: `a' = a_parent + c`, `q̈ = D⁻¹ (u − Uᵀ a')`, `a = a' + S q̈`, on
/// the `U`, `u`, `D⁻¹` of `aba` (`c = None`: no velocity products), writing `qdd`.
#[inline(always)]
fn accelerations(
    topo: &[crate::data::Topo],
    aba: &mut crate::data::AbaData,
    s: &[SpatialMotion],
    c: Option<&[SpatialMotion]>,
    a0: SpatialMotion,
    qdd: &mut [f64],
) {
    for (i, t) in topo.iter().enumerate() {
        let (vo, k, doff) = (t.vo, t.nv, aba.doff[i]);
        let mut ap = if t.parent == usize::MAX {
            a0
        } else {
            aba.a[aba.aslot[t.parent] as usize]
        };
        let slot = aba.aslot[i] as usize;
        if let Some(c) = c {
            ap += c[i];
        }
        let apa = ap.to_array();
        if k == 1 {
            let x = aba.dinv[doff] * (aba.uu[vo] - dot6(&apa, &aba.u[vo]));
            qdd[vo] = x;
            aba.a[slot] = ap + s[vo] * x;
            continue;
        }
        let mut r = [0.0; 6];
        for p in 0..k {
            r[p] = aba.uu[vo + p] - dot6(&apa, &aba.u[vo + p]);
        }
        let mut a = ap;
        for p in 0..k {
            let mut x = 0.0;
            for q in 0..k {
                x += aba.dinv[doff + p * k + q] * r[q];
            }
            qdd[vo + p] = x;
            a += s[vo + p] * x;
        }
        aba.a[slot] = a;
    }
}

#[inline(always)]
fn dot6(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]
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
    let input = crate::refine::RneaInput {
        inertia: &data.inertia,
        v: &data.v,
        c: &data.c,
        s: &data.s,
        gravity: data.gravity,
        tau,
        f_ext,
        qdd: Some(&data.qdd),
    };
    // r = τ − ID(q̈) into uu (aba.a, aba.pa as scratch).
    let aba = &mut data.aba;
    let (scale, rmax) =
        crate::refine::rnea_residual(model, &input, &mut aba.a, &mut aba.pa, &mut aba.uu);
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
            aba.uu[vo + p] -= data.s[vo + p].dot(pa_i);
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
        aba.pa[t.parent] += pa;
    }
    // Pass 3 on the correction (a_0 = 0, no velocity products): Δq̈, then q̈ += Δq̈.
    data.refine.qdd.copy_from_slice(&data.qdd);
    accelerations(topo, aba, &data.s, None, SpatialMotion::ZERO, &mut data.qdd);
    for (q, q0) in data.qdd.iter_mut().zip(&data.refine.qdd) {
        *q += q0;
    }
}
