//! Re-selection through the caches of the rigid subassemblies (O(active region)) against the
//! whole-body re-selection it replaces.

use crate::{Adaptive, Settings};
use articula_dca::{forward_dynamics_slices, Data, Method, State};
use articula_model::Model;
use articula_spatial::SpatialForce;

use articula_testkit::bundled_with as load;

/// A workspace re-selecting through the caches (what these tests exercise; the library's
/// default route is `Reselection::ExactSolve`).
fn caches(mut ad: Adaptive) -> Adaptive {
    ad.set_reselection(crate::Reselection::Caches);
    ad
}

/// Relative agreement required of q̈, predicted error and q̇ after the locking impulses.
const TOL: f64 = 1e-9;

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// Steps a cached and a whole-body (reference) adaptive simulation side by side and checks,
/// every step, the same selected joints, predicted error and q̈ (1e-9 relative), and the same
/// velocities after the locking impulses. `forces(k)` are the external wrenches of step k.
/// One side-by-side run: budget, re-selection period, steps, time step, whether the budget
/// changes every ten steps.
struct Run {
    budget: usize,
    period: u64,
    steps: usize,
    dt: f64,
    vary_budget: bool,
}

fn compare(
    name: &str,
    model: &Model,
    s0: State,
    run: &Run,
    forces: impl Fn(usize) -> Vec<(usize, SpatialForce)>,
) -> usize {
    let Run {
        budget,
        period,
        steps,
        dt,
        vary_budget,
    } = *run;
    let settings = Settings {
        budget: Some(budget),
        reselect_every: period,
        ..Settings::default()
    };
    let (mut fast, mut slow) = (
        caches(Adaptive::new(model, settings.clone())),
        caches(Adaptive::new(model, settings)),
    );
    slow.set_cached_reselection(false);
    let (mut a, mut b) = (s0.clone(), s0);
    a.f_ext.clear();
    b.f_ext.clear();
    let mut reselections = 0;
    let (mut changed, mut locked) = (0, 0);
    let mut worst = 0.0f64;
    let mut prev: Vec<bool> = Vec::new();
    for k in 0..steps {
        if vary_budget && k % 10 == 0 {
            // Every tenth step a smaller or larger budget: joints leave (caches rebuilt) or
            // join from deep in the rigid region (popped from the caches).
            let s = Settings {
                budget: Some([budget, budget / 2, budget + budget / 2][(k / 10) % 3]),
                reselect_every: period,
                ..Settings::default()
            };
            fast.set_settings(s.clone()).unwrap();
            slow.set_settings(s).unwrap();
        }
        let f = forces(k);
        let ra = fast.step_with_forces(model, &mut a, dt, &f).unwrap();
        let rb = slow.step_with_forces(model, &mut b, dt, &f).unwrap();
        assert_eq!(ra.reselected, rb.reselected, "{name} step {k}");
        reselections += usize::from(ra.reselected);
        if ra.reselected && k > 0 {
            // Through the caches, not whole-body passes (which visit every node and, with
            // the caches' build, more than the reference).
            assert!(
                ra.nodes_touched < rb.nodes_touched,
                "{name} step {k}: {} nodes vs {}",
                ra.nodes_touched,
                rb.nodes_touched
            );
        }
        assert_eq!(ra.rigidified, rb.rigidified, "{name} step {k}");
        locked += usize::from(ra.rigidified);
        let now: Vec<bool> = (0..model.bodies.len())
            .map(|i| fast.is_active(model, i))
            .collect();
        changed += usize::from(k > 0 && now != prev);
        prev = now;
        assert_eq!(ra.active_dofs, rb.active_dofs, "{name} step {k}");
        for body in 0..model.bodies.len() {
            assert_eq!(
                fast.is_active(model, body),
                slow.is_active(model, body),
                "{name} step {k}: body {body}"
            );
        }
        let (sa, sb) = (fast.selection(), slow.selection());
        assert_eq!(sa.budget_used, sb.budget_used, "{name} step {k}");
        let scale = sb.total_metric.abs().max(1e-300);
        assert!(
            (sa.total_metric - sb.total_metric).abs() <= TOL * scale
                && (sa.predicted_error - sb.predicted_error).abs() <= TOL * scale,
            "{name} step {k}: {sa:?} vs {sb:?}"
        );
        let dqdd = max_diff(fast.qdd(), slow.qdd());
        worst = worst.max(dqdd / max_abs(slow.qdd()).max(1.0));
        assert!(
            dqdd <= TOL * max_abs(slow.qdd()).max(1.0),
            "{name} step {k}: q̈ {dqdd:e} of {:e}",
            max_abs(slow.qdd())
        );
        let dv = max_diff(&a.qd, &b.qd);
        assert!(
            dv <= TOL * max_abs(&b.qd).max(1.0),
            "{name} step {k}: q̇ {dv:e} of {:e}, rigidified {}",
            max_abs(&b.qd),
            rb.rigidified
        );
        // The same inputs for the next step (chaotic motion would amplify round-off).
        a.q.copy_from_slice(&b.q);
        a.qd.copy_from_slice(&b.qd);
    }
    assert!(reselections >= steps / period as usize, "{name}");
    println!("{name}: {reselections} re-selections, {changed} changed the hybrid body, {locked} locked joints, q̈ {worst:.1e}");
    changed
}

/// A random state with joint torques everywhere (the locked joints' are in the caches'
/// constant columns), scaled to the links: the rope's 3-gram links diverge within a few
/// steps under the chains' torques and velocities.
fn start(model: &Model, seed: u64, scale: f64) -> State {
    let mut s = State::random(model, seed, 0.5 * scale);
    for v in &mut s.qd {
        *v *= 0.5 * scale;
    }
    s
}

#[test]
fn cached_reselection_equals_whole_body_reselection() {
    for (name, floating, budget, scale, dt) in [
        ("chain100", false, 12, 1.0, 1e-3),
        ("chain300", false, 50, 1.0, 1e-3),
        ("humanoid", true, 12, 1.0, 1e-3),
        ("plant", false, 20, 1.0, 1e-3),
        ("rope", true, 15, 0.01, 1e-4),
    ] {
        let model = load(name, floating);
        let mut changed = 0;
        for period in [1u64, 3, 5] {
            let s0 = start(&model, 11 + period, scale);
            let run = Run {
                budget,
                period,
                steps: 100,
                dt,
                vary_budget: period == 5,
            };
            changed += compare(&format!("{name} every {period}"), &model, s0, &run, |_| {
                Vec::new()
            });
        }
        // The selection moved: caches were rebuilt and rigid nodes popped.
        assert!(changed > 0, "{name}");
    }
}

#[test]
fn external_forces_on_rigid_parts_update_their_paths_exactly() {
    // Wrenches on a few bodies that change every step, most of them on locked (rigid) parts:
    // the cached re-selection recomputes the paths from the forced bodies up to their
    // clusters and must still agree with whole-body passes.
    for (name, floating, budget, scale, dt, magnitude) in [
        ("chain100", false, 12, 1.0, 1e-3, 2.0),
        ("chain300", false, 50, 1.0, 1e-3, 2.0),
        ("humanoid", true, 12, 1.0, 1e-3, 5.0),
        ("plant", false, 20, 1.0, 1e-3, 0.5),
        ("rope", true, 15, 0.01, 1e-4, 1e-3),
    ] {
        let model = load(name, floating);
        let nb = model.bodies.len();
        let forces = |k: usize| -> Vec<(usize, SpatialForce)> {
            (0..3)
                .map(|j| {
                    let body = (7 * k + 31 * j + 5) % nb;
                    let t = (k + j) as f64;
                    let f = glam::DVec3::new(t.sin(), (1.3 * t).cos(), 0.5) * magnitude;
                    let n = glam::DVec3::new(0.2, -(0.7 * t).sin(), 0.1) * magnitude;
                    (body, SpatialForce::new(n, f))
                })
                .collect()
        };
        for period in [1u64, 4] {
            let run = Run {
                budget,
                period,
                steps: 60,
                dt,
                vary_budget: period == 4,
            };
            let s0 = start(&model, 21 + period, scale);
            compare(
                &format!("{name} forces every {period}"),
                &model,
                s0,
                &run,
                forces,
            );
        }
    }
}

#[test]
fn forces_deep_in_large_clusters_with_small_budgets() {
    // Small budgets leave nearly the whole body locked, so the forced bodies sit deep in
    // large clusters; several forces share a path (their dirty paths merge), and the budget
    // changes every ten steps so that the selection pops dirty nodes (their maps and
    // children's metrics with the forces' deltas). Cached and reference re-selections must
    // agree.
    for (name, floating, budget) in [
        ("chain100", false, 2),
        ("chain300", false, 4),
        ("humanoid", true, 3),
        ("plant", false, 2),
    ] {
        let model = load(name, floating);
        let nb = model.bodies.len();
        let bodies = [1, 2, nb / 3, nb / 3 + 2, nb - 1];
        let forces = |k: usize| -> Vec<(usize, SpatialForce)> {
            bodies
                .iter()
                .enumerate()
                .map(|(j, &body)| {
                    let t = (k + 3 * j) as f64;
                    let n = glam::DVec3::new(0.3, -0.2 * t.sin(), 0.1);
                    let f = glam::DVec3::new(1.0 + t.cos(), 0.5, -0.7);
                    (body, SpatialForce::new(n, f))
                })
                .collect()
        };
        for period in [1u64, 5] {
            let run = Run {
                budget,
                period,
                steps: 40,
                dt: 1e-3,
                vary_budget: true,
            };
            let s0 = start(&model, 5 + period, 1.0);
            compare(
                &format!("{name} deep forces every {period}"),
                &model,
                s0,
                &run,
                forces,
            );
        }
    }
}

#[test]
fn forced_path_maps_equal_the_recomputed_paths() {
    // A forced path with one leaf is taken from its linear maps of the leaf's wrench (built
    // on the path's second re-selection, reused while the caches below stay). Against the
    // same cached re-selection recomputing every dirty node (maps off) and the whole-body
    // reference: wrenches that change every step on fixed bodies (maps reused, moving
    // clusters: the velocity terms), bodies that change every 12 steps (new paths), two
    // forces sharing a path, and a budget that changes (caches rebuilt, maps invalidated,
    // dirty nodes popped).
    for (name, floating, budget, period) in [
        ("chain100", false, 3, 1u64),
        ("chain300", false, 1, 2),
        ("chain300", false, 6, 3),
        ("humanoid", true, 3, 1),
        ("plant", false, 4, 2),
    ] {
        let model = load(name, floating);
        let nb = model.bodies.len();
        let forces = |k: usize| -> Vec<(usize, SpatialForce)> {
            let moved = (k / 12) * 7;
            [
                nb / 5,
                nb / 2 + moved % (nb / 3),
                nb / 2 + moved % (nb / 3) + 1,
                nb - 2,
            ]
            .iter()
            .enumerate()
            .map(|(j, &body)| {
                let t = (k + 5 * j) as f64;
                let n = glam::DVec3::new(0.3 * t.cos(), -0.2, 0.1 * t.sin());
                let f = glam::DVec3::new(1.0 + t.sin(), 0.5 * (0.7 * t).cos(), -0.7);
                (body, SpatialForce::new(n, f))
            })
            .collect()
        };
        let run = Run {
            budget,
            period,
            steps: 60,
            dt: 1e-3,
            vary_budget: true,
        };
        let s0 = start(&model, 77 + period, 1.0);
        let label = format!("{name} maps, budget {budget}, every {period}");
        // Maps on (default) against the whole-body reference.
        compare(&label, &model, s0.clone(), &run, forces);
        // Maps on against maps off, both cached.
        let settings = Settings {
            budget: Some(budget),
            reselect_every: period,
            ..Settings::default()
        };
        let (mut on, mut off) = (
            caches(Adaptive::new(&model, settings.clone())),
            caches(Adaptive::new(&model, settings)),
        );
        off.set_path_maps(false);
        let (mut a, mut b) = (s0.clone(), s0);
        a.f_ext.clear();
        b.f_ext.clear();
        for k in 0..run.steps {
            if k % 10 == 0 {
                let s = Settings {
                    budget: Some([budget, budget / 2, budget + budget / 2][(k / 10) % 3]),
                    reselect_every: period,
                    ..Settings::default()
                };
                on.set_settings(s.clone()).unwrap();
                off.set_settings(s).unwrap();
            }
            let f = forces(k);
            on.step_with_forces(&model, &mut a, 1e-3, &f).unwrap();
            off.step_with_forces(&model, &mut b, 1e-3, &f).unwrap();
            for body in 0..nb {
                assert_eq!(
                    on.is_active(&model, body),
                    off.is_active(&model, body),
                    "{label} step {k}: body {body}"
                );
            }
            let (sa, sb) = (on.selection(), off.selection());
            let scale = sb.total_metric.abs().max(1e-300);
            assert!(
                (sa.total_metric - sb.total_metric).abs() <= 1e-10 * scale
                    && (sa.predicted_error - sb.predicted_error).abs() <= 1e-10 * scale,
                "{label} step {k}: {sa:?} vs {sb:?}"
            );
            let dqdd = max_diff(on.qdd(), off.qdd());
            assert!(
                dqdd <= 1e-10 * max_abs(off.qdd()).max(1.0),
                "{label} step {k}: q̈ {dqdd:e} of {:e}",
                max_abs(off.qdd())
            );
            a.q.copy_from_slice(&b.q);
            a.qd.copy_from_slice(&b.qd);
        }
        let (builds, evals) = on.path_map_counts();
        println!("{label}: {builds} maps built, {evals} evaluated");
        assert!(
            builds > 0 && evals > builds,
            "{label}: {builds} built, {evals} evaluated"
        );
        assert_eq!(off.path_map_counts(), (0, 0), "{label}");
    }
}

#[test]
fn a_changed_locked_torque_is_detected() {
    // Locked joints' torques are in the caches' constant columns: changing them mid-run must
    // not leave stale caches (detected by the comparison of τ, or by `invalidate` when it is
    // off).
    let model = load("chain100", false);
    for check in [true, false] {
        let settings = Settings {
            budget: Some(12),
            reselect_every: 2,
            ..Settings::default()
        };
        let (mut fast, mut slow) = (
            caches(Adaptive::new(&model, settings.clone())),
            caches(Adaptive::new(&model, settings)),
        );
        fast.set_check_locked_torques(check);
        slow.set_cached_reselection(false);
        let mut a = start(&model, 5, 1.0);
        a.f_ext.clear();
        let mut b = a.clone();
        for k in 0..30 {
            if k == 10 {
                for (i, t) in a.tau.iter_mut().enumerate() {
                    *t += 0.3 * ((i % 7) as f64 - 3.0);
                }
                b.tau.copy_from_slice(&a.tau);
                if !check {
                    fast.invalidate();
                    slow.invalidate();
                }
            }
            fast.step(&model, &mut a, 1e-3).unwrap();
            slow.step(&model, &mut b, 1e-3).unwrap();
            let d = max_diff(fast.qdd(), slow.qdd());
            assert!(
                d <= TOL * max_abs(slow.qdd()).max(1.0),
                "check {check} step {k}: {d:e}"
            );
            // The locked joints' torques show in the fully articulated metric.
            let (sa, sb) = (fast.selection(), slow.selection());
            assert!(
                (sa.total_metric - sb.total_metric).abs() <= TOL * sb.total_metric,
                "check {check} step {k}: {sa:?} vs {sb:?}"
            );
            a.q.copy_from_slice(&b.q);
            a.qd.copy_from_slice(&b.qd);
        }
    }
}

#[test]
fn a_changed_weight_is_not_read_from_stale_caches() {
    // The caches hold Ψ built with the weights: after `set_weight` changes one, a cached
    // re-selection must give the metric of a workspace that re-selects by whole-body passes.
    let model = load("chain100", false);
    let settings = Settings {
        budget: Some(12),
        reselect_every: 2,
        ..Settings::default()
    };
    let (mut fast, mut slow) = (
        caches(Adaptive::new(&model, settings.clone())),
        caches(Adaptive::new(&model, settings)),
    );
    slow.set_cached_reselection(false);
    let mut a = start(&model, 7, 1.0);
    a.f_ext.clear();
    let mut b = a.clone();
    for k in 0..30 {
        if k == 9 {
            // Heavier weights on the tip half: the selection moves there.
            for body in 50..model.bodies.len() {
                fast.set_weight(&model, body, 25.0);
                slow.set_weight(&model, body, 25.0);
            }
        }
        fast.step(&model, &mut a, 1e-3).unwrap();
        slow.step(&model, &mut b, 1e-3).unwrap();
        let (sa, sb) = (fast.selection(), slow.selection());
        assert!(
            (sa.total_metric - sb.total_metric).abs() <= TOL * sb.total_metric,
            "step {k}: {sa:?} vs {sb:?}"
        );
        for body in 0..model.bodies.len() {
            assert_eq!(
                fast.is_active(&model, body),
                slow.is_active(&model, body),
                "step {k}: body {body}"
            );
        }
        a.q.copy_from_slice(&b.q);
        a.qd.copy_from_slice(&b.qd);
    }
}

#[test]
fn gravity_moves_a_free_body_without_changing_its_joint_accelerations() {
    // A free-floating body under uniform gravity: every handle's bias acceleration of a
    // subassembly not holding the ground shifts by a_g and no internal joint acceleration
    // changes (the caches leave gravity out of such nodes' tensors). Checked on the whole
    // body's exact solve: internal q̈ equal with and without gravity, to 1e-9.
    for name in ["humanoid", "chain30", "rope"] {
        let model = load(name, true);
        let mut s = State::random(&model, 3, 1.0);
        s.randomize_forces(4, 0.01);
        let mut with = Data::new(&model);
        let qa = forward_dynamics_slices(
            &model,
            &mut with,
            &s.q,
            &s.qd,
            &s.tau,
            &s.f_ext,
            Method::Dca,
        )
        .unwrap()
        .to_vec();
        let mut without = Data::new(&model);
        without.gravity = glam::DVec3::ZERO;
        let qb = forward_dynamics_slices(
            &model,
            &mut without,
            &s.q,
            &s.qd,
            &s.tau,
            &s.f_ext,
            Method::Dca,
        )
        .unwrap()
        .to_vec();
        let base = model.bodies[0].nv;
        let d = max_diff(&qa[base..], &qb[base..]);
        assert!(d <= 1e-9 * max_abs(&qa).max(1.0), "{name}: {d:e}");
        // The base itself does feel it.
        assert!(max_diff(&qa[..base], &qb[..base]) > 1.0, "{name}");
        // The same through the adaptive solver (articulated coefficients with a_g).
        let mut ad = caches(Adaptive::new(&model, Settings::default()));
        let x = ad
            .forward_dynamics(&model, &s.q, &s.qd, &s.tau, &s.f_ext)
            .unwrap()
            .to_vec();
        ad.data.gravity = glam::DVec3::ZERO;
        let y = ad
            .forward_dynamics(&model, &s.q, &s.qd, &s.tau, &s.f_ext)
            .unwrap()
            .to_vec();
        let d = max_diff(&x[base..], &y[base..]);
        assert!(d <= 1e-9 * max_abs(&x).max(1.0), "{name}: adaptive {d:e}");
    }
}

#[test]
fn a_cached_reselection_touches_the_active_region_only() {
    // Once the caches exist, a re-selection at budget 50 visits a number of nodes bounded by
    // the active region, the same bound on chains of 1,000 and 10,000 links.
    let mut counts = Vec::new();
    for n in [1000usize, 10_000] {
        let model = articula_testkit::chain(n);
        let mut s = State::random(&model, 42, 0.0);
        s.qd.fill(0.0);
        s.f_ext.clear();
        let mut ad = caches(Adaptive::new(
            &model,
            Settings {
                budget: Some(50),
                reselect_every: 1,
                ..Settings::default()
            },
        ));
        let first = ad.step(&model, &mut s, 1e-4).unwrap();
        // The first re-selection builds every cache: O(n).
        assert!(first.nodes_touched > n, "{n}: {}", first.nodes_touched);
        let mut most = 0;
        for _ in 0..20 {
            let r = ad.step(&model, &mut s, 1e-4).unwrap();
            assert!(r.reselected);
            assert_eq!(r.active_dofs, 50);
            most = most.max(r.nodes_touched);
        }
        // Old and new active regions (≤ 51 joins each, ≤ 52 frontier nodes), the nodes the
        // selection reaches below the frontier, rebuilt caches and the step's reduced tree.
        assert!(most <= 10 * 51, "{n}: {most}");
        counts.push(most);
    }
    println!(
        "nodes touched per re-selection: chain1000 {}, chain10000 {}",
        counts[0], counts[1]
    );
}
