//! Armature, damping and springs in adaptive dynamics (docs/loading.md#armature-and-damping),
//! where the exact methods have them:
//!
//! - **Armature** `a` enters the joint-space inertia of every active joint, `D = Sᵀ V S + a`
//!   in the main pass's joins and `D = Sᵀ Iᴬ S + a` in the hybrid step's reduced tree (from
//!   `data.armature`). A locked joint has `q̈ = 0` and `q̇ = 0`: its armature carries no force
//!   and no momentum, and its rigid cluster's inertia is the bodies' alone.
//! - **Damping and springs** are passive joint forces `−b q̇ − k (q − q_spring)` that a step
//!   adds to `τ`, with the damping integrated implicitly over the step `h` by solving with
//!   the armature `a + h b` (articula-dca's `with_passive_forces`; RK4 takes them explicitly,
//!   `h = 0`, as articula-dca's RK4 does). A locked joint's passive force is an internal force
//!   of its rigid cluster: the hybrid step does not read it; the re-selection's whole-body
//!   solve does (it asks how each joint would move if it were free).
//! - `forward_dynamics` with an explicit `τ` stays the rigid-body map plus armature.

use crate::adaptive::Adaptive;
use articula_dca::State;
use articula_model::Model;

impl Adaptive {
    /// Puts the implicit damping of a step of `dt` into the armature of the workspace's solves
    /// (`data.armature = a + dt b`; `dt = 0`: the model's armature alone, for a solve outside
    /// a step or an explicit RK4 stage). Nothing to do for a model without damping; a new
    /// `dt` marks the caches of the rigid subassemblies stale (they hold coefficients built
    /// with the armature).
    pub(crate) fn set_damping_step(&mut self, model: &Model, dt: f64) {
        let d = &model.dynamics;
        if d.damping.is_empty() || self.passive.dt.to_bits() == dt.to_bits() {
            return;
        }
        self.passive.dt = dt;
        self.data.set_damping_step(model, dt);
        self.cache.all_valid = false;
    }

    /// Runs `call` with `state.tau` replaced by every joint's `τ + passive(q, q̇)` at the
    /// state (the whole-body solves of a step's re-selection); `call` alone for a model
    /// without damping or springs, or inputs of the wrong lengths (which `call` reports).
    pub(crate) fn with_passive_tau<R>(
        &mut self,
        model: &Model,
        state: &mut State,
        call: impl FnOnce(&mut Adaptive, &mut State) -> R,
    ) -> R {
        if !model.dynamics.has_passive()
            || state.q.len() != model.nq
            || state.qd.len() != model.nv
            || state.tau.len() != model.nv
        {
            return call(self, state);
        }
        let mut total = std::mem::take(&mut self.passive.tau);
        total.resize(model.nv, 0.0);
        model.passive_forces(&state.q, &state.qd, &mut total);
        for (t, x) in total.iter_mut().zip(&state.tau) {
            *t += x;
        }
        if !model.dynamics.damping.is_empty() {
            let mut locked = std::mem::take(&mut self.passive.locked);
            spring_torques(model, &state.q, &state.tau, &mut locked);
            self.passive.locked = locked;
            self.passive.locked_set = true;
        }
        std::mem::swap(&mut state.tau, &mut total);
        let r = call(self, state);
        std::mem::swap(&mut state.tau, &mut total);
        self.passive.tau = total;
        self.passive.locked_set = false;
        r
    }

    /// The torques `τ + passive(q, 0)` of [`Adaptive::with_passive_tau`] (taken: give them
    /// back to `passive.locked`), when set: those the caches of the rigid subassemblies are
    /// built with — the locked joints' torques once locked (`q̇ = 0`: no damping force), which
    /// the next re-selection compares with the caches'. Empty when not set (a model without
    /// damping: build with the re-selection's `τ` itself, nothing copied).
    pub(crate) fn take_locked_torques(&mut self) -> Vec<f64> {
        if self.passive.locked_set {
            std::mem::take(&mut self.passive.locked)
        } else {
            Vec::new()
        }
    }

    /// `τ + passive(q, q̇)` of the active joints into `out` (length `nv`; the other entries
    /// are not written): the same numbers, to the bit, as [`Model::passive_forces`] plus
    /// `τ`, over the active region only.
    pub(crate) fn active_passive_tau(
        &self,
        model: &Model,
        (q, qd, tau): (&[f64], &[f64], &[f64]),
        out: &mut Vec<f64>,
    ) {
        let d = &model.dynamics;
        out.resize(model.nv, 0.0);
        for rec in &self.hier.records {
            for part in &model.bodies[rec.body()].joint {
                let spring = !d.stiffness.is_empty() && part.nv() == 1 && part.nq() == 1;
                for i in part.v_offset..part.v_offset + part.nv() {
                    let mut p = 0.0;
                    if let Some(b) = d.damping.get(i) {
                        p -= b * qd[i];
                    }
                    if spring {
                        p -= d.stiffness[i] * (q[part.q_offset] - d.spring_ref[i]);
                    }
                    out[i] = p + tau[i];
                }
            }
        }
    }
}

/// `τ + passive(q, 0)` into `out` (resized to `nv`): the springs' forces plus `τ`, the same
/// numbers to the bit as [`Model::passive_forces`] at `q̇ = 0` plus `τ` (its damping term is
/// `+0.0` there).
fn spring_torques(model: &Model, q: &[f64], tau: &[f64], out: &mut Vec<f64>) {
    let d = &model.dynamics;
    out.clear();
    out.resize(model.nv, 0.0);
    if !d.stiffness.is_empty() {
        for p in model.coordinate_parts() {
            if p.nv() == 1 && p.nq() == 1 {
                let i = p.v_offset;
                out[i] -= d.stiffness[i] * (q[p.q_offset] - d.spring_ref[i]);
            }
        }
    }
    for (t, x) in out.iter_mut().zip(tau) {
        *t += x;
    }
}
