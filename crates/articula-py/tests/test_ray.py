"""articula.ray: rollouts sharded over a local Ray cluster started and stopped here. Skipped,
with the reason, when Ray is not installed."""

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
