//! The split of a large hybrid step over the independent subtrees of its reduced tree
//! ([`Subtrees`], found with the records at each re-selection), and where a run of records'
//! workspace starts ([`Base`], [`Chain`]). The passes that use them are in `hierarchy.rs`
//! (docs/scaling.md).

use articula_spatial::{SpatialMotion, SpatialTransform};

/// The smallest reduced tree (active joints) whose hybrid step ([`crate::Adaptive::set_threads`])
/// splits its per-joint sweeps — the angles' sines and cosines and pass 1 of the
/// articulated-body algorithm (each cluster's inertia and bias force) — across threads, and,
/// on a branched reduced tree, its recursions too (the active kinematics and passes 2 and 3
/// over independent subtrees of the reduced tree): below it waking the pool costs more than the
/// share of the step those sweeps save, and the serial loops run whatever the thread count.
/// Measured on two cores (docs/scaling.md).
pub const PARALLEL_HYBRID_MIN_JOINTS: usize = 10_000;

/// Where a run of records' workspace starts: its first record and that record's first slot
/// in `U`/`u`, first velocity coordinate and body. A slice of the workspace from `at` is
/// indexed by `record − at.rec`, `dof − at.dof`, `vo − at.vo`, `body − at.body` (zero: the
/// whole workspace).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Base {
    pub(crate) record: usize,
    pub(crate) first_dof: usize,
    pub(crate) v_offset: usize,
    pub(crate) body: usize,
}

impl Base {
    pub(crate) const ZERO: Base = Base {
        record: 0,
        first_dof: 0,
        v_offset: 0,
        body: 0,
    };
}

/// Pass 3's state after a one-degree-of-freedom record (`pidx`: its index; `usize::MAX`
/// after any other record, which no `pidx` equals: [`NO_PARENT`] is `u32::MAX`): its `a'`,
/// `S` and `q̈`, kept in locals for a child that follows it (on a chain, every record).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Chain {
    pub(crate) pidx: usize,
    /// The record's acceleration `a'` (relative to gravity).
    pub(crate) accel: [f64; 6],
    /// The record's motion-subspace column `S`.
    pub(crate) subspace: [f64; 6],
    /// The record's joint acceleration `q̈`.
    pub(crate) qdd: f64,
}

impl Chain {
    pub(crate) const NONE: Chain = Chain {
        pidx: usize::MAX,
        accel: [0.0; 6],
        subspace: [0.0; 6],
        qdd: 0.0,
    };
}

impl Default for Chain {
    fn default() -> Chain {
        Chain::NONE
    }
}

/// The reduced tree's independent subtrees that passes 2 and 3 of a large hybrid step run on
/// the threads ([`crate::Adaptive::set_threads`]), found with the records (once per re-selection).
///
/// The records are the active bodies in body order, a depth-first pre-order (parents first),
/// so a record's subtree is the run of records from it. The subtrees taken are the largest of
/// at most half the records and at least `SUBTREE_MIN_RECORDS` (1,024, `hierarchy.rs`, where they are found); the records outside them
/// (the "top": on a chain, every record above the last half) run serially. Pass 2 runs each
/// subtree below its root on a task, then the top records and the subtrees' roots serially in
/// the serial order (descending record index), so every parent's `Iᴬ`, `pᴬ` receives its
/// children's terms in the serial order; pass 3 runs the top serially, then each subtree on a
/// task from its root's parent's acceleration. Every record's arithmetic is the serial loop's:
/// the same bits for any thread count.
///
/// A chain has no independent subtrees (ABA's passes are one recursion along it): its passes
/// 2 and 3 stay serial.
#[derive(Clone, Debug, Default)]
#[cfg_attr(not(feature = "parallel"), allow(dead_code))]
pub(crate) struct Subtrees {
    /// Ascending and disjoint.
    pub(crate) tasks: Vec<Subtree>,
    /// Per record, the records in its subtree (while finding them).
    pub(crate) size: Vec<u32>,
}

/// One subtree of [`Subtrees`]: the records `start..end` (`start` its root, whose parent is a
/// top record or none), where its workspace starts, and what pass 3 starts it from (written
/// by the serial part of each step).
#[derive(Clone, Copy, Debug, Default)]
#[cfg_attr(not(feature = "parallel"), allow(dead_code))]
pub(crate) struct Subtree {
    pub(crate) start: usize,
    pub(crate) stop: usize,
    pub(crate) base: Base,
    /// Pass 3's [`Chain`] after the record before `start`.
    pub(crate) entry: Chain,
    /// The acceleration of the root's parent (−a_g for none).
    pub(crate) root: [f64; 6],
    /// The angles (`Hierarchy::angles`) before `start` and before `end`.
    pub(crate) angle_start: usize,
    pub(crate) angle_stop: usize,
    /// No record of the subtree takes the general kinematics path
    /// (`articula_dca::body_kinematics`, which writes the subspace columns in
    /// place): its kinematics may run on a task.
    pub(crate) kin_on_task: bool,
    /// The pose and velocity of the root's parent body (written by the serial part of the
    /// kinematics of each step).
    pub(crate) kin_root: (SpatialTransform, SpatialMotion),
}
