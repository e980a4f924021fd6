//! A scene split over shards (`SceneShard`, the exchanges of `docs/scaling.md`) against the
//! one-process scene: the same bits for every body, the same share of the budget for every
//! body at every re-selection, the same step summaries — with every message going through its
//! bytes, as between processes. And the clear errors of shards that do not fit together.

use articula_view::{
    combine_state_hashes, combine_steps, merge_candidates, merge_depths, Candidates, DepthMessage,
    LoadedScene, SceneShard, SceneSim, SceneStep, ShardStep, ViewError,
};
use glam::DVec3;
use std::path::PathBuf;

fn crowd200() -> LoadedScene {
    let models = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models");
    articula_view::load_scene(models.join("scenes/crowd200.json")).unwrap()
}

/// Per body: the bits of `q` and `q̇`.
type States = Vec<(Vec<u64>, Vec<u64>)>;
/// Per re-selection: each body's share and error bits.
type Shares = Vec<Vec<(usize, u64)>>;

fn bits(x: &[f64]) -> Vec<u64> {
    x.iter().map(|v| v.to_bits()).collect()
}

fn body_states(sim: &SceneSim) -> States {
    sim.bodies
        .iter()
        .map(|b| (bits(&b.state.q), bits(&b.state.qd)))
        .collect()
}

fn shares(sim: &SceneSim) -> Vec<(usize, u64)> {
    sim.bodies
        .iter()
        .map(|b| (b.allocation, b.error.to_bits()))
        .collect()
}

/// The one-process run: its steps, every re-selection's shares, the final states and hash.
fn whole(scene: &LoadedScene, steps: usize) -> (Vec<SceneStep>, Shares, States, u64) {
    let mut sim = SceneSim::new(scene).unwrap();
    let mut out = Vec::new();
    let mut sel = Vec::new();
    for _ in 0..steps {
        let s = sim.step().unwrap();
        if s.reselected {
            sel.push(shares(&sim));
        }
        out.push(s);
    }
    (out, sel, body_states(&sim), sim.state_hash())
}

/// The scene over `count` shards, driven as a driver in another process drives them: every
/// message through its bytes.
fn sharded(
    scene: &LoadedScene,
    count: usize,
    steps: usize,
) -> (Vec<SceneStep>, Shares, States, u64) {
    let parts: Vec<_> = (0..count).map(|k| scene.shard(k, count).unwrap()).collect();
    let mut shards: Vec<SceneShard> = parts
        .iter()
        .map(|(part, range)| SceneShard::new(part, *range).unwrap())
        .collect();
    let total = scene.placements.len();
    let (mut out, mut sel, mut last_error) = (Vec::new(), Vec::new(), 0.0);
    while out.len() < steps {
        let combined = if shards[0].reselects_next() {
            let depths: Vec<DepthMessage> = shards
                .iter_mut()
                .map(|s| DepthMessage::from_bytes(&s.begin().unwrap().to_bytes()).unwrap())
                .collect();
            let merged = merge_depths(&depths).unwrap().to_bytes();
            let merged = DepthMessage::from_bytes(&merged).unwrap();
            let cands: Vec<Candidates> = shards
                .iter_mut()
                .map(|s| Candidates::from_bytes(&s.weigh(&merged).unwrap().to_bytes()).unwrap())
                .collect();
            let taken = merge_candidates(&cands).unwrap();
            let applied: Vec<ShardStep> = shards
                .iter_mut()
                .zip(&taken)
                .map(|(s, &k)| ShardStep::from_bytes(&s.apply(k).unwrap().to_bytes()).unwrap())
                .collect();
            sel.push(shards.iter().flat_map(|s| shares(s.sim())).collect());
            vec![combine_steps(&applied, total, last_error)]
        } else {
            let left = steps - out.len();
            let runs: Vec<Vec<ShardStep>> = shards
                .iter_mut()
                .map(|s| s.advance(left).unwrap())
                .collect();
            (0..runs[0].len())
                .map(|i| {
                    let step: Vec<ShardStep> = runs.iter().map(|r| r[i].clone()).collect();
                    combine_steps(&step, total, last_error)
                })
                .collect()
        };
        for s in combined {
            last_error = s.total_error;
            out.push(s);
        }
    }
    let states = shards.iter().flat_map(|s| body_states(s.sim())).collect();
    let hashes: Vec<_> = shards.iter().map(SceneShard::state_hash).collect();
    (out, sel, states, combine_state_hashes(&hashes))
}

fn assert_same(scene: &LoadedScene, steps: usize, counts: &[usize], what: &str) {
    let one = whole(scene, steps);
    assert!(one.1.len() >= steps / scene.reselect_every);
    for &count in counts {
        let other = sharded(scene, count, steps);
        for (i, (a, b)) in other.0.iter().zip(&one.0).enumerate() {
            assert_eq!(a, b, "{what}, {count} shards: step {i}'s summary");
        }
        assert_eq!(other.0.len(), one.0.len());
        for (r, (a, b)) in other.1.iter().zip(&one.1).enumerate() {
            assert!(a == b, "{what}, {count} shards: shares at re-selection {r}");
        }
        assert_eq!(other.1.len(), one.1.len());
        assert!(other.2 == one.2, "{what}, {count} shards: body states");
        assert_eq!(other.3, one.3, "{what}, {count} shards: state hash");
    }
}

/// crowd200 on its floor, 300 steps (30 re-selections, the pushes acting for the first 0.5 s,
/// the crowd falling, colliding with the floor and standing): over 2 and 3 shards the same
/// bits as one process, and the same shares at every re-selection.
#[test]
fn crowd200_over_2_and_3_shards_equals_one_process() {
    let scene = crowd200();
    assert!(scene.ground.is_some() && scene.tolerance.is_none());
    assert_same(&scene, 300, &[2, 3], "crowd200");
}

/// With a tolerance that stops the queue before the budget (the roots' masses and the masses
/// each pop adds go through the merge) and a budget small enough that shards cut their
/// sequences: still the same bits.
#[test]
fn a_tolerance_and_a_small_budget_stop_where_one_process_stops() {
    let mut scene = crowd200();
    scene.budget = Some(150);
    assert_same(&scene, 40, &[3], "budget 150");
    // The error budget 400 leaves at the first re-selection, then a tolerance of twice it:
    // the queue stops on the tolerance before the budget is spent.
    scene.budget = Some(400);
    let e400 = SceneSim::new(&scene).unwrap().step().unwrap().total_error;
    scene.tolerance = Some(2.0 * e400);
    let mut sim = SceneSim::new(&scene).unwrap();
    let stopped = sim.step().unwrap();
    let used: usize = sim.bodies.iter().map(|b| b.allocation).sum();
    assert!(
        e400 > 0.0 && stopped.total_error <= 2.0 * e400 && used < 400,
        "{used}"
    );
    assert_same(&scene, 40, &[2, 3], "tolerance");
}

/// Floating in zero gravity without a floor (bodies turning rigid, as `crowd2000.json`).
#[test]
fn a_floating_crowd_over_shards_equals_one_process() {
    let mut scene = crowd200();
    scene.gravity = DVec3::ZERO;
    scene.ground = None;
    assert_same(&scene, 60, &[2], "floating crowd200");
}

fn shard_error(r: Result<impl std::fmt::Debug, ViewError>) -> String {
    match r {
        Err(ViewError::Shard(m)) => m,
        other => panic!("expected a shard error, got {other:?}"),
    }
}

#[test]
fn shards_that_do_not_fit_together_are_refused() {
    let scene = crowd200();
    assert!(shard_error(scene.shard(0, 0)).contains("0 shards for 200 bodies"));
    assert!(shard_error(scene.shard(0, 201)).contains("201 shards for 200 bodies"));
    assert!(shard_error(scene.shard(3, 3)).contains("shard 3 of 3"));
    let (a, ra) = scene.shard(0, 2).unwrap();
    let (b, rb) = scene.shard(1, 2).unwrap();
    assert_eq!(
        (ra.first, ra.bodies, rb.first, rb.bodies),
        (0, 100, 100, 100)
    );
    // Shard 1 loaded with another budget: its sequence is cut elsewhere.
    let mut b_other = b.clone();
    b_other.budget = Some(1000);
    let mut sa = SceneShard::new(&a, ra).unwrap();
    let mut sb = SceneShard::new(&b_other, rb).unwrap();
    // Out of order: weigh or apply before begin, advance while a re-selection is due.
    assert!(shard_error(sa.apply(0)).contains("apply out of order"));
    assert!(
        sa.advance(5).unwrap().is_empty(),
        "a re-selection is due: no step"
    );
    let depths = [sa.begin().unwrap(), sb.begin().unwrap()];
    assert!(shard_error(sa.begin()).contains("begin out of order"));
    let merged = merge_depths(&depths).unwrap();
    let mut short = merged.clone();
    short.depth.pop();
    assert!(shard_error(sa.weigh(&short)).contains("depth buffer of step 0"));
    let ca = sa.weigh(&merged).unwrap();
    let cb = sb.weigh(&merged).unwrap();
    let m = shard_error(merge_candidates(&[ca.clone(), cb.clone()]));
    assert!(
        m.contains("shard 1") && m.contains("budget Some(1000)"),
        "{m}"
    );
    // Out of shard order, or a shard missing.
    let m = shard_error(merge_candidates(&[cb.clone(), ca.clone()]));
    assert!(m.contains("expected shard 0"), "{m}");
    assert!(shard_error(merge_candidates(std::slice::from_ref(&ca)))
        .contains("1 messages for 2 shards"));
    // More pops than the shard sent within the budget.
    assert!(shard_error(sa.apply(ca.pops.len() + 1)).contains("pops taken"));
    // Messages cut short, or of another kind.
    let bytes = ca.to_bytes();
    let m = shard_error(Candidates::from_bytes(&bytes[..bytes.len() - 3]));
    let want = format!("candidates message: {} items do not fit", ca.pops.len());
    assert!(m.contains(&want), "{m}");
    assert!(shard_error(Candidates::from_bytes(&bytes[..20])).contains("cut short"));
    assert!(shard_error(DepthMessage::from_bytes(&bytes)).contains("not a depth buffer"));
    assert!(shard_error(ShardStep::from_bytes(&[])).contains("not a shard step"));
}

/// The messages' sizes: a depth buffer costs its finite cells, candidates 24 bytes a pop.
#[test]
fn messages_round_trip_through_their_bytes() {
    let scene = crowd200();
    let (part, range) = scene.shard(1, 2).unwrap();
    let mut s = SceneShard::new(&part, range).unwrap();
    let d = s.begin().unwrap();
    let bytes = d.to_bytes();
    let finite = d.depth.iter().filter(|x| x.is_finite()).count();
    assert!(finite > 0 && finite < d.depth.len());
    assert!(bytes.len() >= 8 * finite && bytes.len() < 8 * finite + 8 * d.depth.len() / 2);
    assert_eq!(DepthMessage::from_bytes(&bytes).unwrap(), d);
    let c = s.weigh(&d).unwrap();
    let cb = c.to_bytes();
    assert_eq!(Candidates::from_bytes(&cb).unwrap(), c);
    assert!(!c.pops.is_empty() && cb.len() < 24 * c.pops.len() + 128);
    let step = s.apply(c.pops.len() / 2).unwrap();
    assert_eq!(ShardStep::from_bytes(&step.to_bytes()).unwrap(), step);
}
