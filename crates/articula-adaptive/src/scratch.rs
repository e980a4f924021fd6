//! Per-call buffers shared by many workspaces of one model ([`Scratch`]).
//!
//! A scene of many bodies keeps one [`Adaptive`] per body. Most of a workspace's memory is
//! written and read within one call only; with one copy per body, every call brings that
//! memory back from beyond the processor's caches. A [`Scratch`] holds those buffers once per
//! model: [`Adaptive::step_with`], [`Adaptive::set_active_with`] and
//! [`Adaptive::node_metrics_with`] exchange the workspace's own buffers with the scratch's for
//! the duration of the call (swapping `Vec` headers: nothing is copied), so every body's call
//! writes and reads the same, cache-resident memory. The results are bit-identical to the
//! plain calls (`tests/scratch.rs`).
//!
//! The buffers exchanged, and why they carry nothing from one call to the next (every call
//! writes what it reads of them first):
//! - the reduced tree's articulated-body workspace (`Iᴬ`, `pᴬ`, accelerations, `D⁻¹` or its
//!   Cholesky factor, `U`, `u`): pass 1 of the reduced ABA writes `Iᴬ`, `pᴬ` of every record,
//!   pass 2 `U`, `u`, `D⁻¹`/factor of every record before pass 3 reads them, and pass 3 a
//!   record's acceleration before its children read it; the sines and cosines of the active
//!   angles, which the kinematics' first sweep writes for every angle before its main loop
//!   reads them;
//! - per node, the composite inertias and external-force sums: written for every node by each
//!   whole-body load, the frontier's force sums by each hybrid step or cached re-selection
//!   before the reduced ABA reads them;
//! - per body, the subtree momenta of a locking impulse and the generalized momenta (written
//!   for the bodies, resp. the active joints, the impulse then reads), the external wrenches in
//!   the computation frame and the dense wrench array of a whole-body pass (filled per call);
//! - the kinematics in `data` (`x`, `v`, `c`, `s`, `inertia`): a whole-body load computes them
//!   all, a hybrid step or cached re-selection those of the active bodies (parents first)
//!   before anything reads them. The one exception is [`Adaptive::node_metrics`]'s kinematics,
//!   which the next call reuses for the same state (`fresh`): a `_with` call that finds them
//!   leaves the kinematics in the workspace, and [`Adaptive::node_metrics_with`] (whose whole
//!   `data` lives in the scratch) hands its kinematics (`origin` copied; `x`, `v`, `c`, `s`,
//!   `inertia` by exchanging buffers) to the workspace's `data`, so that the next load of the
//!   same state (a
//!   [`Adaptive::set_active_with`] after a scene's selection) reuses them as after the plain
//!   call.
//!
//! A step between re-selections (most of a scene's) exchanges only what it reads: the reduced
//! tree's workspace, the sines and cosines, the force sums and the kinematics but `inertia`
//! (thirteen headers, not nineteen).
//!
//! What stays in each workspace: the hybrid body (flags, lists, the reduced tree's records),
//! the caches of rigid subassemblies, the weights, the selection, `qdd` (zero outside the
//! active region), the `data` settings (gravity, origin, refinement flag).
//!
//! After a `_with` call, the kinematics of the call are in the scratch, not in the workspace's
//! public `data` (whose `x`, `v`, `c`, `s`, `inertia` keep those of its last plain call; its
//! `origin` is the call's). The workspace's own buffers stay allocated at full size (~RSS
//! unchanged; untouched memory costs no cache) and are re-fitted to the reduced tree after each
//! `_with` call, so plain calls keep working before and after `_with` calls, in any mix.

use crate::adaptive::Adaptive;
use crate::contact::HybridContact;
use crate::error::AdaptiveError;
use crate::parts::composites::Rigid;
use crate::parts::hierarchy::ReducedAba;
use crate::report::StepReport;
use articula_dca::{ContactSettings, Data, State};
use articula_model::Model;
use articula_spatial::{Mat6, SpatialForce};
use std::mem::swap;

/// The per-call buffers of [`Adaptive`] for one model, shared by every workspace of that model
/// (see the module documentation of `scratch.rs` and [`Adaptive::step_with`]). Build one per
/// model with [`Scratch::new`]; a `_with` call allocates nothing.
#[derive(Clone, Debug)]
pub struct Scratch {
    /// Bodies, degrees of freedom, coordinates and assembly-tree nodes of the model.
    sizes: [usize; 4],
    /// The whole `data` of [`Adaptive::node_metrics_with`]; its kinematics (`x`, `v`, `c`,
    /// `s`, `inertia`) for the other calls.
    data: Data,
    /// The reduced tree's articulated-body workspace.
    reduced_aba: ReducedAba,
    sin_cos: Vec<(f64, f64)>,
    composites: Vec<Rigid>,
    node_sums: Vec<SpatialForce>,
    subtree_forces: Vec<SpatialForce>,
    momenta: Vec<f64>,
    computation_forces: Vec<SpatialForce>,
    dense_forces: Vec<SpatialForce>,
}

impl Scratch {
    /// Allocates the shared buffers for `model`, at their full sizes.
    pub fn new(model: &Model) -> Scratch {
        let nb = model.bodies.len();
        let nv = model.nv;
        let nn = model.assembly.nodes.len();
        Scratch {
            sizes: [nb, nv, model.nq, nn],
            data: Data::new(model),
            reduced_aba: ReducedAba {
                ia: vec![Mat6::ZERO; nb],
                pa: vec![[0.0; 6]; nb],
                acceleration: vec![[0.0; 6]; nb],
                dinv: vec![0.0; nb],
                cholesky: vec![[[0.0; 6]; 6]; nb],
                u: vec![[0.0; 6]; nv],
                uu: vec![0.0; nv],
            },
            sin_cos: vec![(0.0, 1.0); nv],
            composites: vec![Rigid::default(); nn],
            node_sums: vec![SpatialForce::ZERO; nn],
            subtree_forces: vec![SpatialForce::ZERO; nb],
            momenta: vec![0.0; nv],
            computation_forces: Vec::with_capacity(nb),
            dense_forces: vec![SpatialForce::ZERO; nb],
        }
    }

    /// Whether this scratch has the sizes of `ad`'s model.
    fn check(&self, ad: &Adaptive) -> Result<(), AdaptiveError> {
        let own = [
            ad.data.x.len(),
            ad.data.s.len(),
            ad.fresh.q.len(),
            ad.body.active.len(),
        ];
        if own == self.sizes {
            Ok(())
        } else {
            Err(AdaptiveError::Setting(format!(
                "scratch built for another model (bodies, dofs, coordinates, nodes: {:?}, \
                 workspace: {own:?})",
                self.sizes
            )))
        }
    }
}

impl Adaptive {
    /// Exchanges the per-call buffers with `s`'s (the kinematics in `data` too when `kin`).
    /// With `step` (a hybrid step between re-selections, [`Adaptive::between_reselections`]),
    /// only those that step reads: the reduced tree's workspace, the angles' sines and cosines,
    /// the frontier's force sums and the kinematics but `inertia`. (Out of line: one copy of
    /// the code for both exchanges.)
    #[inline(never)]
    fn swap_scratch(&mut self, s: &mut Scratch, kin: bool, step: bool) {
        let h = &mut self.hier;
        swap(&mut h.reduced_aba, &mut s.reduced_aba);
        swap(&mut h.sin_cos, &mut s.sin_cos);
        swap(&mut self.forces.node_sums, &mut s.node_sums);
        if !step {
            swap(&mut self.composites.rigid, &mut s.composites);
            swap(&mut self.impulse.subtree, &mut s.subtree_forces);
            swap(&mut self.impulse.momenta, &mut s.momenta);
            swap(&mut self.forces.computation, &mut s.computation_forces);
            swap(&mut self.forces.dense, &mut s.dense_forces);
        }
        if kin {
            let (d, sd) = (&mut self.data, &mut s.data);
            swap(&mut d.x, &mut sd.x);
            swap(&mut d.v, &mut sd.v);
            swap(&mut d.c, &mut sd.c);
            swap(&mut d.s, &mut sd.s);
            if !step {
                swap(&mut d.inertia, &mut sd.inertia);
            }
        }
    }

    /// Whether the next step is a hybrid step between re-selections (`step_inner`'s last
    /// branch): it reads none of the whole-body buffers (composites, impulse momenta, wrench
    /// arrays, spatial inertias).
    #[inline]
    fn between_reselections(&self) -> bool {
        self.hier.valid
            && !self.switches.full_passes
            && !self
                .steps
                .is_multiple_of(self.settings.period(self.internal))
    }

    /// Runs `call` on this workspace with `s`'s per-call buffers in place of its own (with
    /// `step`, those of a hybrid step between re-selections only: see
    /// [`Adaptive::swap_scratch`]).
    #[inline(always)]
    fn with_scratch<R>(
        &mut self,
        s: &mut Scratch,
        step: bool,
        call: impl FnOnce(&mut Adaptive) -> Result<R, AdaptiveError>,
    ) -> Result<R, AdaptiveError> {
        s.check(self)?;
        // Kinematics left by `node_metrics` for its state are read by the next load: they
        // stay where they are.
        let kin = !self.fresh.valid;
        let full = [s.sizes[0], s.sizes[1]];
        self.swap_scratch(s, kin, step);
        self.hier.fit_reduced(full);
        let r = call(self);
        self.swap_scratch(s, kin, step);
        self.hier.fit_reduced(full);
        if kin {
            // (No call but `node_metrics` sets it; its kinematics would be in the scratch.)
            self.fresh.valid = false;
        }
        r
    }

    /// [`Adaptive::step`] with the per-call buffers of `scratch` (one per model, shared by
    /// every workspace of that model): the same result to the bit, with the memory a step
    /// writes and reads only within the call shared by all workspaces instead of one copy per
    /// workspace — what keeps a scene of many bodies in the processor's caches. See
    /// [`Scratch`]. After the call, the step's kinematics are in the scratch, not in
    /// [`Adaptive::data`]. An error if `scratch` was built for a model of other sizes.
    ///
    /// ```
    /// use articula_adaptive::{Adaptive, Scratch, Settings};
    /// use articula_dca::State;
    /// use articula_model::{LoadOptions, Model};
    ///
    /// // A 30-link planar chain of 1 m, 1 kg rods.
    /// let mut urdf = String::from(r#"<robot name="chain"><link name="l0"/>"#);
    /// for i in 1..=30 {
    ///     urdf += &format!(r#"<link name="l{i}"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/>
    ///         <inertia ixx="0.08" iyy="0.08" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
    ///         <joint name="j{i}" type="continuous"><parent link="l{}"/><child link="l{i}"/>
    ///         <origin xyz="0 0 {}"/><axis xyz="0 1 0"/></joint>"#, i - 1, if i == 1 { 0 } else { -1 });
    /// }
    /// let model = Model::from_urdf_str(&(urdf + "</robot>"), &LoadOptions::default()).unwrap();
    /// let settings = Settings { budget: Some(5), reselect_every: 4, ..Settings::default() };
    /// let mut scratch = Scratch::new(&model);
    /// let (mut a, mut b) = (Adaptive::new(&model, settings.clone()), Adaptive::new(&model, settings.clone()));
    /// let (mut sa, mut sb) = (State::random(&model, 1, 1.0), State::random(&model, 2, 1.0));
    /// let (mut alone, mut sa_alone) = (Adaptive::new(&model, settings), sa.clone());
    /// for _ in 0..10 {
    ///     a.step_with(&mut scratch, &model, &mut sa, 1e-3).unwrap();
    ///     b.step_with(&mut scratch, &model, &mut sb, 1e-3).unwrap();
    ///     alone.step(&model, &mut sa_alone, 1e-3).unwrap();
    /// }
    /// assert_eq!(sa.q, sa_alone.q);
    /// assert_eq!(sa.qd, sa_alone.qd);
    /// ```
    pub fn step_with(
        &mut self,
        scratch: &mut Scratch,
        model: &Model,
        state: &mut State,
        dt: f64,
    ) -> Result<StepReport, AdaptiveError> {
        let step = self.between_reselections();
        self.with_scratch(scratch, step, |ad| ad.step(model, state, dt))
    }

    /// [`Adaptive::step_with_forces`] with the per-call buffers of `scratch` (see
    /// [`Adaptive::step_with`]).
    pub fn step_with_forces_and_scratch(
        &mut self,
        scratch: &mut Scratch,
        model: &Model,
        state: &mut State,
        dt: f64,
        forces: &[(usize, SpatialForce)],
    ) -> Result<StepReport, AdaptiveError> {
        let step = self.between_reselections();
        self.with_scratch(scratch, step, |ad| {
            ad.step_with_forces(model, state, dt, forces)
        })
    }

    /// [`Adaptive::step_with_contact`] with the per-call buffers of `scratch` (see
    /// [`Adaptive::step_with`]): the same step to the bit.
    #[allow(clippy::too_many_arguments)]
    pub fn step_with_contact_and_scratch(
        &mut self,
        scratch: &mut Scratch,
        model: &Model,
        state: &mut State,
        dt: f64,
        forces: &[(usize, SpatialForce)],
        contact: &mut HybridContact,
        settings: &ContactSettings,
    ) -> Result<StepReport, AdaptiveError> {
        let step = self.between_reselections();
        self.with_scratch(scratch, step, |ad| {
            ad.step_with_contact(model, state, dt, forces, contact, settings)
        })
    }

    /// [`Adaptive::set_active`] with the per-call buffers of `scratch` (see
    /// [`Adaptive::step_with`]): the same hybrid body and impulse to the bit.
    pub fn set_active_with(
        &mut self,
        scratch: &mut Scratch,
        model: &Model,
        state: &mut State,
        active: impl Fn(usize) -> bool,
    ) -> Result<bool, AdaptiveError> {
        self.with_scratch(scratch, false, |ad| ad.set_active(model, state, active))
    }

    /// [`Adaptive::node_metrics`] with the whole `data` of `scratch` (its exact solve's
    /// buffers and kinematics; the workspace's gravity): the same metrics and `qdd` to the bit.
    /// Its kinematics are handed to the workspace's `data` (their buffers exchanged with the
    /// workspace's), so that the next load of the same state reuses them, as after the plain
    /// call.
    #[allow(clippy::too_many_arguments)]
    pub fn node_metrics_with(
        &mut self,
        scratch: &mut Scratch,
        model: &Model,
        q: &[f64],
        qd: &[f64],
        tau: &[f64],
        f_ext: &[SpatialForce],
        out: &mut [f64],
    ) -> Result<(), AdaptiveError> {
        self.exact_solve_with(scratch, model, q, qd, tau, f_ext)?;
        self.exact_node_metrics(model, out);
        Ok(())
    }

    /// [`Adaptive::exact_solve`] with the whole `data` of `scratch`, as
    /// [`Adaptive::node_metrics_with`]: the same `qdd` to the bit, and the kinematics handed
    /// to the workspace's `data`.
    pub fn exact_solve_with(
        &mut self,
        scratch: &mut Scratch,
        model: &Model,
        q: &[f64],
        qd: &[f64],
        tau: &[f64],
        f_ext: &[SpatialForce],
    ) -> Result<(), AdaptiveError> {
        scratch.check(self)?;
        self.set_damping_step(model, 0.0);
        // The workspace's settings on the scratch's buffers, solved in place (the
        // workspace's `data`, 1.2 kB, is not exchanged).
        let (d, sd) = (&self.data, &mut scratch.data);
        sd.set_damping_step(model, 0.0);
        sd.gravity = d.gravity;
        sd.refine_floating = d.refine_floating;
        sd.momentum_projection = d.momentum_projection;
        let r = crate::metric::solve_exact(model, sd, &mut self.body.qdd, q, qd, tau, f_ext);
        if r.is_ok() {
            self.mark_fresh(q, qd);
            // The exact solve's kinematics into the workspace, for the next load of this state
            // (`fresh`, as after the plain call): a `set_active_with` that follows (the usual
            // re-selection of a scene) then skips its whole-body forward kinematics. Their
            // buffers are exchanged with the workspace's (of the same lengths), not copied: the
            // scratch's next exact solve, step or load writes every element of them before
            // reading it.
            let (d, sd) = (&mut self.data, &mut scratch.data);
            d.origin = sd.origin;
            swap(&mut d.x, &mut sd.x);
            swap(&mut d.v, &mut sd.v);
            swap(&mut d.c, &mut sd.c);
            swap(&mut d.s, &mut sd.s);
            swap(&mut d.inertia, &mut sd.inertia);
        } else {
            self.fresh.valid = false;
        }
        Ok(r?)
    }
}
