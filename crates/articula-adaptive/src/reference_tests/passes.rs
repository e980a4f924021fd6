//! Steps between re-selections through the hierarchical state (O(active region)) against
//! whole-body kinematics and composites (O(n)), the reference only tests can select.

use crate::{Adaptive, Settings};
use articula_dca::State;
use articula_testkit::bundled_with as load;

/// A workspace re-selecting through the caches (what these tests exercise; the library's
/// default route is `Reselection::ExactSolve`).
fn caches(mut ad: Adaptive) -> Adaptive {
    ad.set_reselection(crate::Reselection::Caches);
    ad
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

#[test]
fn hierarchical_steps_match_whole_body_passes() {
    // Budget 1 on a fixed base: a reduced tree of one joint on a grounded cluster, which the
    // hybrid step solves in closed form (`one_joint`).
    for (name, floating, budget) in [
        ("chain100", false, 12),
        ("chain100", false, 1),
        ("humanoid", true, 10),
        ("plant", false, 20),
        ("plant", false, 1),
        ("rope", true, 15),
    ] {
        for passive in [false, true] {
            let model = with_passive(load(name, floating), passive);
            passes_match(&model, name, budget);
        }
    }
}

/// Armature, damping and springs on every joint but a floating base's (when `on`): the
/// whole-body passes' joins and the hierarchical step's reduced tree both see them.
fn with_passive(mut model: articula_model::Model, on: bool) -> articula_model::Model {
    if on {
        let base = if model.floating_base { 6 } else { 0 };
        let per_dof = |x: f64| -> Vec<f64> {
            (0..model.nv)
                .map(|i| {
                    if i < base {
                        0.0
                    } else {
                        x * (1.0 + (i % 3) as f64)
                    }
                })
                .collect()
        };
        let (a, b, k) = (per_dof(0.01), per_dof(0.05), per_dof(0.5));
        model.dynamics.armature = a;
        model.dynamics.damping = b;
        model.dynamics.stiffness = k;
        model.dynamics.spring_ref = vec![0.1; model.nv];
    }
    model
}

fn passes_match(model: &articula_model::Model, name: &str, budget: usize) {
    let model = model.clone();
    {
        let mut s0 = State::random(&model, 77, 0.0);
        // Light forces: the rope's 3-gram links reach 1e9 rad/s² under the usual ones.
        s0.randomize_forces(78, 0.01);
        let settings = Settings {
            budget: Some(budget),
            reselect_every: 7,
            ..Settings::default()
        };
        let (mut fast, mut slow) = (
            caches(Adaptive::new(&model, settings.clone())),
            caches(Adaptive::new(&model, settings)),
        );
        slow.set_full_passes(true);
        // The same (whole-body) re-selections on both sides: this compares the steps between
        // them; tests/cache.rs compares the cached re-selection (its locking impulses differ
        // from these by rounding, ~1e-11 relative in q̇).
        fast.set_cached_reselection(false);
        let (mut a, mut b) = (s0.clone(), s0);
        for k in 0..40 {
            let ra = fast.step(&model, &mut a, 1e-3).unwrap();
            let rb = slow.step(&model, &mut b, 1e-3).unwrap();
            assert_eq!(ra.active_dofs, rb.active_dofs, "{name} step {k}");
            let da = max_diff(fast.qdd(), slow.qdd());
            assert!(
                da <= 1e-10 * max_abs(slow.qdd()).max(1.0),
                "{name} step {k}: q̈ {da:e}"
            );
            let (dq, dv) = (max_diff(&a.q, &b.q), max_diff(&a.qd, &b.qd));
            // q̇ and q differ by h q̈ and h² q̈ of the difference above (h = 1e-3).
            assert!(
                dq <= 1e-12 + 2e-6 * da && dv <= 1e-12 * (1.0 + max_abs(&b.qd)) + 2e-3 * da,
                "{name} step {k}: {dq:e} {dv:e}"
            );
            // The same inputs for the next step (a chaotic rope would amplify round-off).
            a = b.clone();
        }
    }
}
