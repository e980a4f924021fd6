//! A hybrid step of a large active region across threads (`Adaptive::set_threads`): the same
//! bits as the serial step for any thread count, and the exact dynamics when every joint is
//! active — on chains (the per-record sweeps split) and on branched trees (passes 2 and 3 over
//! independent subtrees too).

use articula_adaptive::{Adaptive, Settings, Threads, PARALLEL_HYBRID_MIN_JOINTS};
use articula_dca::{forward_dynamics_slices, Data, Method, State};
use articula_model::{LoadOptions, Model};

fn bits(xs: &[f64]) -> Vec<u64> {
    xs.iter().map(|x| x.to_bits()).collect()
}

fn start(model: &Model) -> State {
    let mut s = State::random(model, 29, 1.0);
    s.randomize_forces(7, 0.5);
    s
}

/// `steps` adaptive steps (a re-selection every fourth: the others are hybrid steps) on
/// `threads` (`Some(1)`: the serial reference; `None`: the workspace's default), returning the states after each step and the
/// active joints of the last hybrid body.
fn run(model: &Model, budget: usize, threads: Option<usize>, steps: usize) -> (Vec<State>, usize) {
    let (states, ad) = run_with(model, budget, threads, steps);
    (states, ad.active_dofs(model))
}

/// [`run`], returning the workspace.
fn run_with(
    model: &Model,
    budget: usize,
    threads: Option<usize>,
    steps: usize,
) -> (Vec<State>, Adaptive) {
    let settings = Settings {
        budget: Some(budget),
        reselect_every: 4,
        ..Settings::default()
    };
    let mut ad = Adaptive::new(model, settings);
    if let Some(t) = threads {
        ad.set_threads(Threads::new(t).unwrap());
    }
    let mut s = start(model);
    let mut out = Vec::new();
    for _ in 0..steps {
        ad.step(model, &mut s, 1e-3).unwrap();
        out.push(s.clone());
    }
    (out, ad)
}

/// The active joints (records of the reduced tree) of `ad`'s hybrid body.
fn active_joints(model: &Model, ad: &Adaptive) -> usize {
    (0..model.bodies.len())
        .filter(|&b| ad.is_active(model, b))
        .count()
}

/// The states of six steps on 1, 2 and 3 threads equal `reference` (the serial run's) to the
/// bit.
fn assert_same_bits_on_any_thread_count(
    name: &str,
    model: &Model,
    budget: usize,
    reference: &[State],
) {
    for threads in [1, 2, 3] {
        let (states, _) = run(model, budget, Some(threads), 6);
        for (k, (a, b)) in states.iter().zip(reference).enumerate() {
            assert_eq!(
                bits(&a.q),
                bits(&b.q),
                "{name} step {k} on {threads} threads"
            );
            assert_eq!(
                bits(&a.qd),
                bits(&b.qd),
                "{name} step {k} on {threads} threads"
            );
        }
    }
}

#[test]
fn hybrid_step_is_bitwise_serial_for_any_thread_count() {
    let tree = articula_testkit::random_tree_urdf(10_500, 3);
    let models = [
        ("chain10500", articula_testkit::chain(10_500)),
        (
            "tree10500",
            Model::from_urdf_str(&tree, &LoadOptions::default()).unwrap(),
        ),
    ];
    for (name, model) in &models {
        let budget = 10_000;
        assert!(budget >= PARALLEL_HYBRID_MIN_JOINTS);
        let (reference, active) = run(model, budget, Some(1), 6);
        assert!(
            active >= PARALLEL_HYBRID_MIN_JOINTS,
            "{name}: {active} active joints, below the split"
        );
        // The steps move every active joint (a test of a frozen state could not fail).
        assert_ne!(reference[5].q, start(model).q);
        assert_same_bits_on_any_thread_count(name, model, budget, &reference);
    }
}

/// With every joint active, a hybrid step on two threads (after the re-selection) gives the
/// accelerations of exact ABA at the state it starts from, to 1e-8 of their scale.
fn assert_split_step_is_exact(model: &Model) {
    let settings = Settings {
        budget: Some(model.nv),
        reselect_every: 4,
        ..Settings::default()
    };
    let mut ad = Adaptive::new(model, settings);
    ad.set_threads(Threads::new(2).unwrap());
    let mut s = start(model);
    // The re-selection, then a hybrid step from `before`.
    ad.step(model, &mut s, 1e-3).unwrap();
    let before = s.clone();
    ad.step(model, &mut s, 1e-3).unwrap();
    assert_eq!(ad.active_dofs(model), model.nv);
    let mut data = Data::new(model);
    let exact = forward_dynamics_slices(
        model,
        &mut data,
        &before.q,
        &before.qd,
        &before.tau,
        &before.f_ext,
        Method::Aba,
    )
    .unwrap()
    .to_vec();
    let scale = exact.iter().fold(1.0f64, |m, x| m.max(x.abs()));
    let err = ad
        .qdd()
        .iter()
        .zip(&exact)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(err <= 1e-8 * scale, "max |Δq̈| {err:e} (scale {scale:e})");
}

#[test]
fn split_hybrid_step_with_every_joint_active_is_exact_dynamics() {
    assert_split_step_is_exact(&articula_testkit::chain(10_500));
}

/// A branched tree (`articula_testkit::branches_urdf`).
fn branches(lengths: &[usize], floating_base: bool) -> Model {
    let options = LoadOptions::default().with_floating_base(floating_base);
    Model::from_urdf_str(&articula_testkit::branches_urdf(lengths), &options).unwrap()
}

/// Equal branches and a lopsided tree (one long branch — a chain whose upper part has no
/// independent subtrees — and short ones, on a floating base), with ball joints (records of
/// three degrees of freedom) among the revolute ones: hybrid steps on 1, 2 and 3 threads give
/// the serial bits.
#[test]
fn hybrid_step_on_a_branched_tree_is_bitwise_serial_for_any_thread_count() {
    let models = [
        ("four branches", branches(&[3_000; 4], false)),
        ("lopsided", branches(&[8_000, 1_500, 1_200, 1_100], true)),
    ];
    for (name, model) in &models {
        // Most of the tree active: well above the split.
        let budget = model.nv * 19 / 20;
        let (reference, ad) = run_with(model, budget, Some(1), 6);
        let active = active_joints(model, &ad);
        assert!(
            active >= PARALLEL_HYBRID_MIN_JOINTS,
            "{name}: {active} active joints, below the split"
        );
        assert_ne!(reference[5].q, start(model).q);
        assert_same_bits_on_any_thread_count(name, model, budget, &reference);
    }
}

/// Every joint of a branched tree active, its passes split over subtrees: the exact dynamics
/// (the articulated-body algorithm over the whole tree, an independent computation).
#[test]
fn split_tree_step_with_every_joint_active_is_exact_dynamics() {
    assert_split_step_is_exact(&branches(&[4_000, 3_000, 2_000, 1_500], false));
}
