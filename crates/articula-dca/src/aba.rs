//! Reference 1: the articulated-body algorithm (Featherstone, RBDA ch. 7, Table 7.1), run in
//! world coordinates, so no coordinate transforms appear between bodies.

use crate::{Data, DynamicsError};
use articula_model::Model;
use articula_spatial::{SpatialForce, SpatialMotion, SymMat6};

/// Runs ABA on the kinematics in `data`; writes `data.qdd`.
pub(crate) fn aba(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
) -> Result<(), DynamicsError> {
    let n = model.bodies.len();
    // Pass 2 init: Iᴬᵢ = Iᵢ, pᴬᵢ = vᵢ ×* Iᵢ vᵢ − f_ext,i (gravity enters as a_0 = −a_g).
    for i in 0..n {
        let inertia = &data.inertia[i];
        let v = data.v[i];
        data.aba.ia[i] = inertia.to_mat6();
        data.aba.pa[i] = v.cross_force(inertia.mul_motion(v)) - crate::f_ext_of(f_ext, i);
    }
    // Pass 2, leaves to root: U = Iᴬ S, D = Sᵀ U, u = τ − Sᵀ pᴬ,
    // Iᵃ = Iᴬ − U D⁻¹ Uᵀ, pᵃ = pᴬ + Iᵃ c + U D⁻¹ u; added to the parent (same frame).
    for i in (0..n).rev() {
        let body = &model.bodies[i];
        let (vo, k) = (body.v_offset, body.nv);
        if k == 1 {
            // One DOF (the common case): U = Iᴬ s, D = sᵀU scalar.
            let s = data.s[vo];
            let u = data.aba.ia[i].motion_to_force(s);
            let d = s.dot(u);
            if d.is_nan() || d <= 0.0 {
                return Err(DynamicsError::Singular {
                    joint: body.joint_name(),
                    detail: "Sᵀ Iᴬ S is not positive definite",
                });
            }
            let dinv = 1.0 / d;
            let uu = tau[vo] - s.dot(data.aba.pa[i]);
            data.aba.u[vo] = u;
            data.aba.uu[vo] = uu;
            data.aba.dinv[i].k = 1;
            data.aba.dinv[i].a[0][0] = dinv;
            let Some(parent) = body.parent else { continue };
            // pᵃ = pᴬ + Iᵃ c + U D⁻¹ u with Iᵃ c = Iᴬ c − U (Uᵀc) / D
            let c = data.c[i];
            let pa =
                data.aba.pa[i] + data.aba.ia[i].motion_to_force(c) + u * (dinv * (uu - c.dot(u)));
            data.aba.pa[parent] += pa;
            let (lo, hi) = data.aba.ia.split_at_mut(i);
            lo[parent].add_sub_outer(&hi[0], &u.to_array(), dinv);
            continue;
        }
        let ia = data.aba.ia[i];
        let mut dm = crate::small::SmallSpd {
            k,
            a: [[0.0; 6]; 6],
        };
        for p in 0..k {
            let u = ia.motion_to_force(data.s[vo + p]);
            data.aba.u[vo + p] = u;
            for q in 0..=p {
                let x = data.s[vo + q].dot(u);
                dm.a[p][q] = x;
                dm.a[q][p] = x;
            }
            data.aba.uu[vo + p] = tau[vo + p] - data.s[vo + p].dot(data.aba.pa[i]);
        }
        if !dm.invert() {
            return Err(DynamicsError::Singular {
                joint: body.joint_name(),
                detail: "Sᵀ Iᴬ S is not positive definite",
            });
        }
        data.aba.dinv[i] = dm;
        let Some(parent) = body.parent else { continue };
        let mut ia_a = ia;
        let mut du = [0.0; 6];
        dm.mul(&data.aba.uu[vo..vo + k], &mut du);
        let mut pa = data.aba.pa[i];
        for p in 0..k {
            let up = data.aba.u[vo + p].to_array();
            for q in 0..k {
                let x = dm.a[p][q];
                if p == q {
                    ia_a = ia_a.sub_outer(&up, x);
                } else if x != 0.0 {
                    let uq = data.aba.u[vo + q].to_array();
                    ia_a = SymMat6::from_mat6(
                        &(*ia_a.as_mat6() - articula_spatial::Mat6::outer(&up, &uq) * x),
                    );
                }
            }
            pa += data.aba.u[vo + p] * du[p];
        }
        pa += ia_a.motion_to_force(data.c[i]);
        data.aba.ia[parent].add_assign(&ia_a);
        data.aba.pa[parent] += pa;
    }
    // Pass 3, root to leaves: a' = a_parent + c, q̈ = D⁻¹ (u − Uᵀ a'), a = a' + S q̈.
    let a0 = SpatialMotion::new(glam::DVec3::ZERO, -data.gravity);
    for i in 0..n {
        let body = &model.bodies[i];
        let (vo, k) = (body.v_offset, body.nv);
        let ap = match body.parent {
            Some(p) => data.aba.a[p],
            None => a0,
        } + data.c[i];
        let mut r = [0.0; 6];
        for p in 0..k {
            r[p] = data.aba.uu[vo + p] - ap.dot(data.aba.u[vo + p]);
        }
        data.aba.dinv[i].mul(&r[..k], &mut data.qdd[vo..vo + k]);
        let mut a = ap;
        for p in 0..k {
            a += data.s[vo + p] * data.qdd[vo + p];
        }
        data.aba.a[i] = a;
    }
    Ok(())
}
