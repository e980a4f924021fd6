//! The Newton–Euler residual `τ − ID(q, q̇, q̈)` of a candidate `q̈`, shared by DCA's and
//! CRBA's refinement, ABA's floating-base refinement and inverse dynamics.

use crate::Data;
use articula_model::Model;
use articula_spatial::{SpatialForce, SpatialMotion, SpatialTransform};
use glam::DVec3;

/// The inputs of [`rnea_residual`]: the kinematics of a `Data` (borrowed field by field, so
/// that its scratch buffers can be lent at the same time) and the joint forces and accelerations.
pub(crate) struct RneaInput<'a> {
    /// Per body, `X_{C←body}` (its pose in the computation frame).
    pub x: &'a [SpatialTransform],
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

/// `r = τ − ID(q, q̇, q̈)` by the recursive Newton–Euler algorithm in the computation frame,
/// with `a` and `f` per-body scratch: aᵢ = a_parent + cᵢ + Sᵢ q̈ᵢ (a_0 = −a_g),
/// fᵢ = Iᵢ aᵢ + vᵢ ×* Iᵢ vᵢ − f_ext,i accumulated from the leaves to the root, rⱼ = τⱼ − Sⱼᵀ fᵢ.
/// It never forms the joint-space inertia H, so it is accurate to rounding in the joint forces
/// (the residual of CRBA's, ABA's and DCA's refinements). Returns the largest `|τⱼ|` or
/// `|Sⱼᵀ fᵢ|` met (the scale of the joint forces) and the largest `|rⱼ|`.
///
/// Each body's `Iᵢ aᵢ + vᵢ ×* Iᵢ vᵢ` is formed about the body's own origin ([`body_force`]),
/// not about the computation origin: there the rotational inertia is `m |p|²` large for a body
/// at distance `|p|`, and the force of a light body spinning fast about a nearby axis is the
/// difference of such terms (icub's 1.3 kg head, 0.4 mm from its neck axis and 0.5 m from the
/// base, lost ~1e-9 of q̈ to it). About the body origin only the lever arms carry `|p|`, and
/// their rounding is `|p|` times smaller.
pub(crate) fn rnea_residual(
    model: &Model,
    k: &RneaInput,
    a: &mut [SpatialMotion],
    f: &mut [SpatialForce],
    r: &mut [f64],
) -> (f64, f64) {
    let a0 = SpatialMotion::new(DVec3::ZERO, -k.gravity);
    for (i, body) in model.bodies.iter().enumerate() {
        let mut ai = body.parent.map_or(a0, |p| a[p]) + k.c[i];
        if let Some(qdd) = k.qdd {
            for j in body.v_offset..body.v_offset + body.nv {
                ai += k.s[j] * qdd[j];
            }
        }
        a[i] = ai;
        f[i] = body_force(&k.x[i], &body.inertia, ai, k.v[i]) - crate::inputs::f_ext_of(k.f_ext, i);
    }
    let (mut scale, mut rmax) = (0.0f64, 0.0f64);
    for (i, body) in model.bodies.iter().enumerate().rev() {
        let fi = f[i];
        for j in body.v_offset..body.v_offset + body.nv {
            let mut sf = k.s[j].dot(fi);
            // The armature's force A q̈ (docs/loading.md#armature-and-damping).
            if let (Some(qdd), Some(a)) = (k.qdd, k.armature.get(j)) {
                sf += a * qdd[j];
            }
            r[j] = k.tau[j] - sf;
            scale = scale.max(sf.abs()).max(k.tau[j].abs());
            rmax = rmax.max(r[j].abs());
        }
        if let Some(p) = body.parent {
            f[p] += fi;
        }
    }
    (scale, rmax)
}

/// `I a + v ×* I v` about the computation origin for a body of inertia `inertia` (body frame,
/// about its origin) at `x = X_{C←body}`, with `a` and `v` about the computation origin: formed
/// about the body origin `p` (`I_P = rot(E) I`, `m_P = m_O + [0; w × p]`) and moved back
/// (`n_O = n_P + p × f`).
#[inline]
fn body_force(
    x: &SpatialTransform,
    inertia: &articula_spatial::SpatialInertia,
    a: SpatialMotion,
    v: SpatialMotion,
) -> SpatialForce {
    let (rotated, _) = crate::kinematics::rotated_and_world_inertia(x, inertia);
    let p = -(x.e * x.r);
    let at = |m: SpatialMotion| SpatialMotion::new(m.w, m.v + m.w.cross(p));
    let (ap, vp) = (at(a), at(v));
    let fp = rotated.mul_motion(ap) + vp.cross_force(rotated.mul_motion(vp));
    SpatialForce::new(fp.n + p.cross(fp.f), fp.f)
}
