//! How the adaptive solver chooses its joints ([`Settings`]).

use crate::error::AdaptiveError;
use articula_model::Model;

/// How the adaptive solver chooses its joints.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Maximum number of internal degrees of freedom simulated (a floating base's six are free);
    /// `Some(0)` moves the body as one rigid body. `None`: no limit.
    pub budget: Option<usize>,
    /// Stop selecting when the acceleration-metric mass left in the queue is at most this.
    /// `None` or `Some(0.0)`: no tolerance stop.
    pub tolerance: Option<f64>,
    /// Re-select the hybrid body every this many steps; [`Settings::BALANCED`] (0, the
    /// default) picks [`Settings::balanced_period`] of the model and the budget.
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
            reselect_every: Settings::BALANCED,
            velocity_tolerance: None,
        }
    }
}

impl Settings {
    /// The longest re-selection period of [`Settings::balanced_period`].
    pub const MAX_BALANCED_PERIOD: u64 = 50;

    /// `reselect_every` for the balanced period ([`Settings::balanced_period`] of the
    /// workspace's model and the budget): the default, what `articula simulate` uses unless
    /// `--reselect-every` is given (docs/adaptive.md#defaults).
    pub const BALANCED: u64 = 0;

    /// A re-selection period that keeps re-selecting to a fraction of the time: a
    /// re-selection by [`crate::Reselection::ExactSolve`] costs about one exact solve of the
    /// whole body and its locking impulses (O(n) for n internal degrees of freedom, most of a
    /// DCA step), a step between re-selections one solve over the `budget` active joints, so
    /// the period grows like `n / budget`: `⌈2n / budget⌉`, at most
    /// [`Settings::MAX_BALANCED_PERIOD`] (1 when the budget covers every joint, which
    /// re-selects nothing). The command line's default (docs/adaptive.md#defaults).
    pub fn balanced_period(model: &Model, budget: Option<usize>) -> u64 {
        Self::balanced_for(model.nv - if model.floating_base { 6 } else { 0 }, budget)
    }

    /// [`Settings::balanced_period`] of a body of `internal` internal degrees of freedom.
    fn balanced_for(internal: usize, budget: Option<usize>) -> u64 {
        match budget {
            Some(b) if b < internal => {
                ((2 * internal).div_ceil(b.max(1)) as u64).clamp(1, Self::MAX_BALANCED_PERIOD)
            }
            _ => 1,
        }
    }

    /// The re-selection period on a body of `internal` internal degrees of freedom:
    /// `reselect_every`, or the balanced period for [`Settings::BALANCED`].
    #[inline]
    pub(crate) fn period(&self, internal: usize) -> u64 {
        if self.reselect_every == Self::BALANCED {
            Self::balanced_for(internal, self.budget)
        } else {
            self.reselect_every
        }
    }

    /// Checks the values: a finite non-negative tolerance and velocity tolerance.
    ///
    /// Every step checks them (a workspace may have been built with any settings), so the
    /// check is a few inlined comparisons and the messages are built out of line.
    #[inline]
    pub fn validate(&self) -> Result<(), AdaptiveError> {
        let ok = |t: Option<f64>| t.is_none_or(|t| t >= 0.0 && t.is_finite());
        if ok(self.tolerance) && ok(self.velocity_tolerance) {
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
        } else {
            let t = self.velocity_tolerance.unwrap_or(f64::NAN);
            AdaptiveError::Setting(format!(
                "velocity tolerance must be a finite number ≥ 0, got {t}"
            ))
        }
    }
}

/// How a due re-selection finds the new hybrid body ([`crate::Adaptive::set_reselection`]).
/// Both give the same selection (the metric of a node at its exact handle forces); they differ
/// in cost (docs/adaptive.md#cost).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Reselection {
    /// Through the caches of the rigid subassemblies: O(active region) plus a cache rebuild,
    /// a few hundred times a DCA join, for every node leaving the active region; the first
    /// re-selection builds every cache (O(n), tens of DCA steps). Cheaper only when the
    /// selection barely changes between re-selections.
    Caches,
    /// The default: one exact solve of the whole body (articula-dca's ABA), every node's
    /// metric summed bottom-up, the queue, and the locking impulses: O(n) with the constant
    /// of an ABA pass, nothing cached — cheaper when the selection changes between
    /// re-selections (a falling or swinging body), and a first step of about one DCA step.
    #[default]
    ExactSolve,
}
