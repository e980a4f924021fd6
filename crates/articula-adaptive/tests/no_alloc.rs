//! A step — a cached re-selection included — allocates nothing once the workspace is warm.

use articula_adaptive::{Adaptive, Settings};
use articula_dca::State;
use articula_spatial::SpatialForce;
use articula_testkit::{count_allocations, CountingAllocator};

/// A workspace re-selecting through the caches (what these tests exercise; the library's
/// default route is `Reselection::ExactSolve`).
fn caches(mut ad: Adaptive) -> Adaptive {
    ad.set_reselection(articula_adaptive::Reselection::Caches);
    ad
}

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

#[test]
fn cached_reselection_steps_allocate_nothing() {
    let model = articula_testkit::chain(300);
    let mut s = State::random(&model, 42, 0.0);
    s.f_ext.clear();
    // Forces on locked bodies (dirty paths) and a budget that changes (caches rebuilt).
    let forces: Vec<(usize, SpatialForce)> = [17usize, 150, 290]
        .iter()
        .map(|&b| {
            (
                b,
                SpatialForce::new(glam::DVec3::ZERO, glam::DVec3::new(0.5, 0.0, 1.0)),
            )
        })
        .collect();
    for budget in [1usize, 50] {
        let mut ad = None;
        let warm = count_allocations(|| {
            let ad = ad.insert(caches(Adaptive::new(
                &model,
                Settings {
                    budget: Some(budget),
                    reselect_every: 1,
                    ..Settings::default()
                },
            )));
            for _ in 0..50 {
                ad.step_with_forces(&model, &mut s, 1e-4, &forces).unwrap();
            }
        });
        // The counter counts: the workspace and the first step's caches were allocated.
        assert!(warm > 10, "budget {budget}: {warm}");
        let ad = ad.as_mut().unwrap();
        let mut cached = 0;
        let steps = count_allocations(|| {
            for _ in 0..200 {
                let r = ad.step_with_forces(&model, &mut s, 1e-4, &forces).unwrap();
                assert!(r.reselected);
                cached += usize::from(r.nodes_touched < model.assembly.nodes.len());
            }
        });
        assert_eq!(
            cached, 200,
            "budget {budget}: every re-selection through the caches"
        );
        assert_eq!(steps, 0, "budget {budget}: allocations in 200 steps");
    }
}

/// The RK4 step too, its re-selections through the caches included, with forces on locked
/// bodies, once its buffers exist (its first call).
#[test]
fn rk4_steps_allocate_nothing() {
    use articula_dca::Integrator;
    let model = articula_testkit::chain(300);
    let mut s = State::random(&model, 43, 0.0);
    for b in [17usize, 150, 290] {
        s.f_ext[b] = SpatialForce::new(glam::DVec3::ZERO, glam::DVec3::new(0.5, 0.0, 1.0));
    }
    for (budget, every) in [(1usize, 1u64), (50, 1), (50, 4)] {
        let mut ad = None;
        let warm = count_allocations(|| {
            let ad = ad.insert(caches(Adaptive::new(
                &model,
                Settings {
                    budget: Some(budget),
                    reselect_every: every,
                    ..Settings::default()
                },
            )));
            for _ in 0..50 {
                articula_adaptive::step(&model, ad, &mut s, Integrator::Rk4, 1e-4).unwrap();
            }
        });
        assert!(warm > 10, "budget {budget}: {warm}");
        let ad = ad.as_mut().unwrap();
        let mut cached = 0;
        let steps = count_allocations(|| {
            for _ in 0..200 {
                let r = articula_adaptive::step(&model, ad, &mut s, Integrator::Rk4, 1e-4).unwrap();
                cached += usize::from(r.reselected && r.nodes_touched < model.assembly.nodes.len());
            }
        });
        assert_eq!(
            cached,
            200 / every as usize,
            "budget {budget} every {every}"
        );
        assert_eq!(
            steps, 0,
            "budget {budget} every {every}: allocations in 200 steps"
        );
    }
}

/// The exact-solve re-selection and the whole-body step of a full budget allocate nothing
/// once warm either, with forces on locked bodies.
#[test]
fn exact_solve_and_full_budget_steps_allocate_nothing() {
    let model = articula_testkit::chain(300);
    let mut s = State::random(&model, 42, 0.0);
    s.f_ext.clear();
    let forces = [(
        150usize,
        SpatialForce::new(glam::DVec3::ZERO, glam::DVec3::new(0.5, 0.0, 1.0)),
    )];
    for budget in [10usize, 300] {
        let mut ad = caches(Adaptive::new(
            &model,
            Settings {
                budget: Some(budget),
                reselect_every: 1,
                ..Settings::default()
            },
        ));
        ad.set_reselection(articula_adaptive::Reselection::ExactSolve);
        for _ in 0..20 {
            ad.step_with_forces(&model, &mut s, 1e-4, &forces).unwrap();
        }
        let steps = count_allocations(|| {
            for _ in 0..100 {
                let r = ad.step_with_forces(&model, &mut s, 1e-4, &forces).unwrap();
                assert_eq!(r.active_dofs, budget);
            }
        });
        assert_eq!(steps, 0, "budget {budget}: allocations in 100 steps");
    }
}

/// With armature, damping and springs (the passive forces' buffers, the step's armature), both
/// integrators and both re-selection routes allocate nothing once warm, and the caches of the
/// rigid subassemblies stay in use: the locked joints' passive forces do not change.
#[test]
fn steps_with_passive_forces_allocate_nothing() {
    use articula_adaptive::Reselection;
    use articula_dca::Integrator;
    let mut model = articula_testkit::chain(300);
    let per_dof = |x: f64| vec![x; model.nv];
    let (a, b, k) = (per_dof(0.02), per_dof(0.4), per_dof(3.0));
    model.dynamics.armature = a;
    model.dynamics.damping = b;
    model.dynamics.stiffness = k;
    model.dynamics.spring_ref = per_dof(0.1);
    for how in [Reselection::Caches, Reselection::ExactSolve] {
        for integrator in [Integrator::SemiImplicitEuler, Integrator::Rk4] {
            let mut s = State::random(&model, 44, 0.0);
            s.f_ext.clear();
            let mut ad = Adaptive::new(
                &model,
                Settings {
                    budget: Some(20),
                    reselect_every: 2,
                    ..Settings::default()
                },
            );
            ad.set_reselection(how);
            for _ in 0..20 {
                articula_adaptive::step(&model, &mut ad, &mut s, integrator, 1e-4).unwrap();
            }
            let mut cached = 0;
            let steps = count_allocations(|| {
                for _ in 0..200 {
                    let r =
                        articula_adaptive::step(&model, &mut ad, &mut s, integrator, 1e-4).unwrap();
                    cached +=
                        usize::from(r.reselected && r.nodes_touched < model.assembly.nodes.len());
                }
            });
            assert_eq!(steps, 0, "{how:?} {integrator:?}: allocations in 200 steps");
            if how == Reselection::Caches {
                assert_eq!(
                    cached, 100,
                    "{integrator:?}: every re-selection through the caches"
                );
            }
        }
    }
}
