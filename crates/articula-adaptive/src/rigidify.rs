//! Rigidification (docs/design.md#adaptive): joints leaving the hybrid body are locked by internal
//! impulses — an inelastic locking that keeps the generalized momentum of every joint that
//! stays free, hence the whole body's spatial momentum, and never increases kinetic energy.
//!
//! With `N` the basis of the joints that stay free, the new velocities are `q̇' = N u` with
//! `Nᵀ M N u = Nᵀ M q̇`: the hybrid body's forward dynamics at velocity level, with no bias
//! terms and the generalized momenta `pⱼ = Sⱼᵀ Σ_{i ⪰ j} Iᵢ vᵢ` as joint forces. It runs
//! through the same main pass and back-substitution as the accelerations ([`Level::Impulse`]).
//! This is the `M⁻¹` projection `q̇' = q̇ − M⁻¹Jᵀ(J M⁻¹ Jᵀ)⁻¹ J q̇` of the locked rows `J`.
//! With armature `A` the inertia is the dynamics' `M + A` throughout: the momenta gain
//! `aⱼ q̇ⱼ` and the solve's `D` the model's armature (not a step's `h b` of implicit damping,
//! which is no inertia), so `Nᵀ (M + A) q̇` is kept exactly.

use crate::adaptive::Adaptive;
use crate::hybrid::Level;
use articula_dca::{forward_kinematics, DynamicsError, State};
use articula_model::{Model, NodeKind};

impl Adaptive {
    /// Makes the hybrid body the selected joints (plus, with a velocity tolerance, the active
    /// subassemblies still moving faster than it, and their ancestors), builds its hierarchical
    /// state, then locks every joint outside it that still moves. Returns whether an impulse was
    /// applied. With `refresh`, the kinematics in `data` are then recomputed for the new
    /// velocities (whole-body passes follow); otherwise `data` keeps the old velocities (a step
    /// between re-selections recomputes those of the active bodies). With `closed`, `active`
    /// already holds `selected` closed upward (used when there is no velocity tolerance).
    pub(crate) fn rebuild_hybrid(
        &mut self,
        model: &Model,
        state: &mut State,
        refresh: bool,
        closed: bool,
    ) -> Result<bool, DynamicsError> {
        let tree = &model.assembly;
        if let Some(vtol) = self.settings.velocity_tolerance {
            self.velocity_metric(model, &state.qd);
            for n in 0..tree.nodes.len() {
                self.body.active[n] = self.queue.selected[n]
                    || (self.body.active[n] && self.queue.velocity_metric[n] > vtol);
            }
        } else if !closed {
            self.body.active.copy_from_slice(&self.queue.selected);
        }
        // Close upward (post-order: a child comes before its parent); with `closed` and no
        // velocity tolerance, `active` is already `selected` closed ([`Adaptive::set_active`]).
        if !closed || self.settings.velocity_tolerance.is_some() {
            for n in 0..tree.nodes.len() {
                if self.body.active[n] {
                    if let Some(p) = tree.nodes[n].parent {
                        self.body.active[p] = true;
                    }
                }
            }
        }
        self.build_hierarchy(model);
        let mut moving = false;
        for (n, node) in tree.nodes.iter().enumerate() {
            if let NodeKind::Join { joint, .. } = node.kind {
                let body = &model.bodies[joint];
                if !self.body.active[n]
                    && state.qd[body.v_offset..body.v_offset + body.nv]
                        .iter()
                        .any(|x| *x != 0.0)
                {
                    moving = true;
                }
            }
        }
        if !moving {
            return Ok(false);
        }
        self.lock(model, state, refresh)?;
        Ok(true)
    }

    /// The impulse: generalized momenta of the free joints, the hybrid body's velocity-level
    /// solve over its reduced tree ([`Adaptive::reduced_aba`]), locked joints set to exactly
    /// zero.
    fn lock(
        &mut self,
        model: &Model,
        state: &mut State,
        refresh: bool,
    ) -> Result<(), DynamicsError> {
        // h_i = Σ over the kinematic subtree of body i of I v (children after parents).
        for i in 0..model.bodies.len() {
            self.impulse.subtree[i] = self.data.inertia[i].mul_motion(self.data.v[i]);
        }
        for i in (0..model.bodies.len()).rev() {
            if let Some(p) = model.bodies[i].parent {
                let h = self.impulse.subtree[i];
                self.impulse.subtree[p] += h;
            }
        }
        for &i in &self.hier.ajoints {
            let body = &model.bodies[i];
            for p in 0..body.nv {
                self.impulse.momenta[body.v_offset + p] =
                    self.data.s[body.v_offset + p].dot(self.impulse.subtree[i]);
            }
        }
        add_armature_momenta(
            model,
            &self.hier.ajoints,
            &state.qd,
            &mut self.impulse.momenta,
        );
        self.body.qdd.fill(0.0);
        let gmom = std::mem::take(&mut self.impulse.momenta);
        let r = self.reduced_aba(model, &gmom, Level::Impulse);
        self.impulse.momenta = gmom;
        r?;
        state.qd.copy_from_slice(&self.body.qdd);
        self.fresh.valid = false;
        if refresh {
            forward_kinematics(model, &state.q, &state.qd, &mut self.data)?;
        }
        Ok(())
    }
}

/// `pⱼ += aⱼ q̇ⱼ` for the degrees of freedom of the joints `joints` (the model's armature `a`;
/// nothing for a model without): generalized momentum is `(M + A) q̇`.
pub(crate) fn add_armature_momenta(model: &Model, joints: &[usize], qd: &[f64], p: &mut [f64]) {
    let a = &model.dynamics.armature;
    if a.is_empty() {
        return;
    }
    for &i in joints {
        let body = &model.bodies[i];
        for v in body.v_offset..body.v_offset + body.nv {
            p[v] += a[v] * qd[v];
        }
    }
}
