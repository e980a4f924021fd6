//! The exception hierarchy: classes defined in `articula/_errors.py` (so that they can have
//! two bases, `articula.Error` and `ValueError`), raised from here with the library's message.

use articula::prelude::{AdaptiveError, DynamicsError, ModelError, ViewError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyType;

/// Which class of `articula._errors` an error is raised as.
#[derive(Clone, Copy)]
pub(crate) enum Kind {
    /// `articula.ModelError`: loading and model options.
    Model,
    /// `articula.DynamicsError`: inputs and results of dynamics calls.
    Dynamics,
    /// `articula.DivergenceError`: the energy guard of a simulation.
    Divergence,
    /// `articula.SceneError`: scene files, specs and scene steps.
    Scene,
}

static CLASSES: [PyOnceLock<Py<PyType>>; 4] = [
    PyOnceLock::new(),
    PyOnceLock::new(),
    PyOnceLock::new(),
    PyOnceLock::new(),
];

/// The exception `kind` with `message`.
pub(crate) fn error(kind: Kind, message: impl Into<String>) -> PyErr {
    let message = message.into();
    Python::attach(|py| {
        let (slot, name) = match kind {
            Kind::Model => (0, "ModelError"),
            Kind::Dynamics => (1, "DynamicsError"),
            Kind::Divergence => (2, "DivergenceError"),
            Kind::Scene => (3, "SceneError"),
        };
        let class = CLASSES[slot].get_or_try_init(py, || -> PyResult<Py<PyType>> {
            let module = py.import("articula._errors")?;
            Ok(module.getattr(name)?.cast_into::<PyType>()?.unbind())
        });
        match class {
            Ok(class) => PyErr::from_type(class.bind(py).clone(), message),
            Err(e) => e,
        }
    })
}

/// `articula.ModelError`.
pub(crate) fn model_error(e: ModelError) -> PyErr {
    error(Kind::Model, e.to_string())
}

/// `articula.DynamicsError`.
pub(crate) fn dynamics_error(e: impl std::fmt::Display) -> PyErr {
    error(Kind::Dynamics, e.to_string())
}

/// `articula.SceneError`.
pub(crate) fn scene_error(e: ViewError) -> PyErr {
    error(Kind::Scene, e.to_string())
}

/// An adaptive step's error: a bad setting or the dynamics'.
pub(crate) fn adaptive_error(e: AdaptiveError) -> PyErr {
    error(Kind::Dynamics, e.to_string())
}

/// `DynamicsError` for the dynamics layer's typed error.
pub(crate) fn from_dynamics(e: DynamicsError) -> PyErr {
    dynamics_error(e)
}
