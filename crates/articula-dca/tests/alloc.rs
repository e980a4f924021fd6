//! "A step allocates nothing" (docs/design.md#workspace): a counting allocator around DCA and ABA
//! calls and steps on several models, fixed and floating base.
//!
//! The allocator (articula-testkit's) counts only on the thread inside `count_allocations`, so
//! the test harness's other threads (and other tests of this binary running in parallel) cannot
//! add to a test's count. This file is its own test binary, so the allocator touches no other
//! test.

use articula_dca::{forward_dynamics_slices, step, Data, Integrator, Method, State};
use articula_testkit::{bundled_with as load, count_allocations, CountingAllocator};

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

#[test]
fn dca_and_aba_allocate_nothing() {
    for name in ["chain30", "humanoid", "rope"] {
        for floating_base in [false, true] {
            let model = load(name, floating_base);
            let mut data = Data::new(&model);
            // Torques and forces scaled to the model (the rope's segments weigh 2 g), and a
            // short step, so that the trajectory stays tame: the point is the allocations.
            let scale = 0.01 * model.moving_mass();
            let mut start = State::random(&model, 3, scale);
            start.randomize_forces(3, scale);
            let mut state = start.clone();
            let label = format!("{name} floating={floating_base}");
            // Warm up once (every path that could lazily allocate runs before counting).
            for method in [Method::Dca, Method::Aba, Method::Crba] {
                forward_dynamics_slices(
                    &model,
                    &mut data,
                    &state.q,
                    &state.qd,
                    &state.tau,
                    &state.f_ext,
                    method,
                )
                .unwrap();
            }
            for integrator in [Integrator::SemiImplicitEuler, Integrator::Rk4] {
                step(&model, &mut data, &mut state, Method::Dca, integrator, 1e-5).unwrap();
                state.clone_from(&start);
            }

            for method in [Method::Dca, Method::Aba] {
                let n = count_allocations(|| {
                    for _ in 0..100 {
                        forward_dynamics_slices(
                            &model,
                            &mut data,
                            &state.q,
                            &state.qd,
                            &state.tau,
                            &state.f_ext,
                            method,
                        )
                        .unwrap();
                    }
                });
                eprintln!("{label}: 100 x forward_dynamics {method:?}: {n} allocations");
                assert_eq!(n, 0, "{label}: forward_dynamics {method:?} allocated");
                // Without external forces too (an empty slice).
                let n = count_allocations(|| {
                    for _ in 0..100 {
                        forward_dynamics_slices(
                            &model,
                            &mut data,
                            &state.q,
                            &state.qd,
                            &state.tau,
                            &[],
                            method,
                        )
                        .unwrap();
                    }
                });
                assert_eq!(
                    n, 0,
                    "{label}: forward_dynamics {method:?} (no f_ext) allocated"
                );
                for integrator in [Integrator::SemiImplicitEuler, Integrator::Rk4] {
                    state.clone_from(&start);
                    let n = count_allocations(|| {
                        for _ in 0..10 {
                            step(&model, &mut data, &mut state, method, integrator, 1e-5).unwrap();
                        }
                    });
                    eprintln!("{label}: 10 x step {method:?} {integrator:?}: {n} allocations");
                    assert_eq!(n, 0, "{label}: step {method:?} {integrator:?} allocated");
                }
            }

            // CRBA is a reference and allocates: the counter sees it.
            let n = count_allocations(|| {
                forward_dynamics_slices(
                    &model,
                    &mut data,
                    &state.q,
                    &state.qd,
                    &state.tau,
                    &state.f_ext,
                    Method::Crba,
                )
                .unwrap();
            });
            eprintln!("{label}: 1 x forward_dynamics Crba: {n} allocations");
            assert!(n > 0, "{label}: CRBA should allocate (is the counter on?)");
        }
    }
}

#[test]
fn quantities_allocate_nothing_after_the_first_call() {
    use articula_dca::{bias_forces, inverse_dynamics, mass_matrix, ReferenceFrame};
    for name in ["chain30", "humanoid", "rope"] {
        for floating_base in [false, true] {
            let model = load(name, floating_base);
            let label = format!("{name} floating={floating_base}");
            let mut data = Data::new(&model);
            let mut s = State::random(&model, 5, 1.0);
            s.randomize_forces(5, 0.1);
            let link = model
                .find_link(&model.bodies[model.bodies.len() - 1].name)
                .unwrap();
            let qdd = vec![0.25; model.nv];
            let all = |data: &mut Data| {
                articula_dca::forward_dynamics(&model, data, &s, Method::Dca).unwrap();
                inverse_dynamics(&model, data, &s.q, &s.qd, &qdd, &s.f_ext).unwrap();
                inverse_dynamics(&model, data, &s.q, &s.qd, &qdd, &[]).unwrap();
                bias_forces(&model, data, &s.q, &s.qd).unwrap();
                mass_matrix(&model, data, &s.q).unwrap();
                std::hint::black_box(data.center_of_mass());
                data.com_jacobian(&model);
                std::hint::black_box(data.link_pose(&link));
                for frame in [
                    ReferenceFrame::World,
                    ReferenceFrame::Local,
                    ReferenceFrame::LocalWorldAligned,
                ] {
                    data.link_jacobian(&model, &link, frame);
                }
                data.point_jacobian(&model, &link, glam::DVec3::X);
                std::hint::black_box((data.kinetic_energy(), data.potential_energy()));
                std::hint::black_box((data.momentum(), data.centroidal_momentum()));
            };
            // The first call sizes the buffers ...
            let first = count_allocations(|| all(&mut data));
            assert!(first > 0, "{label}: the first call should size buffers");
            // ... the next ones reuse them.
            let n = count_allocations(|| {
                for _ in 0..10 {
                    all(&mut data);
                }
            });
            eprintln!("{label}: first call {first} allocations, next 10: {n}");
            assert_eq!(n, 0, "{label}: the quantities allocated");
        }
    }
}

/// A joint-space inertia matrix beyond `MAX_DENSE_MATRIX_BYTES` (a 17,000-link chain's would
/// take 17,000² × 8 bytes = 2.3 GB) is refused — by CRBA and by `mass_matrix` — with its size
/// and the limit, before anything is allocated; one just within the limit's side (16,384²
/// × 8 bytes is exactly 2 GiB) passes the check.
#[test]
fn dense_matrices_beyond_the_limit_are_refused_before_allocating() {
    use articula_dca::{mass_matrix, DynamicsError, MAX_DENSE_MATRIX_BYTES};
    let n = 17_000;
    let model = articula_testkit::chain(n);
    let mut data = Data::new(&model);
    let state = State::neutral(&model);
    let expected = DynamicsError::TooLarge {
        what: "joint-space inertia matrix",
        rows: n,
        cols: n,
        bytes: (n * n * 8) as u64,
        limit: MAX_DENSE_MATRIX_BYTES,
    };
    let mut result = None;
    let allocations = count_allocations(|| {
        result = Some(
            forward_dynamics_slices(
                &model,
                &mut data,
                &state.q,
                &state.qd,
                &state.tau,
                &[],
                Method::Crba,
            )
            .map(|_| ()),
        );
    });
    assert_eq!(result, Some(Err(expected.clone())));
    assert_eq!(allocations, 0);
    let mut result = None;
    let allocations = count_allocations(|| {
        result = Some(mass_matrix(&model, &mut data, &state.q).map(|_| ()));
    });
    assert_eq!(result, Some(Err(expected)));
    assert_eq!(allocations, 0);
    assert_eq!(MAX_DENSE_MATRIX_BYTES, 16_384 * 16_384 * 8);
    // DCA solves the same chain (memory linear in its length).
    forward_dynamics_slices(
        &model,
        &mut data,
        &state.q,
        &state.qd,
        &state.tau,
        &[],
        Method::Dca,
    )
    .unwrap();
}
