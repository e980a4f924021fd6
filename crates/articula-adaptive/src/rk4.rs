//! The classic fourth-order Runge–Kutta step of the hybrid body ([`Adaptive::step_rk4`]):
//! the same scheme as articula-dca's [`Integrator::Rk4`](articula_dca::Integrator::Rk4), on
//! the active joints of a hybrid body chosen once at the step's start.
//!
//! With `x = (q, q̇)` of the active joints and `f(x) = (q̇, q̈_hybrid(q, q̇))`:
//!
//! ```text
//! k₁ = f(x₀),  k₂ = f(x₀ ⊕ ½h k₁),  k₃ = f(x₀ ⊕ ½h k₂),  k₄ = f(x₀ ⊕ h k₃)
//! x₁ = x₀ ⊕ h (k₁ + 2k₂ + 2k₃ + k₄) / 6
//! ```
//!
//! where `q ⊕ Δ` adds angles and displacements and moves a floating joint by the SE(3)
//! exponential, whose stage slopes carry the `dexp⁻¹` correction (Runge–Kutta–Munthe-Kaas, so
//! the floating base is fourth order too). The re-selection (and its locking impulse) happens
//! before `k₁`, as in the semi-implicit Euler step; the four stages then keep that hybrid body:
//! locked joints have `q̇ = 0` and `q̈ = 0` throughout and keep their `q`, so the rigid
//! clusters' mass properties (in their top bodies' frames) hold for every stage, and each stage
//! is one hybrid step (kinematics of the active joints at the stage's `(q, q̇)`, then the
//! reduced tree's articulated-body pass): O(active region), four times the Euler step's
//! dynamics between re-selections.

use crate::adaptive::Adaptive;
use crate::error::AdaptiveError;
use crate::parts::rk_buffers::RkBuffers;
use crate::report::StepReport;
use crate::{finite, integrate_part, non_finite};
use articula_dca::State;
use articula_model::Model;
use articula_spatial::SpatialForce;

/// The stage weights of classic RK4 and the fractions of `h` at which stages 2–4 are taken.
const WEIGHTS: [f64; 4] = [1.0, 2.0, 2.0, 1.0];
const NEXT: [f64; 3] = [0.5, 0.5, 1.0];

impl Adaptive {
    /// One classic fourth-order Runge–Kutta step of the hybrid body (also [`crate::step`] with
    /// [`Integrator::Rk4`](articula_dca::Integrator::Rk4)). The re-selection is
    /// [`Adaptive::step`]'s (every `reselect_every` steps, the first included, with its locking
    /// impulses and caches); the hybrid body it leaves is kept for the four stages, each an
    /// adaptive forward-dynamics evaluation of the active joints at the stage's state (see
    /// the module `rk4.rs`): with every joint active this is articula-dca's RK4 step (without
    /// its momentum projection, `Data::momentum_projection`), to rounding. Locked joints keep
    /// `q̇ = 0` and their `q`. The external wrenches of `state.f_ext` are held constant over
    /// the step (as in articula-dca).
    ///
    /// Costs four hybrid steps between re-selections (O(active region) each) plus the
    /// re-selection when there is one; allocates nothing after its first call. On an error
    /// in a later stage (a non-finite acceleration or result), the active joints' `q`, `q̇`
    /// are put back to their values at the step's start (after the impulse, if any).
    pub fn step_rk4(
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
        // Passive forces explicit at every stage (no `h b` in the armature), as articula-dca's
        // RK4 step.
        self.set_damping_step(model, 0.0);
        // Stage 1 is the Euler step's dynamics: re-selection, impulse, q̈ of the active joints.
        let mut report = self.step_dynamics(model, state)?;
        let mut rk = std::mem::take(&mut self.rk4);
        rk.fit(model);
        let result = self.rk4_stages(model, state, dt, &mut rk);
        if result.is_err() {
            self.restore(model, state, &rk);
        }
        self.rk4 = rk;
        let (dofs, touched) = result?;
        self.steps += 1;
        report.active_dofs = dofs;
        report.predicted_error = self.last.predicted_error;
        report.nodes_touched = touched;
        Ok(report)
    }

    /// The four stages after `k₁`'s accelerations are in `qdd`, and the update of the active
    /// joints. Returns the active degrees of freedom and the nodes the stages visited.
    fn rk4_stages(
        &mut self,
        model: &Model,
        state: &mut State,
        dt: f64,
        rk: &mut RkBuffers,
    ) -> Result<(usize, usize), AdaptiveError> {
        for rec in &self.hier.records {
            let b = &model.bodies[rec.body()];
            let (qr, vr) = (b.q_offset..b.q_offset + b.nq, b.v_offset..b.v_offset + b.nv);
            rk.q_start[qr.clone()].copy_from_slice(&state.q[qr]);
            rk.qd_start[vr.clone()].copy_from_slice(&state.qd[vr.clone()]);
            rk.slope_sum[vr.clone()].fill(0.0);
            rk.accel_sum[vr.clone()].fill(0.0);
            rk.theta[vr].fill(0.0);
        }
        let mut touched = self.touched;
        for stage in 0..4 {
            if stage > 0 {
                self.hybrid_step(model, &state.q, &state.qd, &state.tau, false)?;
                touched += self.touched;
            }
            let w = WEIGHTS[stage];
            for rec in &self.hier.records {
                let b = &model.bodies[rec.body()];
                let vr = b.v_offset..b.v_offset + b.nv;
                if !finite(&self.body.qdd[vr.clone()]) {
                    return Err(non_finite(model, rec.body(), "qdd", &self.body.qdd).into());
                }
                // The position slope: q̇, but a ball or floating joint's is dexp⁻¹_{−Θ}(ξ).
                for part in &b.joint {
                    let r = part.v_offset..part.v_offset + part.nv();
                    part.kind.rkmk_slope(&rk.theta[r.clone()], &mut state.qd[r]);
                }
                for v in vr.clone() {
                    rk.slope_sum[v] += w * state.qd[v];
                    rk.accel_sum[v] += w * self.body.qdd[v];
                }
                if stage < 3 {
                    // The next stage's state: q0 ⊕ h k_v, q̇0 + h k_a with this stage's k.
                    let h = NEXT[stage] * dt;
                    let qr = b.q_offset..b.q_offset + b.nq;
                    state.q[qr.clone()].copy_from_slice(&rk.q_start[qr]);
                    for part in &b.joint {
                        integrate_part(part, &mut state.q, &state.qd, h);
                    }
                    for v in vr {
                        rk.theta[v] = h * state.qd[v];
                        state.qd[v] = rk.qd_start[v] + h * self.body.qdd[v];
                    }
                }
            }
        }
        let mut dofs = 0;
        for rec in &self.hier.records {
            let b = &model.bodies[rec.body()];
            let (qr, vr) = (b.q_offset..b.q_offset + b.nq, b.v_offset..b.v_offset + b.nv);
            dofs += b.nv;
            state.q[qr.clone()].copy_from_slice(&rk.q_start[qr.clone()]);
            for v in vr.clone() {
                rk.slope_sum[v] /= 6.0;
                state.qd[v] = rk.qd_start[v] + dt * rk.accel_sum[v] / 6.0;
            }
            for part in &b.joint {
                integrate_part(part, &mut state.q, &rk.slope_sum, dt);
            }
            if !finite(&state.q[qr]) {
                return Err(non_finite(model, rec.body(), "q after the step", &state.q).into());
            }
            if !finite(&state.qd[vr]) {
                return Err(non_finite(model, rec.body(), "qd after the step", &state.qd).into());
            }
        }
        Ok((dofs, touched))
    }

    /// Puts the active joints' `q`, `q̇` back to the step's start values.
    fn restore(&self, model: &Model, state: &mut State, rk: &RkBuffers) {
        if rk.q_start.len() != model.nq {
            return;
        }
        for rec in &self.hier.records {
            let b = &model.bodies[rec.body()];
            let (qr, vr) = (b.q_offset..b.q_offset + b.nq, b.v_offset..b.v_offset + b.nv);
            state.q[qr.clone()].copy_from_slice(&rk.q_start[qr]);
            state.qd[vr.clone()].copy_from_slice(&rk.qd_start[vr]);
        }
    }
}
