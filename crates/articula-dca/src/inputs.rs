//! The inputs of a dynamics call: their checks (lengths, finiteness; an error names the joint
//! or body) and the external wrench of a body.

use crate::DynamicsError;
use articula_model::Model;
use articula_spatial::numerics::all_finite;
use articula_spatial::SpatialForce;

/// External wrench on body `i`: an empty slice means none.
#[inline]
pub(crate) fn f_ext_of(f_ext: &[SpatialForce], i: usize) -> SpatialForce {
    f_ext.get(i).copied().unwrap_or(SpatialForce::ZERO)
}

/// `Ok` when `data` was built for `model` (its fingerprint: sizes and shape, O(1)), else
/// [`DynamicsError::WrongModel`]: a workspace of another model would index out of its buffers.
#[inline]
pub(crate) fn check_data(model: &Model, data: &crate::Data) -> Result<(), DynamicsError> {
    let given = crate::data::Fingerprint::of(model);
    if data.fingerprint == given {
        return Ok(());
    }
    Err(DynamicsError::WrongModel {
        data: data.fingerprint.describe(&given),
        model: given.describe(&data.fingerprint),
    })
}

/// Checks the inputs of a dynamics call: lengths of `q`, `qd`, `tau` (and `f_ext` when not
/// empty), and that every number is finite — an error names the joint or body.
#[inline]
pub fn check_inputs(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    f_ext: &[SpatialForce],
) -> Result<(), DynamicsError> {
    check_values(model, q, qd, ("tau", tau), f_ext)
}

/// [`check_inputs`] with the third per-degree-of-freedom vector named (`tau`, `qdd`).
#[inline]
pub(crate) fn check_values(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    (third, tau): (&'static str, &[f64]),
    f_ext: &[SpatialForce],
) -> Result<(), DynamicsError> {
    for (what, len, expected) in [
        ("q", q.len(), model.nq),
        ("qd", qd.len(), model.nv),
        (third, tau.len(), model.nv),
    ] {
        if len != expected {
            return Err(DynamicsError::Dimension {
                what,
                expected,
                found: len,
            });
        }
    }
    if !f_ext.is_empty() && f_ext.len() != model.bodies.len() {
        return Err(DynamicsError::Dimension {
            what: "f_ext",
            expected: model.bodies.len(),
            found: f_ext.len(),
        });
    }
    let all_finite = all_finite(q) && all_finite(qd) && all_finite(tau);
    for (_, part) in model.joint_parts().filter(|_| !all_finite) {
        let (qo, vo) = (part.q_offset, part.v_offset);
        for (what, xs) in [
            ("q", &q[qo..qo + part.nq()]),
            ("qd", &qd[vo..vo + part.nv()]),
            (third, &tau[vo..vo + part.nv()]),
        ] {
            if xs.iter().any(|x| !x.is_finite()) {
                return Err(DynamicsError::NonFinite {
                    what,
                    name: part.name.clone(),
                });
            }
        }
    }
    for (i, f) in f_ext.iter().enumerate() {
        if !f.is_finite() {
            return Err(DynamicsError::NonFinite {
                what: "external force",
                name: model.bodies[i].name.clone(),
            });
        }
    }
    Ok(())
}
