//! A scene split by body over processes or machines, with the scene-wide joint budget kept
//! exact (`docs/scaling.md#across-machines-sharded-scenes`).
//!
//! Shard `k` of `n` holds the bodies `⌊k·N/n⌋..⌊(k+1)·N/n⌋` of the scene's `N` (a
//! [`SceneShard`] over [`LoadedScene::shard`]). Between re-selections the shards step their
//! bodies alone: bodies interact only through the budget and the camera's depth buffer (each
//! touches nothing but the floor). A re-selection is three exchanges with one driver:
//!
//! 1. [`SceneShard::begin`]: each shard's exact solves, frustum classes and the depth buffer
//!    of its occluders ([`DepthMessage`]); the driver keeps the nearest depth per cell
//!    ([`merge_depths`]) — a minimum, the same whatever the order — and sends it back;
//! 2. [`SceneShard::weigh`]: each shard's occlusion test against the merged buffer, weights,
//!    node metrics and its bodies' own queues, merged into one pop sequence cut where its own
//!    pops alone exceed the budget ([`Candidates`]); the driver merges the shards' sequences
//!    ([`merge_candidates`]) and sends each shard how many of its pops the global queue took;
//! 3. [`SceneShard::apply`]: each shard applies its share and steps.
//!
//! Why the merge is exact: the one-process queue pops the largest of every body's next own
//! pop (ties to the smaller body, then node), and a body's own queue changes only when one of
//! its nodes is popped, so the global pops are a merge of the bodies' own sequences. The pops
//! of a shard's bodies are then a prefix of the same merge restricted to them (the shard's
//! sequence), so the global queue is the same merge of the shards' sequences, and each
//! shard's share is a count. A shard pop whose cumulative cost alone exceeds the budget can
//! never be taken (the global budget used already holds the shard's earlier pops); it is sent
//! as the last one, so that the merge stops where the one-process queue stops.

use super::{Entry, GlobalSelection, SceneSim, SceneStep};
use crate::error::ViewError;
use crate::scene_file::LoadedScene;
use std::collections::BinaryHeap;
use std::ops::Range;

mod wire;

/// The most cells a depth buffer message holds (a scene's largest depth buffer).
const MAX_CELLS: usize = 1 << 22;

/// Where a shard's bodies sit in the whole scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShardRange {
    /// This shard's index (0-based).
    pub index: usize,
    /// The number of shards.
    pub count: usize,
    /// The whole scene's first body of this shard.
    pub first: usize,
    /// This shard's bodies.
    pub bodies: usize,
    /// The whole scene's bodies.
    pub total: usize,
}

impl ShardRange {
    /// Shard `index` of `count` over `total` bodies: bodies `⌊index·total/count⌋` up to the
    /// next shard's first. An error unless `1 ≤ count ≤ total` and `index < count`.
    pub fn new(index: usize, count: usize, total: usize) -> Result<ShardRange, ViewError> {
        if count == 0 || count > total {
            return Err(ViewError::Shard(format!(
                "{count} shards for {total} bodies: the count must lie in 1..={total}"
            )));
        }
        if index >= count {
            return Err(ViewError::Shard(format!(
                "shard {index} of {count}: the index must lie in 0..{count}"
            )));
        }
        let bound = |k: usize| (k as u128 * total as u128 / count as u128) as usize;
        let first = bound(index);
        Ok(ShardRange {
            index,
            count,
            first,
            bodies: bound(index + 1) - first,
            total,
        })
    }

    /// The whole scene's bodies of this shard.
    pub fn range(&self) -> Range<usize> {
        self.first..self.first + self.bodies
    }
}

impl LoadedScene {
    /// The scene of shard `index` of `count` ([`ShardRange::new`]): the same scene with only
    /// that shard's placements and the pushes on them (their body indices moved to the
    /// shard's). Every other field — models, camera, budget, tolerance, floor — is the
    /// whole scene's.
    pub fn shard(
        &self,
        index: usize,
        count: usize,
    ) -> Result<(LoadedScene, ShardRange), ViewError> {
        let range = ShardRange::new(index, count, self.placements.len())?;
        let r = range.range();
        let mut part = LoadedScene {
            placements: Vec::new(),
            pushes: Vec::new(),
            ..self.clone_settings()
        };
        part.placements
            .extend_from_slice(&self.placements[r.clone()]);
        part.pushes
            .extend(self.pushes.iter().filter(|p| r.contains(&p.body)).map(|p| {
                let mut p = *p;
                p.body -= r.start;
                p
            }));
        Ok((part, range))
    }

    /// A copy of every field but the placements and pushes (left empty).
    fn clone_settings(&self) -> LoadedScene {
        LoadedScene {
            path: self.path.clone(),
            models: self.models.clone(),
            placements: Vec::new(),
            camera: self.camera.clone(),
            pushes: Vec::new(),
            budget: self.budget,
            tolerance: self.tolerance,
            dt: self.dt,
            reselect_every: self.reselect_every,
            gravity: self.gravity,
            visibility: self.visibility,
            image: self.image,
            joint_springs: self.joint_springs,
            ground: self.ground,
        }
    }
}

/// What a re-selection's first exchange carries: the depth buffer of a shard's occluders
/// (from [`SceneShard::begin`]) or the merged one (from [`merge_depths`]).
#[derive(Clone, Debug, PartialEq)]
pub struct DepthMessage {
    /// The scene step it belongs to.
    pub step: u64,
    /// Cells per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Depths, row-major from the top-left cell (`f64::INFINITY`: empty).
    pub depth: Vec<f64>,
}

/// One pop of a shard's sequence (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// Its node's metric (the view-weighted acceleration metric).
    pub metric: f64,
    /// The whole scene's body.
    pub body: usize,
    /// Its node in the body's assembly tree.
    pub node: usize,
    /// Its joint's degrees of freedom.
    pub cost: usize,
    /// The sum of its join children's metrics (the metric mass it adds; 0 when the scene has
    /// no tolerance, which alone reads it).
    pub added: f64,
}

/// A shard's candidates at a re-selection (from [`SceneShard::weigh`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Candidates {
    /// The shard's place in the scene.
    pub range: ShardRange,
    /// The scene step of the re-selection.
    pub step: u64,
    /// The budget the sequence was cut for (the scene's).
    pub budget: Option<usize>,
    /// The scene's tolerance (the merge stops when the metric mass left falls to it).
    pub tolerance: Option<f64>,
    /// With a tolerance: each of its bodies' root metric mass, `(body, mass)` in body order,
    /// zeros left out (the merge sums them in the one-process order).
    pub roots: Vec<(usize, f64)>,
    /// Its bodies' pops merged in the global queue's order, up to and including the first
    /// whose cumulative cost exceeds the budget.
    pub pops: Vec<Candidate>,
}

/// What a shard's step did (from [`SceneShard::apply`] and [`SceneShard::advance`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ShardStep {
    /// The step over the shard's bodies (its `total_error` is the shard's own).
    pub step: SceneStep,
    /// At a re-selection: each of its bodies' weighted error, `(body, error)` in body order,
    /// zeros left out (summed in body order by [`combine_steps`]).
    pub errors: Vec<(usize, f64)>,
}

/// Where a shard is in a re-selection's exchanges.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Idle,
    Begun {
        forced: bool,
    },
    Weighed {
        forced: bool,
        classes: [[usize; 3]; 2],
    },
}

/// The bodies of one shard of a scene, stepped in the re-selection's exchanges (module
/// documentation). Every body's arithmetic is that of the one-process [`SceneSim`], so a
/// sharded run is the same bits as the whole scene's.
pub struct SceneShard<'s> {
    sim: SceneSim<'s>,
    range: ShardRange,
    phase: Phase,
    /// The last re-selection's sequence: (local body, node, cost) of each pop sent.
    sequence: Vec<(usize, usize, usize)>,
    /// Whether its last pop is the one beyond the budget (never taken).
    cut: bool,
}

impl<'s> SceneShard<'s> {
    /// The shard of `part` (from [`LoadedScene::shard`], with its `range`).
    pub fn new(part: &'s LoadedScene, range: ShardRange) -> Result<SceneShard<'s>, ViewError> {
        if part.placements.len() != range.bodies {
            return Err(ViewError::Shard(format!(
                "shard {} of {} holds {} bodies, its range {}",
                range.index,
                range.count,
                part.placements.len(),
                range.bodies
            )));
        }
        Ok(SceneShard {
            sim: SceneSim::new(part)?,
            range,
            phase: Phase::Idle,
            sequence: Vec::new(),
            cut: false,
        })
    }

    /// Its place in the scene.
    pub fn range(&self) -> ShardRange {
        self.range
    }

    /// Its bodies' running scene (body `i` is the whole scene's `range().first + i`).
    pub fn sim(&self) -> &SceneSim<'s> {
        &self.sim
    }

    /// Steps its bodies on `threads` ([`SceneSim::set_threads`]).
    pub fn set_threads(&mut self, threads: articula_dca::Threads) {
        self.sim.set_threads(threads);
    }

    /// Whether the next step re-selects (then [`SceneShard::begin`] starts it).
    pub fn reselects_next(&self) -> bool {
        self.sim.reselect_next
            || self
                .sim
                .steps
                .is_multiple_of(self.sim.scene.reselect_every as u64)
    }

    fn phase_error(&self, call: &str) -> ViewError {
        ViewError::Shard(format!(
            "shard {} of {}: {call} out of order at step {} ({:?})",
            self.range.index, self.range.count, self.sim.steps, self.phase
        ))
    }

    /// A re-selection's first exchange: its bodies' pushes and springs, exact solves and
    /// frustum classes, and the depth buffer of its occluders. An error when the next step
    /// does not re-select ([`SceneShard::advance`] steps it).
    pub fn begin(&mut self) -> Result<DepthMessage, ViewError> {
        if self.phase != Phase::Idle || !self.reselects_next() {
            return Err(self.phase_error("begin"));
        }
        self.sim.check_bodies()?;
        let (_, forced) = self.sim.reselect_due();
        self.sim.reselect_solve()?;
        self.phase = Phase::Begun { forced };
        let b = &self.sim.classifier.buffer;
        Ok(DepthMessage {
            step: self.sim.steps,
            width: b.width,
            height: b.height,
            depth: b.depth.clone(),
        })
    }

    /// A re-selection's second exchange, with the scene's merged depth buffer: the occlusion
    /// test, weights and node metrics of its bodies, and their candidates.
    pub fn weigh(&mut self, merged: &DepthMessage) -> Result<Candidates, ViewError> {
        let Phase::Begun { forced } = self.phase else {
            return Err(self.phase_error("weigh"));
        };
        let buffer = &mut self.sim.classifier.buffer;
        let fits = (merged.width, merged.height, merged.depth.len())
            == (buffer.width, buffer.height, buffer.depth.len());
        if merged.step != self.sim.steps || !fits {
            return Err(ViewError::Shard(format!(
                "shard {}: a depth buffer of step {} and {}×{} cells ({} depths) for step {} \
                 and {}×{} cells",
                self.range.index,
                merged.step,
                merged.width,
                merged.height,
                merged.depth.len(),
                self.sim.steps,
                buffer.width,
                buffer.height
            )));
        }
        buffer.depth.copy_from_slice(&merged.depth);
        let classes = self.sim.reselect_weigh()?;
        self.phase = Phase::Weighed { forced, classes };
        Ok(self.candidates())
    }

    /// Its bodies' own queues merged into one sequence, cut after the first pop beyond the
    /// budget.
    fn candidates(&mut self) -> Candidates {
        let scene = self.sim.scene;
        let (bodies, first) = (&self.sim.bodies, self.range.first);
        let mut heads = BinaryHeap::with_capacity(bodies.len());
        let mut next = vec![0usize; bodies.len()];
        let head = |b: usize, k: usize| {
            bodies[b].own.pops.get(k).map(|p| Entry {
                metric: p.metric,
                body: b,
                node: p.node,
            })
        };
        heads.extend((0..bodies.len()).filter_map(|b| head(b, 0)));
        let mut pops = Vec::new();
        self.sequence.clear();
        self.cut = false;
        let mut cost = 0usize;
        while let Some(top) = heads.pop() {
            if top.metric <= 0.0 {
                break;
            }
            let pop = bodies[top.body].own.pops[next[top.body]];
            next[top.body] += 1;
            heads.extend(head(top.body, next[top.body]));
            pops.push(Candidate {
                metric: pop.metric,
                body: first + top.body,
                node: pop.node,
                cost: pop.cost,
                added: if scene.tolerance.is_some() {
                    pop.added
                } else {
                    0.0
                },
            });
            self.sequence.push((top.body, pop.node, pop.cost));
            cost = cost.saturating_add(pop.cost);
            if scene.budget.is_some_and(|b| cost > b) {
                self.cut = true;
                break;
            }
        }
        let roots = match scene.tolerance {
            Some(_) => (bodies.iter().enumerate())
                .filter(|(_, b)| b.own.joined && b.own.init != 0.0)
                .map(|(i, b)| (first + i, b.own.init))
                .collect(),
            None => Vec::new(),
        };
        Candidates {
            range: self.range,
            step: self.sim.steps,
            budget: scene.budget,
            tolerance: scene.tolerance,
            roots,
            pops,
        }
    }

    /// A re-selection's last exchange: the global queue took the first `taken` pops of this
    /// shard's candidates ([`merge_candidates`]); its bodies get their shares and step.
    pub fn apply(&mut self, taken: usize) -> Result<ShardStep, ViewError> {
        let Phase::Weighed { forced, classes } = self.phase else {
            return Err(self.phase_error("apply"));
        };
        let takeable = self.sequence.len() - usize::from(self.cut);
        if taken > takeable {
            return Err(ViewError::Shard(format!(
                "shard {}: {taken} pops taken of {takeable} that fit the budget",
                self.range.index
            )));
        }
        self.phase = Phase::Idle;
        let sel = &mut self.sim.selection;
        let n = self.sim.bodies.len();
        *sel = GlobalSelection {
            allocation: vec![0; n],
            error: vec![0.0; n],
            popped: std::mem::take(&mut sel.popped),
            ..GlobalSelection::default()
        };
        sel.popped.resize_with(n, Vec::new);
        for (p, b) in sel.popped.iter_mut().zip(&self.sim.bodies) {
            p.clear();
            p.extend(b.own.free_root.filter(|_| b.own.joined));
        }
        for &(b, node, cost) in &self.sequence[..taken] {
            sel.popped[b].push(node);
            sel.allocation[b] += cost;
            sel.used += cost;
        }
        self.sim.reselect_apply(forced, classes)?;
        let step = self.sim.step_bodies(true)?;
        let first = self.range.first;
        let errors = (self.sim.bodies.iter().enumerate())
            .filter(|(_, b)| b.error != 0.0)
            .map(|(i, b)| (first + i, b.error))
            .collect();
        Ok(ShardStep { step, errors })
    }

    /// Up to `max` steps without re-selection, stopping before the next re-selection (whose
    /// exchanges start with [`SceneShard::begin`]).
    pub fn advance(&mut self, max: usize) -> Result<Vec<ShardStep>, ViewError> {
        if self.phase != Phase::Idle {
            return Err(self.phase_error("advance"));
        }
        let mut out = Vec::new();
        while out.len() < max && !self.reselects_next() {
            self.sim.check_bodies()?;
            let step = self.sim.step_bodies(false)?;
            out.push(ShardStep {
                step,
                errors: Vec::new(),
            });
        }
        Ok(out)
    }

    /// The rotate-xor hash of the bits of its bodies' `q` and `q̇` ([`SceneSim::state_hash`])
    /// and how many numbers it covers, for [`combine_state_hashes`].
    pub fn state_hash(&self) -> (u64, u64) {
        (self.sim.state_hash(), self.sim.state_numbers())
    }
}

impl SceneSim<'_> {
    /// A fingerprint of the scene's state: `h ← rotl(h, 5) ⊕ bits(x)` over every body's `q`
    /// then `q̇`, in body order, from 0 (the state hash `cargo xtask hash` prints).
    pub fn state_hash(&self) -> u64 {
        let numbers = self
            .bodies
            .iter()
            .flat_map(|b| b.state.q.iter().chain(&b.state.qd));
        numbers.fold(0u64, |h, x| h.rotate_left(5) ^ x.to_bits())
    }

    /// How many numbers [`SceneSim::state_hash`] covers.
    fn state_numbers(&self) -> u64 {
        self.bodies
            .iter()
            .map(|b| (b.state.q.len() + b.state.qd.len()) as u64)
            .sum()
    }
}

/// The whole scene's [`SceneSim::state_hash`] from its shards' `(hash, numbers)` in shard
/// order: each number's bits end rotated by 5 per number after it, so
/// `h = rotl(h_a, 5·n_b) ⊕ h_b`.
pub fn combine_state_hashes(parts: &[(u64, u64)]) -> u64 {
    parts.iter().fold(0u64, |h, &(hb, nb)| {
        h.rotate_left(((5 * (nb % 64)) % 64) as u32) ^ hb
    })
}

/// Checks that `ranges` are shards `0..n` of one scene, in order, tiling its bodies.
fn check_ranges(ranges: impl Iterator<Item = ShardRange>) -> Result<usize, ViewError> {
    let (mut count, mut next, mut seen) = (0, 0, 0);
    for (k, r) in ranges.enumerate() {
        let want = ShardRange::new(k, r.count, r.total)?;
        if r != want || (k > 0 && r.first != next) {
            return Err(ViewError::Shard(format!(
                "message {k} is from shard {} of {} (bodies {:?} of {}), expected shard {k}",
                r.index,
                r.count,
                r.range(),
                r.total
            )));
        }
        next = r.first + r.bodies;
        count = r.count;
        seen = k + 1;
    }
    if seen != count {
        return Err(ViewError::Shard(format!(
            "{seen} messages for {count} shards: every shard's is needed, in shard order"
        )));
    }
    Ok(count)
}

/// The scene's depth buffer from its shards' ([`SceneShard::begin`], any order): the
/// nearest depth per cell. An error when the buffers' steps or sizes differ, or none is given.
pub fn merge_depths(parts: &[DepthMessage]) -> Result<DepthMessage, ViewError> {
    let (first, rest) = parts
        .split_first()
        .ok_or_else(|| ViewError::Shard("no depth buffer to merge".into()))?;
    let mut out = first.clone();
    for (k, p) in rest.iter().enumerate() {
        let same = (p.step, p.width, p.height, p.depth.len())
            == (out.step, out.width, out.height, out.depth.len());
        if !same {
            return Err(ViewError::Shard(format!(
                "depth buffer {} is of step {} and {}×{} cells, the first of step {} and {}×{}",
                k + 1,
                p.step,
                p.width,
                p.height,
                out.step,
                out.width,
                out.height
            )));
        }
        for (d, e) in out.depth.iter_mut().zip(&p.depth) {
            *d = if *e < *d { *e } else { *d };
        }
    }
    Ok(out)
}

/// The global queue over the shards' candidates (one per shard, in shard order): how many
/// pops of each shard it takes — exactly the pops of the one-process queue. An error when the
/// messages are not shards `0..n` of one scene in order, or their steps, budgets or
/// tolerances differ.
pub fn merge_candidates(parts: &[Candidates]) -> Result<Vec<usize>, ViewError> {
    check_ranges(parts.iter().map(|p| p.range))?;
    let first = parts
        .first()
        .ok_or_else(|| ViewError::Shard("no candidates to merge".into()))?;
    for p in parts {
        let same = p.step == first.step
            && p.budget == first.budget
            && p.tolerance.map(f64::to_bits) == first.tolerance.map(f64::to_bits);
        if !same {
            return Err(ViewError::Shard(format!(
                "shard {} sent candidates of step {} for budget {:?} and tolerance {:?}, \
                 shard 0 of step {} for budget {:?} and tolerance {:?}",
                p.range.index,
                p.step,
                p.budget,
                p.tolerance,
                first.step,
                first.budget,
                first.tolerance
            )));
        }
    }
    let (budget, tol) = (first.budget, first.tolerance.filter(|t| *t > 0.0));
    // The mass left, summed as the one-process queue sums it: the roots in body order.
    let mut remaining = 0.0;
    for p in parts {
        for &(_, m) in &p.roots {
            remaining += m;
        }
    }
    let mut taken = vec![0usize; parts.len()];
    let head = |s: usize, k: usize| {
        parts[s].pops.get(k).map(|c| {
            (
                Entry {
                    metric: c.metric,
                    body: c.body,
                    node: c.node,
                },
                s,
            )
        })
    };
    let mut heads: BinaryHeap<(Entry, usize)> =
        (0..parts.len()).filter_map(|s| head(s, 0)).collect();
    let mut used = 0usize;
    while let Some(&(top, s)) = heads.peek() {
        if top.metric <= 0.0 || tol.is_some_and(|t| remaining <= t) {
            break;
        }
        let pop = parts[s].pops[taken[s]];
        if budget.is_some_and(|b| used + pop.cost > b) {
            break;
        }
        heads.pop();
        remaining -= top.metric;
        used += pop.cost;
        remaining += pop.added;
        taken[s] += 1;
        heads.extend(head(s, taken[s]));
    }
    Ok(taken)
}

/// The whole scene's step from its shards' (in shard order): the sums and largest
/// penetration over the shards and, at a re-selection, the scene's weighted error summed
/// over every body in body order (as the one-process scene sums it). `last_error` is the
/// error of the last re-selection, kept by steps without one.
pub fn combine_steps(parts: &[ShardStep], total: usize, last_error: f64) -> SceneStep {
    let mut out = SceneStep {
        reselected: parts.iter().any(|p| p.step.reselected),
        total_error: last_error,
        ..SceneStep::default()
    };
    for p in parts {
        // Every field named: a new one must be combined here too.
        let SceneStep {
            reselected: _,
            active_total,
            classes,
            link_classes,
            total_error: _,
            contacts,
            max_penetration,
            contact_solves,
            contact_capped,
            contact_rows,
            contact_sweeps,
        } = p.step;
        out.active_total += active_total;
        for k in 0..3 {
            out.classes[k] += classes[k];
            out.link_classes[k] += link_classes[k];
        }
        out.contacts += contacts;
        out.max_penetration = out.max_penetration.max(max_penetration);
        out.contact_solves += contact_solves;
        out.contact_capped += contact_capped;
        out.contact_rows += contact_rows;
        out.contact_sweeps += contact_sweeps;
    }
    if out.reselected {
        let mut errors = vec![0.0; total];
        for &(b, e) in parts.iter().flat_map(|p| &p.errors) {
            if let Some(x) = errors.get_mut(b) {
                *x = e;
            }
        }
        out.total_error = errors.iter().sum();
    }
    out
}
