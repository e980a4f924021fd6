//! Joint dynamics beyond the rigid bodies: armature (rotor inertia), viscous damping and
//! springs, per degree of freedom ([`DofDynamics`], `docs/loading.md#armature-and-damping`).

use crate::Model;

/// The dynamics a joint adds to its degrees of freedom, as read from the model file
/// (URDF `<dynamics damping>`; MJCF `armature`, `damping`, `stiffness`, `springref`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointDynamics {
    /// Added to the joint-space inertia's diagonal at each of the joint's degrees of freedom
    /// (kg·m² or kg): the reflected inertia of a motor's rotor, MuJoCo's `armature`.
    pub armature: f64,
    /// Viscous damping `b` (N·m·s/rad or N·s/m): passive force `−b q̇`.
    pub damping: f64,
    /// Spring stiffness `k` (N·m/rad or N/m): passive force `−k (q − q_spring)`.
    pub stiffness: f64,
    /// The coordinate at which the spring is at rest, `q_spring` (rad or m).
    pub spring_ref: f64,
}

impl JointDynamics {
    /// Whether every term is zero (a rigid, frictionless joint).
    pub fn is_zero(&self) -> bool {
        *self == JointDynamics::default()
    }
}

/// Armature, damping and springs of every degree of freedom of a [`Model`], in `qd` order.
/// Each vector is empty when no joint of the model has that term (then nothing is added and
/// every algorithm runs exactly as without it), else has length [`Model::nv`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DofDynamics {
    /// Armature per degree of freedom (added to the diagonal of the joint-space inertia).
    pub armature: Vec<f64>,
    /// Viscous damping per degree of freedom.
    pub damping: Vec<f64>,
    /// Spring stiffness per degree of freedom (1-DOF joints only).
    pub stiffness: Vec<f64>,
    /// Spring rest coordinate per degree of freedom (1-DOF joints only).
    pub spring_ref: Vec<f64>,
}

impl DofDynamics {
    /// Per-DOF vectors from each joint's dynamics, `(v_offset, nv, dynamics)`; a vector stays
    /// empty when its term is zero everywhere.
    pub(crate) fn from_joints(nv: usize, joints: &[(usize, usize, JointDynamics)]) -> DofDynamics {
        let spread = |f: fn(&JointDynamics) -> f64| {
            if joints.iter().all(|(_, _, d)| f(d) == 0.0) {
                return Vec::new();
            }
            let mut out = vec![0.0; nv];
            for &(vo, n, ref d) in joints {
                out[vo..vo + n].fill(f(d));
            }
            out
        };
        let stiffness = spread(|d| d.stiffness);
        let spring_ref = if stiffness.is_empty() {
            Vec::new()
        } else {
            let mut r = spread(|d| d.spring_ref);
            r.resize(nv, 0.0);
            r
        };
        DofDynamics {
            armature: spread(|d| d.armature),
            damping: spread(|d| d.damping),
            stiffness,
            spring_ref,
        }
    }

    /// Whether the model has armature anywhere.
    pub fn has_armature(&self) -> bool {
        !self.armature.is_empty()
    }

    /// Whether the model has damping or springs anywhere (a passive force to apply).
    pub fn has_passive(&self) -> bool {
        !self.damping.is_empty() || !self.stiffness.is_empty()
    }
}

impl Model {
    /// The passive joint forces at `(q, q̇)`, like MuJoCo's `qfrc_passive`: for every degree of
    /// freedom `−b q̇ − k (q − q_spring)` (damping `b`, stiffness `k`; springs on 1-DOF joints
    /// only), written to `out` (length [`Model::nv`]). All zero for a model without damping
    /// or springs. Stepping applies them (damping implicitly); `forward_dynamics` with an
    /// explicit `τ` does not (it stays the rigid-body map): add them to `τ` to get MuJoCo's
    /// `qacc_smooth`.
    pub fn passive_forces(&self, q: &[f64], qd: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        let d = &self.dynamics;
        for (i, b) in d.damping.iter().enumerate() {
            out[i] -= b * qd[i];
        }
        if d.stiffness.is_empty() {
            return;
        }
        for p in self.coordinate_parts() {
            if p.nv() == 1 && p.nq() == 1 {
                let i = p.v_offset;
                out[i] -= d.stiffness[i] * (q[p.q_offset] - d.spring_ref[i]);
            }
        }
    }
}
