//! What can go wrong in an adaptive call ([`AdaptiveError`]).

use articula_dca::DynamicsError;

/// What can go wrong in an adaptive call.
#[derive(Debug, thiserror::Error)]
pub enum AdaptiveError {
    /// An invalid setting.
    #[error("invalid adaptive setting: {0}")]
    Setting(String),
    /// A dynamics error (dimension, non-finite value naming its joint, singular inertia).
    #[error(transparent)]
    Dynamics(#[from] DynamicsError),
}
