//! Forward kinematics in world coordinates: poses, velocities, motion subspaces and the
//! velocity-product terms every algorithm shares.

use crate::{Data, DynamicsError};
use articula_model::{Body, JointKind, Model};
use articula_spatial::{SpatialMotion, SpatialTransform};
use glam::{DMat3, DVec3};

/// How forward kinematics handles a body's joint: the common single revolute joint about a
/// coordinate axis of its frame, with a joint origin that only translates, takes a fast path
/// (a rotation of two columns instead of 3×3 products).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum FkPlan {
    /// Anything else: the general composition.
    General,
    /// One revolute/continuous joint about `sign · e_axis`, pure-translation origin.
    AxisRevolute {
        /// The axis index.
        k: usize,
        /// ±1: the axis direction.
        sign: f64,
        /// The joint origin's `r` and the joint's coordinate offsets (copied from the model so
        /// that the loop reads one compact record per body).
        origin_r: DVec3,
        qo: usize,
        vo: usize,
    },
}

impl FkPlan {
    pub(crate) fn of(body: &Body) -> FkPlan {
        let [part] = body.joint.as_slice() else {
            return FkPlan::General;
        };
        if !part.kind.is_hinge() || part.origin.e != DMat3::IDENTITY {
            return FkPlan::General;
        }
        let ax = part.axis;
        for k in 0..3 {
            let mut unit = DVec3::ZERO;
            unit[k] = 1.0;
            for sign in [1.0, -1.0] {
                if ax == unit * sign {
                    return FkPlan::AxisRevolute {
                        k,
                        sign,
                        origin_r: part.origin.r,
                        qo: part.q_offset,
                        vo: part.v_offset,
                    };
                }
            }
        }
        FkPlan::General
    }
}

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
///
/// Errors, before anything is computed: `data` built for another model
/// ([`DynamicsError::WrongModel`]), `q` or `qd` of the wrong length
/// ([`DynamicsError::Dimension`]) or not finite ([`DynamicsError::NonFinite`], naming the
/// joint).
pub fn forward_kinematics(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    data: &mut Data,
) -> Result<(), DynamicsError> {
    crate::inputs::check_data(model, data)?;
    crate::inputs::check_values(model, q, qd, ("qd", qd), &[])?;
    forward_kinematics_unchecked(model, q, qd, data);
    Ok(())
}

/// [`forward_kinematics`] on inputs already checked (a state the crate's own step produced).
pub(crate) fn forward_kinematics_unchecked(model: &Model, q: &[f64], qd: &[f64], data: &mut Data) {
    data.origin = computation_origin(model, q);
    kinematics(model, q, qd, data, |_, _| {});
}

/// The origin of the computation frame for configuration `q` (see [`forward_kinematics`]).
pub fn computation_origin(model: &Model, q: &[f64]) -> DVec3 {
    match model.bodies.first() {
        Some(b) if b.parent.is_none() && b.joint[0].kind == JointKind::Floating => {
            let qo = b.joint[0].q_offset;
            DVec3::new(q[qo], q[qo + 1], q[qo + 2])
        }
        _ => DVec3::ZERO,
    }
}

/// The kinematics loop about `data.origin`; `per_body(i, data)` runs right after body `i` is
/// done, while its numbers are still in cache (ABA initialises its articulated quantities
/// there).
#[inline(always)]
pub(crate) fn kinematics(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    data: &mut Data,
    per_body: impl FnMut(usize, &mut Data),
) {
    kinematics_with(model, q, qd, data, true, per_body)
}

/// [`kinematics`], where `per_body` sets `data.inertia[i]` itself unless `world_inertia`.
#[inline(always)]
pub(crate) fn kinematics_with(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    data: &mut Data,
    world_inertia: bool,
    mut per_body: impl FnMut(usize, &mut Data),
) {
    // X_{C←W} = xlt(origin)
    let x_cw = SpatialTransform::xlt(data.origin);
    for i in 0..model.bodies.len() {
        kinematics_body(model, i, q, qd, data, x_cw, world_inertia);
        per_body(i, data);
    }
}

/// One body of the kinematics loop (its parent done): `X_{C←i}`, `vᵢ`, `cᵢ`, its columns of
/// `S`, and with `world_inertia` its world inertia. `x_cw = X_{C←W}`. DCA's main pass also
/// runs it at each leaf (see `DcaData::leaf_kinematics`).
#[inline(always)]
pub(crate) fn kinematics_body(
    model: &Model,
    i: usize,
    q: &[f64],
    qd: &[f64],
    data: &mut Data,
    x_cw: SpatialTransform,
    world_inertia: bool,
) {
    let body = &model.bodies[i];
    let parent = data.topo[i].parent;
    let (x0, v0) = if parent == usize::MAX {
        (x_cw, SpatialMotion::ZERO)
    } else {
        (data.x[parent], data.v[parent])
    };
    let (x, v, c) = match data.fk_plan[i] {
        FkPlan::AxisRevolute {
            k,
            sign,
            origin_r,
            qo,
            vo,
        } => {
            let qi = sign * q[qo];
            let (x, s) = match k {
                0 => axis_revolute::<0, 1, 2>(x0, origin_r, qi.sin_cos(), sign),
                1 => axis_revolute::<1, 2, 0>(x0, origin_r, qi.sin_cos(), sign),
                _ => axis_revolute::<2, 0, 1>(x0, origin_r, qi.sin_cos(), sign),
            };
            data.s[vo] = s;
            let vj = s * qd[vo];
            (x, v0 + vj, v0.cross_motion(vj))
        }
        FkPlan::General => body_kinematics(body, x0, v0, q, qd, &mut data.s),
    };
    data.x[i] = x;
    data.v[i] = v;
    data.c[i] = c;
    if world_inertia {
        data.inertia[i] = self::world_inertia(&x, &body.inertia);
    }
}

/// The arm `pᵢ − p_parent` from the parent's origin to body i's origin `p` (computation-frame
/// axes; `p` itself for a root), given the poses `x` (parents done). For the one-axis revolute
/// joint it is the joint origin's translation rotated, `−E_parent r_origin`, exact to a few
/// roundings however far the bodies are from the computation origin: the difference of the two
/// positions would carry their rounding, ~1e-16 of the distance (1e-12 m at 10 km), into
/// every arm, bending a straight 100,000-link chain by ~1e-11 rad at each joint. Other joints:
/// that difference.
#[inline(always)]
pub(crate) fn arm(plan: FkPlan, x: &[SpatialTransform], parent: usize, p: DVec3) -> DVec3 {
    if parent == usize::MAX {
        return p;
    }
    let x0 = &x[parent];
    match plan {
        FkPlan::AxisRevolute { origin_r, .. } => -(x0.e * origin_r),
        FkPlan::General => p + x0.e * x0.r,
    }
}

/// `(sin θ, cos θ)` of body `i`'s joint angle `θ = sign · q` on the one-axis revolute fast
/// path (anything else: unused), apart from the pose chain ([`kinematics_pose`]) so that the
/// parallel DCA driver computes them on all threads (`parallel_dca.rs`).
#[inline(always)]
pub(crate) fn joint_trig(plan: FkPlan, q: &[f64]) -> (f64, f64) {
    match plan {
        FkPlan::AxisRevolute { sign, qo, .. } => (sign * q[qo]).sin_cos(),
        FkPlan::General => (0.0, 1.0),
    }
}

/// The part of [`kinematics_body`] (without the world inertia) that needs the parent's pose
/// and velocity, with body `i`'s [`joint_trig`] given: `X_{C←i}`, its columns of `S` and `vᵢ`;
/// on the one-axis revolute fast path `cᵢ` is left to [`kinematics_bias`]. The same
/// arithmetic as [`kinematics_body`]: the same bits.
#[inline(always)]
pub(crate) fn kinematics_pose(
    model: &Model,
    i: usize,
    q: &[f64],
    qd: &[f64],
    data: &mut Data,
    x_cw: SpatialTransform,
    trig: (f64, f64),
) {
    let FkPlan::AxisRevolute {
        k,
        sign,
        origin_r,
        vo,
        ..
    } = data.fk_plan[i]
    else {
        return kinematics_body(model, i, q, qd, data, x_cw, false);
    };
    let parent = data.topo[i].parent;
    let (x0, v0) = if parent == usize::MAX {
        (x_cw, SpatialMotion::ZERO)
    } else {
        (data.x[parent], data.v[parent])
    };
    let (x, s) = match k {
        0 => axis_revolute::<0, 1, 2>(x0, origin_r, trig, sign),
        1 => axis_revolute::<1, 2, 0>(x0, origin_r, trig, sign),
        _ => axis_revolute::<2, 0, 1>(x0, origin_r, trig, sign),
    };
    data.s[vo] = s;
    data.x[i] = x;
    data.v[i] = v0 + s * qd[vo];
}

/// `cᵢ = v_parent × s q̇` of a one-axis revolute body after its [`kinematics_pose`] (and its
/// parent's), as [`kinematics_body`] computes it; nothing for another joint (its pose did it).
#[inline(always)]
pub(crate) fn kinematics_bias(i: usize, qd: &[f64], data: &mut Data) {
    if let FkPlan::AxisRevolute { vo, .. } = data.fk_plan[i] {
        let parent = data.topo[i].parent;
        let v0 = if parent == usize::MAX {
            SpatialMotion::ZERO
        } else {
            data.v[parent]
        };
        data.c[i] = v0.cross_motion(data.s[vo] * qd[vo]);
    }
}

/// `X_{W←i} = X_{W←parent} · xlt(origin) · rot(R_θ)` for a rotation by `θ` about `e_K`, and
/// the joint's world subspace column `s = [ω; p × ω]` (`ω = sign · E e_K`, `p = −E r` the body
/// origin), given `(sin θ, cos θ)`: the pure-translation origin adds to `r`, and the rotation
/// mixes columns `A`, `B` of `E` and entries `A`, `B` of `r` (`(K, A, B)` cyclic).
#[inline(always)]
fn axis_revolute<const K: usize, const A: usize, const B: usize>(
    x0: SpatialTransform,
    origin_r: DVec3,
    (sn, cs): (f64, f64),
    sign: f64,
) -> (SpatialTransform, SpatialMotion) {
    let mut r = (origin_r + x0.r).to_array();
    let mut e = x0.e.to_cols_array_2d();
    let (ca, cb) = (e[A], e[B]);
    for j in 0..3 {
        e[A][j] = ca[j] * cs + cb[j] * sn;
        e[B][j] = cb[j] * cs - ca[j] * sn;
    }
    let (ra, rb) = (r[A], r[B]);
    r[A] = cs * ra + sn * rb;
    r[B] = cs * rb - sn * ra;
    let e = DMat3::from_cols_array_2d(&e);
    let r = DVec3::from_array(r);
    let w = e.col(K) * sign;
    let p = -(e * r);
    (
        SpatialTransform::new(e, r),
        SpatialMotion::new(w, p.cross(w)),
    )
}

/// The body inertia `i` (body frame, about the body origin) with the computation frame's axes:
/// about the body origin, `[E Ī Eᵀ, (E h)×; ·, m]` (ABA's, whose quantities are taken about
/// each body's own origin), and about the computation origin ([`world_inertia`]'s, to the
/// bit), from one `E Ī Eᵀ`. `E Ī Eᵀ` whole, entry `(a, b)` as `(E Ī) Eᵀ` with `E Ī` by the
/// columns of `Ī` (glam's `e * ibar * e.transpose()`, the same bits); the world inertia reads
/// its upper triangle.
#[inline(always)]
pub(crate) fn rotated_and_world_inertia(
    x: &SpatialTransform,
    i: &articula_spatial::SpatialInertia,
) -> (
    articula_spatial::SpatialInertia,
    articula_spatial::SpatialInertia,
) {
    let e = x.e.to_cols_array_2d();
    let ib = i.ibar.to_cols_array_2d();
    // T = E Ī: T_aj = Σ_k E_ak Ī_kj, Ī_kj = ib[j][k].
    let t: [[f64; 3]; 3] = std::array::from_fn(|a| {
        std::array::from_fn(|j| e[0][a] * ib[j][0] + e[1][a] * ib[j][1] + e[2][a] * ib[j][2])
    });
    let te = |a: usize, b: usize| t[a][0] * e[0][b] + t[a][1] * e[1][b] + t[a][2] * e[2][b];
    let r: [[f64; 3]; 3] = std::array::from_fn(|a| std::array::from_fn(|b| te(a, b)));
    let rotated = articula_spatial::SpatialInertia {
        mass: i.mass,
        h: x.e * i.h,
        ibar: DMat3::from_cols(
            DVec3::new(r[0][0], r[1][0], r[2][0]),
            DVec3::new(r[0][1], r[1][1], r[2][1]),
            DVec3::new(r[0][2], r[1][2], r[2][2]),
        ),
    };
    (rotated, parallel_axes(x, i.mass, rotated.h.to_array(), &r))
}

/// `X* I X⁻¹` for `x = X_{C←body}` (the same as [`SpatialTransform::apply_inertia`], fewer
/// products): with `p = −E r` the body origin and `h_P = E h` the first moment about it,
/// `Ī_O = E Ī Eᵀ − h_P pᵀ − p h_Pᵀ − m p pᵀ + (2 p·h_P + m p·p) 1` (parallel axes),
/// `h_O = h_P + m p`; `E Ī Eᵀ` on its upper triangle only.
#[inline(always)]
pub(crate) fn world_inertia(
    x: &SpatialTransform,
    i: &articula_spatial::SpatialInertia,
) -> articula_spatial::SpatialInertia {
    // E by columns (e[k] = E e_k) and Ī by rows (symmetric).
    let e = x.e.to_cols_array_2d();
    let m = i.mass;
    let ib = i.ibar.to_cols_array_2d();
    let ev = |u: [f64; 3]| -> [f64; 3] {
        std::array::from_fn(|k| e[0][k] * u[0] + e[1][k] * u[1] + e[2][k] * u[2])
    };
    let hp = ev(i.h.to_array());
    // T = E Ī: row a is Σ_k E_ak (row k of Ī); then (T Eᵀ)_ab = row a of T · row b of E.
    let t: [[f64; 3]; 3] = std::array::from_fn(|a| {
        std::array::from_fn(|c| e[0][a] * ib[0][c] + e[1][a] * ib[1][c] + e[2][a] * ib[2][c])
    });
    let te = |a: usize, b: usize| t[a][0] * e[0][b] + t[a][1] * e[1][b] + t[a][2] * e[2][b];
    let upper = [
        [te(0, 0), te(0, 1), te(0, 2)],
        [0.0, te(1, 1), te(1, 2)],
        [0.0, 0.0, te(2, 2)],
    ];
    parallel_axes(x, m, hp, &upper)
}

/// The inertia about the computation origin from the one about the body origin `p = −E r`
/// with the computation frame's axes (`E Ī Eᵀ`'s upper triangle in `te`, first moment
/// `h_P = E h`): [`world_inertia`]'s parallel axes.
#[inline(always)]
fn parallel_axes(
    x: &SpatialTransform,
    m: f64,
    hp: [f64; 3],
    te: &[[f64; 3]; 3],
) -> articula_spatial::SpatialInertia {
    let e = x.e.to_cols_array_2d();
    let r = x.r.to_array();
    let er: [f64; 3] = std::array::from_fn(|k| e[0][k] * r[0] + e[1][k] * r[1] + e[2][k] * r[2]);
    let p = [-er[0], -er[1], -er[2]];
    let te = |a: usize, b: usize| te[a][b];
    let dot = |u: &[f64; 3], v: &[f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let d = 2.0 * dot(&p, &hp) + m * dot(&p, &p);
    let mp = [p[0] * m, p[1] * m, p[2] * m];
    // h_P pᵀ + p h_Pᵀ + m p pᵀ = g pᵀ + p gᵀ
    let g = [
        hp[0] + mp[0] * 0.5,
        hp[1] + mp[1] * 0.5,
        hp[2] + mp[2] * 0.5,
    ];
    let xx = te(0, 0) - 2.0 * g[0] * p[0] + d;
    let yy = te(1, 1) - 2.0 * g[1] * p[1] + d;
    let zz = te(2, 2) - 2.0 * g[2] * p[2] + d;
    let xy = te(0, 1) - g[0] * p[1] - p[0] * g[1];
    let xz = te(0, 2) - g[0] * p[2] - p[0] * g[2];
    let yz = te(1, 2) - g[1] * p[2] - p[1] * g[2];
    articula_spatial::SpatialInertia {
        mass: m,
        h: DVec3::new(hp[0] + mp[0], hp[1] + mp[1], hp[2] + mp[2]),
        ibar: DMat3::from_cols(
            DVec3::new(xx, xy, xz),
            DVec3::new(xy, yy, yz),
            DVec3::new(xz, yz, zz),
        ),
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

/// One body's kinematics from its parent's pose `x0` (body → computation frame) and spatial
/// velocity `v0`: its pose, its spatial velocity and the velocity product `c` of its joint; the
/// joint's world subspace columns are written into `s` (indexed like `qd`). The general path of
/// [`forward_kinematics`], for any joint (composed, prismatic, floating).
pub fn body_kinematics(
    body: &Body,
    x0: SpatialTransform,
    v0: SpatialMotion,
    q: &[f64],
    qd: &[f64],
    s: &mut [SpatialMotion],
) -> (SpatialTransform, SpatialMotion, SpatialMotion) {
    let (mut x, mut v) = (x0, v0);
    let mut c = SpatialMotion::ZERO;
    for part in &body.joint {
        // X_{W←k} = X_{W←k-1} · origin · motion(q); for a rotation rot(R_q) the second product
        // is just e = e R_q, r = R_qᵀ r. (The parts after a composed joint's first usually
        // have the identity as origin: its product changes nothing.)
        let o = &part.origin;
        if o.e != DMat3::IDENTITY || o.r != DVec3::ZERO {
            x = x * part.origin;
        }
        if let Some((k, sign)) = part.coordinate_axis() {
            // A rotation about ±e_k: the one-axis fast path's column mix (no translation left
            // to add: the origin is applied above).
            let qi = sign * q[part.q_offset];
            let (xk, sk) = match k {
                0 => axis_revolute::<0, 1, 2>(x, DVec3::ZERO, qi.sin_cos(), sign),
                1 => axis_revolute::<1, 2, 0>(x, DVec3::ZERO, qi.sin_cos(), sign),
                _ => axis_revolute::<2, 0, 1>(x, DVec3::ZERO, qi.sin_cos(), sign),
            };
            x = xk;
            s[part.v_offset] = sk;
            let vj = sk * qd[part.v_offset];
            c += v.cross_motion(vj);
            v += vj;
            continue;
        }
        if part.kind.is_hinge() {
            let rq = DMat3::from_axis_angle(part.axis, q[part.q_offset]);
            x = SpatialTransform::new(x.e * rq, rq.transpose() * x.r);
        } else {
            x = x * part.motion_transform(&q[part.q_offset..part.q_offset + part.nq()]);
        }
        let mut vj = SpatialMotion::ZERO;
        for k in 0..part.nv() {
            let sk = x.apply_motion(part.subspace_column(k));
            s[part.v_offset + k] = sk;
            vj += sk * qd[part.v_offset + k];
        }
        c += v.cross_motion(vj);
        v += vj;
    }
    (x, v, c)
}

#[cfg(test)]
mod tests {
    use super::{rotated_and_world_inertia, world_inertia};
    use crate::{Data, State};

    /// ABA's inertias from one `E Ī Eᵀ`: the world inertia is [`world_inertia`]'s to the bit
    /// (so `data.inertia` is the same whichever method ran), and the rotated one is glam's
    /// `E Ī Eᵀ` and `E h` to the bit, on every body of every bundled model in random poses.
    #[test]
    fn rotated_and_world_inertias_match_their_separate_forms() {
        let bits = |i: &articula_spatial::SpatialInertia| {
            let mut v = vec![i.mass.to_bits()];
            v.extend(i.h.to_array().map(f64::to_bits));
            v.extend(i.ibar.to_cols_array().map(f64::to_bits));
            v
        };
        for (name, _, model) in crate::bundled_models() {
            let mut data = Data::new(&model);
            for seed in 0..3 {
                let s = State::random(&model, seed, 1.0);
                crate::forward_kinematics(&model, &s.q, &s.qd, &mut data).unwrap();
                for (i, body) in model.bodies.iter().enumerate() {
                    let x = &data.x[i];
                    let (rotated, world) = rotated_and_world_inertia(x, &body.inertia);
                    assert_eq!(
                        bits(&world),
                        bits(&world_inertia(x, &body.inertia)),
                        "{name} {i}"
                    );
                    let glam = articula_spatial::SpatialInertia {
                        mass: body.inertia.mass,
                        h: x.e * body.inertia.h,
                        ibar: x.e * body.inertia.ibar * x.e.transpose(),
                    };
                    assert_eq!(bits(&rotated), bits(&glam), "{name} {i}");
                }
            }
        }
    }
}
