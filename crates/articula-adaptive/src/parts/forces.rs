//! The external wrenches of a call (docs/design.md#adaptive): sparse as given, summed per
//! assembly-tree node for the hybrid step, dense per body for a whole-body pass.

use articula_model::Model;
use articula_spatial::SpatialForce;

/// External wrenches in the forms the passes read. (The step between re-selections reads the
/// first two: they come first.)
#[derive(Clone, Debug)]
#[repr(C)]
pub(crate) struct ExternalForces {
    /// Per node: the sum of the external wrenches on its bodies (computation frame; `Σ f_ext`
    /// of the composite, see `Composites`).
    pub node_sums: Vec<SpatialForce>,
    /// The current step's wrenches, sparse `(body, world wrench)`.
    pub sparse: Vec<(usize, SpatialForce)>,
    /// Per body: its wrench in the computation frame (filled by a whole-body load).
    pub computation: Vec<SpatialForce>,
    /// Per body: the dense wrench array of a whole-body pass built from `sparse`.
    pub dense: Vec<SpatialForce>,
}

impl ExternalForces {
    /// Sized for `model`.
    pub(crate) fn new(model: &Model) -> ExternalForces {
        let nb = model.bodies.len();
        ExternalForces {
            node_sums: vec![SpatialForce::ZERO; model.assembly.nodes.len()],
            sparse: Vec::new(),
            computation: Vec::with_capacity(nb),
            dense: vec![SpatialForce::ZERO; nb],
        }
    }
}
