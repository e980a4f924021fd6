//! The batch API across threads: the same bits as a serial loop with a fresh workspace per
//! state, for one thread and for two.

use articula_dca::{
    forward_dynamics, step, Batch, BatchError, Data, DynamicsError, Integrator, Method, State,
    Threads,
};
use articula_testkit::bundled_with;

fn states(model: &articula_model::Model, n: u64) -> Vec<State> {
    (0..n)
        .map(|i| {
            let mut s = State::random(model, 1000 + i, 1.0);
            if i % 3 == 0 {
                s.randomize_forces(i, 0.5);
            }
            s
        })
        .collect()
}

fn bits(xs: &[f64]) -> Vec<u64> {
    xs.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn batch_forward_dynamics_is_bitwise_serial_for_any_thread_count() {
    for (name, floating) in [("humanoid", true), ("chain300", false), ("plant", false)] {
        let model = bundled_with(name, floating);
        let states = states(&model, 37);
        for method in [Method::Dca, Method::Aba] {
            // Reference: each state on a workspace of its own.
            let mut reference = Vec::new();
            for s in &states {
                let mut data = Data::new(&model);
                reference
                    .extend_from_slice(forward_dynamics(&model, &mut data, s, method).unwrap());
            }
            for threads in [1, 2, 3] {
                let mut batch = Batch::new(&model, Threads::new(threads).unwrap());
                let mut qdd = vec![f64::NAN; states.len() * model.nv];
                // Twice: the reused workspaces give the same bits as fresh ones.
                for _ in 0..2 {
                    batch
                        .forward_dynamics(&model, &states, method, &mut qdd)
                        .unwrap();
                    assert_eq!(
                        bits(&qdd),
                        bits(&reference),
                        "{name} {method:?} on {threads} threads"
                    );
                }
            }
        }
    }
}

#[test]
fn batch_step_is_bitwise_serial_for_any_thread_count() {
    let model = bundled_with("humanoid", true);
    let start = states(&model, 21);
    let mut reference = start.clone();
    for s in &mut reference {
        let mut data = Data::new(&model);
        for _ in 0..5 {
            step(&model, &mut data, s, Method::Dca, Integrator::Rk4, 1e-3).unwrap();
        }
    }
    assert_ne!(reference[0].q, start[0].q);
    for threads in [1, 2] {
        let mut batch = Batch::new(&model, Threads::new(threads).unwrap());
        let mut run = start.clone();
        for _ in 0..5 {
            batch
                .step(&model, &mut run, Method::Dca, Integrator::Rk4, 1e-3)
                .unwrap();
        }
        for (a, b) in run.iter().zip(&reference) {
            assert_eq!(bits(&a.q), bits(&b.q), "{threads} threads");
            assert_eq!(bits(&a.qd), bits(&b.qd), "{threads} threads");
        }
    }
}

#[test]
fn batch_reports_the_lowest_failing_state_and_solves_the_others() {
    let model = bundled_with("humanoid", true);
    let mut states = states(&model, 10);
    states[7].q[3] = f64::NAN;
    states[4].qd[0] = f64::INFINITY;
    for threads in [1, 2] {
        let mut batch = Batch::new(&model, Threads::new(threads).unwrap());
        let mut qdd = vec![f64::NAN; states.len() * model.nv];
        let err = batch
            .forward_dynamics(&model, &states, Method::Dca, &mut qdd)
            .unwrap_err();
        match err {
            BatchError::State {
                index: 4,
                source: DynamicsError::NonFinite { what: "qd", .. },
            } => {}
            other => panic!("{threads} threads: {other:?}"),
        }
        // State 9 (after both failures, in the second run on 2 threads) is solved.
        let mut data = Data::new(&model);
        let expected = forward_dynamics(&model, &mut data, &states[9], Method::Dca).unwrap();
        assert_eq!(bits(&qdd[9 * model.nv..]), bits(expected));
        let short = batch.forward_dynamics(&model, &states, Method::Dca, &mut qdd[1..]);
        assert!(matches!(short, Err(BatchError::Output { states: 10, .. })));
    }
    assert_eq!(
        Threads::new(0).unwrap_err(),
        articula_dca::ThreadsError::Zero
    );
}

/// One body's DCA split across threads (`forward_dynamics_threads`): a chain long enough to
/// be split (fixed base; floating base, where the refinement runs too) and a branched tree of
/// general joints (revolute about random axes, prismatic) on DCA's plain assembly tree (no
/// leaf clusters, so that the split solve takes it), the same bits on 1, 2 and 3 threads and
/// on a reused workspace, and within rounding of the serial DCA and of ABA.
#[test]
fn one_body_dca_is_the_same_bits_on_any_thread_count() {
    use articula_dca::{forward_dynamics_threads, PARALLEL_DCA_MIN_BODIES};
    use articula_model::{LoadOptions, Model};
    let n = PARALLEL_DCA_MIN_BODIES + 77;
    let chain = articula_testkit::chain_urdf(n);
    let tree = articula_testkit::random_tree_urdf(n, 7);
    let models = [
        articula_testkit::chain(n),
        Model::from_urdf_str(&chain, &LoadOptions::default().with_floating_base(true)).unwrap(),
        Model::from_urdf_str(&tree, &LoadOptions::default()).unwrap(),
    ];
    for (k, model) in models.iter().enumerate() {
        let clusters = k < 2;
        let workspace = || {
            let mut data = Data::new(model);
            data.set_leaf_clusters(model, clusters);
            data
        };
        assert!(model.bodies.len() >= PARALLEL_DCA_MIN_BODIES);
        for seed in [5, 6] {
            let mut s = State::random(model, seed, 1.0);
            if seed % 2 == 0 {
                s.randomize_forces(seed, 0.5);
            }
            let solve = |threads: usize, data: &mut Data| {
                forward_dynamics_threads(
                    model,
                    data,
                    &s.q,
                    &s.qd,
                    &s.tau,
                    &s.f_ext,
                    Method::Dca,
                    &Threads::new(threads).unwrap(),
                )
                .unwrap()
                .to_vec()
            };
            let mut data = workspace();
            let one = solve(1, &mut data);
            for threads in [2, 3, 1, 2] {
                assert_eq!(
                    bits(&solve(threads, &mut data)),
                    bits(&one),
                    "model {k} seed {seed} on {threads} threads"
                );
            }
            assert_eq!(bits(&solve(2, &mut workspace())), bits(&one));
            for method in [Method::Dca, Method::Aba] {
                let reference = forward_dynamics(model, &mut workspace(), &s, method)
                    .unwrap()
                    .to_vec();
                let scale = reference.iter().fold(1.0f64, |m, x| m.max(x.abs()));
                let diff = reference
                    .iter()
                    .zip(&one)
                    .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
                assert!(
                    diff <= 1e-9 * scale,
                    "model {k} {method:?}: {:e}",
                    diff / scale
                );
            }
        }
    }
}

/// `Threads::for_each_chunk` hands every item to exactly one call, at its index, in chunks of
/// the given length (the last shorter), each call holding a worker no other running call
/// holds: every item is seen once with its own index, the workers' counts add up to the
/// items, and on a pool the chunks spread over more than one worker.
#[test]
fn for_each_chunk_visits_every_item_once_with_a_worker_of_its_own() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Mutex;
    for threads in [1, 2, 3] {
        let pool = Threads::new(threads).unwrap();
        for (n, chunk) in [(0, 4), (1, 4), (7, 3), (1000, 8), (1000, 1000)] {
            let mut items = vec![usize::MAX; n];
            let workers: Vec<Mutex<(usize, bool)>> =
                (0..threads).map(|_| Mutex::new((0, false))).collect();
            let calls = AtomicUsize::new(0);
            pool.for_each_chunk(&mut items, &workers, chunk, |w, first, run| {
                // No other running call holds this worker.
                assert!(!w.1, "worker held twice");
                w.1 = true;
                calls.fetch_add(1, Ordering::Relaxed);
                if threads > 1 && n > chunk {
                    assert!(run.len() <= chunk && first % chunk == 0);
                }
                for (j, x) in run.iter_mut().enumerate() {
                    assert_eq!(*x, usize::MAX, "item {} seen twice", first + j);
                    *x = first + j;
                    // Long enough for the other threads to take chunks meanwhile.
                    std::hint::black_box((0..200).sum::<usize>());
                }
                w.0 += run.len();
                w.1 = false;
            });
            assert!(items.iter().enumerate().all(|(i, x)| *x == i));
            let counts: Vec<usize> = workers.iter().map(|w| w.lock().unwrap().0).collect();
            assert_eq!(
                counts.iter().sum::<usize>(),
                n,
                "{threads} threads, {n} items"
            );
            let expected_calls = if threads > 1 && n > chunk {
                n.div_ceil(chunk)
            } else {
                1
            };
            assert_eq!(calls.load(Ordering::Relaxed), expected_calls);
        }
    }
}
