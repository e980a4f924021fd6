//! DCA against ABA on long chains (the bodies of `models/chainN.urdf`): 20,000 links at seeded
//! random states, and the straight chain — DCA's hardest case — at 4,000 links.
//!
//! The straight chain is where DCA's inverse-inertia (Φ) recursion loses accuracy. Its joints
//! all turn about y, so out of the x–z plane every subassembly is a rigid rod, whose Φ in those
//! directions (rotation about x, translation along y) must shrink like N⁻³ (rotation) as it
//! grows, while the leaves' Φ stays ~1/I_link. Joining two rigid rods, `Φ^C_11 = Φ^A_11 − Φ^A_1j
//! V Φ^A_j1` carries A's rounding-level "fake flexibility" `Φ^A_11 − Φ^A_1j (Φ^A_jj)⁻¹ Φ^A_j1`
//! (exactly 0 for a rigid body) into C unattenuated, while the true value drops 8× per level:
//! the relative error of those entries grows ~16× per doubling (N⁴). Reproduced in isolation
//! on the 2×2 rigid-rod recursion (rotation x, translation y): relative error 3.7e-12 at 16
//! links, 9.3e-10 at 64, 2.2e-7 at 256, 4.9e-5 at 1024, 1.4e-2 at 4096, 3.5 at 16384. On the
//! ground side the exact Φ is zero in those directions and the same residue accumulates. In
//! the straight chain `Φ^A_jj + Φ^B_jj` stops being positive definite at the root join of a
//! long enough chain (DCA then returns `DynamicsError::Singular`; with the current join basis a
//! chain tilted 0.3 rad at its first joint solves at 8,000 links and stops at 10,000, and one
//! hanging exactly straight down solves at 100,000); a crumpled chain has lever arms ~√N instead of N
//! and 100,000 links still agree to ~3e-9 (this file's `difference` at 100,000 links, too slow
//! for a test). Measured here (DCA vs ABA, max |Δq̈| / max |q̈|): straight
//! 1,000 links 1.9e-9, 2,000 8.1e-9, 4,000 4.6e-8; random states at 20,000 links 1.3e-10 and
//! 8.0e-10.

use articula_dca::{forward_dynamics_slices, Data, Method, State};
use articula_model::Model;
use articula_testkit::chain;

/// max |DCA − ABA| / max |q̈| on `s`.
fn difference(model: &Model, data: &mut Data, s: &State) -> f64 {
    let mut run = |m| {
        forward_dynamics_slices(model, data, &s.q, &s.qd, &s.tau, &[], m)
            .unwrap()
            .to_vec()
    };
    let (dca, aba) = (run(Method::Dca), run(Method::Aba));
    let scale = aba.iter().fold(1.0f64, |m, x| m.max(x.abs()));
    let diff = aba
        .iter()
        .zip(&dca)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    diff / scale
}

#[test]
fn chain_20000_random_states_agree() {
    let model = chain(20_000);
    let mut data = Data::new(&model);
    for seed in [1, 2] {
        let d = difference(&model, &mut data, &State::random(&model, seed, 1.0));
        eprintln!("chain 20,000 links, seed {seed}: DCA vs ABA {d:.3e}");
        assert!(d < 3e-9, "seed {seed}: {d:e}");
    }
}

#[test]
fn straight_chain_4000_agrees() {
    let model = chain(4_000);
    let mut data = Data::new(&model);
    let mut s = State::random(&model, 7, 1.0);
    s.q.iter_mut().for_each(|x| *x = 0.0);
    let d = difference(&model, &mut data, &s);
    eprintln!("straight chain 4,000 links, moving: DCA vs ABA {d:.3e}");
    assert!(d < 2e-7, "{d:e}");
}
