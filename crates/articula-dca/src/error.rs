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
    /// The workspace was built for another model ([`Data::new`](crate::Data::new) of a model
    /// of other sizes or shape): checked by every entry point before anything is read.
    #[error(
        "this Data was built for another model (the Data's: {data}; the model's: {model}); \
         build one with Data::new(&model)"
    )]
    WrongModel {
        /// The fingerprint of the model the workspace was built for.
        data: String,
        /// The fingerprint of the model given.
        model: String,
    },
    /// A link frame names a body the model does not have (a frame found in another model).
    #[error(
        "this link frame is on body {body}, and the model has {bodies} bodies: find the link \
         with Model::find_link on the model it is used with"
    )]
    WrongLink {
        /// The frame's body.
        body: usize,
        /// The model's bodies.
        bodies: usize,
    },
    /// A dense matrix the call would allocate is larger than its limit
    /// ([`crate::MAX_DENSE_MATRIX_BYTES`]); checked before anything is allocated.
    #[error(
        "the {what} of {rows} × {cols} numbers would take {} ({bytes} bytes), more than the \
         limit of {} ({limit} bytes); DCA and ABA need memory linear in the size of the model",
        human_bytes(*bytes),
        human_bytes(*limit)
    )]
    MatrixTooLarge {
        /// Which matrix (`joint-space inertia matrix`).
        what: &'static str,
        /// Its rows.
        rows: usize,
        /// Its columns.
        cols: usize,
        /// Its size in bytes (`rows × cols × 8`, saturating).
        bytes: u64,
        /// The limit in bytes.
        limit: u64,
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

/// `bytes` in binary units, three significant digits (`80.0 GiB`).
pub fn human_bytes(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["bytes", "KiB", "MiB", "GiB", "TiB"];
    let mut x = bytes as f64;
    let mut u = 0;
    while x >= 1024.0 && u + 1 < UNITS.len() {
        x /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} bytes")
    } else {
        format!("{x:.1} {}", UNITS[u])
    }
}

/// The largest dense `f64` matrix the dynamics layer allocates: 2 GiB, a 16,384 × 16,384
/// joint-space inertia matrix ([`crate::Method::Crba`], [`crate::mass_matrix`]). Larger ones
/// are refused with [`DynamicsError::MatrixTooLarge`] before any allocation (DCA and ABA need memory
/// linear in the size of the model).
pub const MAX_DENSE_MATRIX_BYTES: u64 = 2 << 30;

/// Checks that a dense `rows × cols` matrix of `f64` fits in [`MAX_DENSE_MATRIX_BYTES`].
/// The detail of [`DynamicsError::Singular`] when a multi-DOF joint's own block `Sᵀ X S`
/// fails `joint_block_regular` (articula-spatial): the same test in DCA, ABA and CRBA.
pub(crate) const JOINT_BLOCK_SINGULAR: &str =
    "its axes are dependent (a gimbal lock) or move no mass: a pivot of its Sᵀ I S block \
     is at most 1e-13 of its diagonal (docs/conventions.md, \"Singular configurations\")";

pub(crate) fn check_dense(
    what: &'static str,
    rows: usize,
    cols: usize,
) -> Result<(), DynamicsError> {
    let bytes = (rows as u128 * cols as u128 * 8).min(u64::MAX as u128) as u64;
    if bytes > MAX_DENSE_MATRIX_BYTES {
        return Err(DynamicsError::MatrixTooLarge {
            what,
            rows,
            cols,
            bytes,
            limit: MAX_DENSE_MATRIX_BYTES,
        });
    }
    Ok(())
}
