//! Time stepping: semi-implicit Euler (default) and RK4, on the configuration manifold
//! (quaternions of floating joints are advanced by the exponential map and renormalised).

use crate::{forward_dynamics_slices, Data, DynamicsError, Method, State};
use articula_model::{JointKind, Model};
use articula_spatial::{SpatialForce, SpatialInertia, SpatialMotion, SpatialTransform};
use glam::DVec3;

/// A time integrator.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Integrator {
    /// `q̇ ← q̇ + h q̈(q, q̇)`, then `q ← q ⊕ h q̇` (symplectic for separable systems).
    #[default]
    SemiImplicitEuler,
    /// Classic fourth-order Runge–Kutta on `(q, q̇)`, with `q ⊕ Δ` for the position update;
    /// on a floating joint it is Runge–Kutta–Munthe-Kaas (the pose moves by the exponential of
    /// a Lie-algebra increment whose stage slopes carry the `dexp⁻¹` correction), so it is
    /// fourth order there too.
    Rk4,
}

/// `q ← q ⊕ h·qd`, joint by joint ([`articula_model::JointKind::integrate`]): angles and
/// displacements add; a ball joint turns by `exp(h ω)` in its moving frame (renormalised); a
/// floating joint moves by the SE(3) exponential of its body twist `h [ω; v]` — the exact
/// motion at constant body velocity ([`integrate_floating`]).
pub fn integrate_q(model: &Model, q: &mut [f64], qd: &[f64], h: f64) {
    for (_, part) in model.joint_parts() {
        part.integrate(q, qd, h);
    }
}

pub use articula_model::integrate_floating;

/// Advances `state` by `dt` with `method` and `integrator`. Allocates nothing for DCA and ABA.
///
/// **Momentum projection** (when `data.momentum_projection`, the default, on a free-floating
/// model — every body below one floating root joint — whose floating joint has zero `τ`):
/// neither integrator conserves the total spatial momentum `h` exactly (per step, relative:
/// ~1e-5 for semi-implicit Euler, ~2e-9 for RK4 at dt = 1e-3 on the humanoid), though the
/// dynamics does. But its exact value after the step is known: joint forces are internal, the
/// external wrenches `f_ext` are constant in the world frame over the step, and the centre of
/// mass moves with the constant acceleration `g + F/M` (`F` their total force, `M` the total
/// mass), so about the world origin
/// `h(t+dt) = h(t) + Σ f_ext dt + [M (c dt + ċ dt²/2) × g + (F × g) dt³/6 ; M g dt]`
/// (`c`, `ċ` the centre of mass and its velocity at `t`). After the integrator's update, a
/// rigid velocity `δ` added to the floating base adds `δ` to every body's spatial velocity,
/// so `h` changes by `I_c δ` (`I_c` the composite inertia of the whole model):
/// `δ = I_c⁻¹ (h_exact − h(q₁, q̇₁))` puts the momentum on its exact value, to rounding. The
/// correction is of the size of the integrator's local error, so the integrator keeps its order
/// (projection onto an invariant, Hairer–Lubich–Wanner IV.4); energy is not projected (its
/// drift stays the integrator's, see `tests/conservation.rs`). It costs one more forward
/// kinematics per step. (A τ on the floating joint is a body-fixed external wrench whose
/// impulse has no closed form: then no projection is made.)
pub fn step(
    model: &Model,
    data: &mut Data,
    state: &mut State,
    method: Method,
    integrator: Integrator,
    dt: f64,
) -> Result<(), DynamicsError> {
    crate::inputs::check_data(model, data)?;
    let project = data.momentum_projection && projectable(model, state);
    let mut start = None;
    match integrator {
        Integrator::SemiImplicitEuler => {
            with_passive_forces(
                model,
                data,
                (&state.q, &state.qd, &state.tau, &state.f_ext),
                method,
                dt,
            )?;
            if project {
                start = Some(MomentumStart::of(data));
            }
            for (v, a) in state.qd.iter_mut().zip(&data.qdd) {
                *v += dt * a;
            }
            integrate_q(model, &mut state.q, &state.qd, dt);
        }
        Integrator::Rk4 => {
            // k_i = (q̇_i, q̈_i); stage states q0 ⊕ (c h) k_{i-1}.
            let mut rk = std::mem::replace(&mut data.rk, crate::data::RkData::empty());
            rk.q0.copy_from_slice(&state.q);
            rk.qd0.copy_from_slice(&state.qd);
            rk.kv.iter_mut().for_each(|x| *x = 0.0);
            rk.ka.iter_mut().for_each(|x| *x = 0.0);
            rk.theta.iter_mut().for_each(|x| *x = 0.0);
            let weights = [1.0, 2.0, 2.0, 1.0];
            let next = [0.5, 0.5, 1.0];
            let mut result = Ok(());
            for stage in 0..4 {
                if let Err(e) = with_passive_forces(
                    model,
                    data,
                    (&state.q, &state.qd, &state.tau, &state.f_ext),
                    method,
                    0.0,
                ) {
                    result = Err(e);
                    break;
                }
                if stage == 0 && project {
                    start = Some(MomentumStart::of(data));
                }
                // The position slope of this stage: q̇, but for a floating joint the RKMK
                // slope dexp⁻¹_{−Θ}(ξ) (Θ the increment that made this stage's pose from q0).
                rkmk_slopes(model, &mut state.qd, &rk.theta);
                for j in 0..model.nv {
                    rk.kv[j] += weights[stage] * state.qd[j];
                    rk.ka[j] += weights[stage] * data.qdd[j];
                }
                if stage < 3 {
                    // Next stage: q = q0 ⊕ h k_v, q̇ = q̇0 + h k_a, with this stage's k.
                    let h = next[stage] * dt;
                    state.q.copy_from_slice(&rk.q0);
                    integrate_q(model, &mut state.q, &state.qd, h);
                    for (t, k) in rk.theta.iter_mut().zip(&state.qd) {
                        *t = h * k;
                    }
                    for j in 0..model.nv {
                        state.qd[j] = rk.qd0[j] + h * data.qdd[j];
                    }
                }
            }
            if result.is_ok() {
                state.q.copy_from_slice(&rk.q0);
                for j in 0..model.nv {
                    rk.kv[j] /= 6.0;
                    state.qd[j] = rk.qd0[j] + dt * rk.ka[j] / 6.0;
                }
                integrate_q(model, &mut state.q, &rk.kv, dt);
            }
            data.rk = rk;
            result?;
        }
    }
    if let Some(start) = start {
        project_momentum(model, data, state, &start, dt);
    }
    check_step_result(model, state)
}

/// The end of a step: no NaN or infinity in `q` or `q̇` (the error names the joint).
pub(crate) fn check_step_result(model: &Model, state: &State) -> Result<(), DynamicsError> {
    for (_, part) in model.joint_parts() {
        let q = &state.q[part.q_offset..part.q_offset + part.nq()];
        let qd = &state.qd[part.v_offset..part.v_offset + part.nv()];
        for (what, xs) in [("q after the step", q), ("qd after the step", qd)] {
            if xs.iter().any(|x| !x.is_finite()) {
                return Err(DynamicsError::NonFinite {
                    what,
                    name: part.name.clone(),
                });
            }
        }
    }
    Ok(())
}

/// Replaces, for every joint on a Lie group (ball, floating), the body velocity `ξ` in `qd` by
/// the RKMK slope `dexp⁻¹_{−Θ}(ξ) = ξ + ½ [Θ, ξ] + ¹⁄₁₂ [Θ, [Θ, ξ]]` (enough for fourth order;
/// `Θ` from `theta`, the stage's increment): with `q(t) = q0 exp(Θ(t))` and the body velocity
/// `ξ`, `Θ̇ = dexp⁻¹_{−Θ}(ξ)` ([`articula_model::JointKind::rkmk_slope`]).
fn rkmk_slopes(model: &Model, qd: &mut [f64], theta: &[f64]) {
    for (_, part) in model.joint_parts() {
        if part.kind.on_a_lie_group() {
            let v = part.v_offset..part.v_offset + part.nv();
            part.kind.rkmk_slope(&theta[v.clone()], &mut qd[v]);
        }
    }
}

/// True when the momentum projection of [`step`] applies: body 0 is the only root, with one
/// floating joint whose `τ` is zero.
fn projectable(model: &Model, state: &State) -> bool {
    let Some(base) = model.bodies.first() else {
        return false;
    };
    let [part] = base.joint.as_slice() else {
        return false;
    };
    part.kind == JointKind::Floating
        && base.parent.is_none()
        && model.bodies[1..].iter().all(|b| b.parent.is_some())
        && state.tau[part.v_offset..part.v_offset + 6]
            .iter()
            .all(|&t| t == 0.0)
}

/// What the projection needs from the start of the step (world frame, about the world
/// origin): momentum, total mass, centre of mass.
struct MomentumStart {
    h: SpatialForce,
    mass: f64,
    com: DVec3,
}

impl MomentumStart {
    /// From the kinematics in `data` (the state at the start of the step).
    fn of(data: &Data) -> MomentumStart {
        let (mass, first_moment) = data
            .inertia
            .iter()
            .fold((0.0, DVec3::ZERO), |(m, h), i| (m + i.mass, h + i.h));
        MomentumStart {
            h: data.momentum(),
            mass,
            com: data.origin + first_moment / mass,
        }
    }
}

/// Corrects the floating base's velocity so that the momentum of `state` (after the step)
/// is the exact `h(t+dt)` of [`step`]'s documentation.
fn project_momentum(
    model: &Model,
    data: &mut Data,
    state: &mut State,
    start: &MomentumStart,
    dt: f64,
) {
    let (m, g) = (start.mass, data.gravity);
    let f_total = state
        .f_ext
        .iter()
        .fold(SpatialForce::ZERO, |acc, f| acc + *f);
    let com_velocity = start.h.f / m;
    let exact = start.h
        + f_total * dt
        + SpatialForce::new(
            (start.com * dt + com_velocity * (0.5 * dt * dt)).cross(g) * m
                + f_total.f.cross(g) * (dt * dt * dt / 6.0),
            g * (m * dt),
        );
    crate::kinematics::forward_kinematics_unchecked(model, &state.q, &state.qd, data);
    // Both sides about the computation origin: X* = xlt(origin)*.
    let x_cw = SpatialTransform::xlt(data.origin);
    let (h1, ic) = data.v.iter().zip(&data.inertia).fold(
        (SpatialForce::ZERO, SpatialInertia::ZERO),
        |(h, ic), (v, i)| (h + i.mul_motion(*v), ic + *i),
    );
    let residual = x_cw.apply_force(exact) - h1;
    let Some(ic_inv) = ic.inverse() else {
        return;
    };
    let delta: SpatialMotion = ic_inv.force_to_motion(residual);
    // The base's q̇ is its velocity in its own coordinates: v₀ = X_{C←0} q̇₀.
    let d = data.x[0].inv_apply_motion(delta).to_array();
    let vo = model.bodies[0].joint[0].v_offset;
    for (v, dv) in state.qd[vo..vo + 6].iter_mut().zip(d) {
        *v += dv;
    }
}

/// Forward dynamics for a step: `τ` plus the model's passive forces
/// ([`Model::passive_forces`]: damping and springs), with the damping `b` integrated implicitly
/// over `dt` by adding `dt b` to the armature for this solve, `(M + A + dt B) q̈ = τ − b(q, q̇)
/// − B q̇ − K (q − q_spring)` (MuJoCo's implicit damping; `dt = 0`: explicit). A model without
/// damping or springs takes the plain [`forward_dynamics_slices`]. `q̈` is left in `data.qdd`.
pub(crate) fn with_passive_forces(
    model: &Model,
    data: &mut Data,
    (q, qd, tau, f_ext): (&[f64], &[f64], &[f64], &[SpatialForce]),
    method: Method,
    dt: f64,
) -> Result<(), DynamicsError> {
    if !model.dynamics.has_passive() {
        return forward_dynamics_slices(model, data, q, qd, tau, f_ext, method).map(|_| ());
    }
    let mut total = std::mem::take(&mut data.passive);
    total.resize(model.nv, 0.0);
    model.passive_forces(q, qd, &mut total);
    for (t, x) in total.iter_mut().zip(tau) {
        *t += x;
    }
    data.set_damping_step(model, dt);
    let result = forward_dynamics_slices(model, data, q, qd, &total, f_ext, method).map(|_| ());
    // The model's own armature back, exactly.
    data.set_damping_step(model, 0.0);
    data.passive = total;
    result
}
