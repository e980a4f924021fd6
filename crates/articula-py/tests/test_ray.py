"""articula.ray: rollouts sharded over a local Ray cluster started and stopped here. Skipped,
with the reason, when Ray is not installed."""

import os

import numpy as np
import pytest

import articula
from conftest import model_path

ray = pytest.importorskip("ray", reason="Ray is not installed (pip install ray): articula.ray untested")
import articula.ray as aray  # noqa: E402

HUMANOID = model_path("humanoid.urdf")


@pytest.fixture(scope="module")
def cluster():
    ray.init(num_cpus=2, include_dashboard=False, ignore_reinit_error=True, log_to_driver=False)
    yield
    aray.shutdown()
    ray.shutdown()


def states(model, n):
    rng = np.random.default_rng(3)
    Q0 = np.tile(model.rest(), (n, 1))
    Q0[:, 2] = 1.1
    V0 = np.zeros((n, model.nv))
    V0[:, 6:] = rng.uniform(-0.5, 0.5, (n, model.nv - 6))
    return Q0, V0


@pytest.mark.parametrize("ground", [None, 0.0])
def test_sharded_rollouts_equal_local(cluster, ground):
    model = articula.Model.from_urdf(HUMANOID, floating_base=True)
    Q0, V0 = states(model, 64)
    local = articula.rollout(model, Q0, V0, steps=30, dt=1e-3, ground=ground)
    remote = aray.rollouts(HUMANOID, Q0, V0, steps=30, dt=1e-3, ground=ground,
                           floating_base=True, num_workers=2)
    assert np.array_equal(remote[0], local[0]) and np.array_equal(remote[1], local[1])


def test_workers_are_reused(cluster):
    a = aray.workers(HUMANOID, num_workers=2, floating_base=True, inertia="accept")
    b = aray.workers(HUMANOID, num_workers=2, floating_base=True, inertia="accept")
    assert a is b


def test_killed_worker_is_a_clear_error_then_recovers(cluster):
    model = articula.Model.from_urdf(HUMANOID, floating_base=True)
    Q0, V0 = states(model, 8)
    pool = aray.workers(HUMANOID, num_workers=2, floating_base=True, inertia="accept")
    ray.kill(pool[1])
    with pytest.raises(aray.WorkerError, match="worker 1 of 2"):
        aray.rollouts(HUMANOID, Q0, V0, steps=5, floating_base=True, num_workers=2, timeout=120)
    Q, _ = aray.rollouts(HUMANOID, Q0, V0, steps=5, floating_base=True, num_workers=2, timeout=120)
    assert np.array_equal(Q, articula.rollout(model, Q0, V0, steps=5)[0])


def test_bad_inputs_raise_articula_errors(cluster):
    model = articula.Model.from_urdf(HUMANOID, floating_base=True)
    Q0, V0 = states(model, 4)
    with pytest.raises(articula.DynamicsError):
        aray.rollouts(HUMANOID, Q0, V0, steps=2, dt=-1.0, floating_base=True, num_workers=2)


CROWD200 = model_path("scenes/crowd200.json")
CROWD_STEPS = 300


def run_in_periods(scene, steps, every):
    """Steps `scene` (articula.Scene or ShardedScene): every step's summary, and every
    body's (share, error) after each re-selection."""
    out, shares = [], []
    while len(out) < steps:
        first = scene.step()
        assert first["reselected"] == (len(out) % every == 0)
        out.append(first)
        if first["reselected"]:
            shares.append(scene.selection())
        n = min(every - 1, steps - len(out))
        if isinstance(scene, articula.Scene):
            out.extend(scene.step() for _ in range(n))
        elif n:
            out.extend(scene.run(n))
    return out, shares


@pytest.fixture(scope="module")
def crowd_one_process():
    scene = articula.Scene.from_file(CROWD200, threads=1)
    steps, shares = run_in_periods(scene, CROWD_STEPS, 10)
    Q = [scene.q(b) for b in range(scene.nbodies)]
    V = [scene.v(b) for b in range(scene.nbodies)]
    return steps, shares, Q, V, scene.state_hash()


@pytest.mark.parametrize("shards", [2, 3])
def test_sharded_crowd_equals_one_process(cluster, crowd_one_process, shards):
    steps, shares, Q, V, h = crowd_one_process
    scene = aray.ShardedScene(CROWD200, num_shards=shards, threads=1, timeout=600)
    try:
        assert len({p for p in scene.pids}) == shards
        got, got_shares = run_in_periods(scene, CROWD_STEPS, scene.reselect_every)
        assert got == steps  # every step's summary, the weighted error to the bit
        assert len(got_shares) == CROWD_STEPS // 10 and got_shares == shares
        q, v = scene.states()
        assert len(q) == len(Q) == 200
        assert all(np.array_equal(a, b) for a, b in zip(q, Q))
        assert all(np.array_equal(a, b) for a, b in zip(v, V))
        assert scene.state_hash() == h
        # Some bodies moved, some were hidden, some had joints: not a trivial run.
        assert steps[-1]["invisible"] > 0 and steps[-1]["visible"] > 0
        assert steps[-1]["active_total"] > 0
        ex = scene.exchanges
        assert len(ex) == CROWD_STEPS // 10
        assert all(e["bytes_candidates_up"] > 0 and e["bytes_depth_up"] > 0 for e in ex)
    finally:
        scene.shutdown()


def test_killed_shard_is_a_clear_error(cluster):
    scene = aray.ShardedScene(CROWD200, num_shards=2, threads=1, timeout=120)
    scene.run(15)
    ray.kill(scene.actors()[1])
    with pytest.raises(aray.WorkerError, match="shard 1 of 2 died"):
        scene.run(10)
    # The scene stays dead: no silent restart from lost states.
    with pytest.raises(aray.WorkerError, match="cannot continue"):
        scene.step()


def test_shard_counts_and_budgets_that_do_not_fit_are_refused(cluster, tmp_path):
    with pytest.raises(ValueError, match="num_shards"):
        aray.ShardedScene(CROWD200, num_shards=0)
    with pytest.raises(articula.SceneError, match="201 shards for 200 bodies"):
        aray.ShardedScene(CROWD200, num_shards=201)
    # Shards of the same crowd read with two budgets: the merge refuses them.
    import json
    spec = json.load(open(CROWD200))
    spec["models"] = {k: os.path.join(os.path.dirname(CROWD200), v)
                      for k, v in spec["models"].items()}
    spec["budget"] = 1000
    other = tmp_path / "crowd200_budget1000.json"
    other.write_text(json.dumps(spec))
    a = articula.SceneShard.from_file(CROWD200, 0, 2, threads=1)
    b = articula.SceneShard.from_file(str(other), 1, 2, threads=1)
    merged = articula._articula.shard_merge_depths([a.begin(), b.begin()])
    parts = [a.weigh(merged), b.weigh(merged)]
    with pytest.raises(articula.SceneError, match="budget Some\\(1000\\)"):
        articula._articula.shard_merge_candidates(parts)
    with pytest.raises(articula.SceneError, match="expected shard 0"):
        articula._articula.shard_merge_candidates(parts[::-1])
