//! The whole-body kinematics a metric query left in `data`, reused by the next load of the
//! same state.

use articula_model::Model;

/// Whether `data` holds the whole-body kinematics of `(q, qd)` (set by
/// `Adaptive::node_metrics`, cleared by every other writer of `data`).
#[derive(Clone, Debug)]
pub(crate) struct FreshKinematics {
    /// `data`'s kinematics are those of `(q, qd)`.
    pub valid: bool,
    /// The symbol `q` (joint positions) of the state they were computed for.
    pub q: Vec<f64>,
    /// The symbol `q̇` (joint velocities) of that state.
    pub qd: Vec<f64>,
}

impl FreshKinematics {
    /// Sized for `model`, holding nothing.
    pub(crate) fn new(model: &Model) -> FreshKinematics {
        FreshKinematics {
            valid: false,
            q: vec![0.0; model.nq],
            qd: vec![0.0; model.nv],
        }
    }
}
