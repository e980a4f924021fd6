//! The buffers of a locking impulse (docs/design.md#adaptive, rigidification): joints leaving
//! the hybrid body are stopped by internal impulses that keep the body's spatial momentum.

use articula_model::Model;
use articula_spatial::SpatialForce;

/// What a locking impulse writes and then reads within one call.
#[derive(Clone, Debug)]
pub(crate) struct LockingImpulse {
    /// Per degree of freedom: the generalized momentum `sᵢᵀ h_sub(i)`.
    pub momenta: Vec<f64>,
    /// Per body: the spatial momentum of its subtree `h_sub(i) = Σ I_j v_j`.
    pub subtree: Vec<SpatialForce>,
}

impl LockingImpulse {
    /// Sized for `model`.
    pub(crate) fn new(model: &Model) -> LockingImpulse {
        LockingImpulse {
            momenta: vec![0.0; model.nv],
            subtree: vec![SpatialForce::ZERO; model.bodies.len()],
        }
    }
}
