//! Forward kinematics in world coordinates: poses, velocities, motion subspaces and the
//! velocity-product terms every algorithm shares.

use crate::Data;
use articula_model::{JointKind, Model};
use articula_spatial::{SpatialMotion, SpatialTransform};
use glam::{DMat3, DVec3};

/// Computes, for every body in order (parents first): `X_{W←i}`, the world-frame inertia, the
/// spatial velocity `vᵢ`, the world-frame subspace columns `S`, and
/// `cᵢ = Σ_k v_{k-1} × s_k q̇_k` — the velocity product of the relative acceleration
/// `aᵢ - a_parent = S q̈ + c`, each axis taken with the velocity of the frame that carries it
/// (for a composed joint, the massless links in between).
///
/// The computation frame has the world's axes and its origin at `data.origin`: the world origin
/// for a fixed base, the floating base's current position otherwise. Keeping the numbers about
/// a nearby point keeps DCA accurate to ~1e-12 however far the body wanders (about a point 1 m
/// away it loses two digits).
pub fn forward_kinematics(model: &Model, q: &[f64], qd: &[f64], data: &mut Data) {
    data.origin = match model.bodies.first() {
        Some(b) if b.parent.is_none() && b.joint[0].kind == JointKind::Floating => {
            let qo = b.joint[0].q_offset;
            DVec3::new(q[qo], q[qo + 1], q[qo + 2])
        }
        _ => DVec3::ZERO,
    };
    // X_{C←W} = xlt(origin)
    let x_cw = SpatialTransform::xlt(data.origin);
    for (i, body) in model.bodies.iter().enumerate() {
        let (mut x, mut v) = match body.parent {
            Some(p) => (data.x[p], data.v[p]),
            None => (x_cw, SpatialMotion::ZERO),
        };
        let mut c = SpatialMotion::ZERO;
        for part in &body.joint {
            // X_{W←k} = X_{W←k-1} · origin · motion(q); for a rotation rot(R_q) the second
            // product is just e = e R_q, r = R_qᵀ r.
            x = x * part.origin;
            match part.kind {
                JointKind::Revolute | JointKind::Continuous => {
                    let rq = DMat3::from_axis_angle(part.axis, q[part.q_offset]);
                    x = SpatialTransform::new(x.e * rq, rq.transpose() * x.r);
                }
                _ => x = x * part.motion_transform(&q[part.q_offset..part.q_offset + part.nq()]),
            }
            let mut vj = SpatialMotion::ZERO;
            for k in 0..part.nv() {
                let s = x.apply_motion(part.subspace_column(k));
                data.s[part.v_offset + k] = s;
                vj += s * qd[part.v_offset + k];
            }
            c += v.cross_motion(vj);
            v += vj;
        }
        data.x[i] = x;
        data.v[i] = v;
        data.c[i] = c;
        data.inertia[i] = x.apply_inertia(&body.inertia);
    }
}

/// Expresses world-frame wrenches (about the world origin) in the computation frame.
pub(crate) fn forces_to_computation_frame(
    f_ext: &[articula_spatial::SpatialForce],
    data: &mut Data,
) {
    let x_cw = SpatialTransform::xlt(data.origin);
    data.f_ext_c.clear();
    data.f_ext_c
        .extend(f_ext.iter().map(|f| x_cw.apply_force(*f)));
}
