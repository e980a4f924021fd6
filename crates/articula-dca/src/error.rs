//! Errors of the dynamics layer.

use thiserror::Error;

/// What can go wrong in a dynamics call. Non-finite values are caught before and after every
/// solve and name the joint or body, so a NaN never travels silently through a trajectory.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DynamicsError {
    /// A vector has the wrong length.
    #[error("{what} has length {found}, the model needs {expected}")]
    Dimension {
        /// Which vector (`q`, `qd`, `tau`, `f_ext`).
        what: &'static str,
        /// The model's size.
        expected: usize,
        /// The length given.
        found: usize,
    },
    /// A NaN or infinite value in an input or a result.
    #[error("non-finite {what} at {name}")]
    NonFinite {
        /// Which quantity (`q`, `qd`, `tau`, `external force`, `qdd`, ...).
        what: &'static str,
        /// The URDF joint (inputs and accelerations) or body (forces) it belongs to.
        name: String,
    },
    /// A matrix that must be positive definite is not (a body without inertia, or a joint whose
    /// motion moves no mass).
    #[error("singular dynamics at joint {joint}: {detail}")]
    Singular {
        /// The joint.
        joint: String,
        /// What failed.
        detail: &'static str,
    },
    /// A model too large for a workspace's indices (DCA stores 32-bit ones).
    #[error("{what} needs {size} entries, above the limit of {limit}")]
    TooLarge {
        /// What is too large.
        what: &'static str,
        /// Its size.
        size: usize,
        /// The largest size supported.
        limit: usize,
    },
}
