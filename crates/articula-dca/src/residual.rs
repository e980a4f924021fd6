//! The Newton–Euler residual `τ − ID(q, q̇, q̈)` of a candidate `q̈`, shared by DCA's and
//! CRBA's refinement, ABA's floating-base refinement and inverse dynamics.

use crate::Data;
use articula_model::Model;
use articula_spatial::{SpatialForce, SpatialInertia, SpatialMotion};
use glam::DVec3;

/// The inputs of [`rnea_residual`]: the kinematics of a `Data` (borrowed field by field, so
/// that its scratch buffers can be lent at the same time) and the joint forces and accelerations.
pub(crate) struct RneaInput<'a> {
    pub inertia: &'a [SpatialInertia],
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
            inertia: &data.inertia,
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
        let (inertia, v) = (&k.inertia[i], k.v[i]);
        f[i] = inertia.mul_motion(ai) + v.cross_force(inertia.mul_motion(v))
            - crate::inputs::f_ext_of(k.f_ext, i);
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
