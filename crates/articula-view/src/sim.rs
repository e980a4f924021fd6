//! Scene stepping: one global priority queue over every body's assembly tree spends one
//! scene-wide budget of joints where the view-weighted acceleration metric is largest.
//!
//! At every re-selection (every `reselect_every` steps, the first included):
//! 1. each body gets its exact solve ([`Adaptive::exact_solve`]: its exact accelerations, and
//!    kinematics from which its link poses are read) — except a body whose whole bounding
//!    sphere, grown by how far it can move before the next re-selection, lies outside the view:
//!    its links are all invisible, so it gets only its pose-only kinematics;
//! 2. the camera classifies every link ([`crate::visibility`]) and gives every joint of every
//!    body its weight `wᵢ` (the acceleration-metric weight `Aᵢ = wᵢ 1`); each body with a
//!    non-zero weight computes the metric `A(C)` of every node of its assembly tree at the
//!    exact handle forces from its solve ([`Adaptive::scaled_node_metrics`], the same numbers
//!    as [`Adaptive::node_metrics`] with those weights) — the values its own queue would see,
//!    since a queued node's ancestors are all expanded exactly;
//! 3. the global queue runs over all bodies' roots: pop the node with the largest metric in the
//!    whole scene, push its children, until the budget of internal degrees of freedom (the
//!    floating bases' six are free) or the tolerance is reached. Each body's popped nodes are a
//!    prefix of its own pop order (its share, as its own budget, would make its own queue
//!    choose exactly them), so each body runs its own queue to its end across threads
//!    ([`OwnQueue`]) and one merge of their pop sequences makes the global choice
//!    ([`merge_own_queues`]: the same pops as one queue over every node);
//! 4. each body whose active joints are not exactly the ones the queue chose gets them
//!    ([`Adaptive::set_active`]: the joints that leave the hybrid body are locked by
//!    momentum-keeping impulses); the others keep their hybrid body as it is. A body whose joints are all locked moves as one
//!    rigid body (invisible bodies: the exact rigid motion of the whole).
//!
//! Nodes of metric 0 are never selected: invisible bodies (all weights 0) keep no joint even
//! with budget to spare.
//!
//! A scene split by body over processes ([`SceneShard`]) runs the same passes on each shard,
//! the depth buffers and the merge of step 3 done by a driver between them (`shard.rs`).

mod culling;
mod exact;
mod shard;
mod springs;
mod view_error;

use crate::error::ViewError;
use crate::render::{rigid_groups, FrameBody};
use crate::scene_file::LoadedScene;
use crate::visibility::{BodyView, Classifier, Placed, PosePlan, Visibility};
use crate::volumes::BodyVolumes;
use articula_adaptive::{Adaptive, AdaptiveError, HybridContact, HybridScratch, Scratch, Settings};
use articula_dca::{ContactSettings, ContactStats, DynamicsError, State, Threads};
use articula_model::{JointKind, Model, NodeKind};
use articula_spatial::{SpatialForce, SpatialInertia, SpatialMotion, SymMat6};
pub use exact::SceneMethod;
use glam::{DMat3, DQuat, DVec3};
pub use shard::{
    combine_state_hashes, combine_steps, merge_candidates, merge_depths, Candidate, Candidates,
    DepthMessage, SceneShard, ShardRange, ShardStep,
};
pub use springs::pose_springs;
use std::collections::BinaryHeap;
use std::sync::Mutex;
pub use view_error::ViewDeviation;

/// A node of some body in the global queue.
#[derive(Clone, Copy, Debug)]
struct Entry {
    metric: f64,
    body: usize,
    node: usize,
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
    // Largest metric first; ties to the smaller body, then the smaller node: a body's own
    // queue's order (`articula_adaptive::selection_order`) keyed by `(body, node)`.
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        articula_adaptive::selection_order(
            self.metric,
            (self.body, self.node),
            o.metric,
            (o.body, o.node),
        )
    }
}

/// What the global queue chose.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct GlobalSelection {
    /// Per body: internal degrees of freedom selected (its share of the budget).
    pub allocation: Vec<usize>,
    /// Per body: the metric mass left unselected (its error against exact dynamics).
    pub error: Vec<f64>,
    /// Σ of `error`: the scene's total weighted error.
    pub total_error: f64,
    /// Σ of `allocation`.
    pub used: usize,
    /// Per body: the join nodes popped (its floating base's root included), in pop order.
    pub popped: Vec<Vec<usize>>,
}

/// The global queue over the assembly trees of `models[b]` with node metrics `metrics[b]`
/// (one per node, from [`Adaptive::node_metrics`]; empty for a body whose weights are all 0).
/// Floating bases' root joints are free; every other join costs its degrees of freedom.
/// Stops when the next node does not fit in `budget`, when the metric mass left is at most
/// `tolerance` (0 or `None`: no tolerance stop), or when only nodes of metric ≤ 0 are left.
#[cfg(test)]
pub(crate) fn global_selection(
    models: &[&Model],
    metrics: &[&[f64]],
    budget: Option<usize>,
    tolerance: Option<f64>,
) -> GlobalSelection {
    let mut heap = BinaryHeap::new();
    let own: Vec<OwnQueue> = models
        .iter()
        .zip(metrics)
        .map(|(m, x)| {
            let mut q = OwnQueue::default();
            q.run(m, x, &mut heap);
            q
        })
        .collect();
    let mut sel = GlobalSelection::default();
    merge_own_queues(
        &mut sel,
        &mut heap,
        own.len(),
        |b| &own[b],
        budget,
        tolerance,
    );
    for b in 0..models.len() {
        let mut chosen = vec![false; models[b].assembly.nodes.len()];
        for &n in &sel.popped[b] {
            chosen[n] = true;
        }
        sel.error[b] = frontier_error(models[b], metrics[b], &sel.popped[b], &chosen);
    }
    sel.total_error = sel.error.iter().sum();
    sel
}

/// One body's own queue over its assembly tree, run to its end: the nodes it pops in order,
/// each with its metric, its cost and the metrics of the children it queues — what the
/// global queue needs of this body. The global queue's top is always the largest of the
/// bodies' own tops (the same order: largest metric, ties to the smaller body, then node),
/// and a body's own queue changes only when one of its nodes is popped, so the global pops
/// are exactly a merge of the bodies' own pop sequences, each taken as a prefix
/// ([`merge_own_queues`]). Each body's run is independent of the others: the bodies' runs go
/// across threads.
#[derive(Clone, Debug, Default)]
struct OwnQueue {
    /// Whether the root is a join (else the body has nothing to select).
    joined: bool,
    /// A floating base's root: popped for free, first.
    free_root: Option<usize>,
    /// Its root's contribution to the metric mass left: the root's metric, or for a floating
    /// base (whose root is free) the sum of its children's.
    init: f64,
    /// Its pops, in order (only nodes of metric > 0, or NaN).
    pops: Vec<OwnPop>,
}

#[derive(Clone, Copy, Debug)]
struct OwnPop {
    metric: f64,
    node: usize,
    /// Its joint's degrees of freedom.
    cost: usize,
    /// The sum of its join children's metrics (queued or not: the mass they add).
    added: f64,
}

impl OwnQueue {
    /// The queue of one body of `model` with node metrics `metrics` (empty: all 0), `heap` its
    /// scratch (cleared first).
    fn run(&mut self, model: &Model, metrics: &[f64], heap: &mut BinaryHeap<Entry>) {
        self.pops.clear();
        self.init = 0.0;
        self.free_root = None;
        heap.clear();
        let tree = &model.assembly;
        let root = tree.root();
        self.joined = matches!(tree.nodes[root].kind, NodeKind::Join { .. });
        if !self.joined {
            return;
        }
        // Queues a node; returns its metric (for the mass left). A node of metric ≤ 0 is never
        // popped (the queue stops at the first one) and adds nothing to the error: it is
        // counted in the mass left but not queued (a NaN is queued).
        let push = |heap: &mut BinaryHeap<Entry>, node: usize| -> f64 {
            let metric = metrics.get(node).copied().unwrap_or(0.0);
            if metric > 0.0 || metric.is_nan() {
                heap.push(Entry {
                    metric,
                    body: 0,
                    node,
                });
            }
            metric
        };
        // Queues a join's children that are joins; returns the sum of their metrics.
        let push_children = |heap: &mut BinaryHeap<Entry>, node: usize| -> f64 {
            let mut added = 0.0;
            if let NodeKind::Join {
                parent_side,
                child_side,
                ..
            } = tree.nodes[node].kind
            {
                for c in [parent_side, child_side] {
                    if matches!(tree.nodes[c].kind, NodeKind::Join { .. }) {
                        added += push(heap, c);
                    }
                }
            }
            added
        };
        self.init = if model.floating_base {
            // Free: expanded at once.
            self.free_root = Some(root);
            push_children(heap, root)
        } else {
            push(heap, root)
        };
        while let Some(top) = heap.peek().copied() {
            if top.metric <= 0.0 {
                break;
            }
            heap.pop();
            let NodeKind::Join { joint, .. } = tree.nodes[top.node].kind else {
                unreachable!("only joins are queued")
            };
            let added = push_children(heap, top.node);
            self.pops.push(OwnPop {
                metric: top.metric,
                node: top.node,
                cost: model.bodies[joint].nv,
                added,
            });
        }
    }
}

/// The global queue over bodies `0..n` from their own queues `own(b)` ([`OwnQueue`]), into
/// `sel` (its allocation, popped nodes and budget used; `heads` holds each body's next pop).
/// Pops the largest head in the scene, until the next one does not fit in `budget`, the mass
/// left is at most `tolerance` (0 or `None`: no tolerance stop), or no body has a pop left
/// (only nodes of metric ≤ 0 are left). The mass left is summed in the order the one global
/// queue sums it (each body's root, then per pop its metric out and its children's in), so
/// the tolerance stops at the same pop. Both buffers are cleared first and reused, so that a
/// scene's re-selection allocates nothing once they have grown.
fn merge_own_queues<'q>(
    sel: &mut GlobalSelection,
    heads: &mut BinaryHeap<Entry>,
    n: usize,
    own: impl Fn(usize) -> &'q OwnQueue,
    budget: Option<usize>,
    tolerance: Option<f64>,
) {
    sel.allocation.clear();
    sel.allocation.resize(n, 0);
    sel.error.clear();
    sel.error.resize(n, 0.0);
    sel.popped.truncate(n);
    sel.popped.iter_mut().for_each(Vec::clear);
    sel.popped.resize_with(n, Vec::new);
    sel.total_error = 0.0;
    sel.used = 0;
    heads.clear();
    let head = |b: usize, k: usize| {
        own(b).pops.get(k).map(|p| Entry {
            metric: p.metric,
            body: b,
            node: p.node,
        })
    };
    let mut remaining = 0.0;
    for b in 0..n {
        let q = own(b);
        if !q.joined {
            continue;
        }
        if let Some(root) = q.free_root {
            sel.popped[b].push(root);
        }
        remaining += q.init;
        heads.extend(head(b, 0));
    }
    let tol = tolerance.filter(|t| *t > 0.0);
    while let Some(&top) = heads.peek() {
        if top.metric <= 0.0 || tol.is_some_and(|t| remaining <= t) {
            break;
        }
        // The body's pops taken so far (after its free root).
        let q = own(top.body);
        let k = sel.popped[top.body].len() - usize::from(q.free_root.is_some());
        let pop = q.pops[k];
        if budget.is_some_and(|b| sel.used + pop.cost > b) {
            break;
        }
        heads.pop();
        remaining -= top.metric;
        sel.used += pop.cost;
        sel.allocation[top.body] += pop.cost;
        sel.popped[top.body].push(top.node);
        remaining += pop.added;
        heads.extend(head(top.body, k + 1));
    }
}

/// Body `model`'s error after the global queue popped `popped` (`chosen`: the popped nodes,
/// marked per node): the metric mass of its frontier — the root when unpopped, and each popped
/// join's children that are joins not popped — `Σ max(metric, 0)` in the order of `popped`
/// (`metrics` empty: all 0). The mass the global queue leaves in its heap for this body.
fn frontier_error(model: &Model, metrics: &[f64], popped: &[usize], chosen: &[bool]) -> f64 {
    let tree = &model.assembly;
    let metric = |n: usize| metrics.get(n).copied().unwrap_or(0.0).max(0.0);
    let root = tree.root();
    let mut error = 0.0;
    if !matches!(tree.nodes[root].kind, NodeKind::Join { .. }) {
        return error;
    }
    if popped.is_empty() {
        error += metric(root);
    }
    for &n in popped {
        if let NodeKind::Join {
            parent_side,
            child_side,
            ..
        } = tree.nodes[n].kind
        {
            for c in [parent_side, child_side] {
                if matches!(tree.nodes[c].kind, NodeKind::Join { .. }) && !chosen[c] {
                    error += metric(c);
                }
            }
        }
    }
    error
}
/// One body of a running scene.
#[derive(Clone, Debug)]
pub struct SimBody {
    /// Index into the scene's models.
    pub model: usize,
    /// Its state. Its `f_ext` stays empty: the external wrenches of the step are in
    /// [`SimBody::forces`].
    pub state: State,
    /// The external wrenches acting at this step, `(model body, world wrench about the world
    /// origin)`, one entry per pushed link (a list: nothing scans or clears a dense array of
    /// every body's links each step).
    pub forces: Vec<(usize, SpatialForce)>,
    /// Its adaptive workspace.
    pub adaptive: Adaptive,
    /// World pose of every model body (at the last re-selection or render).
    pub poses: Vec<(DMat3, DVec3)>,
    /// Internal degrees of freedom active now.
    pub active: usize,
    /// Its share of the budget at the last re-selection.
    pub allocation: usize,
    /// Its error (weighted metric left unselected) at the last re-selection.
    pub error: f64,
    /// Whether every joint weight was 0 at the last re-selection.
    pub unweighted: bool,
    /// While every internal joint is locked: the whole body's spatial inertia and its inverse
    /// in the root frame, so that it steps as one rigid body without the adaptive workspace.
    pub rigid: Option<(SpatialInertia, SymMat6)>,
    /// Whether its hybrid body was set at this step's re-selection.
    changed: bool,
    /// Whether this re-selection's exact solve ran (a body surely outside the view skips it:
    /// its weights are all 0).
    solved: bool,
    /// Its assembly tree's node metrics at the last re-selection (empty when unweighted).
    metrics: Vec<f64>,
    /// The scene's pushes on this body, in the scene's order.
    pushes: Vec<PushSlot>,
    /// Its own queue at the last re-selection (its share of the global queue's work).
    own: OwnQueue,
    /// With a floor: its contact workspace (the last step's figures in
    /// `contact.contact.stats`).
    pub contact: Option<HybridContact>,
}

/// One of the scene's pushes on a body: where its point was when it last acted (the work of
/// that step is added once the point has moved) and the work found at this step.
#[derive(Clone, Debug)]
struct PushSlot {
    /// Its index in the scene's pushes.
    push: usize,
    from: Option<DVec3>,
    work: Option<f64>,
}

impl SimBody {
    /// This step's external wrenches (`forces`) from the pushes acting at time `t`, and the
    /// work of the pushes that acted at the last step, into their slots (`plan`: its model's
    /// pose plan).
    fn set_pushes(&mut self, scene: &LoadedScene, plan: &PosePlan, t: f64) {
        self.forces.clear();
        let model = &scene.models[self.model].model;
        for slot in &mut self.pushes {
            let p = &scene.pushes[slot.push];
            let acts = p.t0 <= t && t < p.t1;
            if !acts && slot.from.is_none() {
                continue;
            }
            // The pushed point alone (carried up its link's root path).
            let at = plan.point(model, &self.state.q, p.link_body, p.point);
            // The work of the last step it acted: its force times its point's displacement.
            if let Some(from) = slot.from.take() {
                slot.work = Some(p.force.dot(at - from));
            }
            if !acts {
                continue;
            }
            slot.from = Some(at);
            let w = SpatialForce::new(at.cross(p.force), p.force);
            // One entry per link, in link order (as a scan of a dense array would list them).
            match self.forces.binary_search_by_key(&p.link_body, |e| e.0) {
                Ok(k) => self.forces[k].1 += w,
                Err(k) => self.forces.insert(k, (p.link_body, w)),
            }
        }
    }

    /// The composite spatial inertia of the whole body in its root frame, in its current
    /// configuration.
    fn composite_in_root(
        &mut self,
        model: &Model,
        plan: &PosePlan,
    ) -> Option<(SpatialInertia, SymMat6)> {
        if !model.floating_base {
            return None;
        }
        plan.poses(model, &self.state.q, &mut self.poses);
        let (r0, p0) = self.poses[0];
        let mut total = SpatialInertia::ZERO;
        for (body, &(r, p)) in model.bodies.iter().zip(&self.poses) {
            let rr = r0.transpose() * r;
            let pr = r0.transpose() * (p - p0);
            let i = &body.inertia;
            total += SpatialInertia::new(
                i.mass,
                rr * i.com() + pr,
                rr * i.inertia_about_com() * rr.transpose(),
            );
        }
        total.inverse().map(|inv| (total, inv))
    }

    /// One semi-implicit Euler step of the whole body as one rigid body (every internal joint is
    /// locked with zero velocity): `I a = f − v ×* I v` in root coordinates (gravity at the
    /// centre of mass, the external wrenches), `v ← v + h a`, `q ← q ⊕ h v`. The same motion the
    /// adaptive step gives a body with no active joint, in O(1) instead of O(n).
    fn rigid_step(&mut self, model: &Model, gravity: DVec3, dt: f64) -> Result<(), DynamicsError> {
        let (inertia, inv) = self.rigid.expect("rigid_step on a rigid body");
        let q = &self.state.q;
        let rot = DMat3::from_quat(DQuat::from_xyzw(q[4], q[5], q[6], q[3]).normalize());
        let p0 = DVec3::new(q[0], q[1], q[2]);
        let gb = rot.transpose() * gravity;
        let fw = self
            .forces
            .iter()
            .fold(SpatialForce::ZERO, |a, (_, f)| a + *f);
        // World wrench about the world origin → root coordinates about the root origin.
        let n = rot.transpose() * (fw.n - p0.cross(fw.f));
        let f = SpatialForce::new(
            inertia.h.cross(gb) + n,
            gb * inertia.mass + rot.transpose() * fw.f,
        );
        let qd = &self.state.qd;
        let v = SpatialMotion::new(
            DVec3::new(qd[0], qd[1], qd[2]),
            DVec3::new(qd[3], qd[4], qd[5]),
        );
        let h = inertia.mul_motion(v);
        // v ×* h = [ω × n + v × f; ω × f]
        let bias = SpatialForce::new(v.w.cross(h.n) + v.v.cross(h.f), v.w.cross(h.f));
        let a = inv.force_to_motion(f - bias);
        let v = SpatialMotion::new(v.w + a.w * dt, v.v + a.v * dt);
        self.state.qd[..6].copy_from_slice(&v.to_array());
        // Only the floating root moves: every internal joint has q̇ = 0 exactly, so the
        // whole-model update would leave its coordinates as they are.
        match model.bodies[0].joint.first() {
            Some(root) if root.kind == JointKind::Floating => {
                let (qo, vo) = (root.q_offset, root.v_offset);
                articula_dca::integrate_floating(
                    &mut self.state.q[qo..qo + 7],
                    &self.state.qd[vo..vo + 6],
                    dt,
                );
            }
            _ => articula_dca::integrate_q(model, &mut self.state.q, &self.state.qd, dt),
        }
        if self.state.q[..7]
            .iter()
            .chain(&self.state.qd[..6])
            .all(|x| x.is_finite())
        {
            Ok(())
        } else {
            Err(DynamicsError::NonFinite {
                what: "floating-base state after a rigid step",
                name: model.bodies[0].joint_name().to_string(),
            })
        }
    }
}

/// What one scene step did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneStep {
    /// Whether visibility and joints were re-selected.
    pub reselected: bool,
    /// Internal degrees of freedom active, summed over bodies.
    pub active_total: usize,
    /// Bodies per visibility class (visible, occluded, invisible).
    pub classes: [usize; 3],
    /// Links per visibility class.
    pub link_classes: [usize; 3],
    /// The scene's total weighted error at the last re-selection.
    pub total_error: f64,
    /// With a floor: contact points pushed by it, summed over bodies.
    pub contacts: usize,
    /// With a floor: the deepest penetration at the start of the step over every body (m).
    pub max_penetration: f64,
    /// With a floor: the bodies whose contact problem had rows this step.
    pub contact_solves: usize,
    /// With a floor: of those, the bodies whose solve ended at its iteration cap
    /// (`LoadedScene::contact_settings`) instead of meeting its tolerance: their impulses are
    /// feasible (never pulling, inside the friction discs) but leave some residual approach
    /// or slip velocity.
    pub contact_capped: usize,
    /// With a floor: rows of the contact problems (`ContactStats::rows`), summed over the
    /// bodies of `contact_solves`.
    pub contact_rows: usize,
    /// With a floor: Gauss–Seidel sweeps (`ContactStats::iterations`), summed over the bodies
    /// of `contact_solves`.
    pub contact_sweeps: usize,
}

/// A scene being simulated.
pub struct SceneSim<'s> {
    /// The scene.
    pub scene: &'s LoadedScene,
    /// The bodies, as placed.
    pub bodies: Vec<SimBody>,
    /// What the camera saw at the last re-selection (one per body).
    pub views: Vec<BodyView>,
    /// Steps done.
    pub steps: u64,
    parents: Vec<Vec<Option<usize>>>,
    /// Per model: its pose-only kinematics, prepared once.
    plans: Vec<PosePlan>,
    /// Per model: the largest `|centre| + radius` of its links' bounding spheres (each in its
    /// link's frame), the reach in the classification margins.
    reach: Vec<f64>,
    /// Per model: a bound on the distance from the root body's origin to any point of any
    /// link's bounding sphere in every configuration ([`whole_reach`]).
    whole_reach: Vec<Option<f64>>,
    /// Per model: the pose springs, in runs of consecutive coordinates.
    springs: Vec<SpringRuns>,
    classifier: Classifier,
    /// The threads the bodies' steps run on ([`SceneSim::set_threads`]; one by default).
    threads: Threads,
    /// One per thread: its buffers (see [`Worker`]), held by one chunk of bodies at a time.
    workers: Vec<Mutex<Worker>>,
    /// Whether the bodies use their worker's `scratch` (default) or their own buffers (the
    /// reference).
    shared: bool,
    /// The last re-selection's global queue and its heap (buffers reused).
    selection: GlobalSelection,
    heap: BinaryHeap<Entry>,
    /// Per body: how far it can move before the next re-selection (classification margins).
    margins: Vec<f64>,
    last: SceneStep,
    /// Internal degrees of freedom active at the last step (0 before the first).
    last_active: usize,
    /// Per model: a workspace for [`SceneSim::energy`] (the bodies' own stay untouched).
    energy_data: Vec<articula_dca::Data>,
    /// Work done by the pushes on the bodies up to the last step they acted, `Σ f · Δx` (J).
    push_work: f64,
    /// Per push: its body and its slot in that body's `pushes`.
    push_slots: Vec<(usize, usize)>,
    /// Adaptive (default) or exact dynamics on every body ([`SceneSim::set_method`]).
    method: SceneMethod,
    /// Whether the next adaptive step re-selects every body's hybrid body whatever the period
    /// (after exact steps moved the states under them).
    reselect_next: bool,
}

/// Bodies per chunk handed to a thread: about this many chunks per thread, so that threads
/// that finish early take the chunks left (the bodies' costs differ by far: see
/// [`Threads::for_each_chunk`]).
const CHUNKS_PER_THREAD: usize = 32;

/// What one thread needs to step a chunk of the bodies (a contiguous run of them): the
/// per-call buffers the adaptive workspaces of its bodies share, per model
/// ([`Adaptive::step_with`]: one copy stays in the core's caches, not one per body), the dense
/// external wrenches of an exact solve, the re-selection's wanted nodes, and this step's sums
/// over its bodies with its first error.
struct Worker {
    scratch: Vec<Scratch>,
    /// Per model: the contact step's buffers the bodies on the floor share
    /// ([`HybridContact::swap_scratch`]).
    contact: Vec<HybridScratch>,
    /// Per model: the exact steps' workspace ([`SceneMethod::Exact`]), with the scene's gravity
    /// and without the momentum projection (plain semi-implicit Euler, as the adaptive step).
    exact: Vec<articula_dca::Data>,
    fdense: Vec<SpatialForce>,
    wanted: Vec<bool>,
    heap: BinaryHeap<Entry>,
    active: usize,
    contacts: usize,
    penetration: f64,
    /// Contact solves (bodies with contact rows) and those that ended at the iteration cap.
    solves: usize,
    capped: usize,
    /// Their rows and sweeps.
    rows: usize,
    sweeps: usize,
    error: Option<(usize, ViewError)>,
}

impl Worker {
    fn new(scene: &LoadedScene) -> Worker {
        Worker {
            scratch: scene
                .models
                .iter()
                .map(|m| Scratch::new(&m.model))
                .collect(),
            contact: if scene.ground.is_some() {
                scene
                    .models
                    .iter()
                    .map(|m| HybridScratch::new(&m.model))
                    .collect()
            } else {
                Vec::new()
            },
            exact: scene
                .models
                .iter()
                .map(|m| {
                    let mut data = scene_data(scene, &m.model);
                    data.momentum_projection = false;
                    data
                })
                .collect(),
            fdense: Vec::new(),
            wanted: Vec::new(),
            // At most every node of a body is queued at once.
            heap: BinaryHeap::with_capacity(
                scene
                    .models
                    .iter()
                    .map(|m| m.model.assembly.nodes.len())
                    .max()
                    .unwrap_or(0),
            ),
            active: 0,
            contacts: 0,
            penetration: 0.0,
            solves: 0,
            capped: 0,
            rows: 0,
            sweeps: 0,
            error: None,
        }
    }

    /// Adds one body's contact figures of this step to the sums.
    fn add_contact(&mut self, stats: &ContactStats) {
        self.contacts += stats.contacts;
        self.penetration = self.penetration.max(stats.max_penetration);
        self.solves += (stats.rows > 0) as usize;
        self.capped += (stats.rows > 0 && !stats.converged) as usize;
        self.rows += stats.rows;
        self.sweeps += stats.iterations;
    }

    /// Records body `i`'s error unless it has one of a lower-numbered body already.
    fn fail(&mut self, i: usize, e: ViewError) {
        if self.error.as_ref().is_none_or(|(j, _)| i < *j) {
            self.error = Some((i, e));
        }
    }
}

/// This step's sums over the workers' bodies into `out` (active joints, contact figures),
/// clearing them.
fn take_sums(workers: &mut [Mutex<Worker>], out: &mut SceneStep) {
    out.active_total = 0;
    out.contacts = 0;
    out.max_penetration = 0.0;
    out.contact_solves = 0;
    out.contact_capped = 0;
    out.contact_rows = 0;
    out.contact_sweeps = 0;
    for w in workers {
        let w = w.get_mut().unwrap_or_else(|p| p.into_inner());
        out.active_total += std::mem::take(&mut w.active);
        out.contacts += std::mem::take(&mut w.contacts);
        out.max_penetration = out.max_penetration.max(std::mem::take(&mut w.penetration));
        out.contact_solves += std::mem::take(&mut w.solves);
        out.contact_capped += std::mem::take(&mut w.capped);
        out.contact_rows += std::mem::take(&mut w.rows);
        out.contact_sweeps += std::mem::take(&mut w.sweeps);
    }
}

/// An exact-dynamics workspace of `model` under the scene's gravity.
fn scene_data(scene: &LoadedScene, model: &Model) -> articula_dca::Data {
    let mut data = articula_dca::Data::new(model);
    data.gravity = scene.gravity;
    data
}

/// The error of the lowest-numbered body among the workers' (the same for any thread
/// count: every body is processed and each worker keeps its lowest), clearing them all.
fn first_error(workers: &mut [Mutex<Worker>]) -> Result<(), ViewError> {
    let mut first: Option<(usize, ViewError)> = None;
    for w in workers {
        let w = w.get_mut().unwrap_or_else(|p| p.into_inner());
        if let Some((i, e)) = w.error.take() {
            if first.as_ref().is_none_or(|(j, _)| i < *j) {
                first = Some((i, e));
            }
        }
    }
    first.map_or(Ok(()), |(_, e)| Err(e))
}

/// The mechanical energy of a scene ([`SceneSim::energy`]), in joules.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SceneEnergy {
    /// `Σ ½ vᵢ·Iᵢvᵢ` over every link of every body.
    pub kinetic: f64,
    /// Gravity's potential `−Σ mᵢ g·cᵢ` (zero at the world origin).
    pub gravity: f64,
    /// The pose springs' potential `Σ ½ k q²`.
    pub springs: f64,
    /// The work the pushes have done on the bodies so far, `Σ ∫ f · dx` at their points.
    pub push_work: f64,
}

impl SceneEnergy {
    /// `kinetic + gravity + springs`.
    pub fn total(&self) -> f64 {
        self.kinetic + self.gravity + self.springs
    }
}

impl<'s> SceneSim<'s> {
    /// Sets every body up in its initial state, after checking the scene
    /// ([`LoadedScene::validate`]: a scene whose public fields were changed by hand, a `q` one
    /// number short, is an error, not a panic).
    pub fn new(scene: &'s LoadedScene) -> Result<SceneSim<'s>, ViewError> {
        scene.validate()?;
        let plans: Vec<PosePlan> = scene
            .models
            .iter()
            .map(|m| PosePlan::new(&m.model))
            .collect();
        let contacts: Vec<Option<HybridContact>> = scene
            .models
            .iter()
            .map(|m| scene.ground.map(|_| HybridContact::new(&m.model)))
            .collect();
        let mut bodies: Vec<SimBody> = scene
            .placements
            .iter()
            .map(|p| {
                let model = &scene.models[p.model].model;
                let mut state = State::neutral(model);
                state.f_ext.clear();
                state.q.copy_from_slice(&p.q);
                state.qd.copy_from_slice(&p.qd);
                // The scene drives re-selection (`set_active`); the workspace never re-selects
                // by itself after its first hybrid body.
                let mut adaptive = Adaptive::new(
                    model,
                    Settings {
                        reselect_every: u64::MAX,
                        ..Settings::default()
                    },
                );
                adaptive.data.gravity = scene.gravity;
                let mut poses = Vec::new();
                plans[p.model].poses(model, &state.q, &mut poses);
                SimBody {
                    model: p.model,
                    state,
                    forces: Vec::new(),
                    adaptive,
                    poses,
                    active: model.nv.saturating_sub(6),
                    allocation: 0,
                    error: 0.0,
                    unweighted: false,
                    rigid: None,
                    changed: false,
                    solved: false,
                    // Sized now: a body first seen after many steps (the camera turning to
                    // it) must not allocate at that re-selection.
                    metrics: Vec::with_capacity(model.assembly.nodes.len()),
                    pushes: Vec::new(),
                    own: OwnQueue {
                        pops: Vec::with_capacity(model.assembly.nodes.len()),
                        ..OwnQueue::default()
                    },
                    // Clones of the model's: one copy of its contact spheres for every body.
                    contact: contacts[p.model].clone(),
                }
            })
            .collect();
        let mut push_slots = Vec::with_capacity(scene.pushes.len());
        for (j, p) in scene.pushes.iter().enumerate() {
            let slots = &mut bodies[p.body].pushes;
            push_slots.push((p.body, slots.len()));
            slots.push(PushSlot {
                push: j,
                from: None,
                work: None,
            });
        }
        let parents = scene
            .models
            .iter()
            .map(|m| m.model.bodies.iter().map(|b| b.parent).collect())
            .collect();
        let springs = scene
            .models
            .iter()
            .map(|m| match scene.joint_springs {
                Some(sp) => SpringRuns::new(
                    &pose_springs(
                        &m.model,
                        sp.frequency_hz,
                        sp.damping_ratio,
                        scene.dt,
                        scene.ground.is_some(),
                    ),
                    &m.model.rest_q(),
                ),
                None => SpringRuns::default(),
            })
            .collect();
        // The global queue's buffers at their largest: a body pops at most its nodes, the heap
        // of the bodies' next pops holds at most one a body (so that no re-selection grows
        // them).
        let nodes = |b: &SimBody| scene.models[b.model].model.assembly.nodes.len();
        let selection = GlobalSelection {
            popped: bodies
                .iter()
                .map(|b| Vec::with_capacity(nodes(b)))
                .collect(),
            ..GlobalSelection::default()
        };
        let heap = BinaryHeap::with_capacity(bodies.len());
        let reach = scene
            .models
            .iter()
            .map(|m| {
                m.volumes
                    .iter()
                    .map(|v| v.bound.0.length() + v.bound.1)
                    .fold(0.0, f64::max)
            })
            .collect();
        let whole_reach = scene
            .models
            .iter()
            .map(|m| whole_reach(&m.model, &m.volumes))
            .collect();
        let mut sim = SceneSim {
            reach,
            whole_reach,
            springs,
            threads: Threads::serial(),
            workers: vec![Mutex::new(Worker::new(scene))],
            shared: true,
            selection,
            heap,
            margins: Vec::new(),
            views: Vec::new(),
            classifier: Classifier::new(&scene.visibility),
            bodies,
            parents,
            plans,
            steps: 0,
            scene,
            last: SceneStep::default(),
            last_active: 0,
            energy_data: scene
                .models
                .iter()
                .map(|m| scene_data(scene, &m.model))
                .collect(),
            push_work: 0.0,
            push_slots,
            method: SceneMethod::Adaptive,
            reselect_next: false,
        };
        sim.set_threads(Threads::default());
        Ok(sim)
    }

    /// Whether the bodies' adaptive calls share one [`Scratch`] per model (default: on) or
    /// use their own workspaces' buffers (off: the reference, the same results to the bit and
    /// slower). For the test that compares the two.
    #[cfg(test)]
    pub(crate) fn set_shared_scratch(&mut self, on: bool) {
        self.shared = on;
    }

    /// Steps the bodies on `threads` (default: [`Threads::default`], one per core). The bodies are split into chunks
    /// of contiguous bodies that the threads take as they come free, each thread with buffers
    /// of its own; the global joint budget stays one choice over every body. Every body's
    /// step does the same arithmetic whatever the chunk and the thread it falls to, and every
    /// sum over bodies runs in body order, so **the scene's state is the same bits for any
    /// thread count**.
    pub fn set_threads(&mut self, threads: Threads) {
        let scene = self.scene;
        self.workers
            .resize_with(threads.count(), || Mutex::new(Worker::new(scene)));
        self.threads = threads;
    }

    /// The threads the bodies are stepped on.
    pub fn threads(&self) -> &Threads {
        &self.threads
    }

    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.steps as f64 * self.scene.dt
    }

    /// The model of body `b`.
    pub fn model(&self, b: usize) -> &'s Model {
        &self.scene.models[self.bodies[b].model].model
    }

    /// Internal degrees of freedom of every body's model (what exact dynamics simulates).
    pub fn dof_total(&self) -> usize {
        (0..self.bodies.len())
            .map(|b| self.model(b).nv.saturating_sub(6))
            .sum()
    }

    /// How far each body can get before the next re-selection (into `margins`): its root
    /// speed plus the rim speed of its bounding sphere, times the period (and one step more).
    fn set_margins(&mut self) {
        let scene = self.scene;
        let margin_steps = scene.reselect_every as f64 * scene.dt;
        self.margins.clear();
        self.margins.extend(self.bodies.iter().map(|b| {
            let (w, v) = (b.state.qd[..3].iter(), b.state.qd[3..6].iter());
            let wn = w.map(|x| x * x).sum::<f64>().sqrt();
            let vn = v.map(|x| x * x).sum::<f64>().sqrt();
            (vn + wn * self.reach[b.model]) * (margin_steps + scene.dt)
        }));
    }

    /// Bodies per chunk handed to a thread ([`CHUNKS_PER_THREAD`]).
    fn chunk(&self) -> usize {
        self.bodies
            .len()
            .div_ceil(self.threads.count() * CHUNKS_PER_THREAD)
            .max(1)
    }

    /// Advances the scene by one step. The bodies' states are public: one whose model index,
    /// `q`, `q̇` or `τ` length no longer fits its model is an error naming it (non-finite
    /// numbers are the dynamics' errors), never a panic.
    pub fn step(&mut self) -> Result<SceneStep, ViewError> {
        let scene = self.scene;
        self.check_bodies()?;
        match self.method {
            SceneMethod::Exact(method) => return self.step_exact(method),
            SceneMethod::Culling => return self.step_culling(),
            SceneMethod::Adaptive => {}
        }
        let (reselect, forced) = self.reselect_due();
        if reselect {
            self.reselect_solve()?;
            let classes = self.reselect_weigh()?;
            // The global queue: a merge of the bodies' own queues (the same pops as one
            // queue over every body's nodes).
            let bodies = &self.bodies;
            merge_own_queues(
                &mut self.selection,
                &mut self.heap,
                bodies.len(),
                |b| &bodies[b].own,
                scene.budget,
                scene.tolerance,
            );
            self.reselect_apply(forced, classes)?;
        }
        self.step_bodies(reselect)
    }

    /// Whether this step re-selects, and whether because it was forced (after exact steps);
    /// clears the forcing.
    fn reselect_due(&mut self) -> (bool, bool) {
        let forced = std::mem::take(&mut self.reselect_next);
        let every = self.scene.reselect_every as u64;
        (forced || self.steps.is_multiple_of(every), forced)
    }

    /// A re-selection's first pass: each body's pushes and pose springs of the step, its exact
    /// solve and its link poses, then the camera's frustum classes and the depth buffer of
    /// the bodies' occluders ([`Classifier::rasterize_with`]).
    ///
    /// Every body's exact solve first: its accelerations give the metrics once the weights
    /// are known, and its kinematics the link poses the camera classifies (no separate pose
    /// pass) and the next hybrid body's load. A body whose whole bounding sphere (about its
    /// root, grown by its margin) lies outside a frustum plane has every link invisible (each
    /// link's sphere is inside it): all its weights will be 0, so its solve is skipped and
    /// the pose-only kinematics give the classifier its poses.
    fn reselect_solve(&mut self) -> Result<(), ViewError> {
        let scene = self.scene;
        let t = self.time();
        let (threads, shared, chunk) = (self.threads.clone(), self.shared, self.chunk());
        self.set_margins();
        let frustum = scene.camera.at(t).frustum();
        let (plans, whole_reach, margins) = (&self.plans, &self.whole_reach, &self.margins);
        let springs = &self.springs;
        threads.for_each_chunk(&mut self.bodies, &self.workers, chunk, |w, first, run| {
            for (j, b) in run.iter_mut().enumerate() {
                let i = first + j;
                prepare(scene, b, springs, plans, t);
                let (plan, model) = (&plans[b.model], &scene.models[b.model].model);
                let outside = whole_reach[b.model].is_some_and(|r| {
                    let root = plan.pose(model, &b.state.q, 0).1;
                    frustum.nearest_plane_distance(root) < -(r + margins[i])
                });
                b.solved = !outside;
                if outside {
                    plan.poses(model, &b.state.q, &mut b.poses);
                } else if let Err(e) = exact_solve(scene, shared, b, i, w) {
                    w.fail(i, e);
                } else {
                    // The solve's kinematics left in the workspace: each body's world pose.
                    let data = &b.adaptive.data;
                    b.poses.clear();
                    b.poses.extend((0..data.x.len()).map(|j| data.body_pose(j)));
                }
            }
        });
        self.add_push_work();
        first_error(&mut self.workers)?;
        let cam = scene.camera.at(t);
        let chunk = self.chunk();
        let n = self.bodies.len();
        let placed = placed(scene, &self.bodies, &self.parents, &self.margins);
        let views = &mut self.views;
        (self.classifier).rasterize_with(&cam, &self.threads, chunk, n, &placed, views);
        Ok(())
    }

    /// A re-selection's second pass, after [`SceneSim::reselect_solve`]: the occlusion test
    /// against the depth buffer and every joint's weight, then each weighted body's node
    /// metrics and its own queue ([`OwnQueue`]). Returns the bodies and the links per class.
    fn reselect_weigh(&mut self) -> Result<[[usize; 3]; 2], ViewError> {
        let scene = self.scene;
        let (threads, shared, chunk) = (self.threads.clone(), self.shared, self.chunk());
        let cam = scene.camera.at(self.time());
        {
            let placed = placed(scene, &self.bodies, &self.parents, &self.margins);
            let (settings, views) = (&scene.visibility, &mut self.views);
            (self.classifier).occlude_with(&cam, settings, &threads, chunk, &placed, views);
        }
        let mut link_classes = [0; 3];
        let mut classes = [0; 3];
        for (b, view) in self.bodies.iter_mut().zip(&self.views) {
            b.unweighted = view.joint_weights.iter().all(|w| *w == 0.0);
            for c in &view.links {
                link_classes[*c as usize] += 1;
            }
            classes[view.summary() as usize] += 1;
        }
        let views = &self.views;
        threads.for_each_chunk(&mut self.bodies, &self.workers, chunk, |w, first, run| {
            for (j, b) in run.iter_mut().enumerate() {
                let i = first + j;
                b.metrics.clear();
                let model = &scene.models[b.model].model;
                if !b.unweighted {
                    b.metrics.resize(model.assembly.nodes.len(), 0.0);
                    if !b.solved {
                        // (Not reached: a body outside the view classifies invisible; a
                        // safeguard against rounding at the frustum's edge.)
                        if let Err(e) = exact_solve(scene, shared, b, i, w) {
                            w.fail(i, e);
                            b.metrics.clear();
                        }
                    }
                    if !b.metrics.is_empty() {
                        let weights = &views[i].joint_weights;
                        b.adaptive
                            .scaled_node_metrics(model, weights, &mut b.metrics);
                    }
                }
                // Its own queue, for the global one.
                b.own.run(model, &b.metrics, &mut w.heap);
            }
        });
        first_error(&mut self.workers)?;
        Ok([classes, link_classes])
    }

    /// A re-selection's last pass, once `self.selection` holds the global queue's choice: each
    /// body's share ([`apply_selection`]), the scene's error summed in body order, and the
    /// step's summary so far (`classes`: bodies and links per class).
    fn reselect_apply(&mut self, forced: bool, classes: [[usize; 3]; 2]) -> Result<(), ViewError> {
        let scene = self.scene;
        let (threads, shared, chunk) = (self.threads.clone(), self.shared, self.chunk());
        let (sel, first_step) = (&self.selection, self.steps == 0 || forced);
        threads.for_each_chunk(&mut self.bodies, &self.workers, chunk, |w, first, run| {
            for (j, b) in run.iter_mut().enumerate() {
                let i = first + j;
                if let Err(e) = apply_selection(scene, shared, sel, first_step, b, i, w) {
                    w.fail(i, e);
                }
            }
        });
        first_error(&mut self.workers)?;
        // The scene's error, summed in body order.
        self.selection.total_error = self.bodies.iter().map(|b| b.error).sum();
        let [classes, link_classes] = classes;
        self.last = SceneStep {
            reselected: true,
            active_total: 0,
            classes,
            link_classes,
            total_error: self.selection.total_error,
            ..SceneStep::default()
        };
        Ok(())
    }

    /// The step of every body (after a re-selection when `reselect`; else first its pushes
    /// and pose springs), and the step's summary.
    fn step_bodies(&mut self, reselect: bool) -> Result<SceneStep, ViewError> {
        let scene = self.scene;
        let t = self.time();
        let (threads, shared, chunk) = (self.threads.clone(), self.shared, self.chunk());
        let contact_settings = scene.contact_settings();
        let (springs, plans) = (&self.springs, &self.plans);
        threads.for_each_chunk(&mut self.bodies, &self.workers, chunk, |w, first, run| {
            for (j, b) in run.iter_mut().enumerate() {
                let i = first + j;
                if !reselect {
                    prepare(scene, b, springs, plans, t);
                }
                if let Err(e) = step_body(scene, shared, plans, &contact_settings, b, i, w) {
                    w.fail(i, e);
                }
            }
        });
        let mut out = self.last.clone();
        out.reselected = reselect;
        take_sums(&mut self.workers, &mut out);
        if !reselect {
            self.add_push_work();
        }
        first_error(&mut self.workers)?;
        self.steps += 1;
        self.last_active = out.active_total;
        Ok(out)
    }

    /// Adds the work of the pushes found at this step's first pass to `push_work`, in the
    /// scene's order of the pushes (whatever thread found each).
    fn add_push_work(&mut self) {
        for &(b, k) in &self.push_slots {
            let slot = self.bodies.get_mut(b).and_then(|b| b.pushes.get_mut(k));
            if let Some(work) = slot.and_then(|s| s.work.take()) {
                self.push_work += work;
            }
        }
    }

    /// The mechanical energy of the scene's current state: kinetic, gravity's and the pose
    /// springs' potential, and the pushes' work so far — with pose-spring damping the only
    /// loss, `total() − push_work` never grows in exact arithmetic, so its growth measures the
    /// integrator's error (`articula scene` stops a run whose energy grows beyond a bound).
    /// One forward-kinematics pass per body (O(n)), in a workspace of its own: the bodies'
    /// adaptive workspaces are not touched. Bodies whose state no longer fits its model are
    /// skipped ([`SceneSim::step`] reports them).
    pub fn energy(&mut self) -> SceneEnergy {
        let scene = self.scene;
        let mut e = SceneEnergy::default();
        for b in &self.bodies {
            let Some(m) = scene.models.get(b.model) else {
                continue;
            };
            let (model, s) = (&m.model, &b.state);
            if s.q.len() != model.nq || s.qd.len() != model.nv {
                continue;
            }
            let data = &mut self.energy_data[b.model];
            if articula_dca::forward_kinematics(model, &s.q, &s.qd, data).is_err() {
                // A state that is not finite has no energy: the sum says so.
                e.kinetic = f64::NAN;
                continue;
            }
            e.kinetic += data.kinetic_energy();
            e.gravity += data.potential_energy();
            let springs = &self.springs[b.model];
            for (q0, _, r) in &springs.runs {
                let q = &s.q[*q0..q0 + r.len()];
                e.springs += q
                    .iter()
                    .zip(&springs.k[r.clone()])
                    .map(|(q, k)| 0.5 * k * q * q)
                    .sum::<f64>();
            }
        }
        // The work of pushes that acted at the last step (their points have moved since).
        e.push_work = self.push_work;
        for (p, &(b, k)) in scene.pushes.iter().zip(&self.push_slots) {
            let Some(b) = self.bodies.get(b) else {
                continue;
            };
            if let Some(from) = b.pushes.get(k).and_then(|s| s.from) {
                let model = &scene.models[b.model].model;
                if b.state.q.len() == model.nq {
                    let at = self.plans[b.model].point(model, &b.state.q, p.link_body, p.point);
                    e.push_work += p.force.dot(at - from);
                }
            }
        }
        e
    }

    /// Checks what [`SceneSim::step`] indexes without checking: each body's model index and
    /// the lengths of its state (O(bodies)).
    fn check_bodies(&self) -> Result<(), ViewError> {
        let scene = self.scene;
        for (i, b) in self.bodies.iter().enumerate() {
            let name = &scene.placements[i].name;
            let Some(m) = scene.models.get(b.model) else {
                return Err(ViewError::BodyState {
                    name: name.clone(),
                    message: format!(
                        "no model {} (the scene has {})",
                        b.model,
                        scene.models.len()
                    ),
                });
            };
            let (m, s) = (&m.model, &b.state);
            for (what, len, expected) in [
                ("q", s.q.len(), m.nq),
                ("qd", s.qd.len(), m.nv),
                ("tau", s.tau.len(), m.nv),
            ] {
                if len != expected {
                    return Err(ViewError::BodyState {
                        name: name.clone(),
                        message: format!("{what} has {len} numbers, its model needs {expected}"),
                    });
                }
            }
        }
        Ok(())
    }

    /// Renders the camera's view of the current state (each rigid subassembly in its own
    /// colour, the active joints of the last step written in the corner) into a PNG file of
    /// the scene's image size.
    #[cfg(feature = "render")]
    pub fn save_frame(&mut self, path: impl AsRef<std::path::Path>) -> Result<(), ViewError> {
        let cam = self.scene.camera.at(self.time());
        let (w, h) = (self.scene.image.width, self.scene.image.height);
        let active = self.last_active;
        let mut groups = Vec::new();
        let bodies = self.frame(&mut groups);
        let pix =
            crate::render::render_view(&cam, w, h, &bodies, active).map_err(ViewError::Frame)?;
        crate::render::save_png(&pix, path.as_ref()).map_err(ViewError::Frame)
    }

    /// Everything the renderer needs, with the poses refreshed to the current state (a body
    /// whose `q` no longer fits its model keeps the poses it had: [`SceneSim::step`] reports
    /// it).
    pub fn frame<'a>(&'a mut self, groups: &'a mut Vec<Vec<usize>>) -> Vec<FrameBody<'a>> {
        let scene = self.scene;
        groups.resize_with(self.bodies.len(), Vec::new);
        for (b, g) in self.bodies.iter_mut().zip(groups.iter_mut()) {
            let Some(m) = scene.models.get(b.model) else {
                continue;
            };
            let model = &m.model;
            if b.state.q.len() == model.nq {
                self.plans[b.model].poses(model, &b.state.q, &mut b.poses);
            }
            // Exact steps move every joint.
            let exact = matches!(self.method, SceneMethod::Exact(_));
            let active: Vec<bool> = (0..model.bodies.len())
                .map(|i| exact || b.adaptive.is_active(model, i))
                .collect();
            rigid_groups(&self.parents[b.model], &active, g);
        }
        self.bodies
            .iter()
            .enumerate()
            .filter_map(|(i, b)| {
                Some(FrameBody {
                    volumes: &scene.models.get(b.model)?.volumes,
                    poses: &b.poses,
                    groups: &groups[i],
                    seed: i as u64,
                    class: self
                        .views
                        .get(i)
                        .map_or(Visibility::Invisible, BodyView::summary),
                    active_joints: b.active,
                })
            })
            .collect()
    }
}

/// Body `b` first in a step's first pass over the bodies: the pushes acting at time `t`
/// (world wrenches about the world origin) and the pose springs' torques.
fn prepare(
    scene: &LoadedScene,
    b: &mut SimBody,
    springs: &[SpringRuns],
    plans: &[PosePlan],
    t: f64,
) {
    b.set_pushes(scene, &plans[b.model], t);
    spring_torques(&springs[b.model], &mut b.state);
}

/// Body `i` as the camera classifies it: its volumes, link poses (those of its current state)
/// and margin.
fn placed<'a>(
    scene: &'a LoadedScene,
    bodies: &'a [SimBody],
    parents: &'a [Vec<Option<usize>>],
    margins: &'a [f64],
) -> impl Fn(usize) -> Placed<'a> + Sync + 'a {
    move |i| {
        let b = &bodies[i];
        Placed {
            volumes: &scene.models[b.model].volumes,
            poses: &b.poses,
            parents: &parents[b.model],
            margin: margins[i],
        }
    }
}

/// Body `i`'s (`b`) share of the global selection `sel`: its allocation and error, and,
/// when the joints the queue chose are not exactly its active ones (or at the first step), its
/// new hybrid body (the joints leaving it locked by momentum-keeping impulses).
fn apply_selection(
    scene: &LoadedScene,
    shared: bool,
    sel: &GlobalSelection,
    first_step: bool,
    b: &mut SimBody,
    i: usize,
    w: &mut Worker,
) -> Result<(), ViewError> {
    b.allocation = sel.allocation[i];
    // Re-select only when the hybrid body must change: the joints the queue chose are not
    // exactly the active ones (the first step always re-selects). An unchanged hybrid body has
    // its other joints locked at zero velocity already.
    let model = &scene.models[b.model].model;
    let tree = &model.assembly;
    w.wanted.clear();
    w.wanted.resize(tree.nodes.len(), false);
    for &n in &sel.popped[i] {
        w.wanted[n] = true;
    }
    let wanted = &w.wanted;
    b.error = frontier_error(model, &b.metrics, &sel.popped[i], wanted);
    let same = (0..model.bodies.len())
        .all(|j| b.adaptive.is_active(model, j) == wanted[tree.joint_node[j]]);
    let needed = first_step || !same;
    b.changed = needed;
    if !needed {
        return Ok(());
    }
    // Exactly the chosen joints stay free; the others are locked by momentum-keeping
    // impulses (no second articulated pass).
    let scratch = shared.then(|| &mut w.scratch[b.model]);
    free_exactly(scene, scratch, b, i, |j| wanted[tree.joint_node[j]])
}

/// Body `i` (`b`) with its share `b.allocation` as its budget and exactly the joints `free`
/// says (by body index) left free, the others locked by momentum-keeping impulses; `scratch`
/// the worker's workspace for the body's model when workspaces are shared.
pub(super) fn free_exactly(
    scene: &LoadedScene,
    scratch: Option<&mut Scratch>,
    b: &mut SimBody,
    i: usize,
    free: impl Fn(usize) -> bool,
) -> Result<(), ViewError> {
    // (Its own re-selection, should the workspace ever run one, keeps the share.)
    let settings = Settings {
        budget: Some(b.allocation),
        tolerance: None,
        reselect_every: u64::MAX,
        velocity_tolerance: None,
    };
    b.adaptive
        .set_settings(settings)
        .map_err(|e| model_error(scene, b.model, e))?;
    let model = &scene.models[b.model].model;
    let (ad, state) = (&mut b.adaptive, &mut b.state);
    match scratch {
        Some(scratch) => ad.set_active_with(scratch, model, state, free),
        None => ad.set_active(model, state, free),
    }
    .map_err(|e| body_error(scene, i, e))?;
    b.rigid = None;
    Ok(())
}

/// One step of body `i` (`b`, its pose springs' torques set): as one rigid body while every
/// internal joint stays locked, else its hybrid step (with a floor, its contact step); adds
/// its active joints and contacts to worker `w`'s sums.
fn step_body(
    scene: &LoadedScene,
    shared: bool,
    plans: &[PosePlan],
    contact_settings: &ContactSettings,
    b: &mut SimBody,
    i: usize,
    w: &mut Worker,
) -> Result<(), ViewError> {
    let model = &scene.models[b.model].model;
    let reselects = std::mem::take(&mut b.changed);
    if !reselects && b.rigid.is_some() {
        return b
            .rigid_step(model, scene.gravity, scene.dt)
            .map_err(|e| body_error(scene, i, e.into()));
    }
    let (ad, state, forces) = (&mut b.adaptive, &mut b.state, &b.forces);
    if let Some(hc) = &mut b.contact {
        // On the floor: the hybrid body's contact step (shared: with the worker's buffers of
        // its model, the adaptive step's and the contact step's).
        let (dt, settings) = (scene.dt, contact_settings);
        let r = if shared {
            let (scratch, contact) = (&mut w.scratch[b.model], &mut w.contact[b.model]);
            hc.swap_scratch(contact);
            let r =
                ad.step_with_contact_and_scratch(scratch, model, state, dt, forces, hc, settings);
            hc.swap_scratch(contact);
            r
        } else {
            ad.step_with_contact(model, state, dt, forces, hc, settings)
        };
        w.add_contact(&hc.contact.stats);
        r
    } else if shared {
        let scratch = &mut w.scratch[b.model];
        ad.step_with_forces_and_scratch(scratch, model, state, scene.dt, forces)
    } else {
        ad.step_with_forces(model, state, scene.dt, forces)
    }
    .map_err(|e| body_error(scene, i, e))?;
    b.active = b
        .adaptive
        .active_dofs(model)
        .saturating_sub(if model.floating_base { 6 } else { 0 });
    w.active += b.active;
    // Every internal joint locked (at zero velocity): from now on, one rigid body (without a
    // floor: the rigid step knows no contact).
    b.rigid = if b.contact.is_none()
        && b.active == 0
        && b.state.qd[6.min(b.state.qd.len())..]
            .iter()
            .all(|x| *x == 0.0)
    {
        match b.rigid {
            Some(r) if !reselects => Some(r),
            _ => b.composite_in_root(model, &plans[b.model]),
        }
    } else {
        None
    };
    Ok(())
}

/// Body `i`'s (`b`) exact solve at its current state and forces (the metrics' accelerations
/// and the kinematics the classification and the next hybrid body reuse), with the buffers
/// of worker `w` (`shared`) or its own.
fn exact_solve(
    scene: &LoadedScene,
    shared: bool,
    b: &mut SimBody,
    i: usize,
    w: &mut Worker,
) -> Result<(), ViewError> {
    let model = &scene.models[b.model].model;
    let (s, ad) = (&b.state, &mut b.adaptive);
    // The exact solve takes the wrenches as a dense array (empty: none).
    w.fdense.clear();
    if !b.forces.is_empty() {
        w.fdense.resize(model.bodies.len(), SpatialForce::ZERO);
        for &(i, f) in &b.forces {
            w.fdense[i] = f;
        }
    }
    let f_ext = &w.fdense;
    if shared {
        let scratch = &mut w.scratch[b.model];
        ad.exact_solve_with(scratch, model, &s.q, &s.qd, &s.tau, f_ext)
    } else {
        ad.exact_solve(model, &s.q, &s.qd, &s.tau, f_ext)
    }
    .map_err(|e| body_error(scene, i, e))
}

/// An upper bound on the distance from the root body's origin to any point of any link's
/// bounding sphere (`volumes[i].bound`, in link `i`'s frame), whatever the configuration: the
/// joint origins' offsets summed along each root path (rotations keep lengths) plus the
/// sphere's reach. `None` when a joint below the root translates (prismatic, floating) or the
/// model has another root than body 0.
pub(crate) fn whole_reach(model: &Model, volumes: &[BodyVolumes]) -> Option<f64> {
    let mut path = vec![0.0; model.bodies.len()];
    let mut bound = 0.0f64;
    for (i, body) in model.bodies.iter().enumerate() {
        if body.parent.is_none() && i != 0 {
            return None;
        }
        if let Some(p) = body.parent {
            let mut r = path[p];
            for part in &body.joint {
                if !part.kind.keeps_origin() {
                    return None;
                }
                r += part.origin.r.length();
            }
            path[i] = r;
        }
        let (c, radius) = volumes.get(i)?.bound;
        bound = bound.max(path[i] + c.length() + radius);
    }
    Some(bound)
}

/// Pose springs grouped in runs whose `q` and `q̇` indices both advance by one (every internal
/// degree of freedom of a floating humanoid is one run, `q` one ahead of `q̇` for the root's
/// quaternion), so that [`spring_torques`] is a plain loop over slices.
#[derive(Clone, Debug, Default)]
struct SpringRuns {
    /// Per run: its first `q` index, first `q̇` index, and its range in `k`, `c` and `rest`.
    runs: Vec<(usize, usize, std::ops::Range<usize>)>,
    k: Vec<f64>,
    c: Vec<f64>,
    /// The coordinate each spring holds (`Model::rest_q`).
    rest: Vec<f64>,
}

impl SpringRuns {
    /// The runs of the springs `(q index, v index, k, c)`, in their order, holding the
    /// coordinates at `rest` (a configuration).
    fn new(springs: &[(usize, usize, f64, f64)], rest: &[f64]) -> Self {
        let mut out = SpringRuns::default();
        for (i, &(qi, vi, k, c)) in springs.iter().enumerate() {
            // (The last run always ends at spring i: every spring is appended.)
            let extends = out
                .runs
                .last()
                .is_some_and(|(q0, v0, r)| qi == q0 + r.len() && vi == v0 + r.len());
            match out.runs.last_mut() {
                Some(run) if extends => run.2.end += 1,
                _ => out.runs.push((qi, vi, i..i + 1)),
            }
            out.k.push(k);
            out.c.push(c);
            out.rest.push(rest[qi]);
        }
        out
    }
}

/// `τ = −k (q − q_rest) − c q̇` of each pose spring.
#[inline]
fn spring_torques(springs: &SpringRuns, s: &mut State) {
    for (q0, v0, r) in &springs.runs {
        let n = r.len();
        let (k, c) = (&springs.k[r.clone()], &springs.c[r.clone()]);
        let rest = &springs.rest[r.clone()];
        let (q, qd) = (&s.q[*q0..q0 + n], &s.qd[*v0..v0 + n]);
        for ((t, (k, c)), ((q, qd), q_rest)) in s.tau[*v0..v0 + n]
            .iter_mut()
            .zip(k.iter().zip(c))
            .zip(q.iter().zip(qd).zip(rest))
        {
            *t = -k * (q - q_rest) - c * qd;
        }
    }
}

/// A dynamics failure of model `model`'s shared workspace, naming the model.
fn model_error(scene: &LoadedScene, model: usize, error: AdaptiveError) -> ViewError {
    ViewError::Dynamics {
        what: "model",
        name: scene.models[model].name.clone(),
        error,
    }
}

/// A dynamics failure of body `b`, naming the body.
fn body_error(scene: &LoadedScene, b: usize, error: AdaptiveError) -> ViewError {
    ViewError::Dynamics {
        what: "body",
        name: scene.placements[b].name.clone(),
        error,
    }
}

#[cfg(test)]
mod tests {
    use super::{pose_springs, spring_torques, whole_reach, SceneSim, SpringRuns};
    use crate::visibility::body_poses;
    use crate::volumes::body_volumes;
    use articula_dca::State;

    /// Every link's bounding sphere stays within `whole_reach` of the root body's origin, in
    /// random configurations (the bound is what lets a re-selection skip the exact solve of a
    /// body outside the view), and some link comes within a factor of two of it.
    #[test]
    fn whole_reach_bounds_every_link_sphere() {
        let model = articula_testkit::bundled_with("humanoid", true);
        let volumes = body_volumes(&model);
        let bound = whole_reach(&model, &volumes).unwrap();
        let mut farthest = 0.0f64;
        let mut poses = Vec::new();
        for seed in 0..500 {
            let s = State::random(&model, seed, 3.0);
            body_poses(&model, &s.q, &mut poses);
            let root = poses[0].1;
            for (v, &(r, p)) in volumes.iter().zip(&poses) {
                let (c, radius) = v.bound;
                let d = (r * c + p - root).length() + radius;
                assert!(d <= bound * (1.0 + 1e-12), "{d} > {bound}");
                farthest = farthest.max(d);
            }
        }
        assert!(farthest > 0.5 * bound, "{farthest} against {bound}");
    }

    /// The runs give every spring's `τ = −k (q − q_rest) − c q̇` to the bit, one spring at a time as the
    /// reference: on the humanoid (one run) and on a shuffled, gapped list (many runs).
    #[test]
    fn spring_runs_equal_one_spring_at_a_time() {
        let model = articula_testkit::bundled_with("humanoid", true);
        let springs = pose_springs(&model, 2.0, 0.2, 1.0 / 600.0, false);
        assert_eq!(springs.len(), model.nv - 6);
        let rest: Vec<f64> = (0..model.nq).map(|i| 0.01 * i as f64 - 0.2).collect();
        assert_eq!(SpringRuns::new(&springs, &rest).runs.len(), 1);
        let mut gapped: Vec<_> = springs.iter().copied().step_by(3).collect();
        gapped.extend(springs.iter().rev().take(5));
        gapped.extend(&springs[10..16]);
        let runs = SpringRuns::new(&gapped, &rest);
        assert!(runs.runs.len() > 10, "{}", runs.runs.len());
        for seed in 0..20 {
            let mut s = State::random(&model, seed, 2.0);
            spring_torques(&runs, &mut s);
            for &(qi, vi, k, c) in &gapped {
                let want = -k * (s.q[qi] - rest[qi]) - c * s.qd[vi];
                assert_eq!(s.tau[vi].to_bits(), want.to_bits());
            }
        }
    }

    /// Every coordinate of a composed joint gets the stiffness and damping of its heaviest
    /// one (so that none rings slower than the set frequency in any configuration of the
    /// joint): on the humanoid's shoulders, the twist axis along the hanging arm, whose own
    /// effective inertia is over 50 times smaller, is as stiff as the heaviest axis; single-axis
    /// joints keep their own `k = ω² / (M⁻¹)ᵢᵢ`. The damper is the coordinate's own
    /// backward-Euler one, `c = d m / (m + dt d)` with `d = 2ζω m_heaviest` and `m` a quarter
    /// of its own inertia.
    #[test]
    fn composed_joint_coordinates_share_their_heaviest_stiffness() {
        let model = articula_testkit::bundled_with("humanoid", true);
        let (f, zeta) = (2.0, 0.2);
        let w = 2.0 * std::f64::consts::PI * f;
        let dt = 1.0 / 600.0;
        let springs = pose_springs(&model, f, zeta, dt, false);
        let spring = |v: usize| *springs.iter().find(|s| s.1 == v).unwrap();
        // The effective inertia of each coordinate alone, from exact DCA (no gravity).
        let mut data = articula_dca::Data::new(&model);
        data.gravity = glam::DVec3::ZERO;
        let q = model.neutral_q();
        let mut own = |v: usize| {
            let mut tau = vec![0.0; model.nv];
            tau[v] = 1.0;
            let qdd = articula_dca::forward_dynamics_slices(
                &model,
                &mut data,
                &q,
                &vec![0.0; model.nv],
                &tau,
                &[],
                articula_dca::Method::Dca,
            )
            .unwrap();
            1.0 / qdd[v]
        };
        for body in &model.bodies[1..] {
            let m: Vec<f64> = body.joint.iter().map(|p| own(p.v_offset)).collect();
            let heaviest = m.iter().copied().fold(0.0, f64::max);
            for (p, m) in body.joint.iter().zip(&m) {
                let (_, _, k, c) = spring(p.v_offset);
                let expected = if body.joint.len() > 1 { heaviest } else { *m };
                // The integrator's share of its own inertia: at 2 Hz no spring reaches the
                // bound ω dt = ½ on it.
                let own = m / 4.0;
                assert!(w * w * expected < own / (dt * dt), "{}", p.name);
                assert!((k - w * w * expected).abs() <= 1e-12 * k, "{}", p.name);
                let d = 2.0 * zeta * w * expected;
                assert!(
                    (c - d * own / (own + dt * d)).abs() <= 1e-12 * c,
                    "{}",
                    p.name
                );
            }
        }
        let arm = model
            .bodies
            .iter()
            .find(|b| b.name == "l_upper_arm")
            .unwrap();
        let twist = own(arm.joint[1].v_offset);
        let heaviest = arm
            .joint
            .iter()
            .map(|p| own(p.v_offset))
            .fold(0.0, f64::max);
        assert!(heaviest > 50.0 * twist, "{heaviest} against {twist}");
    }

    fn same(a: &[f64], b: &[f64]) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
    }

    /// The bundled crowd stepped with one shared adaptive scratch per model (the default)
    /// follows the trajectory of the reference that gives every body its own buffers, to the
    /// bit: 300 steps (30 re-selections, every body's node metrics, hybrid bodies set by hand,
    /// pushes on every body, bodies turning rigid and back).
    #[test]
    fn crowd200_with_a_shared_scratch_follows_the_per_body_trajectory() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/scenes/crowd200.json"
        );
        if !std::path::Path::new(path).exists() {
            // The crate as packaged: the workspace's models/ is not shipped (the workspace
            // runs this test).
            eprintln!("skipped: {path} is outside the packaged crate");
            return;
        }
        let scene = crate::load_scene(path).unwrap();
        let mut shared = SceneSim::new(&scene).unwrap();
        let mut own = SceneSim::new(&scene).unwrap();
        own.set_shared_scratch(false);
        let mut changed = 0;
        for k in 0..300 {
            let before: Vec<usize> = own.bodies.iter().map(|b| b.active).collect();
            let a = shared.step().unwrap();
            let b = own.step().unwrap();
            assert_eq!(a, b, "step {k}");
            for (i, (x, y)) in shared.bodies.iter().zip(&own.bodies).enumerate() {
                assert!(same(&x.state.q, &y.state.q), "step {k}, body {i}: q");
                assert!(same(&x.state.qd, &y.state.qd), "step {k}, body {i}: q̇");
                assert_eq!(x.active, y.active, "step {k}, body {i}");
                assert_eq!(x.rigid.is_some(), y.rigid.is_some(), "step {k}, body {i}");
                assert!(
                    same(x.adaptive.qdd(), y.adaptive.qdd()),
                    "step {k}, body {i}: q̈"
                );
            }
            changed += own
                .bodies
                .iter()
                .zip(&before)
                .filter(|(b, a)| b.active != **a)
                .count();
        }
        // Hybrid bodies changed along the way (set by hand at re-selections), and bodies moved.
        assert!(changed > 100, "{changed}");
        assert!(shared
            .bodies
            .iter()
            .all(|b| b.state.qd.iter().any(|x| *x != 0.0)));
    }
}

/// The scene-level tests: rigid motion of invisible bodies, the global queue, classified poses.
#[cfg(all(test, feature = "serde"))]
mod scene_tests;
