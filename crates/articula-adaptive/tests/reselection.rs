//! The two re-selection routes give the same hybrid bodies, and a budget that covers every
//! joint steps the whole body exactly (docs/adaptive.md#cost).

use articula_adaptive::{Adaptive, Reselection, Settings};
use articula_dca::{forward_dynamics_slices, Data, Integrator, Method, State};
use articula_testkit::bundled_with as load;

/// A workspace re-selecting through the caches (what these tests exercise; the library's
/// default route is `Reselection::ExactSolve`).
fn caches(mut ad: Adaptive) -> Adaptive {
    ad.set_reselection(articula_adaptive::Reselection::Caches);
    ad
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// Budget = every internal DOF: semi-implicit Euler steps equal articula-dca's (momentum
/// projection off), the selection reports no error and the total metric is `Σ q̈²` of the
/// exact accelerations at the step's start. With one DOF less the step differs (the check can
/// fail).
#[test]
fn full_budget_steps_are_exact_dca_steps() {
    for (name, floating) in [("chain30", false), ("chain30", true), ("humanoid", true)] {
        let model = load(name, floating);
        let internal = model.nv - if floating { 6 } else { 0 };
        let mut start = State::random(&model, 5, 1.5);
        start.randomize_forces(2, 1.0);
        let dt = 1e-3;
        let (mut e, mut a, mut short) = (start.clone(), start.clone(), start.clone());
        let mut data = Data::new(&model);
        data.momentum_projection = false;
        let settings = |b| Settings {
            budget: Some(b),
            ..Settings::default()
        };
        let mut ad = caches(Adaptive::new(&model, settings(internal)));
        let mut ad_short = caches(Adaptive::new(&model, settings(internal - 1)));
        for k in 0..20 {
            let exact = forward_dynamics_slices(
                &model,
                &mut data,
                &e.q,
                &e.qd,
                &e.tau,
                &e.f_ext,
                Method::Dca,
            )
            .unwrap()
            .to_vec();
            let total: f64 = exact.iter().map(|x| x * x).sum();
            articula_dca::step(
                &model,
                &mut data,
                &mut e,
                Method::Dca,
                Integrator::SemiImplicitEuler,
                dt,
            )
            .unwrap();
            let r = ad.step(&model, &mut a, dt).unwrap();
            assert_eq!(r.active_dofs, model.nv, "{name} step {k}");
            let sel = ad.selection();
            assert_eq!(sel.predicted_error, 0.0);
            assert!(
                (sel.total_metric - total).abs() <= 1e-9 * total,
                "{name} step {k}: total metric {} vs {total}",
                sel.total_metric
            );
            ad_short.step(&model, &mut short, dt).unwrap();
        }
        let (dq, dv) = (max_diff(&a.q, &e.q), max_diff(&a.qd, &e.qd));
        assert!(dq < 1e-10 && dv < 1e-9, "{name}: q {dq:e}, q̇ {dv:e}");
        assert!(max_diff(&short.q, &e.q) > 1e3 * dq.max(1e-13), "{name}");
    }
}

/// The exact-solve re-selection chooses the hybrid bodies the cached one chooses: side by side
/// for 60 steps under gravity with torques and forces, re-selecting every 1 and 3 steps, the
/// same active DOFs and predicted errors every step and the same trajectory to 1e-9.
#[test]
fn exact_solve_reselection_equals_cached_reselection() {
    for (name, floating, budget) in [
        ("chain100", false, 12),
        ("chain300", false, 50),
        ("humanoid", true, 8),
    ] {
        let model = load(name, floating);
        for every in [1, 3] {
            let mut start = State::random(&model, 9, 1.0);
            start.qd.fill(0.0);
            let settings = Settings {
                budget: Some(budget),
                reselect_every: every,
                ..Settings::default()
            };
            let mut cached = caches(Adaptive::new(&model, settings.clone()));
            let mut exact = caches(Adaptive::new(&model, settings));
            exact.set_reselection(Reselection::ExactSolve);
            assert_eq!(cached.reselection(), Reselection::Caches);
            let (mut a, mut b) = (start.clone(), start.clone());
            for k in 0..60 {
                let ra = cached.step(&model, &mut a, 1e-3).unwrap();
                let rb = exact.step(&model, &mut b, 1e-3).unwrap();
                assert_eq!(
                    ra.active_dofs, rb.active_dofs,
                    "{name} every {every} step {k}"
                );
                assert_eq!(ra.reselected, rb.reselected);
                let (pa, pb) = (ra.predicted_error, rb.predicted_error);
                let scale = cached.selection().total_metric.max(1e-300);
                assert!(
                    (pa - pb).abs() <= 1e-9 * scale,
                    "{name} every {every} step {k}: predicted {pa:e} vs {pb:e}"
                );
            }
            let dq = max_diff(&a.q, &b.q);
            assert!(dq < 1e-9, "{name} every {every}: q {dq:e}");
        }
    }
}

/// The balanced period: `⌈2n / budget⌉` internal DOFs, at most 50, 1 when nothing is locked.
#[test]
fn balanced_period_follows_the_budget() {
    let chain = load("chain300", false);
    assert_eq!(Settings::balanced_period(&chain, Some(50)), 12);
    assert_eq!(Settings::balanced_period(&chain, Some(10)), 50);
    assert_eq!(Settings::balanced_period(&chain, Some(0)), 50);
    assert_eq!(Settings::balanced_period(&chain, Some(300)), 1);
    assert_eq!(Settings::balanced_period(&chain, None), 1);
    // A floating base's six DOFs are free: the humanoid's internal ones count.
    let humanoid = load("humanoid", true);
    let internal = humanoid.nv - 6;
    assert_eq!(
        Settings::balanced_period(&humanoid, Some(internal)),
        1,
        "every internal DOF"
    );
    assert_eq!(
        Settings::balanced_period(&humanoid, Some(4)),
        (2 * internal).div_ceil(4) as u64
    );
}

/// `Settings::default()` re-selects at the balanced period of the workspace's model and budget
/// (`Settings::BALANCED`), what `articula simulate` does without `--reselect-every`: on the
/// 300-link chain at budget 50 the steps that re-select are 0, 12, 24, …; an explicit
/// `reselect_every` still wins.
#[test]
fn default_settings_reselect_at_the_balanced_period() {
    let model = load("chain300", false);
    assert_eq!(Settings::default().reselect_every, Settings::BALANCED);
    // The route of the command line too: one exact solve per re-selection.
    assert_eq!(
        Adaptive::new(&model, Settings::default()).reselection(),
        Reselection::ExactSolve
    );
    let mut s = State::random(&model, 9, 0.3);
    s.f_ext.clear();
    let run = |settings: Settings, s: &mut State| -> Vec<u64> {
        let mut ad = caches(Adaptive::new(&model, settings));
        (0..40u64)
            .filter(|_| ad.step(&model, s, 1e-4).unwrap().reselected)
            .collect()
    };
    let balanced = Settings {
        budget: Some(50),
        ..Settings::default()
    };
    assert_eq!(run(balanced, &mut s.clone()), [0, 12, 24, 36]);
    let every7 = Settings {
        budget: Some(50),
        reselect_every: 7,
        ..Settings::default()
    };
    assert_eq!(run(every7, &mut s.clone()), [0, 7, 14, 21, 28, 35]);
}
