//! What one adaptive step did ([`StepReport`]).

/// What one adaptive step did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Whether the hybrid body was re-selected this step.
    pub reselected: bool,
    /// Whether joints were locked (rigidified) this step.
    pub rigidified: bool,
    /// Degrees of freedom in the hybrid body's active region (simulated this step).
    pub active_dofs: usize,
    /// The last selection's predicted acceleration-metric error.
    pub predicted_error: f64,
    /// Assembly-tree nodes the step's passes visited (the cost of adaptive updates).
    pub nodes_touched: usize,
}
