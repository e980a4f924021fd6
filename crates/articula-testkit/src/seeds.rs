//! The state of the adaptive benchmarks' seeds table (`cargo bench -p articula-adaptive
//! --bench adaptive`, `cargo xtask speedup seeds`): a random configuration at rest with
//! constant external forces on evenly spread bodies.

use articula_dca::{forward_kinematics, Data, State};
use articula_model::Model;
use articula_spatial::SpatialForce;
use glam::DVec3;

/// A random configuration (seed 42) at rest with `forces` constant external forces on evenly
/// spread bodies (body `k n / forces` for `k < forces`), each a point force of direction
/// `(1, sin k, cos k)` at its body's origin.
pub fn seeded_state(model: &Model, forces: usize) -> State {
    let mut s = State::random(model, 42, 0.0);
    s.qd.fill(0.0);
    let mut data = Data::new(model);
    forward_kinematics(model, &s.q, &s.qd, &mut data).expect("a random state is finite and sized");
    let n = model.bodies.len();
    for k in 0..forces.min(n) {
        let body = (k * n) / forces.min(n);
        let dir = DVec3::new(1.0, (k as f64).sin(), (k as f64).cos());
        s.f_ext[body] = data.point_force(body, DVec3::ZERO, dir);
    }
    s
}

/// The non-zero wrenches of a dense external-force array as `(body, wrench)` pairs: how the
/// adaptive runs take their forces (`Adaptive::step_with_forces`: no O(n) scan of a dense
/// array per step).
pub fn force_list(f_ext: &[SpatialForce]) -> Vec<(usize, SpatialForce)> {
    f_ext
        .iter()
        .enumerate()
        .filter(|(_, f)| **f != SpatialForce::ZERO)
        .map(|(i, f)| (i, *f))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forces_sit_on_evenly_spread_bodies() {
        let model = crate::chain(300);
        let s = seeded_state(&model, 5);
        let bodies: Vec<usize> = force_list(&s.f_ext).iter().map(|(b, _)| *b).collect();
        assert_eq!(bodies, [0, 60, 120, 180, 240]);
        assert!(s.qd.iter().all(|&v| v == 0.0));
        // The force of the third is (1, sin 2, cos 2) and its moment is about the world origin.
        let (_, f) = force_list(&s.f_ext)[2];
        assert_eq!(f.f, DVec3::new(1.0, 2f64.sin(), 2f64.cos()));
        assert_ne!(f.n, DVec3::ZERO);
    }
}
