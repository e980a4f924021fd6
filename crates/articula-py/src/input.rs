//! Arrays in: numpy float64 arrays are read in place (C-contiguous ones without a copy), other
//! sequences go through `numpy.asarray(x, dtype=float64)`; every shape is checked against the
//! model and every error names the argument.

use crate::errors::dynamics_error;
use articula::model::{JointKind, Model};
use articula::prelude::SpatialForce;
use numpy::{
    PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;

/// Numbers read from Python: borrowed from a contiguous float64 array, or copied.
pub(crate) enum Input<'py> {
    /// A C-contiguous float64 array, read in place.
    Borrowed(PyReadonlyArrayDyn<'py, f64>),
    /// A copy (a non-contiguous array, or a Python sequence), with its shape.
    Owned(Vec<f64>, Vec<usize>),
}

impl Input<'_> {
    /// The numbers, in C order.
    pub(crate) fn slice(&self) -> &[f64] {
        match self {
            Input::Borrowed(a) => a.as_slice().expect("checked contiguous"),
            Input::Owned(v, _) => v,
        }
    }

    /// The shape.
    pub(crate) fn shape(&self) -> Vec<usize> {
        match self {
            Input::Borrowed(a) => a.shape().to_vec(),
            Input::Owned(_, s) => s.clone(),
        }
    }
}

/// Reads `obj` (argument `name`) as float64 numbers of any shape.
pub(crate) fn read<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Input<'py>> {
    if let Ok(untyped) = obj.cast::<PyUntypedArray>() {
        let Ok(array) = obj.cast::<PyArrayDyn<f64>>() else {
            let dtype = untyped.dtype();
            return Err(PyTypeError::new_err(format!(
                "{name} has dtype {dtype}, articula needs float64 (use {name}.astype(float))"
            )));
        };
        let ro = array
            .try_readonly()
            .map_err(|e| PyTypeError::new_err(format!("{name} cannot be read: {e}")))?;
        if ro.as_slice().is_ok() {
            return Ok(Input::Borrowed(ro));
        }
        let shape = ro.shape().to_vec();
        return Ok(Input::Owned(ro.as_array().iter().copied().collect(), shape));
    }
    let py = obj.py();
    let numpy = py.import("numpy")?;
    let kwargs = pyo3::types::PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let converted = numpy
        .call_method("asarray", (obj,), Some(&kwargs))
        .map_err(|e| {
            PyTypeError::new_err(format!(
                "{name} is not an array of numbers ({}): {e}",
                obj.get_type().name().map_or("?".into(), |n| n.to_string())
            ))
        })?;
    let array = converted.cast::<PyArrayDyn<f64>>()?;
    let ro = array.readonly();
    let shape = ro.shape().to_vec();
    Ok(Input::Owned(ro.as_array().iter().copied().collect(), shape))
}

/// The shape as Python writes it: `(7,)`, `(3, 7)`.
pub(crate) fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// Checks that `input` (argument `name`) has shape `expected`.
pub(crate) fn expect_shape(input: &Input, name: &str, expected: &[usize]) -> PyResult<()> {
    let shape = input.shape();
    if shape != expected {
        return Err(dynamics_error(format!(
            "{name} has shape {}, the model needs {}",
            shape_text(&shape),
            shape_text(expected)
        )));
    }
    Ok(())
}

/// Reads a vector of length `n`.
pub(crate) fn vector<'py>(obj: &Bound<'py, PyAny>, name: &str, n: usize) -> PyResult<Input<'py>> {
    let input = read(obj, name)?;
    expect_shape(&input, name, &[n])?;
    Ok(input)
}

/// How far a floating joint's quaternion norm may be from 1.
pub(crate) const QUATERNION_TOLERANCE: f64 = 1e-6;

/// Checks every floating joint's quaternion in `q` (length `model.nq`): finite numbers are the
/// library's to check; a finite quaternion whose norm is not 1 within
/// [`QUATERNION_TOLERANCE`] is an error naming the joint. `what` names the argument (`q`,
/// `Q[3]`).
pub(crate) fn check_quaternions(model: &Model, q: &[f64], what: &str) -> PyResult<()> {
    for (_, part) in model.joint_parts() {
        if part.kind != JointKind::Floating {
            continue;
        }
        let quat = &q[part.q_offset + 3..part.q_offset + 7];
        let norm = quat.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm.is_finite() && (norm - 1.0).abs() > QUATERNION_TOLERANCE {
            return Err(dynamics_error(format!(
                "{what}: the quaternion (qw, qx, qy, qz) of joint {} has norm {norm}, not 1 \
                 (normalise it)",
                part.name
            )));
        }
    }
    Ok(())
}

/// External wrenches: `None`, or an array `(bodies, 6)` of `[n; f]` rows in world coordinates
/// about the world origin, one per body of `model.body_names`.
pub(crate) fn wrenches(
    model: &Model,
    f_ext: Option<&Bound<'_, PyAny>>,
) -> PyResult<Vec<SpatialForce>> {
    let Some(obj) = f_ext.filter(|o| !o.is_none()) else {
        return Ok(Vec::new());
    };
    let input = read(obj, "f_ext")?;
    let nb = model.bodies.len();
    expect_shape(&input, "f_ext", &[nb, 6])?;
    let forces: Vec<SpatialForce> = input
        .slice()
        .chunks_exact(6)
        .map(|r| SpatialForce::from_array([r[0], r[1], r[2], r[3], r[4], r[5]]))
        .collect();
    Ok(forces)
}

/// `q`, `v` and a third per-DOF vector (`tau`, `a`) read and checked (shapes, quaternions,
/// finite numbers by joint).
pub(crate) struct Triple<'py> {
    /// Positions.
    pub q: Input<'py>,
    /// Velocities.
    pub v: Input<'py>,
    /// Forces or accelerations.
    pub third: Input<'py>,
}

/// Reads `(q, v, third)` for `model`.
pub(crate) fn triple<'py>(
    model: &Model,
    q: &Bound<'py, PyAny>,
    v: &Bound<'py, PyAny>,
    (name, third): (&'static str, &Bound<'py, PyAny>),
) -> PyResult<Triple<'py>> {
    let q = vector(q, "q", model.nq)?;
    let v = vector(v, "v", model.nv)?;
    let third = vector(third, name, model.nv)?;
    check_quaternions(model, q.slice(), "q")?;
    Ok(Triple { q, v, third })
}
