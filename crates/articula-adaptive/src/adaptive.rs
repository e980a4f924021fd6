//! The adaptive-dynamics workspace ([`Adaptive`]): settings, step counters and the named parts
//! the passes read and write (`parts/`). Its methods live with the passes that run them: the
//! public calls here and in `scratch.rs`, the main pass in `hybrid.rs`, the metric and
//! selection in `metric.rs`, rigidification in `rigidify.rs`, the hierarchical state in
//! `hierarchy.rs`, the caches in `cache.rs` and `update.rs`, the RK4 step in `rk4.rs`.

use crate::hybrid::Level;
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
use crate::parts::passive::PassiveForces;
use crate::parts::rk_buffers::RkBuffers;
use crate::parts::selection_queue::{Selection, SelectionQueue};
use crate::parts::switches::Switches;
use crate::settings::{Reselection, Settings};
use crate::{metric, update};
use crate::{AdaptiveError, StepReport};
use articula_dca::{check_inputs, forward_kinematics, Data, DynamicsError, State, Threads};
use articula_model::{Model, NodeKind};
use articula_spatial::numerics::all_finite;
use articula_spatial::{SpatialForce, SpatialTransform};

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
    pub(crate) rk4: RkBuffers,
    /// The model's internal degrees of freedom (a floating base's six left out): what
    /// [`Settings::BALANCED`] resolves against.
    pub(crate) internal: usize,
    /// The threads a hybrid step of a large active region splits its per-joint sweeps over
    /// ([`Adaptive::set_threads`]; serial by default).
    pub(crate) threads: Threads,
    /// The step's implicit damping in the armature and its joint forces with the passive
    /// ones (`parts/passive.rs`).
    pub(crate) passive: PassiveForces,
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
                sin_cos: Vec::with_capacity(model.nv),
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
            rk4: RkBuffers::default(),
            internal: model.nv - if model.floating_base { 6 } else { 0 },
            threads: Threads::default(),
            passive: PassiveForces::default(),
        }
    }
}

/// Advances `state` by `dt` with adaptive dynamics: the stepping call of
/// [`articula_dca::step`] with the same argument order — model, workspace, state, integrator,
/// time step — and the same integrators, for code that switches between exact and adaptive
/// dynamics:
///
/// ```text
/// articula_dca::step(&model, &mut data, &mut state, Method::Dca, Integrator::Rk4, dt)?;
/// articula_adaptive::step(&model, &mut adaptive, &mut state, Integrator::Rk4, dt)?;
/// ```
///
/// - [`Integrator::SemiImplicitEuler`](articula_dca::Integrator::SemiImplicitEuler):
///   [`Adaptive::step`] (`q̇ ← q̇ + h q̈`, then `q ← q ⊕ h q̇` on the active joints).
/// - [`Integrator::Rk4`](articula_dca::Integrator::Rk4): [`Adaptive::step_rk4`], classic
///   fourth-order Runge–Kutta (Munthe-Kaas on a floating joint) on the active joints of the
///   hybrid body chosen at the step's start.
///
/// Both re-select the hybrid body at the step's start every
/// [`Settings::reselect_every`] steps, and apply the model's damping and springs as
/// articula-dca's steps do (passive forces added to `τ`, damping implicit over the Euler
/// step; armature in the inertia). With every joint active they are articula-dca's steps
/// of the same integrator to rounding (articula-dca's momentum projection of free-floating
/// models, `Data::momentum_projection`, has no adaptive counterpart).
pub fn step(
    model: &Model,
    adaptive: &mut Adaptive,
    state: &mut State,
    integrator: articula_dca::Integrator,
    dt: f64,
) -> Result<StepReport, AdaptiveError> {
    match integrator {
        articula_dca::Integrator::SemiImplicitEuler => adaptive.step(model, state, dt),
        articula_dca::Integrator::Rk4 => adaptive.step_rk4(model, state, dt),
    }
}

impl Adaptive {
    /// The settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Replaces the settings (checked).
    pub fn set_settings(&mut self, settings: Settings) -> Result<(), AdaptiveError> {
        settings.validate()?;
        self.settings = settings;
        Ok(())
    }

    /// Acceleration-metric weight of body `body`'s joint: `A = scale · 1` (scale ≥ 0).
    ///
    /// The caches of the rigid subassemblies hold metric coefficients built with the weights:
    /// a weight that changes marks them stale, so the next re-selection runs whole-body passes
    /// (an unchanged weight keeps them).
    pub fn set_weight(&mut self, model: &Model, body: usize, scale: f64) {
        if self.metric.set_accel_weight(model, body, scale) {
            self.cache.all_valid = false;
        }
    }

    /// Velocity-metric weight of body `body`'s joint: `V = scale · 1` (scale ≥ 0).
    pub fn set_velocity_weight(&mut self, model: &Model, body: usize, scale: f64) {
        self.metric.set_velocity_weight(model, body, scale);
    }

    /// The acceleration-metric weight matrix `A_i` (k × k, row-major) of body `body`'s joint.
    pub fn weight(&self, model: &Model, body: usize) -> &[f64] {
        self.metric.accel_weight(model, body)
    }

    /// The last selection.
    pub fn selection(&self) -> &Selection {
        &self.last
    }

    /// Whether body `body`'s joint was selected by the last selection.
    pub fn is_selected(&self, model: &Model, body: usize) -> bool {
        self.queue.selected[model.assembly.joint_node[body]]
    }

    /// Whether body `body`'s joint is in the hybrid body's active region (it moves).
    pub fn is_active(&self, model: &Model, body: usize) -> bool {
        self.body.active[model.assembly.joint_node[body]]
    }

    /// Degrees of freedom in the hybrid body's active region.
    pub fn active_dofs(&self, model: &Model) -> usize {
        if self.hier.valid {
            // Counted when the records were built (`Σ nv` over `ajoints`).
            return self.hier.dofs;
        }
        model
            .assembly
            .nodes
            .iter()
            .enumerate()
            .filter(|(n, _)| self.body.active[*n])
            .map(|(_, node)| match node.kind {
                NodeKind::Join { joint, .. } => model.bodies[joint].nv,
                _ => 0,
            })
            .sum()
    }

    /// Kinematics and external forces of a state into the workspace (checked), then the
    /// composites of every node.
    pub(crate) fn load(
        &mut self,
        model: &Model,
        q: &[f64],
        qd: &[f64],
        tau: &[f64],
        f_ext: &[SpatialForce],
    ) -> Result<(), AdaptiveError> {
        self.load_state(model, q, qd, tau, f_ext)?;
        // The external wrenches in the computation frame, `X*_{c←w} f` (only the composites'
        // force sums read them: not built for `set_active`'s impulse).
        let x_cw = SpatialTransform::xlt(self.data.origin);
        self.forces.computation.clear();
        self.forces
            .computation
            .extend(f_ext.iter().map(|f| x_cw.apply_force(*f)));
        self.composites(model);
        Ok(())
    }

    /// [`Adaptive::load`] without the external wrenches' frame change and the composites.
    pub(crate) fn load_state(
        &mut self,
        model: &Model,
        q: &[f64],
        qd: &[f64],
        tau: &[f64],
        f_ext: &[SpatialForce],
    ) -> Result<(), AdaptiveError> {
        if model.assembly.has_gather() {
            return Err(unsupported_tree(model));
        }
        check_inputs(model, q, qd, tau, f_ext)?;
        // Kinematics left by node_metrics for this very state are reused (the same bits:
        // compared by `memcmp`, much cheaper than `f64` equality; a `-0.0` for a
        // `0.0` now recomputes them).
        if !(self.fresh.valid
            && update::same_bits(&self.fresh.q, q)
            && update::same_bits(&self.fresh.qd, qd))
        {
            forward_kinematics(model, q, qd, &mut self.data)?;
        }
        self.fresh.valid = false;
        Ok(())
    }

    /// Adaptive forward dynamics of one state: the articulated coefficients and the metric
    /// bottom-up, then the joint selection (budget / tolerance of the settings). Selected joints
    /// get their exact accelerations, the others zero; [`Adaptive::selection`] tells how many
    /// were selected and the predicted error (`Σ q̈ᵀAq̈` of the difference to exact DCA).
    pub fn forward_dynamics(
        &mut self,
        model: &Model,
        q: &[f64],
        qd: &[f64],
        tau: &[f64],
        f_ext: &[SpatialForce],
    ) -> Result<&[f64], AdaptiveError> {
        self.settings.validate()?;
        // The rigid-body map plus armature: no passive force, no implicit damping.
        self.set_damping_step(model, 0.0);
        self.cache.all_valid = false;
        self.load(model, q, qd, tau, f_ext)?;
        self.main_pass(model, tau, Level::Acceleration, true)?;
        self.metric_pass(model);
        self.last = self.select(model);
        check_qdd(model, &self.body.qdd)?;
        Ok(&self.body.qdd)
    }

    /// The acceleration metric `A(C)` of every node of the assembly tree at its handle forces in
    /// the exact (fully articulated) solution, written into `out` (one per node; 0 at leaves).
    /// The exact accelerations are left in [`Adaptive::qdd`].
    ///
    /// At the exact handle forces the quadratic form `Fᵀ Ψ F + Fᵀ p + η` equals
    /// `Σ_{i∈C} q̈ᵢᵀ Aᵢ q̈ᵢ` of the exact accelerations (docs/design.md#adaptive; tested against
    /// [`Adaptive::predicted_node_metrics`] to 1e-8), so this sums that bottom-up after one exact
    /// solve — articula-dca's articulated-body algorithm, the fastest exact solver on these
    /// trees — instead of building Ψ, p, η: a fraction of the cost, and never negative.
    pub fn node_metrics(
        &mut self,
        model: &Model,
        q: &[f64],
        qd: &[f64],
        tau: &[f64],
        f_ext: &[SpatialForce],
        out: &mut [f64],
    ) -> Result<(), AdaptiveError> {
        self.exact_solve(model, q, qd, tau, f_ext)?;
        self.exact_node_metrics(model, out);
        Ok(())
    }

    /// The exact solve behind [`Adaptive::node_metrics`] alone: the exact accelerations of
    /// `(q, q̇, τ, f_ext)` into [`Adaptive::qdd`] and their kinematics into
    /// [`Adaptive::data`] (`data.x[i]` maps body `i`'s coordinates to the computation frame's,
    /// whose origin is `data.origin`; `data.body_pose(i)` is its world pose), which the next
    /// load of the same state reuses. Follow it with
    /// [`Adaptive::scaled_node_metrics`] when every weight is a multiple of the identity and
    /// the weights are known only after the solve (a scene that classifies from the solve's
    /// poses).
    pub fn exact_solve(
        &mut self,
        model: &Model,
        q: &[f64],
        qd: &[f64],
        tau: &[f64],
        f_ext: &[SpatialForce],
    ) -> Result<(), AdaptiveError> {
        self.set_damping_step(model, 0.0);
        self.exact_solve_inner(model, q, qd, tau, f_ext)
    }

    /// [`Adaptive::exact_solve`] with the armature the workspace holds (a step's re-selection:
    /// its implicit damping's `h b` included).
    pub(crate) fn exact_solve_inner(
        &mut self,
        model: &Model,
        q: &[f64],
        qd: &[f64],
        tau: &[f64],
        f_ext: &[SpatialForce],
    ) -> Result<(), AdaptiveError> {
        metric::solve_exact(model, &mut self.data, &mut self.body.qdd, q, qd, tau, f_ext)?;
        self.mark_fresh(q, qd);
        Ok(())
    }

    /// Records that `data` holds the whole-body kinematics of `(q, q̇)` (an exact solve's),
    /// for the next load of the same state to reuse.
    pub(crate) fn mark_fresh(&mut self, q: &[f64], qd: &[f64]) {
        self.fresh.valid = true;
        self.fresh.q.copy_from_slice(q);
        self.fresh.qd.copy_from_slice(qd);
    }

    /// The node metrics of the last exact solve ([`Adaptive::exact_solve`],
    /// [`Adaptive::node_metrics`]) with the weights `Aᵢ = weights[i] · 1` (one per model body,
    /// its joint's scale) instead of the workspace's own: `out[n] = Σ_{i∈C} wᵢ q̈ᵢᵀq̈ᵢ` over
    /// node `n`'s subtree. The same numbers, to the bit, as [`Adaptive::set_weight`] of every
    /// body followed by [`Adaptive::node_metrics`] (the products and sums in the same order),
    /// without writing the weight matrices.
    pub fn scaled_node_metrics(&self, model: &Model, weights: &[f64], out: &mut [f64]) {
        crate::metric::subtree_scaled_quadratic(model, weights, &self.body.qdd, out);
    }

    /// The metric `A(C) = Fᵀ Ψ F + Fᵀ p + η` predicted at every node of the assembly tree from
    /// its handle forces in the exact (fully articulated) solution — through the metric
    /// coefficients Ψ, p, η of the whole tree, as the selection computes them — written into
    /// `out` (one per node; 0 at leaves). The exact accelerations are left in
    /// [`Adaptive::qdd`]. Same values as [`Adaptive::node_metrics`], at several times its cost.
    pub fn predicted_node_metrics(
        &mut self,
        model: &Model,
        q: &[f64],
        qd: &[f64],
        tau: &[f64],
        f_ext: &[SpatialForce],
        out: &mut [f64],
    ) -> Result<(), AdaptiveError> {
        self.set_damping_step(model, 0.0);
        self.load(model, q, qd, tau, f_ext)?;
        self.main_pass(model, tau, Level::Acceleration, true)?;
        self.metric_pass(model);
        let tree = &model.assembly;
        self.body.qdd.fill(0.0);
        let root = tree.root();
        let (ho, nh) = (self.coef.layout.hoff[root], self.coef.handles[root]);
        self.coef.force[ho..ho + nh].fill(SpatialForce::ZERO);
        for n in (0..tree.nodes.len()).rev() {
            out[n] = self.metric_at(n);
            self.expand(model, n);
        }
        Ok(())
    }

    /// The joint accelerations of the last call.
    pub fn qdd(&self) -> &[f64] {
        &self.body.qdd
    }

    /// Re-selects the hybrid body of `state` now: the joints chosen by the acceleration metric
    /// (settings' budget / tolerance) stay free, every other moving joint is locked by internal
    /// impulses (`state.qd` changes; spatial momentum is kept, kinetic energy cannot grow).
    /// Returns whether joints were locked.
    pub fn reselect(&mut self, model: &Model, state: &mut State) -> Result<bool, AdaptiveError> {
        self.settings.validate()?;
        self.set_damping_step(model, 0.0);
        self.load(model, &state.q, &state.qd, &state.tau, &state.f_ext)?;
        self.reselect_loaded(model, state, false)
    }

    /// Whole-body re-selection; with `build` (and no velocity tolerance), the caches of every
    /// rigid subassembly are built on the way (O(n), the first step's cost) so that the next
    /// re-selections go through them.
    pub(crate) fn reselect_loaded(
        &mut self,
        model: &Model,
        state: &mut State,
        build: bool,
    ) -> Result<bool, AdaptiveError> {
        self.main_pass(model, &state.tau, Level::Acceleration, true)?;
        let mut touched = self.touched;
        self.metric_pass(model);
        self.last = self.select(model);
        let build = build && self.settings.velocity_tolerance.is_none();
        if build {
            // Positions and torques only: the impulse below does not change them (the
            // locked joints' damping forces, zero once locked: `take_locked_torques`).
            let locked = self.take_locked_torques();
            let tau = if locked.is_empty() {
                &state.tau
            } else {
                &locked
            };
            let built = self.build_all_caches(model, &state.q, tau);
            if !locked.is_empty() {
                self.passive.locked = locked;
            }
            built?;
            touched += model.assembly.nodes.len();
        } else {
            self.cache.all_valid = false;
        }
        // (An impulse changes velocities only: the composites stay valid.)
        let locked = self.rebuild_hybrid(model, state, true, false)?;
        if locked {
            touched += self.touched;
        }
        if self.cache.all_valid {
            // Caches of the nodes left in the active region (velocity tolerance) would be
            // stale; the selection's nodes for the next cached one.
            self.cache.reselection.selected.clear();
            for (n, node) in model.assembly.nodes.iter().enumerate() {
                if self.body.active[n] {
                    self.cache.tensors.node_valid[n] = false;
                }
                if self.queue.selected[n] && matches!(node.kind, NodeKind::Join { .. }) {
                    self.cache.reselection.selected.push(n);
                }
            }
        }
        self.touched = touched;
        Ok(locked)
    }

    /// One semi-implicit Euler step of the hybrid body (also [`step`], the free function with
    /// the argument order of [`articula_dca::step`]; [`Adaptive::step_rk4`] is the RK4 step). Every `reselect_every` steps (the first
    /// included) the joints are re-selected on the fully articulated coefficients and the
    /// joints leaving the hybrid body are locked by impulses. A re-selection is one exact
    /// whole-body solve ([`Reselection::ExactSolve`], the default); with
    /// [`Reselection::Caches`] the first re-selection (and the next after
    /// [`Adaptive::invalidate`], a changed locked torque, or with a velocity tolerance) visits
    /// the whole body and builds the caches of the rigid subassemblies, and the others go
    /// through those caches and visit the old and new active regions, their frontiers, the
    /// nodes the selection reaches and the paths of external forces on rigid parts only. The steps in between visit the active region and its rigid frontier only
    /// (hierarchical state). Then `q̇ ← q̇ + h q̈`, `q ← q ⊕ h q̇` on the active joints (locked
    /// joints keep `q̇ = 0` and their `q`).
    ///
    /// Apart from the whole-body re-selections, only the active joints' inputs are read and
    /// checked (and τ compared, see [`Adaptive::set_check_locked_torques`]; a body of at most
    /// 64 degrees of freedom has all its `q`, `q̇`, `τ` swept for non-finite numbers first, an
    /// error still only for an active joint's); `data` then holds
    /// the kinematics of the active bodies only. A non-empty `state.f_ext` is scanned for
    /// non-zero wrenches (pass an empty one, or use [`Adaptive::step_with_forces`], when there
    /// are none).
    pub fn step(
        &mut self,
        model: &Model,
        state: &mut State,
        dt: f64,
    ) -> Result<StepReport, AdaptiveError> {
        self.forces.sparse.clear();
        for (i, f) in state.f_ext.iter().enumerate() {
            if *f != SpatialForce::ZERO {
                self.forces.sparse.push((i, *f));
            }
        }
        self.step_inner(model, state, dt)
    }

    /// [`Adaptive::step`] with the external wrenches given as a list `(body, world wrench about
    /// the world origin)` instead of `state.f_ext` (which must then be empty): between
    /// re-selections each force costs a walk from its body to its rigid cluster, and nothing
    /// scans the whole body.
    pub fn step_with_forces(
        &mut self,
        model: &Model,
        state: &mut State,
        dt: f64,
        forces: &[(usize, SpatialForce)],
    ) -> Result<StepReport, AdaptiveError> {
        self.set_forces(model, state, forces)?;
        self.step_inner(model, state, dt)
    }

    /// The external wrenches of a step given as a list (checked; `state.f_ext` must be empty).
    pub(crate) fn set_forces(
        &mut self,
        model: &Model,
        state: &State,
        forces: &[(usize, SpatialForce)],
    ) -> Result<(), AdaptiveError> {
        if !state.f_ext.is_empty() {
            return Err(AdaptiveError::Setting(
                "give the external forces either in state.f_ext or as a list, not both".into(),
            ));
        }
        self.forces.sparse.clear();
        for &(i, f) in forces {
            let Some(body) = model.bodies.get(i) else {
                return Err(DynamicsError::Dimension {
                    what: "external force body index",
                    expected: model.bodies.len(),
                    found: i,
                }
                .into());
            };
            if !f.is_finite() {
                return Err(DynamicsError::NonFinite {
                    what: "external force",
                    name: body.name.clone(),
                }
                .into());
            }
            self.forces.sparse.push((i, f));
        }
        Ok(())
    }

    /// The dynamics of a step, before integration: re-selection (when due) with its locking
    /// impulse, then the active joints' `q̈` of the hybrid body. Shared by the Euler step and
    /// RK4's first stage.
    pub(crate) fn step_dynamics(
        &mut self,
        model: &Model,
        state: &mut State,
    ) -> Result<StepReport, AdaptiveError> {
        self.settings.validate()?;
        let mut report = StepReport {
            reselected: !self.hier.valid
                || self
                    .steps
                    .is_multiple_of(self.settings.period(self.internal)),
            ..StepReport::default()
        };
        if report.reselected && !self.switches.full_passes && self.selects_everything(model) {
            // Every joint would be selected and none locked: the step is the exact solve of
            // the whole body (reduced-tree ABA over every joint), no metric, no queue, no
            // caches (docs/adaptive.md#cost).
            self.whole_body_step(model, state)?;
        } else if report.reselected
            && self.switches.reselection == Reselection::ExactSolve
            && !self.switches.full_passes
            && self.settings.velocity_tolerance.is_none()
        {
            // The selection's exact solve with the passive forces of the state before the
            // impulse; the hybrid step adds those after it (`passive.rs`).
            report.rigidified =
                self.with_passive_tau(model, state, |ad, state| ad.exact_reselect(model, state))?;
            self.check_active_inputs(model, state)?;
            self.hybrid_step(model, &state.q, &state.qd, &state.tau, false)?;
            // The exact solve and the metric sums visited every node.
            self.touched += model.assembly.nodes.len();
        } else if report.reselected || self.switches.full_passes {
            self.step_passes(model, state, &mut report)?;
        } else {
            self.check_active_inputs(model, state)?;
            self.hybrid_step(model, &state.q, &state.qd, &state.tau, false)?;
        }
        Ok(report)
    }

    /// Whether the settings select every joint whatever the metric: no budget or one that
    /// covers every internal degree of freedom, no tolerance stop.
    pub(crate) fn selects_everything(&self, model: &Model) -> bool {
        let internal = model.nv - if model.floating_base { 6 } else { 0 };
        self.settings.budget.is_none_or(|b| b >= internal)
            && self.settings.tolerance.is_none_or(|t| t <= 0.0)
    }

    /// The dynamics of a step whose selection would keep every joint: the whole body as the
    /// hybrid body (installed once, as [`Adaptive::set_active`] does, with nothing to lock),
    /// then the reduced-tree step over every joint. The selection reports every degree of
    /// freedom, a predicted error of 0 and the total metric `Σ q̈ᵢᵀ Aᵢ q̈ᵢ` of the exact
    /// accelerations.
    pub(crate) fn whole_body_step(
        &mut self,
        model: &Model,
        state: &mut State,
    ) -> Result<(), AdaptiveError> {
        if !(self.hier.valid && self.hier.dofs == model.nv) {
            let steps = self.steps;
            self.set_active(model, state, |_| true)?;
            self.steps = steps;
        }
        self.check_active_inputs(model, state)?;
        self.hybrid_step(model, &state.q, &state.qd, &state.tau, false)?;
        let mut total = 0.0;
        for (j, body) in model.bodies.iter().enumerate() {
            let a = &self.body.qdd[body.v_offset..body.v_offset + body.nv];
            let w = self.metric.accel_weight(model, j);
            for r in 0..body.nv {
                for c in 0..body.nv {
                    total += a[r] * w[r * body.nv + c] * a[c];
                }
            }
        }
        self.last = Selection {
            active_dofs: model.nv,
            budget_used: model.nv - if model.floating_base { 6 } else { 0 },
            predicted_error: 0.0,
            total_metric: total,
        };
        Ok(())
    }

    /// How a due re-selection finds the new hybrid body (default
    /// [`Reselection::ExactSolve`]); the selection is the same either way.
    pub fn set_reselection(&mut self, how: Reselection) {
        self.switches.reselection = how;
    }

    /// How a due re-selection finds the new hybrid body.
    pub fn reselection(&self) -> Reselection {
        self.switches.reselection
    }

    /// The threads a hybrid step splits its work over when the active region has at least
    /// 10,000 joints (`PARALLEL_HYBRID_MIN_JOINTS`): the active angles' sines and cosines and each
    /// cluster's spatial inertia and bias force (pass 1 of the articulated-body algorithm) in
    /// runs of joints; the pose sweep and the two recursions (articulated inertias,
    /// accelerations) over the independent subtrees of a branched reduced tree (a chain has
    /// none: docs/scaling.md). Default [`Threads::default`], one per core (the process's
    /// shared pool: a crowd's workspace per character holds a handle, not threads of its
    /// own, and a character below the threshold never uses it). Every joint's arithmetic is
    /// the serial one and every sum over joints keeps the serial order: **the result is the
    /// same bits for any thread count**. Below the threshold (or without the `parallel`
    /// feature) the serial loops run.
    pub fn set_threads(&mut self, threads: Threads) {
        self.threads = threads;
    }

    /// The threads of [`Adaptive::set_threads`].
    pub fn threads(&self) -> &Threads {
        &self.threads
    }

    /// The re-selection of [`Reselection::ExactSolve`]: one exact solve of the whole body
    /// (articula-dca's ABA), the metric of every node at the exact handle forces summed
    /// bottom-up (`A(C) = Σ_{i∈C} q̈ᵢᵀ Aᵢ q̈ᵢ`, what the top-down queue evaluates from Ψ, p, η),
    /// the same top-down queue on those numbers, then the new hybrid body installed as by
    /// [`Adaptive::set_active`] (locking impulses). Returns whether joints were locked.
    pub(crate) fn exact_reselect(
        &mut self,
        model: &Model,
        state: &mut State,
    ) -> Result<bool, AdaptiveError> {
        let mut fdense = std::mem::take(&mut self.forces.dense);
        fdense.fill(SpatialForce::ZERO);
        for &(i, f) in &self.forces.sparse {
            fdense[i] += f;
        }
        // (Its whole-body kinematics stay in `data` for `load_state` below.)
        let solved = self
            .exact_solve_inner(model, &state.q, &state.qd, &state.tau, &fdense)
            .and_then(|()| Ok(check_qdd(model, &self.body.qdd)?));
        if let Err(e) = solved {
            self.forces.dense = fdense;
            return Err(e);
        }
        let mut m = std::mem::take(&mut self.queue.exact_metric);
        self.exact_node_metrics(model, &mut m);
        self.queue.selected.fill(false);
        let tree = &model.assembly;
        let sel = self.run_queue(
            model,
            m[tree.root()],
            |_, _| true,
            |_, _, c| matches!(tree.nodes[c].kind, NodeKind::Join { .. }).then(|| m[c]),
        );
        self.queue.exact_metric = m;
        let steps = self.steps;
        let r = self.load_state(model, &state.q, &state.qd, &state.tau, &fdense);
        self.forces.dense = fdense;
        r?;
        let locked = self.install_selected(model, state)?;
        self.steps = steps;
        self.last = sel;
        Ok(locked)
    }

    pub(crate) fn step_inner(
        &mut self,
        model: &Model,
        state: &mut State,
        dt: f64,
    ) -> Result<StepReport, AdaptiveError> {
        // Damping implicit over the step, as articula-dca's semi-implicit Euler step.
        self.set_damping_step(model, dt);
        let mut report = self.step_dynamics(model, state)?;
        let mut dofs = 0;
        for rec in &self.hier.records {
            if rec.axis().is_some() {
                // One revolute coordinate: the same semi-implicit Euler update, written back
                // only when finite (otherwise the general path below reports it).
                let (vo, qo) = (rec.v_offset(), rec.q_offset());
                let a = self.body.qdd[vo];
                let v = state.qd[vo] + dt * a;
                let q = state.q[qo] + v * dt;
                if all_finite(&[a, v, q]) {
                    state.qd[vo] = v;
                    state.q[qo] = q;
                    dofs += 1;
                    continue;
                }
            } else if rec.revs == 3 {
                // Three revolute coordinates (a composed joint: the humanoid's hips,
                // shoulders, spine, neck), contiguous: the same update per coordinate as the
                // general path below (`q̇ += h q̈`, then `q += q̇ h`), written back when all
                // nine numbers are finite.
                let (vo, qo) = (rec.v_offset(), rec.q_offset());
                let (qdd, qd, q) = (
                    &self.body.qdd[vo..vo + 3],
                    &mut state.qd[vo..vo + 3],
                    &mut state.q[qo..qo + 3],
                );
                let mut x = [0.0; 9];
                for p in 0..3 {
                    let v = qd[p] + dt * qdd[p];
                    x[p] = qdd[p];
                    x[3 + p] = v;
                    x[6 + p] = q[p] + v * dt;
                }
                if all_finite(&x) {
                    qd.copy_from_slice(&x[3..6]);
                    q.copy_from_slice(&x[6..9]);
                    dofs += 3;
                    continue;
                }
            }
            let body = &model.bodies[rec.body()];
            dofs += body.nv;
            let r = body.v_offset..body.v_offset + body.nv;
            if !finite(&self.body.qdd[r.clone()]) {
                return Err(non_finite(model, rec.body(), "qdd", &self.body.qdd).into());
            }
            for (v, a) in state.qd[r.clone()].iter_mut().zip(&self.body.qdd[r]) {
                *v += dt * a;
            }
            for part in &body.joint {
                integrate_part(part, &mut state.q, &state.qd, dt);
            }
            let q = &state.q[body.q_offset..body.q_offset + body.nq];
            let qd = &state.qd[body.v_offset..body.v_offset + body.nv];
            if !(finite(q) && finite(qd)) {
                let what = if !finite(q) {
                    ("q after the step", &state.q)
                } else {
                    ("qd after the step", &state.qd)
                };
                return Err(non_finite(model, rec.body(), what.0, what.1).into());
            }
        }
        self.steps += 1;
        report.active_dofs = dofs;
        report.predicted_error = self.last.predicted_error;
        report.nodes_touched = self.touched;
        Ok(report)
    }

    /// The dynamics of a step that re-selects (through the caches or by whole-body passes)
    /// or runs the reference whole-body passes: `q̈` into `qdd`, `report.rigidified`. (Out of
    /// line: the steps between re-selections, most of a scene's, keep their code short.)
    #[inline(never)]
    pub(crate) fn step_passes(
        &mut self,
        model: &Model,
        state: &mut State,
        report: &mut StepReport,
    ) -> Result<(), AdaptiveError> {
        // (The locked joints' torques the caches hold are with their passive forces.)
        let cached = report.reselected
            && self.with_passive_tau(model, state, |ad, state| {
                ad.can_reselect_cached(model, state)
            });
        let full = (report.reselected && !cached) || self.switches.full_passes;
        if full {
            // Whole-body passes read the forces as one wrench per body.
            let mut fdense = std::mem::take(&mut self.forces.dense);
            fdense.fill(SpatialForce::ZERO);
            for &(i, f) in &self.forces.sparse {
                fdense[i] += f;
            }
            let r = self.load(model, &state.q, &state.qd, &state.tau, &fdense);
            self.forces.dense = fdense;
            r?;
        }
        if cached {
            // O(active region): the caches of the rigid subassemblies (update.rs), then the
            // step on the new hybrid body's reduced tree.
            let r =
                self.with_passive_tau(model, state, |ad, state| ad.cached_reselect(model, state));
            let fresh = std::mem::take(&mut self.hier.kin_fresh);
            report.rigidified = r?;
            let touched = self.touched;
            if !fresh {
                // New active joints or velocities after an impulse (`cached_reselect` checked
                // the old active joints' inputs; with the hybrid body kept they are these).
                self.check_active_inputs(model, state)?;
            }
            self.hybrid_step(model, &state.q, &state.qd, &state.tau, fresh)?;
            self.touched += touched;
        } else if report.reselected {
            self.hier.valid = false;
            let build = self.switches.use_cache && !self.switches.full_passes;
            report.rigidified = self.with_passive_tau(model, state, |ad, state| {
                ad.reselect_loaded(model, state, build)
            })?;
            let mut touched = self.touched;
            // The dynamics at the velocities after the impulse, their passive forces.
            self.with_passive_tau(model, state, |ad, state| {
                ad.main_pass(model, &state.tau, Level::Acceleration, false)
            })?;
            touched += self.touched;
            self.back_substitution(model, false);
            self.touched = touched;
        } else if self.switches.full_passes {
            // Reference path: whole-body kinematics and composites, same hybrid body.
            self.with_passive_tau(model, state, |ad, state| {
                ad.main_pass(model, &state.tau, Level::Acceleration, false)
            })?;
            self.back_substitution(model, false);
        }
        Ok(())
    }

    /// Sets the hybrid body by hand: the joints of the bodies for which `active(body)` holds
    /// (closed upward in the assembly tree, so the result may hold more) stay free, every other
    /// moving joint is locked by the impulses of a re-selection. The next steps keep this hybrid
    /// body until the next re-selection. Returns whether joints were locked. (After an impulse,
    /// `data` keeps the positions and the velocities from before it.)
    pub fn set_active(
        &mut self,
        model: &Model,
        state: &mut State,
        active: impl Fn(usize) -> bool,
    ) -> Result<bool, AdaptiveError> {
        self.load_state(model, &state.q, &state.qd, &state.tau, &state.f_ext)?;
        let tree = &model.assembly;
        for (n, node) in tree.nodes.iter().enumerate() {
            self.queue.selected[n] = match node.kind {
                NodeKind::Join { joint, .. } => {
                    active(joint) || n == tree.root() && model.floating_base
                }
                _ => false,
            };
        }
        self.install_selected(model, state)
    }

    /// The hybrid body of the joints flagged in `queue.selected` (kinematics loaded): the
    /// rigid composites, the locking impulses, `q̈ = 0`, the step count from a re-selection.
    pub(crate) fn install_selected(
        &mut self,
        model: &Model,
        state: &mut State,
    ) -> Result<bool, AdaptiveError> {
        let tree = &model.assembly;
        // The active region now (as `rebuild_hybrid` closes it, with no velocity tolerance),
        // so that only the composites outside it are formed.
        self.body.active.copy_from_slice(&self.queue.selected);
        for (n, node) in tree.nodes.iter().enumerate() {
            if let (true, Some(p)) = (self.body.active[n], node.parent) {
                self.body.active[p] = true;
            }
        }
        self.rigid_composites(model);
        self.cache.all_valid = false;
        let vtol = self.settings.velocity_tolerance.take();
        let locked = self.rebuild_hybrid(model, state, false, true);
        self.settings.velocity_tolerance = vtol;
        let locked = locked?;
        // Joints outside the hybrid body have q̈ = 0 until the next re-selection.
        self.body.qdd.fill(0.0);
        // The steps count on from a re-selection.
        self.steps = 1;
        Ok(locked)
    }

    /// Makes the next step re-select the hybrid body by whole-body passes (rebuilding the
    /// caches of the rigid subassemblies). Call it after changing the state of locked joints
    /// (their `q` or `q̇`) from outside — between re-selections a step reads only the active
    /// joints, and a cached re-selection takes the locked ones from the caches — and after
    /// changing their torques when [`Adaptive::set_check_locked_torques`] is off.
    pub fn invalidate(&mut self) {
        self.hier.valid = false;
        self.cache.all_valid = false;
    }

    /// Whether a re-selection compares the joint torques with those the caches of the rigid
    /// subassemblies were built with (default: on). The locked joints' torques sit in the
    /// caches' constant columns: when one changed, the re-selection runs whole-body passes
    /// and rebuilds the caches. The comparison reads all of τ — O(n), noticeable on very long
    /// chains whose data has left the processor's caches. Turn it off when the
    /// locked joints' torques never change, or call [`Adaptive::invalidate`] after changing
    /// them.
    pub fn set_check_locked_torques(&mut self, on: bool) {
        self.cache.check_torques = on;
    }

    /// Re-select through the caches of the rigid subassemblies (default, O(active region)) or
    /// by whole-body passes (off: the reference, O(n)). For the tests that compare the two.
    #[cfg(test)]
    pub(crate) fn set_cached_reselection(&mut self, on: bool) {
        self.switches.use_cache = on;
        self.cache.all_valid = false;
    }

    /// Run the hybrid step's reduced ABA with fused multiply–adds where the CPU has AVX2 and
    /// FMA (default: whenever available) or portably everywhere (off: the reference; the same
    /// solution to rounding). The same switch picks the AVX2 + FMA compilations of the other
    /// hot passes, whose arithmetic is the portable one (the same bits either way). Asking for
    /// it on a CPU without them keeps it off. For the tests that compare the two.
    #[cfg(test)]
    pub(crate) fn set_fused(&mut self, on: bool) {
        self.switches.fused = on && articula_spatial::numerics::fused_available();
    }

    /// Take a forced path's deltas from its linear maps of the leaf's wrench (default) or
    /// recompute every dirty node from its children's (off: the reference). For the tests
    /// that compare the two.
    #[cfg(test)]
    pub(crate) fn set_path_maps(&mut self, on: bool) {
        self.cache.without_maps = !on;
    }

    /// Forced-path maps built and evaluated so far (for tests: whether the maps were used).
    #[cfg(test)]
    pub(crate) fn path_map_counts(&self) -> (u64, u64) {
        (self.cache.maps.builds, self.cache.maps.evaluations)
    }

    /// Between re-selections, run whole-body kinematics and composites instead of the
    /// hierarchical state (the reference; same results, cost O(n)). For the tests that
    /// compare the two.
    #[cfg(test)]
    pub(crate) fn set_full_passes(&mut self, on: bool) {
        self.switches.full_passes = on;
    }

    /// Checks the inputs a step between re-selections reads: the active joints' `q`, `q̇`, `τ`
    /// and the external forces.
    pub(crate) fn check_active_inputs(
        &self,
        model: &Model,
        state: &State,
    ) -> Result<(), DynamicsError> {
        if state.q.len() != model.nq
            || state.qd.len() != model.nv
            || state.tau.len() != model.nv
            || !(state.f_ext.is_empty() || state.f_ext.len() == model.bodies.len())
        {
            return check_inputs(model, &state.q, &state.qd, &state.tau, &state.f_ext);
        }
        // A small body's whole state is a few cache lines that the step reads most of anyway:
        // one sweep over all of it costs less than the walk over the records below, which
        // then runs only when the sweep finds a non-finite number (the same errors; a large
        // body keeps to its active joints, O(active region)).
        let swept = model.nv <= SWEEP_NV && all_finite3(&state.q, &state.qd, &state.tau);
        if !swept {
            self.check_active_records(model, state)?;
        }
        if let Some(&(i, _)) = self.forces.sparse.iter().find(|(_, f)| !f.is_finite()) {
            return Err(DynamicsError::NonFinite {
                what: "external force",
                name: model.bodies[i].name.clone(),
            });
        }
        Ok(())
    }

    /// The records' walk of [`Adaptive::check_active_inputs`]: the active joints' `q`, `q̇`,
    /// `τ` (lengths checked).
    #[inline(never)]
    pub(crate) fn check_active_records(
        &self,
        model: &Model,
        state: &State,
    ) -> Result<(), DynamicsError> {
        for rec in &self.hier.records {
            if rec.axis().is_some() {
                if all_finite(&[
                    state.q[rec.q_offset()],
                    state.qd[rec.v_offset()],
                    state.tau[rec.v_offset()],
                ]) {
                    continue;
                }
                return check_inputs(model, &state.q, &state.qd, &state.tau, &state.f_ext);
            }
            if rec.revs == 3 {
                // Three contiguous coordinates (a composed joint), nine numbers.
                let (qo, vo) = (rec.q_offset(), rec.v_offset());
                let (q, qd, tau) = (
                    &state.q[qo..qo + 3],
                    &state.qd[vo..vo + 3],
                    &state.tau[vo..vo + 3],
                );
                let x = [
                    q[0], q[1], q[2], qd[0], qd[1], qd[2], tau[0], tau[1], tau[2],
                ];
                if all_finite(&x) {
                    continue;
                }
                return check_inputs(model, &state.q, &state.qd, &state.tau, &state.f_ext);
            }
            let b = &model.bodies[rec.body()];
            let bad = state.q[b.q_offset..b.q_offset + b.nq]
                .iter()
                .chain(&state.qd[b.v_offset..b.v_offset + b.nv])
                .chain(&state.tau[b.v_offset..b.v_offset + b.nv])
                .any(|x| !x.is_finite());
            if bad {
                return check_inputs(model, &state.q, &state.qd, &state.tau, &state.f_ext);
            }
        }
        Ok(())
    }
}

/// The most degrees of freedom of a body whose step between re-selections checks all of its
/// `q`, `q̇`, `τ` at once ([`Adaptive::check_active_inputs`]).
pub(crate) const SWEEP_NV: usize = 64;

/// Whether every number of `a`, `b`, `c` is finite ([`zero_sum`] of each is zero).
#[inline]
pub(crate) fn all_finite3(a: &[f64], b: &[f64], c: &[f64]) -> bool {
    zero_sum(a) + zero_sum(b) + zero_sum(c) == 0.0
}

/// [`all_finite`] through [`zero_sum`] (one out-of-line copy of its loop).
#[inline]
pub(crate) fn finite(xs: &[f64]) -> bool {
    zero_sum(xs) == 0.0
}

/// `Σ x · 0` over `xs` (as [`all_finite`]): zero unless some `x` is infinite or NaN. Out of
/// line and called once per slice: one short loop of code for the instruction cache (a
/// crowd's step runs through more code than the 32 kB L1i holds).
#[inline(never)]
pub(crate) fn zero_sum(xs: &[f64]) -> f64 {
    let mut acc = [0.0f64; 4];
    let mut chunks = xs.chunks_exact(4);
    for c in &mut chunks {
        for k in 0..4 {
            acc[k] += c[k] * 0.0;
        }
    }
    // At most three left. (Sums paired as the lanes of two-wide vectors: no shuffles.)
    let rest = chunks.remainder().iter().fold(0.0, |r, &x| r + x * 0.0);
    (acc[0] + acc[2]) + (acc[1] + acc[3]) + rest
}

/// The error naming the part of body `j`'s joint whose value in `x` is not finite.
#[cold]
#[inline(never)]
pub(crate) fn non_finite(model: &Model, j: usize, what: &'static str, x: &[f64]) -> DynamicsError {
    let body = &model.bodies[j];
    let name = body
        .joint
        .iter()
        .find(|p| {
            let r = if what.starts_with("q after") {
                p.q_offset..p.q_offset + p.nq()
            } else {
                p.v_offset..p.v_offset + p.nv()
            };
            x[r].iter().any(|v| !v.is_finite())
        })
        .map_or_else(|| body.joint_name(), |p| p.name.clone());
    DynamicsError::NonFinite { what, name }
}

/// `q ← q ⊕ h q̇` for one joint part (see [`articula_dca::integrate_q`]).
pub(crate) fn integrate_part(part: &articula_model::JointPart, q: &mut [f64], qd: &[f64], h: f64) {
    part.integrate(q, qd, h);
}

pub(crate) fn check_qdd(model: &Model, qdd: &[f64]) -> Result<(), DynamicsError> {
    if qdd.iter().all(|x| x.is_finite()) {
        return Ok(());
    }
    for (_, part) in model.joint_parts() {
        if qdd[part.v_offset..part.v_offset + part.nv()]
            .iter()
            .any(|x| !x.is_finite())
        {
            return Err(DynamicsError::NonFinite {
                what: "qdd",
                name: part.name.clone(),
            });
        }
    }
    Ok(())
}

/// The error for a model whose assembly tree has a gather node (see
/// [`AdaptiveError::Unsupported`]).
#[cold]
pub(crate) fn unsupported_tree(model: &Model) -> AdaptiveError {
    let tree = &model.assembly;
    let hub = tree.nodes.iter().find_map(|n| match n.kind {
        NodeKind::Gather { body, count, .. } => Some((body, count)),
        _ => None,
    });
    let (name, count) = match hub {
        Some((Some(b), count)) => (format!("link {}", model.bodies[b].name), count),
        Some((None, count)) => ("the fixed base".to_string(), count),
        None => (String::new(), 0),
    };
    AdaptiveError::Unsupported(format!(
        "{name} has {count} children (more than {}); use the exact methods (dca, aba, crba)",
        articula_model::GATHER_ABOVE
    ))
}
