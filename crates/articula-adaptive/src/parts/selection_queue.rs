//! The joint selection (docs/design.md#adaptive): the max-priority queue of the acceleration
//! metric, the nodes it chose and the velocity metric that keeps fast joints active.

use articula_model::Model;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// The selection order of every priority queue over nodes: the larger metric first
/// ([`f64::total_cmp`]), ties to the smaller key. A body's own queue keys its nodes by index, a
/// scene's global queue by `(body, node)`, so both pop a body's nodes in the same order.
#[inline]
pub fn selection_order<K: Ord>(metric: f64, key: K, other_metric: f64, other_key: K) -> Ordering {
    metric
        .total_cmp(&other_metric)
        .then_with(|| other_key.cmp(&key))
}

/// A node waiting in the selection queue, ordered by its acceleration metric
/// ([`selection_order`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Entry {
    pub metric: f64,
    pub node: usize,
}

impl PartialEq for Entry {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o).is_eq()
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    fn cmp(&self, o: &Self) -> Ordering {
        selection_order(self.metric, self.node, o.metric, o.node)
    }
}

/// What the last joint selection chose.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Selection {
    /// Degrees of freedom whose accelerations were computed (the floating base's six included).
    pub active_dofs: usize,
    /// Internal degrees of freedom selected (what the budget counts; the floating base is free).
    pub budget_used: usize,
    /// The acceleration-metric mass left in the queue: `Σ q̈ᵀ A q̈` over every joint whose
    /// acceleration was set to zero — the error of this selection against exact DCA.
    pub predicted_error: f64,
    /// The acceleration metric of the whole body, `A(root)`.
    pub total_metric: f64,
}

/// The selection's per-node state and its queue (written by `Adaptive::select`,
/// `Adaptive::velocity_metric` and the cached re-selection).
#[derive(Clone, Debug)]
pub(crate) struct SelectionQueue {
    /// Per node: selected by the last acceleration-metric selection.
    pub selected: Vec<bool>,
    /// Per node: the velocity metric `V(C) = Σ q̇ᵢᵀ Vᵢ q̇ᵢ` of its subassembly.
    pub velocity_metric: Vec<f64>,
    /// Per node: the acceleration metric `A(C)` at the exact handle forces (the exact-solve
    /// re-selection, [`crate::Reselection::ExactSolve`]).
    pub exact_metric: Vec<f64>,
    /// The nodes waiting, by their acceleration metric `A(C)` (top-down).
    pub heap: BinaryHeap<Entry>,
}

impl SelectionQueue {
    /// Sized for `model`'s assembly tree.
    pub(crate) fn new(model: &Model) -> SelectionQueue {
        let nn = model.assembly.nodes.len();
        SelectionQueue {
            selected: vec![false; nn],
            velocity_metric: vec![0.0; nn],
            exact_metric: vec![0.0; nn],
            heap: BinaryHeap::with_capacity(nn),
        }
    }
}
