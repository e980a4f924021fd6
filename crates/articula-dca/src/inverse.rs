//! Inverse dynamics by the recursive Newton–Euler algorithm (RBDA ch. 5), and the bias forces.

use crate::data::sized;
use crate::inputs::check_values;
use crate::residual::{rnea_residual, RneaInput};
use crate::{kinematics, Data, DynamicsError};
use articula_model::Model;
use articula_spatial::numerics::all_finite;
use articula_spatial::{SpatialForce, SpatialMotion};

/// Inverse dynamics `τ = ID(q, q̇, q̈, f_ext)`: the joint forces that give the accelerations
/// `q̈`, with gravity (`Data::gravity`) and the external wrenches `f_ext` (empty, or one per
/// body in world coordinates about the world origin, as for [`crate::forward_dynamics`]), so
/// that `ID(q, q̇, FD(q, q̇, τ, f_ext), f_ext) = τ`. Equal to `M(q) q̈ + b(q, q̇) − Σ Jᵢᵀ f_ext,i`
/// ([`crate::mass_matrix`], [`bias_forces`]). The recursive Newton–Euler algorithm:
/// `aᵢ = a_parent + cᵢ + Sᵢ q̈ᵢ` from `a_0 = −g`, `fᵢ = Iᵢ aᵢ + vᵢ ×* Iᵢ vᵢ − f_ext,i`,
/// summed from the leaves to the root, `τ_j = s_jᵀ fᵢ`. The velocity coordinates are those of
/// `q̇` (`docs/conventions.md`: a floating joint's `τ` is the wrench on its body in the body's
/// frame, `[n; f]`).
///
/// Returns `τ` (length nv); `data` then holds the kinematics of `(q, q̇)`. Sizes its buffers
/// on the first call, then allocates nothing.
pub fn inverse_dynamics<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    f_ext: &[SpatialForce],
) -> Result<&'d [f64], DynamicsError> {
    crate::inputs::check_data(model, data)?;
    check_values(model, q, qd, ("qdd", qdd), f_ext)?;
    rnea(model, data, q, qd, Some(qdd), f_ext)
}

/// The bias forces `b(q, q̇) = ID(q, q̇, 0)`: Coriolis, centrifugal and gravity forces, no
/// external force (Pinocchio's `nonLinearEffects`), so that `M(q) q̈ + b(q, q̇) = τ` without
/// external forces. Returns `b` (length nv); `data` then holds the kinematics of `(q, q̇)`.
/// Sizes its buffers on the first call, then allocates nothing.
pub fn bias_forces<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
    qd: &[f64],
) -> Result<&'d [f64], DynamicsError> {
    crate::inputs::check_data(model, data)?;
    let mut zero = std::mem::take(&mut data.quant.zero);
    sized(&mut zero, model.nv, 0.0);
    let checked = check_values(model, q, qd, ("qdd", &zero), &[]);
    data.quant.zero = zero;
    checked?;
    rnea(model, data, q, qd, None, &[])
}

/// Kinematics, then the RNEA residual with `τ = 0` (`r = −ID`), negated.
fn rnea<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
    qd: &[f64],
    qdd: Option<&[f64]>,
    f_ext: &[SpatialForce],
) -> Result<&'d [f64], DynamicsError> {
    let (n, nv) = (model.bodies.len(), model.nv);
    data.origin = kinematics::computation_origin(model, q);
    kinematics::kinematics(model, q, qd, data, |_, _| {});
    kinematics::forces_to_computation_frame(f_ext, data);
    let quant = &mut data.quant;
    sized(&mut quant.zero, nv, 0.0);
    sized(&mut quant.a, n, SpatialMotion::ZERO);
    sized(&mut quant.f, n, SpatialForce::ZERO);
    sized(&mut quant.tau, nv, 0.0);
    let input = RneaInput {
        x: &data.x,
        fk_plan: &data.fk_plan,
        v: &data.v,
        c: &data.c,
        s: &data.s,
        gravity: data.gravity,
        tau: &quant.zero,
        f_ext: &data.f_ext_c,
        qdd,
        armature: &data.armature,
    };
    rnea_residual(model, &input, &mut quant.a, &mut quant.f, &mut quant.tau);
    // r = 0 − τ, so 0 − r = τ exactly.
    for t in quant.tau.iter_mut() {
        *t = 0.0 - *t;
    }
    if !all_finite(&quant.tau) {
        for (_, part) in model.joint_parts() {
            if quant.tau[part.v_offset..part.v_offset + part.nv()]
                .iter()
                .any(|x| !x.is_finite())
            {
                return Err(DynamicsError::NonFinite {
                    what: "tau",
                    name: part.name.clone(),
                });
            }
        }
    }
    Ok(&quant.tau)
}
