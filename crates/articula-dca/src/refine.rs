//! Iterative refinement of a floating-base solve (Wilkinson), for DCA.
//!
//! With a floating base, DCA's root join inverts the whole body's compliance at the base. On a
//! long chain that compliance is tiny in the directions where the body is rigid (out of a
//! planar chain's plane) while the joins' rounding residue is not, and q̈ ends up ~4e-10
//! relative off on the floating 1,000-link chain (a fixed base never inverts it). The residual
//! `r = τ − ID(q, q̇, q̈)` by the recursive Newton–Euler algorithm forms no such quantity; when
//! it is above rounding level, the correction `Δ = H⁻¹ r` is one more DCA solve with `τ = r`
//! and no velocity, gravity or external force, and `q̈ += Δ`.
//!
//! A model with a point or rod mass (a singular body inertia, loaded as written) is solved by
//! DCA with a regularised copy of that inertia at its leaf (`data::REGULARISE`), while the
//! residual uses the exact one: the same refinement is then an iteration on the exact system
//! that shrinks the error by about the relative perturbation per step, run to convergence
//! ([`refine_regularised`]).
//!
//! The same iteration to convergence refines two more kinds of solve. (1) A join whose 5×5
//! constraint system `TᵀKT` had a pivot that rounding made non-positive: `K = Φ^A_jj + Φ^B_jj`
//! is positive semidefinite in exact arithmetic, but where a light body is joined to a heavy
//! one its compliance in the directions the joint holds rigid is the small difference of the
//! light body's large ones (1e9 mass ratio: ~1e-9 out of ~1e5), and its rounding can leave
//! negative eigenvalues. The factorisation takes the pivot's magnitude (`ldl5` in articula-spatial), which
//! is a nearby positive definite system, and the iteration corrects it. (2) Models whose
//! neighbouring bodies differ in mass by more than [`MASS_RATIO`](crate::mass_ratio::MASS_RATIO)
//! (the same cancellation, short of a lost pivot: 4e-8 on a 1,000-link chain of ratio 1e6).
//! There DCA's leaves of light bodies between heavy ones invert a heavier inertia
//! (`mass_ratio.rs`): each solve then loses at most 4 digits, and each step shrinks the error
//! ~5,000-fold.

use crate::residual::{rnea_residual, RneaInput};
use crate::{Data, DynamicsError};
use articula_model::Model;
use articula_spatial::SpatialForce;
use glam::DVec3;

/// A correction runs when the largest residual exceeds this fraction of the largest joint force
/// of the Newton–Euler pass. (H of a long chain is so badly conditioned that even an exact-to-
/// rounding q̈ leaves residuals far above rounding level: measured maxima 1.6e-12 on the
/// floating humanoid, 2.2e-11 on chain10, 9e-10 on chain30, 1.5e-7 on chain100, 4e-5 on
/// chain300, 2e-2 on chain1000. Below 1e-8 the solution is kept: those models agree with ABA and
/// CRBA to ≤ 2e-11 unrefined.)
const TRIGGER: f64 = 1e-8;

/// One refinement step of DCA's `data.qdd` (floating bases), when the residual asks for it;
/// with regularised leaves, [`refine_regularised`]. `Ok(false)`: the refinement did not
/// converge, and the caller answers with an exact method instead (`forward::dca_or_fall_back`).
pub(crate) fn refine_dca(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
) -> Result<bool, DynamicsError> {
    if data.refine.regularised || data.refine.mass_ratio || data.dca.clamped > 0 {
        return refine_regularised(model, tau, f_ext, data);
    }
    let (scale, rmax) = residual(model, tau, f_ext, data);
    if rmax <= TRIGGER * scale {
        return Ok(true);
    }
    data.refine.corrections += 1;
    correct(model, data).map(|_| true)
}

/// Correction steps at most with regularised leaves.
const MAX_STEPS: usize = 8;

/// With regularised leaves, refinement stops when the last correction `Δ_k` bounds the
/// remaining error below this fraction of `max |q̈|`: `|Δ_k| ≤ CONVERGED |q̈|`, or
/// `ρ |Δ_k| ≤ CONVERGED |q̈|` with the contraction `ρ = |Δ_k| / |Δ_{k−1}| ≤ ½` measured.
/// (The error after step k is `E e_k` with `Δ_k = (1 − E) e_k`, `E = 1 − H'⁻¹ H` for the
/// regularised `H'`, so it is at most `ρ/(1 − ρ) |Δ_k|`.)
pub(crate) const CONVERGED: f64 = 1e-10;

/// ... or when the corrections stop shrinking (`ρ > ½`) below this fraction of `max |q̈|`:
/// the rounding floor of the residual, amplified by `H⁻¹` (on icub, whose 1.3 kg head is 0.4 mm
/// from its neck axis, `|q̈|` reaches 5e8 on random states and the floor ~1e-8 of it: ABA and
/// CRBA differ by as much). The error is then about `|Δ_k|`.
pub(crate) const FLOOR: f64 = 1e-7;

/// Iterative refinement to convergence, for a model whose DCA leaves invert a regularised
/// inertia: `q̈ += H'⁻¹ (τ − ID(q̈))` until [`CONVERGED`] or [`FLOOR`], at most [`MAX_STEPS`] steps;
/// `Ok(false)` when it does not converge, never a silently wrong `q̈`.
///
/// When a step grows the correction (`ρ > 1`), or the steps run out, DCA's solve is wrong by
/// more than the error in some directions: a join pivot lost where a subassembly's compliance
/// mixes a huge and a tiny principal value (a 100,000-link chain hanging tilted, see
/// `krylov.rs`). The iterate before that step is then refined by GMRES preconditioned by the
/// same DCA solve ([`crate::krylov::refine_gmres`]), which does not need the fixed-point
/// iteration to contract. (The residual itself is formed about each body's own origin,
/// [`rnea_residual`], and carries no rounding of the chain's 10 km of lever arms.) Only when
/// GMRES does not converge either does the caller answer with ABA.
fn refine_regularised(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
) -> Result<bool, DynamicsError> {
    let mut last = f64::INFINITY;
    for _ in 0..MAX_STEPS {
        let (_, rmax) = residual(model, tau, f_ext, data);
        if rmax == 0.0 {
            return Ok(true);
        }
        data.refine.corrections += 1;
        let dn = correct(model, data)?;
        let xn = data.qdd.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        // No contraction is measured after the first step (NaN: the comparisons fail).
        let rho = if last.is_finite() {
            dn / last
        } else {
            f64::NAN
        };
        if rho > 1.0 {
            // Diverging: DCA's solve is wrong by more than the error in some directions.
            // Back to the iterate before this step, and GMRES from there (`krylov.rs`).
            data.qdd.copy_from_slice(&data.refine.qdd);
            return crate::krylov::refine_gmres(model, tau, f_ext, data);
        }
        let converged = dn <= CONVERGED * xn
            || (rho <= 0.5 && rho * dn <= CONVERGED * xn)
            || (rho > 0.5 && dn <= FLOOR * xn);
        if converged {
            return Ok(true);
        }
        last = dn;
    }
    crate::krylov::refine_gmres(model, tau, f_ext, data)
}

/// The residual `r = τ − ID(q, q̇, q̈)` of `data.qdd` into `data.refine.r`; returns the scale of
/// the joint forces and `max |r|` (see [`rnea_residual`]).
pub(crate) fn residual(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
) -> (f64, f64) {
    let input = RneaInput {
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
    let rd = &mut data.refine;
    rnea_residual(model, &input, &mut rd.a, &mut rd.f, &mut rd.r)
}

/// `q̈ += Δ` with `Δ = H⁻¹ r` for the residual in `data.refine.r` ([`solve_unbiased`]).
/// Returns `max |Δ|`.
fn correct(model: &Model, data: &mut Data) -> Result<f64, DynamicsError> {
    data.refine.qdd.copy_from_slice(&data.qdd);
    let r = std::mem::take(&mut data.refine.r);
    let result = solve_unbiased(model, data, &r);
    data.refine.r = r;
    result?;
    let mut dn = 0.0f64;
    for (q, q0) in data.qdd.iter_mut().zip(&data.refine.qdd) {
        dn = dn.max(q.abs());
        *q += q0;
    }
    Ok(dn)
}

/// `data.qdd = H⁻¹ rhs` by DCA with `τ = rhs` and no velocity products, gravity or external
/// force (the kinematics of `data` kept): the correction solve of the fixed-point refinement
/// and GMRES's preconditioner (`krylov.rs`).
pub(crate) fn solve_unbiased(
    model: &Model,
    data: &mut Data,
    rhs: &[f64],
) -> Result<(), DynamicsError> {
    std::mem::swap(&mut data.v, &mut data.refine.zv);
    std::mem::swap(&mut data.c, &mut data.refine.zc);
    let g = std::mem::replace(&mut data.gravity, DVec3::ZERO);
    let result = crate::dca::dca(model, rhs, &[], data, false);
    data.gravity = g;
    std::mem::swap(&mut data.v, &mut data.refine.zv);
    std::mem::swap(&mut data.c, &mut data.refine.zc);
    result
}
