//! The back-substitution maps of the main pass (docs/design.md#dca, docs/design.md#adaptive):
//! per join node the joint accelerations and the joint force as affine maps of its handle
//! forces, and the bias maps of one join that the cache builds record.

use articula_model::{HandleLayout, Model, NodeKind};

/// The bias maps of one join (docs/design.md#dca), recorded by `Adaptive::join` when
/// [`JoinMaps::record`] is set (cache builds): `k = κ_β β + κ_Q Q` and
/// `n = γ = ν_β β + ν_Q Q`, computation-frame axes (docs/adaptive.md#caches).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct BiasMaps {
    /// The symbol `κ_β` of `k = κ_β β + κ_Q Q` (nv × 6).
    pub kappa_beta: [[f64; 6]; 6],
    /// The symbol `κ_Q` of `k = κ_β β + κ_Q Q` (nv × nv).
    pub kappa_q: [[f64; 6]; 6],
    /// The symbol `ν_β` of `n = γ = ν_β β + ν_Q Q` (6 × 6).
    pub nu_beta: [[f64; 6]; 6],
    /// The symbol `ν_Q` of `n = γ = ν_β β + ν_Q Q` (6 × nv).
    pub nu_q: [[f64; 6]; 6],
}

/// Per join node, what the back-substitution reads: `q̈ = K F + k` and the joint force on B
/// `f = N F + n` in terms of the node's handle forces `F` (written by the main pass's joins).
#[derive(Clone, Debug)]
pub(crate) struct JoinMaps {
    /// `K` (nv × 6nh, row-major) of every join node, at [`JoinMaps::qdd_gain_at`].
    pub qdd_gain: Vec<f64>,
    /// Per node: where its `K` starts in [`JoinMaps::qdd_gain`].
    pub qdd_gain_at: Vec<usize>,
    /// `k`, per degree of freedom (at the joint's velocity offset).
    pub qdd_bias: Vec<f64>,
    /// `N` (6 × 6nh, row-major) of every join node, at `36 hoff` (the node's first handle).
    pub force_gain: Vec<f64>,
    /// `n`, per node.
    pub force_bias: Vec<[f64; 6]>,
    /// Record the bias maps of every join into [`JoinMaps::recorded`] (cache builds).
    pub record: bool,
    /// The bias maps of the last join computed while [`JoinMaps::record`] was set.
    pub recorded: BiasMaps,
}

impl JoinMaps {
    /// Sized for `model` and its handle layout.
    pub(crate) fn new(model: &Model, lay: &HandleLayout) -> JoinMaps {
        let tree = &model.assembly;
        let mut qdd_gain_at = Vec::with_capacity(tree.nodes.len());
        let mut at = 0;
        for node in &tree.nodes {
            qdd_gain_at.push(at);
            if let NodeKind::Join { joint, .. } = node.kind {
                at += model.bodies[joint].nv * 6 * node.handles.len();
            }
        }
        JoinMaps {
            qdd_gain: vec![0.0; at],
            qdd_gain_at,
            qdd_bias: vec![0.0; model.nv],
            force_gain: vec![0.0; 36 * lay.handles],
            force_bias: vec![[0.0; 6]; tree.nodes.len()],
            record: false,
            recorded: BiasMaps::default(),
        }
    }
}
