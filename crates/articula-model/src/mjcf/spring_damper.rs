//! MJCF `springdamper="timeconst dampratio"`: a joint's stiffness and damping derived from its
//! inertia, as MuJoCo's compiler does (`mjCModel::AutoSpringDamper`).
//!
//! MuJoCo takes the joint's effective inertia at the reference configuration `qpos0`,
//! `m = 1 / (M⁻¹)ᵢᵢ` (its `dof_invweight0`, with armature in `M`), and sets
//! `k = m / (τ² ζ²)` and `b = 2 m / τ` for time constant `τ` and damping ratio `ζ`.

use crate::{Model, ModelError};
use articula_spatial::numerics::{cholesky_rows, cholesky_rows_solve};
use articula_spatial::{SpatialInertia, SpatialMotion, SpatialTransform};
use std::collections::HashMap;

/// MuJoCo's `mjMINVAL`, the floor of the denominators.
const MIN_VAL: f64 = 1e-15;

/// Sets the stiffness and damping of the joints in `joints` (name → `[timeconst,
/// dampratio]`, one-coordinate joints) from the joint-space inertia at `qpos0` (joint name →
/// coordinate; others neutral).
pub(crate) fn apply(
    model: &mut Model,
    joints: &[(String, [f64; 2])],
    qpos0: &HashMap<String, f64>,
) -> Result<(), ModelError> {
    if joints.is_empty() {
        return Ok(());
    }
    let mut q = model.neutral_q();
    for (_, p) in model.joint_parts() {
        if let Some(&x) = qpos0.get(&p.name) {
            q[p.q_offset] = x;
        }
    }
    let nv = model.nv;
    let mut m = mass_matrix(model, &q);
    if !cholesky_rows(&mut m, nv) {
        return Err(ModelError::Mjcf {
            file: model.name.clone(),
            element: "<joint springdamper>".into(),
            attribute: Some("springdamper".into()),
            message: "the joint-space inertia at qpos0 is singular: springdamper needs every \
                      joint to move mass"
                .into(),
        });
    }
    let d = &mut model.dynamics;
    for v in [&mut d.stiffness, &mut d.damping, &mut d.spring_ref] {
        if v.is_empty() {
            v.resize(nv, 0.0);
        }
    }
    for (name, [timeconst, dampratio]) in joints {
        let Some(dof) = model
            .bodies
            .iter()
            .flat_map(|b| &b.joint)
            .find(|p| &p.name == name)
            .map(|p| p.v_offset)
        else {
            continue;
        };
        let mut e = vec![0.0; nv];
        e[dof] = 1.0;
        cholesky_rows_solve(&m, nv, &mut e);
        let inertia = 1.0 / e[dof].max(MIN_VAL);
        let d = &mut model.dynamics;
        d.stiffness[dof] = inertia / (timeconst * timeconst * dampratio * dampratio).max(MIN_VAL);
        d.damping[dof] = 2.0 * inertia / timeconst.max(MIN_VAL);
    }
    Ok(())
}

/// The joint-space inertia `M(q)` with armature, dense row-major, by the composite-rigid-body
/// algorithm in world coordinates.
fn mass_matrix(model: &Model, q: &[f64]) -> Vec<f64> {
    let nb = model.bodies.len();
    let nv = model.nv;
    let mut x = vec![SpatialTransform::IDENTITY; nb];
    let mut s = vec![SpatialMotion::ZERO; nv];
    let mut ic = vec![SpatialInertia::ZERO; nb];
    for (i, body) in model.bodies.iter().enumerate() {
        // X_{W←i}: the parent's, then each part's origin and motion.
        let mut xi = body.parent.map_or(SpatialTransform::IDENTITY, |p| x[p]);
        for part in &body.joint {
            xi = xi * part.origin;
            xi = xi * part.motion_transform(&q[part.q_offset..part.q_offset + part.nq()]);
            for k in 0..part.nv() {
                s[part.v_offset + k] = xi.apply_motion(part.subspace_column(k));
            }
        }
        x[i] = xi;
        ic[i] = xi.apply_inertia(&body.inertia);
    }
    for i in (0..nb).rev() {
        if let Some(p) = model.bodies[i].parent {
            let c = ic[i];
            ic[p] += c;
        }
    }
    let mut m = vec![0.0; nv * nv];
    for (i, body) in model.bodies.iter().enumerate() {
        for a in body.v_offset..body.v_offset + body.nv {
            let f = ic[i].mul_motion(s[a]);
            let mut j = Some(i);
            while let Some(jj) = j {
                let bj = &model.bodies[jj];
                for b in bj.v_offset..bj.v_offset + bj.nv {
                    m[a * nv + b] = s[b].dot(f);
                    m[b * nv + a] = m[a * nv + b];
                }
                j = bj.parent;
            }
        }
    }
    let armature = &model.dynamics.armature;
    for (k, a) in armature.iter().enumerate() {
        m[k * nv + k] += a;
    }
    m
}
