//! The Newton–Euler residual `τ − ID(q, q̇, q̈)` of a candidate `q̈`, shared by DCA's and
//! CRBA's refinement, ABA's floating-base refinement and inverse dynamics.

use crate::aba::{force_back, motion_at};
use crate::kinematics::FkPlan;
use crate::Data;
use articula_model::Model;
use articula_spatial::{SpatialForce, SpatialMotion, SpatialTransform};
use glam::DVec3;

/// The inputs of [`rnea_residual`]: the kinematics of a `Data` (borrowed field by field, so
/// that its scratch buffers can be lent at the same time) and the joint forces and accelerations.
pub(crate) struct RneaInput<'a> {
    /// Per body, `X_{C←body}` (its pose in the computation frame).
    pub x: &'a [SpatialTransform],
    /// Per body, its kinematic fast path (for the arms and the local `S`).
    pub fk_plan: &'a [FkPlan],
    pub v: &'a [SpatialMotion],
    pub c: &'a [SpatialMotion],
    pub s: &'a [SpatialMotion],
    pub gravity: DVec3,
    pub tau: &'a [f64],
    pub f_ext: &'a [SpatialForce],
    /// `None`: q̈ = 0 (then `r = τ − C`, the bias forces of CRBA).
    pub qdd: Option<&'a [f64]>,
    /// Per degree of freedom, the armature whose force `a q̈` joins `ID` (empty: none).
    pub armature: &'a [f64],
}

impl<'a> RneaInput<'a> {
    /// The kinematics of `data` (when none of its buffers is lent at the same time).
    pub(crate) fn of(
        data: &'a Data,
        tau: &'a [f64],
        f_ext: &'a [SpatialForce],
        qdd: Option<&'a [f64]>,
    ) -> RneaInput<'a> {
        RneaInput {
            x: &data.x,
            fk_plan: &data.fk_plan,
            v: &data.v,
            c: &data.c,
            s: &data.s,
            gravity: data.gravity,
            tau,
            f_ext,
            qdd,
            armature: &data.armature,
        }
    }
}

/// `r = τ − ID(q, q̇, q̈)` by the recursive Newton–Euler algorithm, with `a` and `f` per-body
/// scratch: aᵢ = a_parent + cᵢ + Sᵢ q̈ᵢ (a_0 = −a_g), fᵢ = Iᵢ aᵢ + vᵢ ×* Iᵢ vᵢ − f_ext,i
/// accumulated from the leaves to the root, rⱼ = τⱼ − Sⱼᵀ fᵢ. It never forms the joint-space
/// inertia H, so it is accurate to rounding in the joint forces (the residual of CRBA's, ABA's
/// and DCA's refinements). Returns the largest `|τⱼ|` or `|Sⱼᵀ fᵢ|` met (the scale of the joint
/// forces) and the largest `|rⱼ|`.
///
/// Every quantity is taken as ABA takes it (`aba.rs`): world axes about each body's own origin
/// `pᵢ`, `a` moved forward and `f` moved back by the short arm `pᵢ − p_parent`
/// ([`crate::kinematics::arm`]). About the computation origin instead, a body at distance `|p|`
/// has a rotational inertia `m |p|²` and a joint torque is the difference of moments `|p|`
/// times larger than itself: icub's 1.3 kg head (0.4 mm from its neck axis, 0.5 m from the
/// base) lost ~1e-9 of q̈ to it, and on a tilted chain 2 km long (20,000 links hanging at
/// rest) the residual's rounding stalled DCA's refinement at 5e-7 of q̈.
pub(crate) fn rnea_residual(
    model: &Model,
    k: &RneaInput,
    a: &mut [SpatialMotion],
    f: &mut [SpatialForce],
    r: &mut [f64],
) -> (f64, f64) {
    let a0 = SpatialMotion::new(DVec3::ZERO, -k.gravity);
    for (i, body) in model.bodies.iter().enumerate() {
        let x = &k.x[i];
        let p = -(x.e * x.r);
        let arm = crate::kinematics::arm(k.fk_plan[i], k.x, body.parent.unwrap_or(usize::MAX), p);
        let mut ai = motion_at(body.parent.map_or(a0, |q| a[q]), arm) + motion_at(k.c[i], p);
        if let Some(qdd) = k.qdd {
            for j in body.v_offset..body.v_offset + body.nv {
                ai += local_s(k, i, j, p) * qdd[j];
            }
        }
        a[i] = ai;
        let (rotated, _) = crate::kinematics::rotated_and_world_inertia(x, &body.inertia);
        let v = motion_at(k.v[i], p);
        f[i] = rotated.mul_motion(ai) + v.cross_force(rotated.mul_motion(v))
            - force_back(crate::inputs::f_ext_of(k.f_ext, i), -p);
    }
    let (mut scale, mut rmax) = (0.0f64, 0.0f64);
    for (i, body) in model.bodies.iter().enumerate().rev() {
        let fi = f[i];
        let x = &k.x[i];
        let p = -(x.e * x.r);
        for j in body.v_offset..body.v_offset + body.nv {
            let mut sf = local_s(k, i, j, p).dot(fi);
            // The armature's force A q̈ (docs/loading.md#armature-and-damping).
            if let (Some(qdd), Some(a)) = (k.qdd, k.armature.get(j)) {
                sf += a * qdd[j];
            }
            r[j] = k.tau[j] - sf;
            scale = scale.max(sf.abs()).max(k.tau[j].abs());
            rmax = rmax.max(r[j].abs());
        }
        if let Some(q) = body.parent {
            let arm = crate::kinematics::arm(k.fk_plan[i], k.x, q, p);
            f[q] += force_back(fi, arm);
        }
    }
    (scale, rmax)
}

/// Column `j` of body `i`'s `S` about its origin `p`: `[ω; 0]` exactly for a revolute axis
/// through it (as in `aba.rs`), else moved from the computation origin.
#[inline]
fn local_s(k: &RneaInput, i: usize, j: usize, p: DVec3) -> SpatialMotion {
    match k.fk_plan[i] {
        FkPlan::AxisRevolute { .. } => SpatialMotion::new(k.s[j].w, DVec3::ZERO),
        FkPlan::General => motion_at(k.s[j], p),
    }
}
