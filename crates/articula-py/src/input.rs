//! Arrays in: numpy float64 arrays are read in place (C-contiguous ones without a copy), other
//! sequences go through `numpy.asarray(x, dtype=float64)`; every shape is checked against the
//! model and every error names the argument.

use crate::errors::dynamics_error;
use articula::model::Model;
use articula::prelude::SpatialForce;
use numpy::{
    PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyTypeError;

/// numpy's type number of float64.
const NPY_DOUBLE: std::os::raw::c_int = 12;
use pyo3::prelude::*;

/// Numbers read from Python: a C-contiguous float64 array read in place, or a copy.
pub(crate) enum Input<'py> {
    /// A C-contiguous float64 array, read in place while the GIL is held.
    Borrowed(Bound<'py, PyArrayDyn<f64>>),
    /// A copy (a non-contiguous array, or a Python sequence), with its shape.
    Owned(Vec<f64>, Vec<usize>),
}

impl Input<'_> {
    /// The numbers, in C order. Only for use while the GIL is held: a call that releases it
    /// copies its inputs first ([`Input::to_vec`]), since another Python thread may then
    /// write into the array.
    pub(crate) fn slice(&self) -> &[f64] {
        match self {
            // SAFETY: the array is C-contiguous and float64 (checked in `read`), the returned
            // slice borrows `self`, which holds a reference to the array, and it is read only
            // while this thread holds the GIL, so no Python code runs meanwhile; articula never
            // writes into an input array. (numpy's own borrow tracking costs ~0.3 µs a
            // vector, a third of a small model's whole call, and guards against nothing here.)
            Input::Borrowed(a) => unsafe { a.as_slice() }.expect("checked C-contiguous"),
            Input::Owned(v, _) => v,
        }
    }

    /// A copy of the numbers, for a call that releases the GIL.
    pub(crate) fn to_vec(&self) -> Vec<f64> {
        self.slice().to_vec()
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
        let dtype = untyped.dtype();
        // float64 in native byte order (numpy's NPY_DOUBLE); compared by number, which is
        // cheaper than numpy's own cast (a descriptor lookup and an equivalence call).
        if dtype.num() != NPY_DOUBLE || dtype.is_native_byteorder() == Some(false) {
            return Err(PyTypeError::new_err(format!(
                "{name} has dtype {dtype}, articula needs float64 (use {name}.astype(float))"
            )));
        }
        // SAFETY: an ndarray whose dtype is float64 in native byte order (checked above).
        let array = unsafe { untyped.cast_unchecked::<PyArrayDyn<f64>>() };
        if array.is_c_contiguous()
            && (array.data() as usize).is_multiple_of(std::mem::align_of::<f64>())
        {
            return Ok(Input::Borrowed(array.clone()));
        }
        let ro = array.readonly();
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
        let Some(o) = part.kind.quaternion_offset() else {
            continue;
        };
        let quat = &q[part.q_offset + o..part.q_offset + o + 4];
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
