//! Why a run ended ([`Stop`], [`StopReason`]) and why a simulation cannot start
//! ([`SimulationError`]).

use super::guard::EnergyStop;
use crate::AdaptiveError;
use articula_dca::{ContactError, DynamicsError};

/// A time for a message, rounded to the nanosecond: 68 steps of 0.05 s read `3.4`, not
/// `3.4000000000000004` (the CLI's and the Python bindings' stop and gimbal messages).
pub fn message_time(t: f64) -> f64 {
    (t * 1e9).round() / 1e9
}

/// Where and why a run ended.
#[derive(Clone, Debug, PartialEq)]
pub struct Stop {
    /// The step that stopped the run (numbered from 1; for [`StopReason::StepsDone`] the last
    /// step done, for [`StopReason::Interrupted`] the step that was not started, for a
    /// recorder that failed at the start 0).
    pub step: u64,
    /// Why.
    pub reason: StopReason,
}

/// Why a run ended.
#[derive(Clone, Debug, PartialEq)]
pub enum StopReason {
    /// Every step asked for was done.
    StepsDone,
    /// The stop flag was raised; the run ended at a step boundary.
    Interrupted,
    /// The step itself failed (a non-finite value naming its joint, a singular inertia, a
    /// contact setting it cannot use, ...).
    StepFailed(StepError),
    /// The exact reference beside an adaptive run failed.
    ReferenceFailed(StepError),
    /// The state after the step holds a non-finite coordinate or velocity.
    NonFiniteState,
    /// The energy balance stopped the run (non-finite, or grown beyond the bound).
    Energy(EnergyStop),
    /// A recorder could not write (the message names the file and the cause).
    RecorderFailed(String),
}

impl StopReason {
    /// Whether the run did every step asked for.
    pub fn is_complete(&self) -> bool {
        matches!(self, StopReason::StepsDone)
    }

    /// A short, stable name: `steps_done`, `interrupted`, `step_failed`, `reference_failed`,
    /// `non_finite_state`, `energy_not_finite`, `energy_diverged`, `recorder_failed`.
    pub fn name(&self) -> &'static str {
        match self {
            StopReason::StepsDone => "steps_done",
            StopReason::Interrupted => "interrupted",
            StopReason::StepFailed(_) => "step_failed",
            StopReason::ReferenceFailed(_) => "reference_failed",
            StopReason::NonFiniteState => "non_finite_state",
            StopReason::Energy(EnergyStop::NotFinite { .. }) => "energy_not_finite",
            StopReason::Energy(EnergyStop::Diverged { .. }) => "energy_diverged",
            StopReason::RecorderFailed(_) => "recorder_failed",
        }
    }
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StopReason::StepsDone => write!(f, "every step done"),
            StopReason::Interrupted => write!(f, "interrupted"),
            StopReason::StepFailed(e) => write!(f, "{e}"),
            StopReason::ReferenceFailed(e) => write!(f, "exact reference: {e}"),
            StopReason::NonFiniteState => write!(f, "the state is not finite"),
            StopReason::Energy(EnergyStop::NotFinite { energy }) => {
                write!(f, "non-finite energy ({energy} J)")
            }
            StopReason::Energy(EnergyStop::Diverged {
                growth,
                bound,
                scale,
            }) => write!(
                f,
                "the energy grew by {growth:.3e} J (E - E0 - work of the applied forces), more \
                 than max_energy_growth {bound} × {scale:.3e} J, the largest energy in play: \
                 the integration diverges"
            ),
            StopReason::RecorderFailed(e) => write!(f, "{e}"),
        }
    }
}

/// The error of one step, from whichever step the run takes.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StepError {
    /// An exact step without contact.
    #[error(transparent)]
    Dynamics(#[from] DynamicsError),
    /// An exact step with contact.
    #[error(transparent)]
    Contact(#[from] ContactError),
    /// An adaptive step, with or without contact.
    #[error(transparent)]
    Adaptive(#[from] AdaptiveError),
}

/// Why a simulation cannot start.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SimulationError {
    /// A setting outside its range (`what` names the option).
    #[error("{what}: {detail}")]
    Invalid {
        /// The option (`dt`, `ground.friction`, `drop`, ...).
        what: &'static str,
        /// What is wrong with it.
        detail: String,
    },
    /// Contact is solved in the semi-implicit Euler step; RK4 was asked for.
    #[error(
        "ground contact needs the semi-implicit Euler integrator (contact is solved in its step)"
    )]
    ContactNeedsEuler,
    /// The floor drop raises the floating base; the model has none.
    #[error("the drop onto the floor needs a floating base")]
    DropNeedsFloatingBase,
    /// The state's size does not match the model's.
    #[error("the state has {found} {what} where the model has {expected}")]
    StateSize {
        /// `q`, `qd`, `tau` or `f_ext`.
        what: &'static str,
        /// The model's size.
        expected: usize,
        /// The state's.
        found: usize,
    },
    /// With ground contact, the body starts deeper inside the floor than
    /// `GroundOptions::max_start_penetration`: the position correction would throw it out
    /// with an energy that no integration can follow.
    #[error(
        "the body starts inside the floor: link {link}'s lowest contact point is {depth:.3} m \
         below the ground (z = {lowest:.3} m against {ground:.3} m; at most {limit} m is \
         allowed at the start): raise the body (the drop onto the floor, or a state above it)"
    )]
    StartsInsideFloor {
        /// The link whose contact sphere is lowest.
        link: String,
        /// Its lowest point's height (m).
        lowest: f64,
        /// The ground's height (m).
        ground: f64,
        /// How deep below the ground it is (m).
        depth: f64,
        /// The allowed depth (m).
        limit: f64,
    },
    /// The adaptive workspace refused its settings or the model.
    #[error(transparent)]
    Adaptive(#[from] AdaptiveError),
    /// The first kinematics or energy of the start state failed.
    #[error(transparent)]
    Dynamics(#[from] DynamicsError),
}
