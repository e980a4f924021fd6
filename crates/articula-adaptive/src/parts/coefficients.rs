//! The hybrid body's articulated coefficients (docs/design.md#dca, docs/design.md#adaptive):
//! per assembly-tree node, `a_h = Σ_k Φ_hk f_k + b_h` over its handles, written bottom-up by
//! the main pass and read top-down by the back-substitution.

use articula_model::{HandleLayout, Model};
use articula_spatial::{Mat6, SpatialForce, SpatialMotion};
use glam::DVec3;

/// The coefficients `Φ`, `b` and the handle forces `F` of every node, in the handle layout of
/// the model's assembly tree.
#[derive(Clone, Debug)]
pub(crate) struct HybridCoefficients {
    /// Where each node's handles (`hoff`) and `Φ` blocks (`boff`) start, and which child
    /// handle each of a join's handles comes from.
    pub layout: HandleLayout,
    /// Per node: its handles' count `nh`.
    pub handles: Vec<usize>,
    /// Per body: the origin of its frame in the computation frame, the point each handle's
    /// vectors are taken about (long bodies keep their digits).
    pub point: Vec<DVec3>,
    /// The symbol `Φ_hk` of docs/design.md#dca (handle-pair blocks, `nh × nh` per node at `boff`; see [`Self::phi_at`]).
    pub phi: Vec<Mat6>,
    /// `b_h`, the bias acceleration of each handle.
    pub bias: Vec<SpatialMotion>,
    /// `f_h`, the force on each handle (top-down, from the back-substitution).
    pub force: Vec<SpatialForce>,
}

impl HybridCoefficients {
    /// Sized for `model`.
    pub(crate) fn new(model: &Model) -> HybridCoefficients {
        let tree = &model.assembly;
        let layout = tree.handle_layout();
        HybridCoefficients {
            handles: tree.nodes.iter().map(|n| n.handles.len()).collect(),
            point: vec![DVec3::ZERO; model.bodies.len()],
            phi: vec![Mat6::ZERO; layout.blocks],
            bias: vec![SpatialMotion::ZERO; layout.handles],
            force: vec![SpatialForce::ZERO; layout.handles],
            layout,
        }
    }

    /// `Φ_hk` of node `n`.
    #[inline]
    pub(crate) fn phi_at(&self, n: usize, h: usize, k: usize) -> &Mat6 {
        &self.phi[self.layout.boff[n] + h * self.handles[n] + k]
    }
}
