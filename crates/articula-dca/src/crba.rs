//! Reference 2: the composite-rigid-body algorithm (RBDA ch. 6) for the joint-space inertia
//! matrix H, the recursive Newton–Euler algorithm for the bias forces C, and faer's Cholesky
//! factorisation for `H q̈ = τ − C`, then iterative refinement against the RNEA residual.
//! World coordinates. Allocates (it is a reference).
//!
//! H of a long chain is badly conditioned (cond(H) grows like n⁴): the Cholesky solution alone
//! is off by ~1e-8 relative on a 300-link chain. Each refinement step computes the residual
//! `r = τ − ID(q, q̇, q̈)` with the recursive Newton–Euler algorithm — which never forms H, so
//! it is accurate to rounding in the joint forces — and corrects `q̈ += H⁻¹ r` with the same
//! factor (Wilkinson's iterative refinement; RBDA §6.4 notes the same use of RNEA). A few steps
//! bring CRBA to the accuracy of the recursive algorithms.

use crate::{Data, DynamicsError};
use articula_model::Model;
use articula_spatial::{SpatialForce, SpatialMotion};
use faer::prelude::*;

/// Runs CRBA + RNEA + Cholesky on the kinematics in `data`; writes `data.qdd`.
pub(crate) fn crba(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
) -> Result<(), DynamicsError> {
    let n = model.bodies.len();
    let nv = model.nv;
    // RNEA with q̈ = 0: aᵢ = a_parent + cᵢ (a_0 = −a_g), fᵢ = Iᵢ aᵢ + vᵢ ×* Iᵢ vᵢ − f_ext,i,
    // accumulated leaves to root; Cᵢ = Sᵢᵀ fᵢ.
    let a0 = SpatialMotion::new(glam::DVec3::ZERO, -data.gravity);
    let mut a = vec![SpatialMotion::ZERO; n];
    let mut f = vec![SpatialForce::ZERO; n];
    for i in 0..n {
        let body = &model.bodies[i];
        a[i] = body.parent.map_or(a0, |p| a[p]) + data.c[i];
        let inertia = &data.inertia[i];
        f[i] = inertia.mul_motion(a[i]) + data.v[i].cross_force(inertia.mul_motion(data.v[i]))
            - crate::f_ext_of(f_ext, i);
    }
    let mut rhs = Mat::<f64>::zeros(nv, 1);
    joint_forces(model, tau, &mut f, data, &mut rhs);
    // Composite inertias Iᶜᵢ = Iᵢ + Σ Iᶜ_children; H_ij = Sᵢᵀ Iᶜᵢ Sⱼ for j = i and its ancestors.
    let mut ic = data.inertia.clone();
    for i in (0..n).rev() {
        if let Some(p) = model.bodies[i].parent {
            let c = ic[i];
            ic[p] += c;
        }
    }
    let mut h = Mat::<f64>::zeros(nv, nv);
    for i in 0..n {
        let body = &model.bodies[i];
        for p in 0..body.nv {
            let row = body.v_offset + p;
            let fcol = ic[i].mul_motion(data.s[row]);
            let mut j = Some(i);
            while let Some(jj) = j {
                let bj = &model.bodies[jj];
                for q in 0..bj.nv {
                    let col = bj.v_offset + q;
                    let x = data.s[col].dot(fcol);
                    h[(row, col)] = x;
                    h[(col, row)] = x;
                }
                j = bj.parent;
            }
        }
    }
    let llt = h
        .llt(faer::Side::Lower)
        .map_err(|_| DynamicsError::Singular {
            joint: model
                .bodies
                .first()
                .map(|b| b.joint_name())
                .unwrap_or_default(),
            detail: "the joint-space inertia matrix is not positive definite",
        })?;
    llt.solve_in_place(&mut rhs);
    for j in 0..nv {
        data.qdd[j] = rhs[(j, 0)];
    }
    // Iterative refinement: r = τ − ID(q̈) by RNEA (aᵢ = a_parent + Sᵢ q̈ᵢ + cᵢ), q̈ += H⁻¹ r,
    // until the correction is at rounding level (at most a few steps).
    for _ in 0..REFINEMENT_STEPS {
        for i in 0..n {
            let body = &model.bodies[i];
            let mut ai = body.parent.map_or(a0, |p| a[p]) + data.c[i];
            for p in 0..body.nv {
                let j = body.v_offset + p;
                ai += data.s[j] * data.qdd[j];
            }
            a[i] = ai;
            let inertia = &data.inertia[i];
            f[i] = inertia.mul_motion(ai) + data.v[i].cross_force(inertia.mul_motion(data.v[i]))
                - crate::f_ext_of(f_ext, i);
        }
        joint_forces(model, tau, &mut f, data, &mut rhs);
        llt.solve_in_place(&mut rhs);
        let (mut dn, mut xn) = (0.0f64, 0.0f64);
        for j in 0..nv {
            data.qdd[j] += rhs[(j, 0)];
            dn = dn.max(rhs[(j, 0)].abs());
            xn = xn.max(data.qdd[j].abs());
        }
        if dn <= 4.0 * f64::EPSILON * xn {
            break;
        }
    }
    Ok(())
}

/// Refinement steps at most; each costs one RNEA pass and one pair of triangular solves.
const REFINEMENT_STEPS: usize = 4;

/// `rhs_j = τ_j − S_jᵀ f_i` for every joint, with the bodies' net forces `f` accumulated from
/// the leaves to the root in place (RNEA's backward pass).
fn joint_forces(
    model: &Model,
    tau: &[f64],
    f: &mut [SpatialForce],
    data: &Data,
    rhs: &mut Mat<f64>,
) {
    for i in (0..model.bodies.len()).rev() {
        let body = &model.bodies[i];
        for p in 0..body.nv {
            let j = body.v_offset + p;
            rhs[(j, 0)] = tau[j] - data.s[j].dot(f[i]);
        }
        if let Some(par) = body.parent {
            let fi = f[i];
            f[par] += fi;
        }
    }
}
