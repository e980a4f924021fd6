//! The hybrid body (docs/design.md#adaptive): which joints move, and their accelerations.

use articula_model::{Model, NodeKind};

/// Which assembly-tree nodes are in the active region and the joint accelerations of the last
/// call.
#[derive(Clone, Debug)]
#[repr(C)]
pub(crate) struct HybridBody {
    /// Per node: in the hybrid body's active region (its principal joint moves).
    pub active: Vec<bool>,
    /// The symbol `q̈` (eq. of docs/design.md#adaptive): the joint accelerations of the last call (zero outside the active region).
    pub qdd: Vec<f64>,
}

impl HybridBody {
    /// Every joint of `model` active.
    pub(crate) fn new(model: &Model) -> HybridBody {
        let active = model
            .assembly
            .nodes
            .iter()
            .map(|node| matches!(node.kind, NodeKind::Join { .. }))
            .collect();
        HybridBody {
            active,
            qdd: vec![0.0; model.nv],
        }
    }
}
