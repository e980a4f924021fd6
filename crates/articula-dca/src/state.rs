//! The state of an articulated body and the inputs of one dynamics call.

use articula_model::Model;
use articula_spatial::SpatialForce;

/// Joint positions, velocities and forces, and external forces on the bodies.
///
/// `q` and `qd` follow the model's coordinate order (`docs/conventions.md`); `tau` has one
/// entry per degree of freedom (like `qd`). `f_ext[i]` is the external wrench on body `i`,
/// in world coordinates about the world origin (use [`crate::Data::point_force`] for a force at
/// a point).
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    /// Positions (length `model.nq`).
    pub q: Vec<f64>,
    /// Velocities (length `model.nv`).
    pub qd: Vec<f64>,
    /// Joint forces/torques (length `model.nv`).
    pub tau: Vec<f64>,
    /// External wrenches per body, world frame (length `model.bodies.len()`).
    pub f_ext: Vec<SpatialForce>,
}

impl State {
    /// The model at rest in its neutral configuration, no forces.
    pub fn neutral(model: &Model) -> State {
        State {
            q: model.neutral_q(),
            qd: vec![0.0; model.nv],
            tau: vec![0.0; model.nv],
            f_ext: vec![SpatialForce::ZERO; model.bodies.len()],
        }
    }

    /// A reproducible random state: each joint's [`articula_model::JointKind::random_q`]
    /// (angles in [-1.2, 1.2] rad, clear of the gimbal lock of composed 3-axis joints at ±π/2
    /// where every method loses digits; displacements in [-0.2, 0.2] m; random orientations
    /// for ball and floating joints), velocities in [-2, 2], torques in
    /// [-tau_scale, tau_scale].
    /// No external forces.
    pub fn random(model: &Model, seed: u64, tau_scale: f64) -> State {
        let mut rng = SplitMix64(seed);
        let mut s = State::neutral(model);
        for (_, part) in model.joint_parts() {
            let q = &mut s.q[part.q_offset..part.q_offset + part.nq()];
            part.kind.random_q(q, &mut |lo, hi| rng.uniform(lo, hi));
        }
        for x in s.qd.iter_mut() {
            *x = rng.uniform(-2.0, 2.0);
        }
        for x in s.tau.iter_mut() {
            *x = rng.uniform(-tau_scale, tau_scale);
        }
        s
    }

    /// Random external wrenches on every body (components in [-scale, scale]).
    pub fn randomize_forces(&mut self, seed: u64, scale: f64) {
        let mut rng = SplitMix64(seed ^ 0x9e37_79b9_7f4a_7c15);
        for f in self.f_ext.iter_mut() {
            let mut a = [0.0; 6];
            for x in a.iter_mut() {
                *x = rng.uniform(-scale, scale);
            }
            *f = SpatialForce::from_array(a);
        }
    }
}

/// A tiny deterministic generator (SplitMix64) for reproducible states without a dependency:
/// the one [`State::random`] draws from, for callers that want the same stream.
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
}
