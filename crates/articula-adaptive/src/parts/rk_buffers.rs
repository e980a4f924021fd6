//! The buffers of the fourth-order Runge–Kutta step of the hybrid body (the step is
//! `Adaptive::step_rk4` in `rk4.rs`).

use articula_model::Model;

/// Start values and stage sums of the RK4 step, over all coordinates (only the active joints'
/// entries are read and written). Empty until the first RK4 step: a workspace stepped by
/// semi-implicit Euler holds none of it.
#[derive(Clone, Debug, Default)]
pub(crate) struct RkBuffers {
    /// `q`, `q̇` at the start of the step (after the re-selection's impulse).
    pub(crate) q_start: Vec<f64>,
    pub(crate) qd_start: Vec<f64>,
    /// `Σ wᵢ` of the stages' position slopes and accelerations (`w = 1, 2, 2, 1`).
    pub(crate) slope_sum: Vec<f64>,
    pub(crate) accel_sum: Vec<f64>,
    /// The Lie-algebra increment that made the current stage's floating pose from `q_start`.
    pub(crate) theta: Vec<f64>,
}

impl RkBuffers {
    /// Sized for `model` (allocates at the first call only).
    pub(crate) fn fit(&mut self, model: &Model) {
        if self.q_start.len() != model.nq || self.qd_start.len() != model.nv {
            self.q_start = vec![0.0; model.nq];
            for v in [
                &mut self.qd_start,
                &mut self.slope_sum,
                &mut self.accel_sum,
                &mut self.theta,
            ] {
                *v = vec![0.0; model.nv];
            }
        }
    }
}
