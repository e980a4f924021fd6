//! Time stepping: semi-implicit Euler (default) and RK4, on the configuration manifold
//! (quaternions of floating joints are advanced by the exponential map and renormalised).

use crate::{forward_dynamics, Data, DynamicsError, Method, State};
use articula_model::{JointKind, Model};
use glam::{DQuat, DVec3};

/// A time integrator.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Integrator {
    /// `q̇ ← q̇ + h q̈(q, q̇)`, then `q ← q ⊕ h q̇` (symplectic for separable systems).
    #[default]
    SemiImplicitEuler,
    /// Classic fourth-order Runge–Kutta on `(q, q̇)`, with `q ⊕ Δ` for the position update.
    /// (On a floating joint the stage increments are composed through the exponential without
    /// the `dexp⁻¹` corrections of Runge–Kutta–Munthe-Kaas, so there it is second order.)
    Rk4,
}

/// `q ← q ⊕ h·qd`: angles and displacements add; a floating joint moves by the SE(3)
/// exponential of its body twist `h [ω; v]` — the exact motion at constant body velocity:
/// orientation `R exp(ω h)` (renormalised), position `p + R J(ω h) v h` with
/// `J(φ) = ∫₀¹ exp(s [φ]×) ds = 1 + a [φ]× + b [φ]×²`, `a = (1 − cos θ)/θ²`,
/// `b = (θ − sin θ)/θ³`, `θ = |φ|`. (`p + R v h` alone is only first order in `h` and makes
/// RK4 first order on a floating base.)
pub fn integrate_q(model: &Model, q: &mut [f64], qd: &[f64], h: f64) {
    for (_, part) in model.joint_parts() {
        let (qo, vo) = (part.q_offset, part.v_offset);
        match part.kind {
            JointKind::Floating => {
                integrate_floating(&mut q[qo..qo + 7], &qd[vo..vo + 6], h);
            }
            JointKind::Fixed => {}
            _ => q[qo] += qd[vo] * h,
        }
    }
}

/// `q ← q ⊕ h·v` for one floating joint: `q = [x, y, z, qw, qx, qy, qz]`, `v = [ω; v]` its
/// body twist (see [`integrate_q`]).
pub fn integrate_floating(q: &mut [f64], v: &[f64], h: f64) {
    let rot = DQuat::from_xyzw(q[4], q[5], q[6], q[3]).normalize();
    let w = DVec3::new(v[0], v[1], v[2]);
    let v = DVec3::new(v[3], v[4], v[5]);
    let phi = w * h;
    let th = phi.length();
    let (a, b) = if th < 1e-2 {
        // Taylor series (the closed forms cancel); the next terms are < 1e-16.
        let t2 = th * th;
        (
            0.5 - t2 / 24.0 + t2 * t2 / 720.0,
            1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0,
        )
    } else {
        let s = (0.5 * th).sin();
        (2.0 * s * s / (th * th), (th - th.sin()) / (th * th * th))
    };
    let pv = phi.cross(v);
    let p = DVec3::new(q[0], q[1], q[2]) + rot * ((v + a * pv + b * phi.cross(pv)) * h);
    let angle = w.length() * h;
    let dr = if angle > 0.0 {
        DQuat::from_axis_angle(w.normalize(), angle)
    } else {
        DQuat::IDENTITY
    };
    let r = (rot * dr).normalize();
    q[..7].copy_from_slice(&[p.x, p.y, p.z, r.w, r.x, r.y, r.z]);
}

/// Advances `state` by `dt` with `method` and `integrator`. Allocates nothing for DCA and ABA.
pub fn step(
    model: &Model,
    data: &mut Data,
    state: &mut State,
    method: Method,
    integrator: Integrator,
    dt: f64,
) -> Result<(), DynamicsError> {
    match integrator {
        Integrator::SemiImplicitEuler => {
            forward_dynamics(
                model,
                data,
                &state.q,
                &state.qd,
                &state.tau,
                &state.f_ext,
                method,
            )?;
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
            let weights = [1.0, 2.0, 2.0, 1.0];
            let next = [0.5, 0.5, 1.0];
            let mut result = Ok(());
            for stage in 0..4 {
                if let Err(e) = forward_dynamics(
                    model,
                    data,
                    &state.q,
                    &state.qd,
                    &state.tau,
                    &state.f_ext,
                    method,
                ) {
                    result = Err(e);
                    break;
                }
                for j in 0..model.nv {
                    rk.kv[j] += weights[stage] * state.qd[j];
                    rk.ka[j] += weights[stage] * data.qdd[j];
                }
                if stage < 3 {
                    // Next stage: q = q0 ⊕ h k_v, q̇ = q̇0 + h k_a, with this stage's k.
                    let h = next[stage] * dt;
                    state.q.copy_from_slice(&rk.q0);
                    integrate_q(model, &mut state.q, &state.qd, h);
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
