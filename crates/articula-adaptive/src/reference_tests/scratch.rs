//! Workspaces of one model stepped interleaved through one shared [`Scratch`] give the same
//! states, accelerations, metrics, hybrid bodies and reports, to the bit, as each workspace
//! stepped alone with its own buffers — through re-selections of every kind (cached,
//! whole-body, by hand with `set_active` after `node_metrics`, the way articula-view's scene
//! does it: every body's metrics first, then the hybrid bodies), budget changes, external
//! forces (dense and as a list), a floating base and fixed-base trees, and plain calls mixed
//! with shared ones on the same workspace.

use crate::{Adaptive, Scratch, Settings};
use articula_dca::State;
use articula_model::Model;
use articula_spatial::SpatialForce;
use glam::DVec3;

use articula_testkit::bundled_with as load;

/// A workspace re-selecting through the caches (what these tests exercise; the library's
/// default route is `Reselection::ExactSolve`).
fn caches(mut ad: Adaptive) -> Adaptive {
    ad.set_reselection(crate::Reselection::Caches);
    ad
}

/// Bitwise equality of two float slices (`==` would take −0 for 0 and reject NaN).
fn same(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

/// The settings of workspace `i`: cached re-selections, or with a velocity tolerance (whole-body
/// re-selections), at different periods.
fn settings(i: usize, budget: usize) -> Settings {
    Settings {
        budget: Some(budget),
        reselect_every: 3 + i as u64,
        velocity_tolerance: (i % 3 == 1).then_some(0.5),
        ..Settings::default()
    }
}

/// Whether workspace `i` re-selects by hand at step `k`: node metrics, then `set_active` on
/// the joints whose metric is above the median.
fn by_hand(i: usize, k: usize) -> bool {
    (k + 2 * i) % 11 == 5
}

/// The joints whose node metric is above the median of all joints' (a floating base's root is
/// kept free by `set_active` anyway).
fn above_median(model: &Model, metrics: &[f64]) -> Vec<bool> {
    let m: Vec<f64> = (0..model.bodies.len())
        .map(|j| metrics[model.assembly.joint_node[j]])
        .collect();
    let mut sorted = m.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    m.iter().map(|x| *x > median).collect()
}

/// `n` workspaces and their states.
struct Side {
    ads: Vec<Adaptive>,
    states: Vec<State>,
    metrics: Vec<Vec<f64>>,
}

impl Side {
    fn new(model: &Model, n: usize, budget: usize, dense_forces: bool) -> Side {
        let mut side = Side {
            ads: Vec::new(),
            states: Vec::new(),
            metrics: vec![vec![0.0; model.assembly.nodes.len()]; n],
        };
        for i in 0..n {
            let mut ad = caches(Adaptive::new(model, settings(i, budget)));
            if i % 3 == 2 {
                // Whole-body re-selections without caches.
                ad.set_cached_reselection(false);
            }
            // The scene's zero gravity on one of them (a per-workspace setting of `data`).
            if i == 1 {
                ad.data.gravity = DVec3::ZERO;
            }
            side.ads.push(ad);
            let mut s = State::random(model, 100 + i as u64, 1.0);
            if dense_forces {
                s.randomize_forces(200 + i as u64, 0.3);
            } else {
                s.f_ext.clear();
            }
            side.states.push(s);
        }
        side
    }
}

/// Steps `n` workspaces of `model` alone and, interleaved, through one scratch, `steps` steps
/// of `dt`, comparing everything after each step. `forces`: external forces given as a list
/// (the states' `f_ext` empty) instead of dense random ones. Workspace 0 of the shared side
/// mixes plain calls with shared ones.
fn alone_and_shared(
    name: &str,
    model: &Model,
    n: usize,
    budgets: [usize; 2],
    steps: usize,
    dt: f64,
    forces: Option<&[(usize, SpatialForce)]>,
) {
    let mut alone = Side::new(model, n, budgets[0], forces.is_none());
    let mut shared = Side::new(model, n, budgets[0], forces.is_none());
    let mut scratch = Scratch::new(model);
    let mut plain_calls = 0;
    for k in 0..steps {
        if k == steps / 2 {
            for i in 0..n {
                let s = settings(i, budgets[1]);
                alone.ads[i].set_settings(s.clone()).unwrap();
                shared.ads[i].set_settings(s).unwrap();
            }
        }
        // Alone: each workspace by itself.
        let mut alone_reports = Vec::new();
        for i in 0..n {
            let (ad, s) = (&mut alone.ads[i], &mut alone.states[i]);
            if by_hand(i, k) {
                ad.node_metrics(model, &s.q, &s.qd, &s.tau, &s.f_ext, &mut alone.metrics[i])
                    .unwrap();
                let want = above_median(model, &alone.metrics[i]);
                ad.set_active(model, s, |j| want[j]).unwrap();
            }
            let r = match forces {
                Some(f) => ad.step_with_forces(model, s, dt, f),
                None => ad.step(model, s, dt),
            };
            alone_reports.push(r.unwrap());
        }
        // Shared: every workspace's metrics, then every hybrid body, then every step.
        let plain = |i: usize, call: usize| i == 0 && (k + call).is_multiple_of(3);
        for i in 0..n {
            if !by_hand(i, k) {
                continue;
            }
            let (ad, s) = (&mut shared.ads[i], &shared.states[i]);
            let out = &mut shared.metrics[i];
            if plain(i, 0) {
                plain_calls += 1;
                ad.node_metrics(model, &s.q, &s.qd, &s.tau, &s.f_ext, out)
            } else {
                ad.node_metrics_with(&mut scratch, model, &s.q, &s.qd, &s.tau, &s.f_ext, out)
            }
            .unwrap();
        }
        for i in 0..n {
            if !by_hand(i, k) {
                continue;
            }
            let (ad, s) = (&mut shared.ads[i], &mut shared.states[i]);
            let want = above_median(model, &shared.metrics[i]);
            if plain(i, 1) {
                plain_calls += 1;
                ad.set_active(model, s, |j| want[j])
            } else {
                ad.set_active_with(&mut scratch, model, s, |j| want[j])
            }
            .unwrap();
        }
        for i in 0..n {
            let (ad, s) = (&mut shared.ads[i], &mut shared.states[i]);
            let r = match (forces, plain(i, 2)) {
                (Some(f), true) => ad.step_with_forces(model, s, dt, f),
                (Some(f), false) => ad.step_with_forces_and_scratch(&mut scratch, model, s, dt, f),
                (None, true) => ad.step(model, s, dt),
                (None, false) => ad.step_with(&mut scratch, model, s, dt),
            }
            .unwrap();
            plain_calls += usize::from(plain(i, 2));
            let (a, sa) = (&alone.ads[i], &alone.states[i]);
            let at = format!("{name}: workspace {i}, step {k}");
            assert_eq!(r, alone_reports[i], "{at}: report");
            assert!(same(&s.q, &sa.q), "{at}: q");
            assert!(same(&s.qd, &sa.qd), "{at}: q̇");
            assert!(same(ad.qdd(), a.qdd()), "{at}: q̈");
            assert!(same(&shared.metrics[i], &alone.metrics[i]), "{at}: metrics");
            assert_eq!(ad.selection(), a.selection(), "{at}: selection");
            for j in 0..model.bodies.len() {
                assert_eq!(ad.is_active(model, j), a.is_active(model, j), "{at}: {j}");
            }
        }
    }
    assert!(plain_calls > 0);
    // The states moved, and the hybrid bodies were partial.
    for (s, a) in shared.states.iter().zip(&shared.ads) {
        assert!(s.qd.iter().any(|x| *x != 0.0), "{name}");
        assert!(a.active_dofs(model) < model.nv, "{name}");
    }
}

#[test]
fn floating_humanoids_through_one_scratch_step_as_alone() {
    let model = load("humanoid", true);
    alone_and_shared("humanoid", &model, 4, [8, 15], 60, 1e-3, None);
}

#[test]
fn fixed_base_chains_through_one_scratch_step_as_alone() {
    let model = load("chain100", false);
    alone_and_shared("chain100", &model, 3, [12, 30], 50, 1e-3, None);
    // Forces as a list, on locked and active bodies.
    let forces: Vec<(usize, SpatialForce)> = [(7usize, 1.0), (55, -0.5), (99, 0.3)]
        .iter()
        .map(|&(b, s)| {
            (
                b,
                SpatialForce::new(DVec3::new(0.0, s, 0.0), DVec3::new(s, 0.0, 0.2)),
            )
        })
        .collect();
    alone_and_shared("chain100 list", &model, 3, [20, 6], 50, 1e-3, Some(&forces));
}

#[test]
fn branching_trees_through_one_scratch_step_as_alone() {
    let model = load("plant", false);
    alone_and_shared("plant", &model, 3, [10, 25], 40, 1e-3, None);
}

#[test]
fn a_scratch_of_another_model_is_an_error() {
    let (a, b) = (load("chain30", false), load("chain100", false));
    let mut ad = caches(Adaptive::new(&a, Settings::default()));
    let mut s = State::random(&a, 1, 1.0);
    let before = s.clone();
    let mut wrong = Scratch::new(&b);
    assert!(ad.step_with(&mut wrong, &a, &mut s, 1e-3).is_err());
    assert_eq!(s.q, before.q);
    // The right one works.
    let mut right = Scratch::new(&a);
    ad.step_with(&mut right, &a, &mut s, 1e-3).unwrap();
}
