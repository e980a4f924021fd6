"""The rest of the API: model metadata, identities between the functions, stepping with
contact and limits, the energy guard, adaptive dynamics, scenes and the builder."""

import os

import numpy as np
import pytest

import articula
from conftest import model_path

HUMANOID = model_path("humanoid.urdf")


@pytest.fixture(scope="module")
def humanoid():
    return articula.Model.from_urdf(HUMANOID, floating_base=True)


def test_model_metadata(humanoid):
    m = humanoid
    assert (m.nq, m.nv) == (41, 40) and m.floating_base
    assert m.joint_names[0] == "floating_base" and m.joint_size("floating_base") == (7, 6)
    assert m.idx_q("floating_base") == 0 and m.idx_v(m.joint_names[1]) == 6
    assert len(m.body_names) == m.nbodies
    assert np.array_equal(m.neutral()[3:7], [1, 0, 0, 0])
    lo, hi = m.lower_limits, m.upper_limits
    assert lo.shape == (m.nq,) and np.all(lo <= hi) and np.all(np.isinf(lo[:7]))
    r = m.rest()
    assert np.all((r >= lo) & (r <= hi))
    assert m.mass > 0 and "humanoid" in repr(m)


def test_from_string_equals_from_file(humanoid):
    text = open(HUMANOID).read()
    m = articula.Model.from_urdf(text, floating_base=True)
    q, v, tau = m.random_state(3)
    a = articula.forward_dynamics(m, articula.Data(m), q, v, tau)
    b = articula.forward_dynamics(humanoid, articula.Data(humanoid), q, v, tau)
    assert np.array_equal(a, b)


def test_identities(humanoid):
    m, d = humanoid, articula.Data(humanoid)
    q, v, tau = m.random_state(5)
    f = np.zeros((m.nbodies, 6))
    f[3] = [0.1, -0.2, 0.3, 5.0, -3.0, 2.0]
    a = articula.forward_dynamics(m, d, q, v, tau, f_ext=f)
    assert np.allclose(articula.inverse_dynamics(m, d, q, v, a, f_ext=f), tau, atol=1e-9)
    M = articula.mass_matrix(m, d, q)
    b = articula.bias_forces(m, d, q, v)
    a0 = articula.forward_dynamics(m, d, q, v, tau)
    assert np.allclose(M @ a0 + b, tau, atol=1e-9)
    assert np.allclose(M, M.T, atol=0) and np.all(np.linalg.eigvalsh(M) > 0)
    articula.forward_kinematics(m, d, q, v)
    assert articula.kinetic_energy(m, d) == pytest.approx(0.5 * v @ M @ v, rel=1e-12)
    Jc = articula.com_jacobian(m, d)
    h = articula.momentum(m, d)
    assert np.allclose(h[3:], m.mass * Jc @ v, rtol=1e-12, atol=1e-12)


def test_simulate_conserves_energy_without_forces(humanoid):
    r = articula.simulate(humanoid, humanoid.rest(), np.zeros(humanoid.nv), steps=300, dt=1e-3)
    assert r["q"].shape == (301, 41) and r["t"][-1] == pytest.approx(0.3)
    e = r["energy"]
    assert np.max(np.abs(e - e[0])) < 1e-6 * max(1.0, abs(e[0]))


def test_energy_guard_raises_divergence():
    """A stiff chain stepped with a huge dt diverges: the guard names the step."""
    m = articula.Model.from_urdf(model_path("chain30.urdf"))
    q0 = np.full(m.nq, 0.5)
    with pytest.raises(articula.DivergenceError, match="energy grew"):
        articula.simulate(m, q0, np.zeros(m.nv), steps=2000, dt=0.2, integrator="euler")


def test_ground_holds_a_dropped_humanoid(humanoid):
    q0 = humanoid.rest()
    q0[2] = 1.3
    r = articula.simulate(humanoid, q0, np.zeros(humanoid.nv), steps=800, dt=1e-3, ground=0.0,
                          max_energy_growth=None)
    z = r["q"][:, 2]
    assert z[-1] > 0.1, "the pelvis went through the floor"
    free = articula.simulate(humanoid, q0, np.zeros(humanoid.nv), steps=800, dt=1e-3)
    assert free["q"][-1, 2] < 0.0, "without a ground it falls through z = 0"
    with pytest.raises(articula.DynamicsError, match="semi-implicit Euler"):
        articula.simulate(humanoid, q0, np.zeros(humanoid.nv), steps=2, ground=0.0,
                          integrator="rk4")


def test_joint_limits_hold():
    """5 N·m on every limited joint of the welded humanoid: without limits the joints pass
    their upper limits by radians within 50 ms; with them, by no more than the solver's slop."""
    m = articula.Model.from_urdf(HUMANOID)
    lo, hi = m.lower_limits, m.upper_limits
    limited = np.isfinite(lo)
    tau = np.where(limited, 5.0, 0.0)
    over = lambda q: np.max(q[:, limited] - hi[limited])
    free = articula.simulate(m, m.rest(), np.zeros(m.nv), tau, steps=50, dt=1e-3,
                             integrator="euler", max_energy_growth=None)
    assert over(free["q"]) > 1.0
    r = articula.simulate(m, m.rest(), np.zeros(m.nv), tau, steps=500, dt=1e-3,
                          joint_limits=True, max_energy_growth=None)
    assert over(r["q"]) < 0.01


def test_adaptive_budget_and_full(humanoid):
    q0 = humanoid.rest()
    v0 = np.zeros(humanoid.nv)
    v0[6:] = np.random.default_rng(4).uniform(-1, 1, humanoid.nv - 6)
    ad = articula.Adaptive(humanoid, q0, v0, budget=10)
    rep = ad.step(1e-3)
    assert set(rep) == {"reselected", "rigidified", "active_dofs", "predicted_error", "nodes_touched"}
    assert rep["active_dofs"] <= 10 + 6 and ad.selection["budget_used"] <= 10
    assert ad.selection["predicted_error"] >= 0.0
    # With every joint active, adaptive dynamics is exact DCA to rounding (welded base:
    # the DCA step's momentum projection of free-floating bodies has no adaptive counterpart).
    fixed = articula.Model.from_urdf(HUMANOID)
    q0, v0 = fixed.rest(), np.random.default_rng(4).uniform(-1, 1, fixed.nv)
    full = articula.Adaptive(fixed, q0, v0)
    state = articula.State(fixed, q0, v0)
    data = articula.Data(fixed)
    for _ in range(20):
        full.step(1e-3)
        articula.step(fixed, data, state, 1e-3, integrator="euler")
    assert np.allclose(full.q, state.q, rtol=0, atol=1e-11)
    assert np.allclose(full.v, state.v, rtol=0, atol=1e-9)


def test_scene_builder_steps_and_writes_frames(tmp_path, root):
    scene = (articula.SceneBuilder()
             .model("humanoid", HUMANOID)
             .crowd("humanoid", rows=2, columns=2, origin=(4, -0.5, 1.021), spacing=(1.2, 0.9),
                    name="crowd")
             .camera(eye=(0, 0, 1.4), target=(12, 0, 1.1))
             .budget(40).dt(1 / 600).reselect_every(5).ground(0.0).joint_springs(2.0, 0.2)
             .image(160, 90)
             .build(threads=2))
    assert scene.nbodies == 4 and scene.body_name(0) == "crowd[0,0]"
    for _ in range(10):
        s = scene.step()
    assert s["active_total"] <= 40
    summary = scene.summary()
    assert summary["steps"] == 10 and summary["bodies"] == 4 and summary["dof_total"] == 4 * 34
    frame, mp = scene.save_frame(tmp_path, 10)
    assert os.path.getsize(frame) > 0 and os.path.getsize(mp) > 0
    q = scene.q(0)
    assert q.shape == (41,) and abs(np.linalg.norm(q[3:7]) - 1) < 1e-12
    # The same spec from a file gives the same bits.
    path = tmp_path / "s.json"
    spec = (articula.SceneBuilder().model("humanoid", HUMANOID)
            .crowd("humanoid", rows=2, columns=2, origin=(4, -0.5, 1.021), spacing=(1.2, 0.9))
            .camera(eye=(0, 0, 1.4), target=(12, 0, 1.1))
            .budget(40).dt(1 / 600).reselect_every(5).ground(0.0).joint_springs(2.0, 0.2)
            .image(160, 90))
    path.write_text(spec.to_json())
    again = articula.Scene.from_file(path, threads=1)
    for _ in range(10):
        again.step()
    assert all(np.array_equal(again.q(b), scene.q(b)) for b in range(4))


def test_bundled_scene_loads(root):
    scene = articula.Scene.from_file(os.path.join(root, "models", "scenes", "crowd200.json"))
    assert scene.nbodies == 200
    scene.step()
    assert scene.summary()["visible"] + scene.summary()["occluded"] + scene.summary()["invisible"] == 200
