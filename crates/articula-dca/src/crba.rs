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

use crate::residual::{rnea_residual, RneaInput};
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
    // C by RNEA with q̈ = 0: the right-hand side τ − C.
    let mut a = vec![SpatialMotion::ZERO; n];
    let mut f = vec![SpatialForce::ZERO; n];
    let mut r = vec![0.0; nv];

    rnea_residual(
        model,
        &RneaInput::of(data, tau, f_ext, None),
        &mut a,
        &mut f,
        &mut r,
    );
    let mut rhs = Mat::<f64>::from_fn(nv, 1, |j, _| r[j]);
    let mut ic = data.inertia.clone();
    let mut h = Mat::<f64>::zeros(nv, nv);
    let armature = &data.armature;
    crate::mass_matrix::composite_mass_matrix(
        model,
        &data.inertia,
        &data.s,
        armature,
        &mut ic,
        |r, c, x| {
            h[(r, c)] = x;
            h[(c, r)] = x;
        },
    );
    // A locked joint's coordinates (after every body's) are no body's: H is the identity
    // there and the right-hand side zero, so their q̈ is 0.
    for l in &model.locked {
        for k in 0..l.joint.nv() {
            h[(l.joint.v_offset + k, l.joint.v_offset + k)] = 1.0;
        }
    }
    // Each multi-DOF joint's own block first, as DCA and ABA test theirs (a gimbal lock).
    for body in model.bodies.iter().filter(|b| b.nv >= 2 && b.nv <= 6) {
        let block: [[f64; 6]; 6] = std::array::from_fn(|r| {
            std::array::from_fn(|c| {
                if r < body.nv && c < body.nv {
                    h[(body.v_offset + r, body.v_offset + c)]
                } else {
                    0.0
                }
            })
        });
        if !articula_spatial::numerics::joint_block_regular(&block, body.nv) {
            return Err(DynamicsError::Singular {
                joint: body.joint_name(),
                detail: crate::error::JOINT_BLOCK_SINGULAR,
            });
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
    let mut qdd: Vec<f64> = (0..nv).map(|j| rhs[(j, 0)]).collect();
    // Iterative refinement: r = τ − ID(q̈) by RNEA, q̈ += H⁻¹ r, until the correction is at
    // rounding level (at most a few steps).
    for _ in 0..REFINEMENT_STEPS {
        rnea_residual(
            model,
            &RneaInput::of(data, tau, f_ext, Some(&qdd)),
            &mut a,
            &mut f,
            &mut r,
        );
        let mut dq = Mat::<f64>::from_fn(nv, 1, |j, _| r[j]);
        llt.solve_in_place(&mut dq);
        let (mut dn, mut xn) = (0.0f64, 0.0f64);
        for j in 0..nv {
            qdd[j] += dq[(j, 0)];
            dn = dn.max(dq[(j, 0)].abs());
            xn = xn.max(qdd[j].abs());
        }
        if dn <= 4.0 * f64::EPSILON * xn {
            break;
        }
    }
    data.qdd.copy_from_slice(&qdd);
    Ok(())
}

/// Refinement steps at most; each costs one RNEA pass and one pair of triangular solves.
const REFINEMENT_STEPS: usize = 4;
