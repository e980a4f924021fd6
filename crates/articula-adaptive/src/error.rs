//! What can go wrong in an adaptive call ([`AdaptiveError`]).

use articula_dca::DynamicsError;

/// What can go wrong in an adaptive call.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AdaptiveError {
    /// An invalid setting.
    #[error("invalid adaptive setting: {0}")]
    Setting(String),
    /// A dynamics error (dimension, non-finite value naming its joint, singular inertia).
    #[error(transparent)]
    Dynamics(#[from] DynamicsError),
    /// A model adaptive dynamics cannot simulate: one whose assembly tree has a gather node (a
    /// body with more than `articula_model::GATHER_ABOVE` children, docs/design.md#assembly-tree).
    #[error("adaptive dynamics does not support this model: {0}")]
    Unsupported(String),
}
