//! One body's DCA across cores (docs/design.md#dca, docs/scaling.md): the two sides of a join
//! are independent subassemblies, so the main pass builds them on two threads and joins them
//! on one, and the back-substitution hands each side its handle forces and solves the two
//! sides on two threads.
//!
//! The driver splits the assembly tree's top [`SPLIT_DEPTH`](crate::banked::SPLIT_DEPTH) levels with `rayon::join`; each
//! node at depth [`SPLIT_DEPTH`](crate::banked::SPLIT_DEPTH) (or a leaf above it) is the root of a subtree that one task
//! solves serially, by the same per-node code as the serial passes ([`crate::dca`]'s
//! `main_range` and `back_range`). In post-order a subtree is a contiguous node range. Every
//! node's arithmetic is the one of the serial pass, reading only its children's outputs (main
//! pass) or its parent's (back-substitution), so the result is the same bits for any thread
//! count and any schedule.
//!
//! The serial passes keep the slots of the diagonal blocks, biases and handle forces per
//! (depth, side), reused from one subtree to the next; tasks running side by side need their
//! own. The banked layout ([`crate::banked::banked_slots`]) gives each of the top nodes a slot and a join
//! scratch of its own, and each subtree below them a bank of per-(depth, side) slots and a
//! scratch; it is built by the first parallel call on a workspace ([`Data::ensure_dca_banked`]).

#[cfg(any(test, feature = "parallel"))]
use crate::banked::SPLIT_DEPTH;
use crate::{Data, DynamicsError, Threads};
#[cfg(feature = "parallel")]
use articula_model::AssemblyTree;
use articula_model::Model;
use articula_spatial::SpatialForce;

/// The smallest model (bodies) whose DCA [`forward_dynamics_threads`] splits across threads:
/// below it the split's cost (waking a thread, a few µs, and the banked slots' wider working
/// set) outweighs half the solve, and the serial DCA of [`crate::forward_dynamics`] runs
/// whatever the thread count. Measured by `cargo xtask parallel` on two cores: the split on
/// two threads loses at 2,000 bodies and is about even to 1.2× at 5,000 (docs/scaling.md).
pub const PARALLEL_DCA_MIN_BODIES: usize = 5_000;

/// Forward dynamics of one body, DCA split across the threads of `threads` when the model has
/// at least [`PARALLEL_DCA_MIN_BODIES`] bodies (and no gather node); otherwise, or for another
/// `method`, exactly [`crate::forward_dynamics_slices`]. Returns `q̈` (also in `data.qdd`).
///
/// Whether the solve is split depends only on the model and the method, never on the thread
/// count, and a split solve does every node's arithmetic as the serial pass does: **the result
/// is the same bits for any thread count** (1 included). A split solve runs the kinematics in a
/// loop of their own before the passes (the serial DCA runs each body's at its parent's leaf),
/// so it may differ from [`crate::forward_dynamics_slices`] in the last bits. The first split
/// call on a workspace lays its DCA buffers out for the split (once); later calls allocate
/// nothing but the pool's bookkeeping.
#[allow(clippy::too_many_arguments)]
pub fn forward_dynamics_threads<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    f_ext: &[SpatialForce],
    method: crate::Method,
    threads: &Threads,
) -> Result<&'d [f64], DynamicsError> {
    let split = method == crate::Method::Dca
        && model.bodies.len() >= PARALLEL_DCA_MIN_BODIES
        && !model.assembly.has_gather();
    if !split {
        return crate::forward_dynamics_slices(model, data, q, qd, tau, f_ext, method);
    }
    forward_split(model, data, q, qd, tau, f_ext, threads)
}

/// [`forward_dynamics_threads`]' split solve whatever the model's size (a tree with gather
/// nodes runs the serial passes on the kinematics loop).
pub fn forward_split<'d>(
    model: &Model,
    data: &'d mut Data,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    f_ext: &[SpatialForce],
    threads: &Threads,
) -> Result<&'d [f64], DynamicsError> {
    crate::inputs::check_data(model, data)?;
    crate::check_inputs(model, q, qd, tau, f_ext)?;
    data.origin = crate::kinematics::computation_origin(model, q);
    crate::kinematics::forces_to_computation_frame(f_ext, data);
    let f_ext = std::mem::take(&mut data.f_ext_c);
    let result = solve(model, q, qd, tau, &f_ext, data, threads);
    data.f_ext_c = f_ext;
    result?;
    crate::forward::check_qdd(model, data)?;
    Ok(&data.qdd)
}

/// The kinematics, the split passes and, where the serial DCA takes it, the refinement (and
/// its fallback to ABA: `forward::dca_or_fall_back`).
fn solve(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
    threads: &Threads,
) -> Result<(), DynamicsError> {
    crate::forward::dca_or_fall_back(model, q, qd, tau, f_ext, data, |data| {
        split(model, q, qd, tau, f_ext, data, threads)
    })
}

/// The kinematics and the split passes.
fn split(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
    threads: &Threads,
) -> Result<(), DynamicsError> {
    let banked = data.ensure_dca_banked(model)?;
    if banked && threads.count() > 1 && model.bodies.len() >= PARALLEL_KINEMATICS_MIN_BODIES {
        kinematics(model, q, qd, data, threads, KINEMATICS_GRAIN);
    } else {
        // The same bits as the split kinematics, in one loop.
        crate::dca::kinematics_loop(model, q, qd, data);
    }
    data.dca.clamped = 0;
    // DCA's own tree: the model's assembly tree whenever the layout is banked (a tree with
    // leaf clusters or gather nodes never is, and runs the serial passes).
    let nodes = data.dca.node.len();
    if banked && threads.count() > 1 && nodes > 1 {
        passes(model, tau, f_ext, data, threads)
    } else {
        // One thread: the same nodes in the same order as the split (each node's arithmetic
        // does not depend on the order).
        crate::dca::main_range(model, tau, f_ext, data, true, 0..nodes)?;
        crate::dca::back_range(tau, data, 0..nodes);
        Ok(())
    }
}

/// Bodies per task of the kinematics' per-body parts: enough to amortise a task's
/// scheduling, few enough for the work-stealing pool to even out the threads.
const KINEMATICS_GRAIN: usize = 4096;

/// The smallest model (bodies) whose split solve runs the kinematics' per-body parts across
/// threads: below it the two extra rounds of waking the pool cost about what they save
/// (`articula bench` on a 2,000-link chain, 2 threads: ~20 µs slower across threads), and
/// the kinematics run in one loop (the same bits).
const PARALLEL_KINEMATICS_MIN_BODIES: usize = 4 * KINEMATICS_GRAIN;

/// The kinematics loop of the serial DCA ([`crate::dca::kinematics_loop`]), with what does not
/// need the parent's pose across threads (banked layout, several threads): the joints' sines
/// and cosines ([`crate::kinematics::joint_trig`]) on all threads, then the pose chain
/// `X_{C←i}`, `S`, `vᵢ` on one thread ([`pose_range`], in blocks of `grain / 4` bodies) while
/// the others follow it with the bias terms `cᵢ`, the points and arms
/// ([`crate::dca::bias_range`], in blocks of `grain` bodies whose poses are done); the chain's
/// thread joins them on the blocks left once it is through. Each body's arithmetic is the
/// loop's, so the result is its bits for any thread count and any `grain`.
#[cfg(feature = "parallel")]
fn kinematics(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    data: &mut Data,
    threads: &Threads,
    grain: usize,
) {
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicUsize, Ordering};
    let n = model.bodies.len();
    let (plans, trig) = (&data.fk_plan, &mut data.dca.bodies.trig);
    threads.install(|| {
        trig.par_chunks_mut(grain)
            .zip(plans.par_chunks(grain))
            .for_each(|(t, p)| {
                for (t, &p) in t.iter_mut().zip(p) {
                    *t = crate::kinematics::joint_trig(p, q);
                }
            })
    });
    // `posed`: the bodies whose poses are done (a prefix: parents come first); `next`: the
    // next block of bias terms to take.
    let (posed, next) = (AtomicUsize::new(0), AtomicUsize::new(0));
    let shared = Shared(data as *mut Data);
    let shared = &shared;
    let bias_blocks = || loop {
        let t = next.fetch_add(1, Ordering::Relaxed);
        let bodies = t * grain..n.min((t + 1) * grain);
        if bodies.is_empty() {
            return;
        }
        let mut spins = 0u32;
        while posed.load(Ordering::Acquire) < bodies.end {
            spins += 1;
            if spins < 64 {
                std::hint::spin_loop();
            } else {
                std::thread::yield_now();
            }
        }
        // SAFETY: see `Shared`: each block writes only its own bodies' entries (`c`,
        // `dca.point`, `dca.arm`) and reads the poses and velocities of bodies the chain has
        // done (released by `posed`), never those it is writing.
        crate::dca::bias_range(qd, unsafe { &mut *shared.0 }, bodies);
    };
    let block = (grain / 4).max(1);
    threads.install(|| {
        rayon::join(
            || {
                for start in (0..n).step_by(block) {
                    let bodies = start..n.min(start + block);
                    let end = bodies.end;
                    // SAFETY: see `Shared`: the chain alone writes poses, joint columns and
                    // velocities (and `c` of bodies off the one-axis fast path, which the bias
                    // blocks leave alone); the bias blocks read them only once released.
                    pose_range(model, q, qd, unsafe { &mut *shared.0 }, bodies);
                    posed.store(end, Ordering::Release);
                }
                bias_blocks();
            },
            bias_blocks,
        )
    });
}

articula_spatial::fma_dispatch! {
    /// The part of the kinematics loop that needs the parent's pose, for the bodies `bodies`
    /// (their parents done before): each body's [`crate::kinematics::kinematics_pose`], from
    /// the joint sines and cosines in `data.dca.trig`.
    fn pose_range(
        model: &Model,
        q: &[f64],
        qd: &[f64],
        data: &mut Data,
        bodies: std::ops::Range<usize>,
    );
    avx2_fma: data.dca.fused, Fused;
    |A| {
        let x_cw = articula_spatial::SpatialTransform::xlt(data.origin);
        for i in bodies {
            let trig = data.dca.bodies.trig[i];
            crate::kinematics::kinematics_pose(model, i, q, qd, data, x_cw, trig);
        }
    }
}

/// Without the `parallel` feature: the same parts on the calling thread.
#[cfg(not(feature = "parallel"))]
fn kinematics(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    data: &mut Data,
    _threads: &Threads,
    _grain: usize,
) {
    for (t, &p) in data.dca.bodies.trig.iter_mut().zip(&data.fk_plan) {
        *t = crate::kinematics::joint_trig(p, q);
    }
    pose_range(model, q, qd, data, 0..model.bodies.len());
    crate::dca::bias_range(qd, data, 0..model.bodies.len());
}

/// The main pass and the back-substitution split over `threads` (banked layout, several
/// threads).
#[cfg(feature = "parallel")]
fn passes(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
    threads: &Threads,
) -> Result<(), DynamicsError> {
    let root = model.assembly.root();
    let shared = Shared(data as *mut Data);
    let at = Split {
        tree: &model.assembly,
        model,
        tau,
        f_ext,
        data: &shared,
    };
    threads.install(|| at.main(root))?;
    threads.install(|| at.back(root));
    Ok(())
}

/// Without the `parallel` feature: the serial passes.
#[cfg(not(feature = "parallel"))]
fn passes(
    model: &Model,
    tau: &[f64],
    f_ext: &[SpatialForce],
    data: &mut Data,
    _threads: &Threads,
) -> Result<(), DynamicsError> {
    let nodes = data.dca.node.len();
    crate::dca::main_range(model, tau, f_ext, data, true, 0..nodes)?;
    crate::dca::back_range(tau, data, 0..nodes);
    Ok(())
}

/// The workspace the tasks share. Each task of the kinematics writes only its own bodies'
/// entries; each task of the passes writes only what belongs to the nodes of its own
/// range — their bodies' and joints' entries, their nodes' blocks, their slots and their
/// scratch bank of the banked layout — and reads what its children (main pass) or its parent
/// (back-substitution) wrote before the task began; no buffer is resized while tasks run.
#[cfg(feature = "parallel")]
struct Shared(*mut Data);

// SAFETY: see `Shared`: the tasks touch disjoint entries, and `rayon::join` orders a node's
// work after (main pass) or before (back-substitution) its subtrees'; the kinematics' tasks
// read only what the serial pose chain wrote before they began.
#[cfg(feature = "parallel")]
unsafe impl Sync for Shared {}

/// What every task of one split solve reads.
#[cfg(feature = "parallel")]
struct Split<'a> {
    tree: &'a AssemblyTree,
    model: &'a Model,
    tau: &'a [f64],
    f_ext: &'a [SpatialForce],
    data: &'a Shared,
}

#[cfg(feature = "parallel")]
impl Split<'_> {
    /// The first node of `n`'s subtree (post-order: the subtree is `first..=n`). A tree
    /// without gather nodes is binary: a subtree of `size` leaves has `2 size − 1` nodes.
    fn first(&self, n: usize) -> usize {
        n + 2 - 2 * self.tree.nodes[n].size
    }

    /// A join above the split depth: its two sides, the one first in post-order first.
    fn sides(&self, n: usize) -> Option<(usize, usize)> {
        let nd = &self.tree.nodes[n];
        match nd.kind {
            articula_model::NodeKind::Join {
                parent_side,
                child_side,
                ..
            } if nd.depth < SPLIT_DEPTH => Some(if parent_side < child_side {
                (parent_side, child_side)
            } else {
                (child_side, parent_side)
            }),
            _ => None,
        }
    }

    /// The workspace, for the nodes of one task.
    #[allow(clippy::mut_from_ref)]
    fn data(&self) -> &mut Data {
        // SAFETY: see `Shared`: each caller touches only its own nodes' entries.
        unsafe { &mut *self.data.0 }
    }

    /// Main pass of `n`'s subtree: its two sides on two tasks above the split depth, then `n`;
    /// the subtree serially below. The error is the serial pass's (the first in post-order).
    fn main(&self, n: usize) -> Result<(), DynamicsError> {
        let (model, tau, f_ext) = (self.model, self.tau, self.f_ext);
        let Some((x, y)) = self.sides(n) else {
            return crate::dca::main_range(
                model,
                tau,
                f_ext,
                self.data(),
                true,
                self.first(n)..n + 1,
            );
        };
        let (rx, ry) = rayon::join(|| self.main(x), || self.main(y));
        rx?;
        ry?;
        crate::dca::main_range(model, tau, f_ext, self.data(), true, n..n + 1)
    }

    /// Back-substitution of `n`'s subtree: `n`, then its two sides on two tasks above the
    /// split depth; the subtree serially below.
    fn back(&self, n: usize) {
        let Some((x, y)) = self.sides(n) else {
            return crate::dca::back_range(self.tau, self.data(), self.first(n)..n + 1);
        };
        crate::dca::back_range(self.tau, self.data(), n..n + 1);
        rayon::join(|| self.back(x), || self.back(y));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::banked::banked_slots;
    use crate::{forward_dynamics_slices, Method, State};
    use articula_model::NodeKind;

    /// The banked layout keeps every slot a join reads below its own (`c_blocks`) and gives
    /// subtrees solved side by side disjoint slots and scratch.
    #[test]
    fn banked_slots_are_disjoint_across_subtrees() {
        let model = articula_testkit::chain(300);
        let tree = &model.assembly;
        let mut side = vec![0; tree.nodes.len()];
        for nd in &tree.nodes {
            if let NodeKind::Join { child_side, .. } = nd.kind {
                side[child_side] = 1;
            }
        }
        let (si, nsi, ys, nys) = banked_slots(tree, &side);
        assert!(si.iter().all(|&s| s < nsi) && ys.iter().all(|&s| s < nys));
        for (n, nd) in tree.nodes.iter().enumerate() {
            if let NodeKind::Join {
                parent_side,
                child_side,
                ..
            } = nd.kind
            {
                assert!(si[n] < si[parent_side] && si[n] < si[child_side]);
            }
        }
        // Two nodes of different subtrees (or a top node and any other) never share a slot
        // or a scratch bank.
        let root_of = |mut n: usize| {
            while tree.nodes[n].depth > SPLIT_DEPTH {
                n = tree.nodes[n].parent.unwrap();
            }
            n
        };
        for a in 0..tree.nodes.len() {
            for b in a + 1..tree.nodes.len() {
                let (ra, rb) = (root_of(a), root_of(b));
                let top = tree.nodes[a].depth < SPLIT_DEPTH || tree.nodes[b].depth < SPLIT_DEPTH;
                if top || ra != rb {
                    assert_ne!(si[a], si[b], "slots of nodes {a} and {b}");
                    assert_ne!(ys[a], ys[b], "scratch of nodes {a} and {b}");
                }
            }
        }
        // In post-order a subtree is `first..=n`.
        for (n, nd) in tree.nodes.iter().enumerate() {
            let first = n + 2 - 2 * nd.size;
            let inside = (first..=n).filter(|&m| {
                let mut k = m;
                loop {
                    if k == n {
                        return true;
                    }
                    match tree.nodes[k].parent {
                        Some(p) => k = p,
                        None => return false,
                    }
                }
            });
            assert_eq!(inside.count(), n + 1 - first);
        }
    }

    /// The split solve on one, two and three threads (kinematics and passes across threads)
    /// is the serial DCA on the kinematics loop, bit for bit, and within rounding of the
    /// serial DCA with the leaves' kinematics (a chain with fixed and floating base, and a
    /// branched tree of general joints on DCA's plain assembly tree, with external forces).
    #[test]
    fn split_on_any_thread_count_is_the_serial_pass() {
        let tree = articula_model::Model::from_urdf_str(
            &articula_testkit::random_tree_urdf(300, 3),
            &articula_model::LoadOptions::default(),
        )
        .unwrap();
        let models = [
            (articula_testkit::bundled_with("chain300", false), true),
            (articula_testkit::bundled_with("chain300", true), true),
            (tree, false),
        ];
        for (k, (model, clusters)) in models.iter().enumerate() {
            let mut s = State::random(model, 3, 1.0);
            s.randomize_forces(3, 0.5);
            let workspace = || {
                let mut data = Data::new(model);
                data.set_leaf_clusters(model, *clusters);
                data
            };
            let mut serial = workspace();
            serial.ensure_dca(model).unwrap();
            let leaves = forward_dynamics_slices(
                model,
                &mut serial,
                &s.q,
                &s.qd,
                &s.tau,
                &s.f_ext,
                Method::Dca,
            )
            .unwrap()
            .to_vec();
            serial.dca.leaf_kinematics = false;
            let looped = forward_dynamics_slices(
                model,
                &mut serial,
                &s.q,
                &s.qd,
                &s.tau,
                &s.f_ext,
                Method::Dca,
            )
            .unwrap()
            .to_vec();
            let mut data = workspace();
            for threads in [1, 2, 3] {
                let split = forward_split(
                    model,
                    &mut data,
                    &s.q,
                    &s.qd,
                    &s.tau,
                    &s.f_ext,
                    &Threads::new(threads).unwrap(),
                )
                .unwrap()
                .to_vec();
                assert!(data.dca.banked, "model {k}");
                assert_eq!(split, looped, "model {k} on {threads} threads");
            }
            // The kinematics across threads, in small tasks, against the loop.
            let fresh = || {
                let mut d = workspace();
                d.ensure_dca_banked(model).unwrap();
                d.origin = serial.origin;
                d
            };
            for threads in [2, 3] {
                let mut split = fresh();
                kinematics(
                    model,
                    &s.q,
                    &s.qd,
                    &mut split,
                    &Threads::new(threads).unwrap(),
                    7,
                );
                let mut one = fresh();
                crate::dca::kinematics_loop(model, &s.q, &s.qd, &mut one);
                let m = format!("model {k} on {threads} threads");
                assert_eq!(format!("{:?}", split.x), format!("{:?}", one.x), "{m}");
                assert_eq!(format!("{:?}", split.v), format!("{:?}", one.v), "{m}");
                assert_eq!(format!("{:?}", split.c), format!("{:?}", one.c), "{m}");
                assert_eq!(format!("{:?}", split.s), format!("{:?}", one.s), "{m}");
                assert_eq!(split.dca.bodies.point, one.dca.bodies.point, "{m}");
                assert_eq!(split.dca.bodies.arm, one.dca.bodies.arm, "{m}");
            }
            let scale = leaves.iter().fold(1.0f64, |m, x| m.max(x.abs()));
            let diff = leaves
                .iter()
                .zip(&looped)
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            assert!(diff <= 1e-11 * scale, "model {k}: {:e}", diff / scale);
        }
    }
}
