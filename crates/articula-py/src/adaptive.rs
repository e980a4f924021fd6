//! `articula.Adaptive`: adaptive dynamics of one model (Redon–Galoppo–Lin), which owns its
//! state because its workspace follows the hierarchical state from step to step.

use crate::errors::{adaptive_error, dynamics_error};
use crate::input::{check_quaternions, vector};
use crate::model::PyModel;
use articula::model::Model;
use articula::prelude::{Adaptive, Integrator, Settings, State, StepReport};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Arc;

/// Adaptive dynamics of one model: only the joints that matter most move, the others are
/// locked (rigidified) keeping momentum, and the error is reported.
///
/// Adaptive(model, q0=None, v0=None, budget=None, tolerance=None, reselect_every=0,
/// velocity_tolerance=None): budget caps the internal degrees of freedom simulated (a floating
/// base's 6 are free; 0 moves the body as one rigid body), tolerance stops selecting when the
/// acceleration-metric error left is below it; reselect_every 0 picks the balanced period.
/// q0 and v0 default to the rest pose at rest. step(dt) advances the owned state; q, v and tau
/// are its arrays.
#[pyclass(name = "Adaptive", module = "articula")]
pub struct PyAdaptive {
    model: Arc<Model>,
    adaptive: Adaptive,
    state: State,
}

/// A step report as a dict.
fn report<'py>(py: Python<'py>, r: &StepReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("reselected", r.reselected)?;
    d.set_item("rigidified", r.rigidified)?;
    d.set_item("active_dofs", r.active_dofs)?;
    d.set_item("predicted_error", r.predicted_error)?;
    d.set_item("nodes_touched", r.nodes_touched)?;
    Ok(d)
}

#[pymethods]
impl PyAdaptive {
    #[new]
    #[pyo3(signature = (model, q0=None, v0=None, budget=None, tolerance=None, reselect_every=0,
                        velocity_tolerance=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: &PyModel,
        q0: Option<&Bound<'_, PyAny>>,
        v0: Option<&Bound<'_, PyAny>>,
        budget: Option<usize>,
        tolerance: Option<f64>,
        reselect_every: u64,
        velocity_tolerance: Option<f64>,
    ) -> PyResult<PyAdaptive> {
        let m = model.model.clone();
        let settings = Settings {
            budget,
            tolerance,
            reselect_every,
            velocity_tolerance,
        };
        settings.validate().map_err(adaptive_error)?;
        let mut state = State::neutral(&m);
        state.q = m.rest_q();
        if let Some(q0) = q0.filter(|o| !o.is_none()) {
            let q = vector(q0, "q0", m.nq)?;
            check_quaternions(&m, q.slice(), "q0")?;
            state.q.copy_from_slice(q.slice());
        }
        if let Some(v0) = v0.filter(|o| !o.is_none()) {
            state.qd.copy_from_slice(vector(v0, "v0", m.nv)?.slice());
        }
        articula::dca::check_inputs(&m, &state.q, &state.qd, &state.tau, &[])
            .map_err(dynamics_error)?;
        let adaptive = Adaptive::new(&m, settings);
        Ok(PyAdaptive {
            model: m,
            adaptive,
            state,
        })
    }

    /// Advances the state by dt (integrator "euler", semi-implicit, or "rk4") and returns the
    /// step's report: {"reselected", "rigidified", "active_dofs", "predicted_error",
    /// "nodes_touched"}. Releases the GIL.
    #[pyo3(signature = (dt, integrator="euler"))]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        dt: f64,
        integrator: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(dynamics_error(format!(
                "dt must be a finite number > 0, got {dt}"
            )));
        }
        let integrator = match integrator {
            "euler" => Integrator::SemiImplicitEuler,
            "rk4" => Integrator::Rk4,
            other => {
                return Err(dynamics_error(format!(
                    "integrator must be 'rk4' or 'euler', not '{other}'"
                )))
            }
        };
        let PyAdaptive {
            model,
            adaptive,
            state,
        } = self;
        let r = py
            .detach(|| articula::adaptive::step(model, adaptive, state, integrator, dt))
            .map_err(adaptive_error)?;
        report(py, &r)
    }

    /// Positions (a copy; assign to set them).
    #[getter]
    fn get_q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.state.q)
    }

    #[setter]
    fn set_q(&mut self, q: &Bound<'_, PyAny>) -> PyResult<()> {
        let q = vector(q, "q", self.model.nq)?;
        check_quaternions(&self.model, q.slice(), "q")?;
        self.state.q.copy_from_slice(q.slice());
        self.adaptive.invalidate();
        Ok(())
    }

    /// Velocities (a copy; assign to set them).
    #[getter]
    fn get_v<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.state.qd)
    }

    #[setter]
    fn set_v(&mut self, v: &Bound<'_, PyAny>) -> PyResult<()> {
        let v = vector(v, "v", self.model.nv)?;
        self.state.qd.copy_from_slice(v.slice());
        self.adaptive.invalidate();
        Ok(())
    }

    /// Joint forces held over the following steps (a copy; assign to set them).
    #[getter]
    fn get_tau<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.state.tau)
    }

    #[setter]
    fn set_tau(&mut self, tau: &Bound<'_, PyAny>) -> PyResult<()> {
        let t = vector(tau, "tau", self.model.nv)?;
        self.state.tau.copy_from_slice(t.slice());
        Ok(())
    }

    /// The joint accelerations of the last step (zero on locked joints).
    #[getter]
    fn qdd<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, self.adaptive.qdd())
    }

    /// The last selection: {"active_dofs", "budget_used", "predicted_error", "total_metric"};
    /// predicted_error is the acceleration-metric mass left unselected (the error against
    /// exact dynamics).
    #[getter]
    fn selection<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.adaptive.selection();
        let d = PyDict::new(py);
        d.set_item("active_dofs", s.active_dofs)?;
        d.set_item("budget_used", s.budget_used)?;
        d.set_item("predicted_error", s.predicted_error)?;
        d.set_item("total_metric", s.total_metric)?;
        Ok(d)
    }

    /// Degrees of freedom active now.
    #[getter]
    fn active_dofs(&self) -> usize {
        self.adaptive.active_dofs(&self.model)
    }
}
