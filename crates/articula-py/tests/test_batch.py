"""Batches equal the single-state loop bit for bit, for any thread count; rollouts equal
simulate; the GIL is released during long calls."""

import threading
import time

import numpy as np
import pytest

import articula
from conftest import model_path


@pytest.fixture(scope="module")
def humanoid():
    return articula.Model.from_urdf(model_path("humanoid.urdf"), floating_base=True)


def states(model, n, seed0=1):
    Q, V, T = zip(*(model.random_state(seed0 + i) for i in range(n)))
    return np.array(Q), np.array(V), np.array(T)


@pytest.mark.parametrize("method", ["dca", "aba", "crba"])
@pytest.mark.parametrize("threads", [1, 2, 3])
def test_forward_dynamics_batch_equals_loop(humanoid, method, threads):
    Q, V, T = states(humanoid, 37)
    A = articula.forward_dynamics_batch(humanoid, Q, V, T, method=method, threads=threads)
    data = articula.Data(humanoid)
    loop = np.array([articula.forward_dynamics(humanoid, data, q, v, t, method=method)
                     for q, v, t in zip(Q, V, T)])
    assert A.shape == (37, humanoid.nv)
    assert np.array_equal(A, loop)


@pytest.mark.parametrize("ground", [None, 0.0])
def test_rollout_equals_simulate(humanoid, ground):
    n, steps = 6, 40
    Q0 = np.tile(humanoid.rest(), (n, 1))
    Q0[:, 2] = 1.05 + 0.01 * np.arange(n)  # the pelvis just above the floor
    V0 = np.zeros((n, humanoid.nv))
    V0[:, :3] = np.random.default_rng(0).uniform(-1, 1, (n, 3))
    TAU = np.random.default_rng(1).uniform(-2, 2, (n, humanoid.nv))
    TAU[:, :6] = 0.0
    runs = [articula.rollout(humanoid, Q0, V0, TAU, steps=steps, dt=1e-3, ground=ground,
                             threads=k) for k in (1, 2, 4)]
    for Q, V in runs[1:]:
        assert np.array_equal(Q, runs[0][0]) and np.array_equal(V, runs[0][1])
    Q, V = runs[0]
    assert Q.shape == (n, steps, humanoid.nq) and V.shape == (n, steps, humanoid.nv)
    for i in range(n):
        r = articula.simulate(humanoid, Q0[i], V0[i], TAU[i], steps=steps, dt=1e-3,
                              ground=ground, max_energy_growth=None)
        assert np.array_equal(Q[i], r["q"][1:]) and np.array_equal(V[i], r["v"][1:])


def test_rollout_per_step_torques(humanoid):
    n, steps = 3, 10
    Q0, V0 = np.tile(humanoid.rest(), (n, 1)), np.zeros((n, humanoid.nv))
    TAU = np.random.default_rng(2).uniform(-1, 1, (n, steps, humanoid.nv))
    Q, _ = articula.rollout(humanoid, Q0, V0, TAU, steps=steps, dt=1e-3)
    for i in range(n):
        r = articula.simulate(humanoid, Q0[i], V0[i], TAU[i], steps=steps, dt=1e-3)
        assert np.array_equal(Q[i], r["q"][1:])


def test_step_equals_simulate(humanoid):
    state = articula.State.rest(humanoid)
    state.v[:3] = [0.3, -0.2, 0.1]
    q0, v0 = state.q.copy(), state.v.copy()
    data = articula.Data(humanoid)
    for _ in range(25):
        articula.step(humanoid, data, state, 1e-3)
    r = articula.simulate(humanoid, q0, v0, steps=25, dt=1e-3)
    assert np.array_equal(state.q, r["q"][-1]) and np.array_equal(state.v, r["v"][-1])
    assert state.t == pytest.approx(0.025)


def test_gil_released_python_runs_during_a_rollout(humanoid):
    """While one thread is inside a long rollout, the main thread keeps running Python code
    (with the GIL held it could not run at all between the call's start and end)."""
    n, steps = 16, 200
    Q0, V0 = np.tile(humanoid.rest(), (n, 1)), np.zeros((n, humanoid.nv))
    window = {}

    def call():
        window["start"] = time.perf_counter()
        articula.rollout(humanoid, Q0, V0, steps=steps, dt=1e-3, threads=1)
        window["end"] = time.perf_counter()

    t = threading.Thread(target=call)
    ticks = []
    t.start()
    while t.is_alive():
        ticks.append(time.perf_counter())
    t.join()
    a, b = window["start"], window["end"]
    inside = [x for x in ticks if a + 0.2 * (b - a) < x < b - 0.2 * (b - a)]
    assert b - a > 0.02, "the call must be long enough to measure"
    assert len(inside) > 100, f"the main thread ran {len(inside)} times during the call"


def test_gil_released_two_threads_take_the_time_of_one(humanoid):
    """Two Python threads each calling a long single-threaded rollout take about the time of
    one call on 2 cores, not the time of two in a row (best of 3, alternated)."""
    import os
    if (os.cpu_count() or 1) < 2:
        pytest.skip("needs 2 cores")
    load = os.getloadavg()[0]
    if load > 0.5 * (os.cpu_count() or 1):
        pytest.skip(f"the machine is busy (load average {load:.1f}): two free cores are needed "
                    "to time two threads side by side")
    n, steps = 16, 150
    Q0, V0 = np.tile(humanoid.rest(), (n, 1)), np.zeros((n, humanoid.nv))

    def call():
        articula.rollout(humanoid, Q0, V0, steps=steps, dt=1e-3, threads=1)

    call()
    serial, parallel = np.inf, np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        call()
        call()
        serial = min(serial, time.perf_counter() - t0)
        ts = [threading.Thread(target=call) for _ in range(2)]
        t0 = time.perf_counter()
        for t in ts:
            t.start()
        for t in ts:
            t.join()
        parallel = min(parallel, time.perf_counter() - t0)
    # Serialised by a held GIL the two would take as long as two calls in a row.
    assert parallel < 0.8 * serial, f"two threads took {parallel:.3f} s, two calls in a row {serial:.3f} s"
