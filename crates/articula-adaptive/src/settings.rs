//! How the adaptive solver chooses its joints ([`Settings`]).

use crate::error::AdaptiveError;

/// How the adaptive solver chooses its joints.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Maximum number of internal degrees of freedom simulated (a floating base's six are free);
    /// `Some(0)` moves the body as one rigid body. `None`: no limit.
    pub budget: Option<usize>,
    /// Stop selecting when the acceleration-metric mass left in the queue is at most this.
    /// `None` or `Some(0.0)`: no tolerance stop.
    pub tolerance: Option<f64>,
    /// Re-select the hybrid body every this many steps (at least 1).
    pub reselect_every: u64,
    /// At re-selection, a joint not selected is locked unless this is set and the velocity
    /// metric `V(C)` of its subassembly exceeds it (it then stays in the hybrid body, counted
    /// as active). `None`: every joint not selected is locked.
    pub velocity_tolerance: Option<f64>,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            budget: None,
            tolerance: None,
            reselect_every: 1,
            velocity_tolerance: None,
        }
    }
}

impl Settings {
    /// Checks the values: a finite non-negative tolerance and velocity tolerance, a re-selection
    /// period of at least one step.
    ///
    /// Every step checks them (a workspace may have been built with any settings), so the
    /// check is a few inlined comparisons and the messages are built out of line.
    #[inline]
    pub fn validate(&self) -> Result<(), AdaptiveError> {
        let ok = |t: Option<f64>| t.is_none_or(|t| t >= 0.0 && t.is_finite());
        if ok(self.tolerance) && ok(self.velocity_tolerance) && self.reselect_every != 0 {
            Ok(())
        } else {
            Err(self.invalid())
        }
    }

    /// The error naming the first invalid setting (see [`Settings::validate`]).
    #[cold]
    #[inline(never)]
    fn invalid(&self) -> AdaptiveError {
        let bad = |t: Option<f64>| t.filter(|t| !(*t >= 0.0 && t.is_finite()));
        if let Some(t) = bad(self.tolerance) {
            AdaptiveError::Setting(format!("tolerance must be a finite number ≥ 0, got {t}"))
        } else if let Some(t) = bad(self.velocity_tolerance) {
            AdaptiveError::Setting(format!(
                "velocity tolerance must be a finite number ≥ 0, got {t}"
            ))
        } else {
            AdaptiveError::Setting("reselect_every must be at least 1".into())
        }
    }
}
