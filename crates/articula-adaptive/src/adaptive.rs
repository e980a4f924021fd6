//! The adaptive-dynamics workspace ([`Adaptive`]): settings, step counters and the named parts
//! the passes read and write (`parts/`). Its methods live with the passes that run them: the
//! public calls in `lib.rs` and `scratch.rs`, the main pass in `hybrid.rs`, the metric and
//! selection in `metric.rs`, rigidification in `rigidify.rs`, the hierarchical state in
//! `hierarchy.rs`, the caches in `cache.rs` and `update.rs`, the RK4 step in `rk4.rs`.

use crate::parts::caches::Caches;
use crate::parts::coefficients::HybridCoefficients;
use crate::parts::composites::Composites;
use crate::parts::forces::ExternalForces;
use crate::parts::fresh::FreshKinematics;
use crate::parts::hierarchy::Hierarchy;
use crate::parts::hybrid_body::HybridBody;
use crate::parts::impulse::LockingImpulse;
use crate::parts::join_maps::JoinMaps;
use crate::parts::metric_coefficients::MetricCoefficients;
use crate::parts::pass_scratch::PassScratch;
use crate::parts::rk_buffers::RkBuffers;
use crate::parts::selection_queue::{Selection, SelectionQueue};
use crate::parts::switches::Switches;
use crate::settings::Settings;
use articula_dca::{Data, Threads};
use articula_model::Model;

/// The adaptive-dynamics workspace of one articulated body: the hybrid-body state (which
/// joints are active) and every buffer, beside the immutable [`Model`].
#[derive(Clone, Debug)]
#[repr(C)]
pub struct Adaptive {
    pub(crate) settings: Settings,
    // The fields a step between re-selections reads come first, in this order (`repr(C)`):
    // a crowd's step then touches a few cache lines of each workspace, not seventeen.
    /// Steps counted from the last re-selection (the next at a multiple of the period).
    pub(crate) steps: u64,
    /// Nodes visited by the passes of the last call (the cost measure of adaptive updates).
    pub(crate) touched: usize,
    /// The last selection.
    pub(crate) last: Selection,
    /// External wrenches: sparse, per node, per body.
    pub(crate) forces: ExternalForces,
    /// Which nodes are active, and the joint accelerations.
    pub(crate) body: HybridBody,
    /// Which implementation each pass runs.
    pub(crate) switches: Switches,
    /// The whole-body kinematics a metric query left in `data`, and their state.
    pub(crate) fresh: FreshKinematics,
    /// The reduced tree of active joints and the rigid clusters' frames.
    pub(crate) hier: Hierarchy,
    /// Kinematics of the last call (poses, velocities, subspaces, world inertias).
    pub data: Data,
    /// The articulated coefficients `Φ`, `b` and handle forces `F` of the main pass.
    pub(crate) coef: HybridCoefficients,
    /// The back-substitution maps `q̈ = K F + k`, `f = N F + n` of every join.
    pub(crate) maps: JoinMaps,
    /// The acceleration metric's `Ψ`, `p`, `η` and the metric weights.
    pub(crate) metric: MetricCoefficients,
    /// Every node's composite inertia, ground flag and top body.
    pub(crate) composites: Composites,
    /// The selection's flags, velocity metrics and queue.
    pub(crate) queue: SelectionQueue,
    /// The momenta of a locking impulse.
    pub(crate) impulse: LockingImpulse,
    /// Per-join and per-node scratch of the main and metric passes.
    pub(crate) scratch: PassScratch,
    /// Caches of the rigid subassemblies (adaptive update mechanism, `cache.rs`).
    pub(crate) cache: Caches,
    /// The RK4 step's start values and stage sums (`rk4.rs`), sized at its first call.
    pub(crate) rk: RkBuffers,
    /// The model's internal degrees of freedom (a floating base's six left out): what
    /// [`Settings::BALANCED`] resolves against.
    pub(crate) internal: usize,
    /// The threads a hybrid step of a large active region splits its per-joint sweeps over
    /// ([`Adaptive::set_threads`]; serial by default).
    pub(crate) threads: Threads,
}

impl Adaptive {
    /// Allocates the workspace for `model`. Every joint starts active.
    pub fn new(model: &Model, settings: Settings) -> Adaptive {
        let coef = HybridCoefficients::new(model);
        Adaptive {
            settings,
            steps: 0,
            touched: 0,
            last: Selection::default(),
            forces: ExternalForces::new(model),
            body: HybridBody::new(model),
            switches: Switches::default(),
            fresh: FreshKinematics::new(model),
            // The angles' sines and cosines at full size now: a `_with` call exchanges them
            // with a scratch's, and a body whose first hybrid bodies turn no angle would
            // otherwise grow its own in a later step.
            hier: Hierarchy {
                sc: Vec::with_capacity(model.nv),
                ..Default::default()
            },
            data: Data::new(model),
            maps: JoinMaps::new(model, &coef.layout),
            coef,
            metric: MetricCoefficients::new(model),
            composites: Composites::new(model),
            queue: SelectionQueue::new(model),
            impulse: LockingImpulse::new(model),
            scratch: PassScratch::new(model),
            cache: Caches {
                check_torques: true,
                ..Default::default()
            },
            rk: RkBuffers::default(),
            internal: model.nv - if model.floating_base { 6 } else { 0 },
            threads: Threads::default(),
        }
    }
}
