//! The hybrid step's reduced ABA compiled with fused multiply–adds (on a CPU with AVX2 and
//! FMA) and the portable compilation give the same accelerations and velocities to rounding:
//! two steps from the same state (a whole-body selection with its locking impulses, then a
//! hybrid step), on every bundled model (fixed and floating base), at several budgets, with
//! and without external forces. With every joint active, the fused hybrid step's `q̈` also
//! equals articula-dca's ABA on the same state. Where the CPU has FMA the two compilations
//! must differ somewhere, which shows that the fused one ran.

use crate::{Adaptive, Settings};
use articula_dca::{forward_dynamics_slices, Data, Method, State};

use articula_testkit::bundled_with as load;

/// A workspace re-selecting through the caches (what these tests exercise; the library's
/// default route is `Reselection::ExactSolve`).
fn caches(mut ad: Adaptive) -> Adaptive {
    ad.set_reselection(crate::Reselection::Caches);
    ad
}

/// max |x − y| / max(1, max |x|).
fn rel(x: &[f64], y: &[f64]) -> f64 {
    let scale = x.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    x.iter()
        .zip(y)
        .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()))
        / scale
}

#[test]
fn fused_and_portable_reduced_aba_agree() {
    let mut differ = false;
    for name in ["chain10", "chain300", "humanoid", "plant", "rope"] {
        // The 300-link chain's solves are ill-conditioned: its roundings differ by up to
        // ~5e-10 (relative) after an impulse and a step; the others by less than 1e-11.
        let tol = if name == "chain300" { 2e-9 } else { 1e-10 };
        for floating in [false, true] {
            let model = load(name, floating);
            // Budgets in degrees of freedom; `n`: every joint.
            let n = model.nv;
            for budget in [1, 5, n / 3, n] {
                for seed in 0..3u64 {
                    let mut s = State::random(&model, seed, 1.0);
                    if seed == 1 {
                        s.randomize_forces(seed, 0.5);
                    }
                    let run = |fused: bool| {
                        let mut ad = caches(Adaptive::new(
                            &model,
                            Settings {
                                budget: Some(budget),
                                reselect_every: 10,
                                ..Settings::default()
                            },
                        ));
                        ad.set_fused(fused);
                        let mut st = s.clone();
                        ad.step(&model, &mut st, 1e-4).unwrap();
                        let before = st.clone();
                        ad.step(&model, &mut st, 1e-4).unwrap();
                        (ad.qdd().to_vec(), st.qd, before)
                    };
                    let (a1, v1, _) = run(false);
                    let (a2, v2, before) = run(true);
                    let case = format!("{name} floating={floating} budget {budget} seed {seed}");
                    assert!(rel(&a1, &a2) <= tol, "{case} qdd: {:e}", rel(&a1, &a2));
                    assert!(rel(&v1, &v2) <= tol, "{case} qd: {:e}", rel(&v1, &v2));
                    differ |= a1 != a2 || v1 != v2;
                    if budget >= n {
                        let mut data = Data::new(&model);
                        let b = &before;
                        let exact = forward_dynamics_slices(
                            &model,
                            &mut data,
                            &b.q,
                            &b.qd,
                            &b.tau,
                            &b.f_ext,
                            Method::Aba,
                        )
                        .unwrap();
                        assert!(
                            rel(exact, &a2) <= tol,
                            "{case} vs ABA: {:e}",
                            rel(exact, &a2)
                        );
                    }
                }
            }
        }
    }
    assert_eq!(differ, articula_spatial::numerics::fused_available());
}
