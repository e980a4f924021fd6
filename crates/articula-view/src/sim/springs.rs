//! Pose springs: the stiffness and damping of every internal degree of freedom of a model
//! (`docs/view.md#pose-springs`).
//!
//! A coordinate `i` gets `τᵢ = −kᵢ qᵢ − cᵢ q̇ᵢ` with, for a frequency `ω = 2π f`, a damping
//! ratio `ζ` and the time step `h`:
//!
//! ```text
//! kᵢ = min(ω² mᵢ, m̂ᵢ / h²)                 the spring: at most ω h = ½ on the coordinate's own inertia
//! cᵢ = dᵢ m̂ᵢ / (m̂ᵢ + h dᵢ),  dᵢ = 2ζω mᵢ   the damper, backward Euler on the coordinate alone
//! ```
//!
//! with `m̂ᵢ = mᵢᶠ / 4` ([`INTEGRATION_SHARE`]) and `mᵢᶠ = 1 / (M⁻¹)ᵢᵢ` the coordinate's
//! effective inertia with the body free-floating in the rest pose (`Model::rest_q`: the
//! neutral pose moved into the joint limits) (the response `q̈ᵢ` to a
//! unit `τᵢ` with everything else free). `mᵢ` is the inertia the frequency is meant for: `mᵢᶠ`
//! without a floor; with one the **stance** inertia ([`stance_inertia`]): a standing
//! humanoid's ankle carries the whole body, its free inertia is the foot's (0.006 kg m²), its
//! stance inertia the body's about the ankle (75 kg m²), and only the latter gives a spring that
//! holds the body up. A composed joint's coordinates all take its heaviest coordinate's `mᵢ`
//! (an Euler angle's inertia changes with the joint's other angles: a light twist axis with a
//! weak spring drifts to gimbal lock).
//!
//! Both are explicit torques of semi-implicit Euler, so each is bounded by what the
//! coordinate's own (smallest, free) inertia lets the scheme integrate: the spring to
//! `ω h ≤ ½` (the scheme's limit for one coordinate alone is 2; coupled coordinates ring
//! faster), and the damper is the exact backward-Euler damper of the coordinate alone,
//! `q̇⁺ = q̇ m̂ᵢ / (m̂ᵢ + h dᵢ)`, which never reverses a velocity however large `dᵢ` (an explicit
//! damper diverges once `h dᵢ / m > 2`: 8 Hz with ζ = 0.5 on the shoulder's twist axis gave 8).

use articula_dca::{forward_dynamics_slices, forward_kinematics, Data, Method};
use articula_model::{CollisionModel, JointKind, Model};
use articula_spatial::SpatialInertia;

/// Contact points within this height of the lowest one in the neutral pose are the stance's
/// (m).
const STANCE_BAND: f64 = 5e-3;

/// The share of a coordinate's free inertia its spring and damper are integrated against:
/// `ω dt ≤ ½` on its own (coupled coordinates ring faster than each alone).
const INTEGRATION_SHARE: f64 = 0.25;

/// Pose springs of every internal one-coordinate degree of freedom of `model` for time step
/// `dt`, `(q index, v index, k, c)` (module documentation); `stance`: scale them by the stance
/// inertia (a scene with a floor). A coordinate the dynamics cannot move gets none.
pub fn pose_springs(
    model: &Model,
    frequency_hz: f64,
    damping_ratio: f64,
    dt: f64,
    stance: bool,
) -> Vec<(usize, usize, f64, f64)> {
    let q = model.rest_q();
    let mut data = Data::new(model);
    data.gravity = glam::DVec3::ZERO;
    // DCA on the model's own tree: leaf clusters give the same stiffnesses to rounding but
    // other bits, and with them every scene's trajectory.
    data.set_leaf_clusters(model, false);
    let qd = vec![0.0; model.nv];
    let mut tau = vec![0.0; model.nv];
    let w = 2.0 * std::f64::consts::PI * frequency_hz;
    // (body, q index, v index, free inertia)
    let mut coords: Vec<(usize, usize, usize, f64)> = Vec::new();
    for (b, part) in model.joint_parts() {
        if !part.kind.is_scalar()
            || model.bodies[b].parent.is_none()
                && model.floating_base
                && part.kind == JointKind::Floating
        {
            continue;
        }
        let v = part.v_offset;
        tau[v] = 1.0;
        let r = forward_dynamics_slices(model, &mut data, &q, &qd, &tau, &[], Method::Dca)
            .map(|qdd| qdd[v]);
        tau[v] = 0.0;
        if let Ok(minv) = r {
            if minv > 0.0 && minv.is_finite() {
                coords.push((b, part.q_offset, v, 1.0 / minv));
            }
        }
    }
    let stance = if stance {
        stance_inertia(model, &q)
    } else {
        None
    };
    // The inertia each coordinate's frequency is meant for.
    let meant = |v: usize, free: f64| match &stance {
        Some(m) => m[v].max(free),
        None => free,
    };
    let mut joint_max = vec![0.0f64; model.bodies.len()];
    for &(b, _, v, free) in &coords {
        joint_max[b] = joint_max[b].max(meant(v, free));
    }
    coords
        .iter()
        .map(|&(b, qi, v, free)| {
            let m = if model.bodies[b].joint.len() > 1 {
                joint_max[b]
            } else {
                meant(v, free)
            };
            // The integrator's share of the coordinate's own inertia.
            let own = INTEGRATION_SHARE * free;
            let k = (w * w * m).min(own / (dt * dt));
            let d = 2.0 * damping_ratio * w * m;
            let c = d * own / (own + dt * d);
            (qi, v, k, c)
        })
        .collect()
}

/// Per degree of freedom at `q`: the inertia about its axis of the side of its joint away
/// from the stance, `sᵢᵀ I sᵢ` with `I` the composite spatial inertia of the joint's subtree if
/// that holds no stance body, else of the rest of the body (the body minus the subtree); the
/// stance bodies are those with a contact point within [`STANCE_BAND`] of the lowest (world
/// z). `None` without a floating base or contact points.
fn stance_inertia(model: &Model, q: &[f64]) -> Option<Vec<f64>> {
    if !model.floating_base {
        return None;
    }
    let collision = CollisionModel::new(model);
    let mut data = Data::new(model);
    forward_kinematics(model, q, &vec![0.0; model.nv], &mut data).ok()?;
    let low = |s: &articula_model::ContactSphere| {
        let (r, p) = data.body_pose(s.body);
        (r * s.center_facing(r.transpose() * glam::DVec3::Z) + p).z - s.radius
    };
    let lowest = collision
        .spheres
        .iter()
        .map(low)
        .fold(f64::INFINITY, f64::min);
    if !lowest.is_finite() {
        return None;
    }
    let n = model.bodies.len();
    let mut holds_stance = vec![false; n];
    for s in &collision.spheres {
        if low(s) <= lowest + STANCE_BAND {
            holds_stance[s.body] = true;
        }
    }
    // Composite inertias of the subtrees in computation-frame coordinates (bodies are stored
    // parents first).
    let mut sub: Vec<SpatialInertia> = model
        .bodies
        .iter()
        .enumerate()
        .map(|(b, body)| {
            let (r, p) = data.body_pose(b);
            let i = &body.inertia;
            SpatialInertia::new(
                i.mass,
                r * i.com() + p - data.origin,
                r * i.inertia_about_com() * r.transpose(),
            )
        })
        .collect();
    for b in (0..n).rev() {
        if let Some(p) = model.bodies[b].parent {
            let child = sub[b];
            sub[p] += child;
            holds_stance[p] |= holds_stance[b];
        }
    }
    let total = sub[0];
    let mut out = vec![0.0; model.nv];
    for (b, body) in model.bodies.iter().enumerate() {
        let side = if holds_stance[b] {
            let mut rest = total;
            rest += SpatialInertia::new(-sub[b].mass, sub[b].com(), -sub[b].inertia_about_com());
            rest
        } else {
            sub[b]
        };
        let r = body.v_offset..body.v_offset + body.nv;
        for (o, s) in out[r.clone()].iter_mut().zip(&data.s[r]) {
            *o = 2.0 * side.kinetic_energy(*s);
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::stance_inertia;
    use articula_dca::{forward_kinematics, Data};

    /// The stance inertia of a leg joint is the rest of the body turning about the joint's
    /// axis, summed body by body (`m |ω × (c − a)|² + ωᵀ I_c ω` for every body outside the
    /// joint's subtree); an arm joint's is its own subtree's.
    #[test]
    fn stance_inertia_is_the_far_side_turning_about_the_axis() {
        let model = articula_testkit::bundled_with("humanoid", true);
        let q = model.neutral_q();
        let got = stance_inertia(&model, &q).unwrap();
        let mut data = Data::new(&model);
        forward_kinematics(&model, &q, &vec![0.0; model.nv], &mut data).unwrap();
        let in_subtree = |b: usize, root: usize| {
            let mut x = Some(b);
            while let Some(y) = x {
                if y == root {
                    return true;
                }
                x = model.bodies[y].parent;
            }
            false
        };
        for (name, feet_side) in [("l_ankle_y", true), ("r_knee", true), ("l_elbow", false)] {
            let (jb, part) = model.joint_parts().find(|(_, p)| p.name == name).unwrap();
            let s = data.s[part.v_offset];
            let w = s.w;
            // A point on the axis (world): v = a × ω for a rotation about a.
            let a = w.cross(s.v) / w.length_squared() + data.origin;
            let mut expected = 0.0;
            for (b, body) in model.bodies.iter().enumerate() {
                if in_subtree(b, jb) == feet_side {
                    continue;
                }
                let (r, p) = data.body_pose(b);
                let i = &body.inertia;
                let c = r * i.com() + p;
                let v = w.cross(c - a);
                expected += i.mass * v.length_squared()
                    + w.dot(r * i.inertia_about_com() * r.transpose() * w);
            }
            let m = got[part.v_offset];
            assert!(
                (m - expected).abs() <= 1e-9 * expected,
                "{name}: {m} vs {expected}"
            );
            eprintln!("stance inertia of {name}: {m:.4} kg m²");
        }
    }
}
