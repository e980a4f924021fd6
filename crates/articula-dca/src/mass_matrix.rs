//! The joint-space mass matrix `M(q)` by the composite-rigid-body algorithm (RBDA ch. 6).

use crate::data::sized;
use crate::inputs::check_inputs;
use crate::{kinematics, Data, DynamicsError};
use articula_model::Model;
use articula_spatial::{SpatialInertia, SpatialMotion};

/// The joint-space mass matrix `M(q)` (nv × nv, symmetric positive definite for a model whose
/// every joint moves mass; row-major and column-major alike), so that the equations of motion
/// read `M(q) q̈ + b(q, q̇) = τ + Σ Jᵢᵀ f_ext,i` ([`crate::bias_forces`]) and the kinetic energy
/// is `½ q̇ᵀ M q̇`. The composite-rigid-body algorithm: `Iᶜᵢ = Iᵢ + Σ Iᶜ` of the children,
/// `M_jk = s_jᵀ Iᶜᵢ s_k` for `j` a degree of freedom of body `i` and `k` one of `i` or of an
/// ancestor, zero for unrelated joints. The velocity coordinates are those of `q̇`
/// (`docs/conventions.md`: a floating joint's `[ω; v]` in its own frame).
///
/// Runs forward kinematics at `(q, 0)` (`data` then holds it: zero velocities); sizes its
/// buffers on the first call, then allocates nothing. A matrix larger than
/// [`crate::MAX_DENSE_MATRIX_BYTES`] is refused ([`DynamicsError::MatrixTooLarge`]) before any
/// allocation.
pub fn mass_matrix<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
) -> Result<&'d [f64], DynamicsError> {
    crate::inputs::check_data(model, data)?;
    let nv = model.nv;
    crate::error::check_dense("joint-space inertia matrix", nv, nv)?;
    let mut zero = std::mem::take(&mut data.quant.zero);
    sized(&mut zero, nv, 0.0);
    let checked = check_inputs(model, q, &zero, &zero, &[]);
    if checked.is_ok() {
        data.origin = kinematics::computation_origin(model, q);
        kinematics::kinematics(model, q, &zero, data, |_, _| {});
    }
    data.quant.zero = zero;
    checked?;
    let quant = &mut data.quant;
    let ic = sized(&mut quant.ic, model.bodies.len(), SpatialInertia::ZERO);
    let m = sized(&mut quant.mass_matrix, nv * nv, 0.0);
    m.fill(0.0);
    let armature = &model.dynamics.armature;
    composite_mass_matrix(
        model,
        &data.inertia,
        &data.s,
        armature,
        ic,
        |row, col, x| {
            m[row * nv + col] = x;
            m[col * nv + row] = x;
        },
    );
    Ok(m)
}

/// The composite-rigid-body algorithm on the inertias and subspace columns of some kinematics
/// (one frame for all): the composite inertias into `ic`, then `set(row, col, M_row,col)` for
/// every entry on or below the diagonal that is not structurally zero, in body order, with
/// `armature` (empty, or one per degree of freedom) added to the diagonal (also
/// CRBA's reference solve, [`crate::Method::Crba`]).
pub(crate) fn composite_mass_matrix(
    model: &Model,
    inertia: &[SpatialInertia],
    s: &[SpatialMotion],
    armature: &[f64],
    ic: &mut [SpatialInertia],
    mut set: impl FnMut(usize, usize, f64),
) {
    // Composite inertias Iᶜᵢ = Iᵢ + Σ Iᶜ_children; H_ij = Sᵢᵀ Iᶜᵢ Sⱼ for j = i and its ancestors.
    ic.copy_from_slice(inertia);
    for i in (0..model.bodies.len()).rev() {
        if let Some(p) = model.bodies[i].parent {
            let c = ic[i];
            ic[p] += c;
        }
    }
    for (i, body) in model.bodies.iter().enumerate() {
        for p in 0..body.nv {
            let row = body.v_offset + p;
            let fcol = ic[i].mul_motion(s[row]);
            let mut j = Some(i);
            while let Some(jj) = j {
                let bj = &model.bodies[jj];
                for q in 0..bj.nv {
                    let col = bj.v_offset + q;
                    let mut x = s[col].dot(fcol);
                    // Armature on the diagonal (docs/loading.md#armature-and-damping).
                    if row == col {
                        x += armature.get(row).copied().unwrap_or(0.0);
                    }
                    set(row, col, x);
                }
                j = bj.parent;
            }
        }
    }
}
