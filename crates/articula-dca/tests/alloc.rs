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

/// DCA through leaf clusters (branched models: the point-mass humanoid, a random tree; the
/// humanoid above has clusters too) allocates nothing either, in a solve or a step.
#[test]
fn leaf_clusters_allocate_nothing() {
    use articula_model::{LoadOptions, Model};
    let urdfs = [
        (
            "point-mass humanoid",
            articula_testkit::point_mass_humanoid_urdf(),
        ),
        ("random tree", articula_testkit::random_tree_urdf(40, 7)),
    ];
    for (name, urdf) in urdfs {
        for floating_base in [false, true] {
            let options = LoadOptions::default().with_floating_base(floating_base);
            let model = Model::from_urdf_str(&urdf, &options).unwrap();
            let label = format!("{name} floating={floating_base}");
            let mut data = Data::new(&model);
            let mut state = State::random(&model, 3, 0.1);
            state.randomize_forces(3, 0.1);
            let solve = |data: &mut Data, state: &State| {
                forward_dynamics_slices(
                    &model,
                    data,
                    &state.q,
                    &state.qd,
                    &state.tau,
                    &state.f_ext,
                    Method::Dca,
                )
                .map(|_| ())
                .unwrap();
            };
            solve(&mut data, &state);
            step(
                &model,
                &mut data,
                &mut state,
                Method::Dca,
                Integrator::Rk4,
                1e-5,
            )
            .unwrap();
            let n = count_allocations(|| {
                for _ in 0..10 {
                    solve(&mut data, &state);
                    step(
                        &model,
                        &mut data,
                        &mut state,
                        Method::Dca,
                        Integrator::Rk4,
                        1e-5,
                    )
                    .unwrap();
                }
            });
            eprintln!("{label}: 10 x (DCA solve + RK4 step): {n} allocations");
            assert_eq!(n, 0, "{label}: DCA with leaf clusters allocated");
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
                data.com_jacobian(&model).unwrap();
                std::hint::black_box(data.link_pose(&link).unwrap());
                for frame in [
                    ReferenceFrame::World,
                    ReferenceFrame::Local,
                    ReferenceFrame::LocalWorldAligned,
                ] {
                    data.link_jacobian(&model, &link, frame).unwrap();
                }
                data.point_jacobian(&model, &link, glam::DVec3::X).unwrap();
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
    let expected = DynamicsError::MatrixTooLarge {
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

/// `Data::new` leaves DCA's buffers out: ABA and CRBA never build them, the first DCA call
/// does (it allocates), and the DCA calls after it allocate nothing.
#[test]
fn dca_buffers_are_built_by_the_first_dca_call() {
    use articula_dca::forward_dynamics;
    let model = load("humanoid", true);
    let mut data = Data::new(&model);
    let state = State::random(&model, 4, 0.01 * model.moving_mass());
    let aba = forward_dynamics(&model, &mut data, &state, Method::Aba)
        .unwrap()
        .to_vec();
    let mut solve = |method, times| {
        count_allocations(|| {
            for _ in 0..times {
                forward_dynamics(&model, &mut data, &state, method).unwrap();
            }
        })
    };
    assert_eq!(solve(Method::Aba, 10), 0, "ABA allocated");
    assert!(
        solve(Method::Dca, 1) > 0,
        "the first DCA call should build DCA's buffers"
    );
    assert_eq!(
        solve(Method::Dca, 10),
        0,
        "DCA allocated after its first call"
    );
    let dca = forward_dynamics(&model, &mut data, &state, Method::Dca).unwrap();
    let scale = aba.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let diff = aba
        .iter()
        .zip(dca)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(diff <= 1e-10 * scale, "DCA vs ABA: {:e}", diff / scale);
}

/// A star of K links: the model (its assembly tree) and DCA's workspace grow linearly in K.
/// 40 times the children take less than 60 times the bytes (a node with a handle per child,
/// and 36 nh² numbers per node, would take ~64,000 times).
#[test]
fn a_star_allocates_linearly_in_its_children() {
    use articula_model::{LoadOptions, Model};
    use articula_testkit::count_allocated_bytes;
    for floating_base in [false, true] {
        let bytes = |k: usize| {
            let urdf = articula_testkit::star_urdf(k);
            let options = LoadOptions::default().with_floating_base(floating_base);
            let mut model = None;
            let load = count_allocated_bytes(|| {
                model = Some(Model::from_urdf_str(&urdf, &options).unwrap());
            });
            let model = model.unwrap();
            let state = State::random(&model, 2, 1.0);
            let dca = count_allocated_bytes(|| {
                let mut data = Data::new(&model);
                articula_dca::forward_dynamics(&model, &mut data, &state, Method::Dca).unwrap();
            });
            (load, dca)
        };
        let (small, large) = (bytes(50), bytes(2000));
        eprintln!("star floating={floating_base}: K = 50 {small:?} bytes, K = 2000 {large:?}");
        assert!(large.0 < 60 * small.0, "model: {small:?} → {large:?}");
        assert!(
            large.1 < 60 * small.1,
            "DCA workspace: {small:?} → {large:?}"
        );
    }
}

/// The contact step allocates nothing once its buffers have met the largest contact problem:
/// the floating humanoid standing on the floor 0.9 m below its base, 600 steps to settle,
/// then 50 more steps counted, with DCA and ABA, and with every solver.
#[test]
fn contact_step_allocates_nothing_after_warm_up() {
    use articula_dca::{step_with_contact, ContactData, ContactSettings, ContactSolver, Ground};
    let model = load("humanoid", true);
    for (method, solver) in [
        (Method::Dca, ContactSolver::GaussSeidel),
        (Method::Aba, ContactSolver::GaussSeidel),
        (Method::Dca, ContactSolver::Subspace),
        (Method::Dca, ContactSolver::Newton),
        (Method::Aba, ContactSolver::Newton),
    ] {
        let settings = ContactSettings {
            ground: Some(Ground::horizontal(-0.9)),
            solver,
            ..ContactSettings::default()
        };
        let mut data = Data::new(&model);
        let mut contact = ContactData::new(&model);
        let mut state = State::neutral(&model);
        let mut run = |state: &mut State, steps: usize| {
            for _ in 0..steps {
                step_with_contact(
                    &model,
                    &mut data,
                    &mut contact,
                    state,
                    method,
                    1e-3,
                    &settings,
                )
                .unwrap();
            }
        };
        run(&mut state, 600);
        let n = count_allocations(|| run(&mut state, 50));
        assert_eq!(n, 0, "{method:?} {solver:?}: the contact step allocated");
        assert!(
            contact.stats.contacts >= 4,
            "{method:?}: {:?}",
            contact.stats
        );
    }
}
