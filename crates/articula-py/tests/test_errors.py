"""Bad inputs raise the right exception, with a message naming what is wrong; a fuzz loop of
1,000 random calls never kills the interpreter."""

import os
import subprocess
import sys

import numpy as np
import pytest

import articula
from conftest import model_path

HUMANOID = model_path("humanoid.urdf")


@pytest.fixture(scope="module")
def m():
    return articula.Model.from_urdf(HUMANOID, floating_base=True)


def test_hierarchy():
    for cls in (articula.ModelError, articula.DynamicsError, articula.SceneError):
        assert issubclass(cls, articula.Error) and issubclass(cls, ValueError)
    assert issubclass(articula.DivergenceError, articula.DynamicsError)


def test_missing_file():
    with pytest.raises(articula.ModelError, match="cannot read .*no_such.urdf"):
        articula.Model.from_urdf("no_such.urdf")


@pytest.mark.parametrize("text,match", [
    ("<robot name='x'>", "malformed XML"),
    ("<notarobot/>", "expected <robot>"),
    ("<robot name='r'><link name='a'/><link name='b'/><joint name='j' type='planar'>"
     "<parent link='a'/><child link='b'/></joint></robot>", "planar"),
    ("<robot name='r'><link name='a'/><link name='b'/><joint name='j' type='bogus'>"
     "<parent link='a'/><child link='b'/></joint></robot>", "unknown type 'bogus'"),
])
def test_bad_urdf(text, match):
    with pytest.raises(articula.ModelError, match=match):
        articula.Model.from_urdf(text)


def test_bad_options():
    with pytest.raises(articula.ModelError, match="inertia must be"):
        articula.Model.from_urdf(HUMANOID, inertia="maybe")
    with pytest.raises(articula.ModelError, match="bound_mass"):
        articula.Model.from_urdf(HUMANOID, bound_mass=1.0)  # needs inertia="repair"
    with pytest.raises(articula.ModelError, match="source must be"):
        articula.Model.from_urdf(42)


def test_shapes(m):
    d = articula.Data(m)
    q, v, tau = m.random_state(1)
    with pytest.raises(articula.DynamicsError, match=r"q has shape \(40,\), the model needs \(41,\)"):
        articula.forward_dynamics(m, d, q[:-1], v, tau)
    with pytest.raises(articula.DynamicsError, match="v has shape"):
        articula.forward_dynamics(m, d, q, v[None, :], tau)
    with pytest.raises(articula.DynamicsError, match="tau has shape"):
        articula.forward_dynamics(m, d, q, v, np.zeros(3))
    with pytest.raises(articula.DynamicsError, match=r"f_ext has shape"):
        articula.forward_dynamics(m, d, q, v, tau, f_ext=np.zeros((m.nbodies, 3)))
    with pytest.raises(articula.DynamicsError, match="Q0 has shape"):
        articula.rollout(m, np.zeros((2, 5)), np.zeros((2, m.nv)))
    with pytest.raises(articula.DynamicsError, match="V has shape"):
        articula.forward_dynamics_batch(m, np.tile(q, (3, 1)), np.zeros((2, m.nv)), np.zeros((3, m.nv)))
    with pytest.raises(articula.DynamicsError, match="TAU has shape"):
        articula.rollout(m, np.tile(q, (2, 1)), np.zeros((2, m.nv)), np.zeros((2, 3, m.nv)), steps=4)


def test_dtypes(m):
    d = articula.Data(m)
    q, v, tau = m.random_state(1)
    with pytest.raises(TypeError, match="q has dtype int64"):
        articula.forward_dynamics(m, d, q.astype(np.int64), v, tau)
    with pytest.raises(TypeError, match="v has dtype float32"):
        articula.forward_dynamics(m, d, q, v.astype(np.float32), tau)
    with pytest.raises(TypeError, match="tau is not an array of numbers"):
        articula.forward_dynamics(m, d, q, v, ["a"] * m.nv)
    # Lists of numbers and non-contiguous float64 arrays are read (copied).
    a = articula.forward_dynamics(m, d, list(q), v, tau)
    wide = np.zeros((m.nv, 2))
    wide[:, 0] = tau
    assert np.array_equal(articula.forward_dynamics(m, d, q, v, wide[:, 0]), a)


def test_non_finite_named_by_joint(m):
    d = articula.Data(m)
    q, v, tau = m.random_state(1)
    j = m.joint_names[5]
    bad = v.copy()
    bad[m.idx_v(j)] = np.nan
    with pytest.raises(articula.DynamicsError, match=f"non-finite qd at {j}"):
        articula.forward_dynamics(m, d, q, bad, tau)
    bad = tau.copy()
    bad[m.idx_v(j)] = np.inf
    with pytest.raises(articula.DynamicsError, match=f"non-finite tau at {j}"):
        articula.forward_dynamics(m, d, q, v, bad)
    with pytest.raises(articula.DynamicsError, match="non-finite"):
        articula.simulate(m, q, np.full(m.nv, np.nan), steps=2)


def test_non_unit_quaternion(m):
    d = articula.Data(m)
    q, v, tau = m.random_state(1)
    q[3:7] *= 1.5
    for call in (lambda: articula.forward_dynamics(m, d, q, v, tau),
                 lambda: articula.mass_matrix(m, d, q),
                 lambda: articula.forward_kinematics(m, d, q),
                 lambda: articula.rollout(m, q[None, :], v[None, :], steps=1)):
        with pytest.raises(articula.DynamicsError, match="floating_base has norm 1.5"):
            call()


def test_wrong_data_and_missing_kinematics(m):
    other = articula.Model.from_urdf(HUMANOID)
    d = articula.Data(other)
    q, v, tau = m.random_state(1)
    with pytest.raises(articula.DynamicsError, match="made for another model"):
        articula.forward_dynamics(m, d, q, v, tau)
    fresh = articula.Data(m)
    with pytest.raises(articula.DynamicsError, match="no kinematics"):
        articula.com(m, fresh)
    articula.forward_kinematics(m, fresh, q)
    with pytest.raises(articula.ModelError, match="no link named 'nope'"):
        articula.link_pose(m, fresh, "nope")
    with pytest.raises(articula.DynamicsError, match="frame must be"):
        articula.jacobian(m, fresh, m.body_names[1], frame="body")


def test_bad_step_options(m):
    q, v = m.rest(), np.zeros(m.nv)
    with pytest.raises(articula.DynamicsError, match="dt must be"):
        articula.simulate(m, q, v, dt=-1.0)
    with pytest.raises(articula.DynamicsError, match="integrator must be"):
        articula.simulate(m, q, v, integrator="verlet")
    with pytest.raises(articula.DynamicsError, match="unknown method"):
        articula.simulate(m, q, v, method="fast")
    with pytest.raises(articula.DynamicsError, match="ground must be"):
        articula.simulate(m, q, v, ground="floor")
    with pytest.raises(articula.DynamicsError, match="tolerance"):
        articula.Adaptive(m, tolerance=-1.0)


def test_bad_scenes(tmp_path):
    with pytest.raises(articula.SceneError, match="cannot read scene file"):
        articula.Scene.from_file(tmp_path / "none.json")
    p = tmp_path / "bad.json"
    p.write_text('{"models": {"h": "%s"}, "bodies": [{"model": "nobody", "position": [0,0,1]}],'
                 ' "camera": {"eye": [0,0,1], "target": [1,0,1]}}' % HUMANOID)
    with pytest.raises(articula.SceneError, match="nobody"):
        articula.Scene.from_file(p)
    with pytest.raises(articula.SceneError):
        articula.SceneBuilder().build()


FUZZ = r'''
import numpy as np, articula, sys
rng = np.random.default_rng(int(sys.argv[2]))
m = articula.Model.from_urdf(sys.argv[1], floating_base=True)
fixed = articula.Model.from_urdf(sys.argv[1])
d = articula.Data(m)
def arr():
    k = rng.integers(0, 9)
    n = [m.nq, m.nv, m.nq - 1, 0, 6, 3][rng.integers(0, 6)]
    x = rng.normal(size=n) * 10 ** rng.uniform(-3, 6)
    if k == 0: return x.astype(np.int32)
    if k == 1: return None
    if k == 2: x[rng.integers(0, max(n, 1)) if n else 0:] = np.nan; return x
    if k == 3: return [str(t) for t in x]
    if k == 4: return x.reshape(1, -1)
    if k == 5: return np.inf * x
    return x
calls = [
    lambda: articula.forward_dynamics(m, d, arr(), arr(), arr(), method=["dca", "aba", "crba", "x"][rng.integers(0, 4)]),
    lambda: articula.inverse_dynamics(m, d, arr(), arr(), arr()),
    lambda: articula.mass_matrix(m, d, arr()),
    lambda: articula.bias_forces(m, d, arr(), arr()),
    lambda: articula.forward_kinematics(m, d, arr(), arr()),
    lambda: articula.jacobian(m, d, rng.choice(m.body_names + ["x"]), frame=rng.choice(["world", "local", "y"])),
    lambda: articula.link_pose(m, d, rng.choice(m.link_names + ["x"])),
    lambda: articula.com_jacobian(m, d),
    lambda: articula.simulate(m, arr(), arr(), arr(), steps=int(rng.integers(0, 5)), dt=float(rng.choice([1e-3, 0.5, -1.0, np.nan])), ground=rng.choice([None, 0.0])),
    lambda: articula.rollout(m, np.array([arr()]), np.array([arr()]), steps=2),
    lambda: articula.forward_dynamics_batch(m, rng.normal(size=(3, m.nq)), rng.normal(size=(3, m.nv)), rng.normal(size=(int(rng.integers(2, 4)), m.nv))),
    lambda: articula.forward_dynamics(fixed, d, arr(), arr(), arr()),
    lambda: articula.Model.from_urdf(rng.choice(["<robot", "<robot name='a'/>", "/nonexistent", "<robot name='r'><link name='a'/></robot>"])),
]
ok = errors = 0
for i in range(1000):
    try:
        calls[rng.integers(0, len(calls))]()
        ok += 1
    except (articula.Error, TypeError, ValueError) as e:
        errors += 1
print(ok, errors)
'''


def test_fuzz_never_kills_the_interpreter(tmp_path):
    script = tmp_path / "fuzz.py"
    script.write_text(FUZZ)
    for seed in (1, 2):
        r = subprocess.run([sys.executable, str(script), HUMANOID, str(seed)],
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, f"exit {r.returncode}: {r.stderr[-2000:]}"
        ok, errors = map(int, r.stdout.split())
        assert ok + errors == 1000 and errors > 100
