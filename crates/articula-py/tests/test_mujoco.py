"""Against MuJoCo: MJCF models loaded by articula.Model.from_mjcf and compiled by MuJoCo, the
joint-space inertia M (mj_fullM) and the smooth acceleration qacc_smooth (passive forces
included: forward_dynamics(q, v, passive_forces(q, v))), on random states.

Coordinates: hinges, slides and ball joints (quaternion [w, x, y, z], angular velocity in the
child frame) are MuJoCo's. A free joint is q = [x, y, z, qw, qx, qy, qz] on both sides; its
velocity is [w; v] in the body frame here and [v_world; w_body] in MuJoCo, so qvel = P v with
P = [[0, R], [I, 0]], M_mujoco = P M Pᵀ and MuJoCo's linear acceleration is R (v̇ + w × v).

Error: max |x - x_mj| / max(1, max |x_mj|); the bound is 1e-10 for every quantity.
"""

import numpy as np
import pytest

import articula
from conftest import model_path

mujoco = pytest.importorskip("mujoco", reason="MuJoCo (pip install mujoco) is not installed")

TOL = 1e-10

# Every joint kind and the passive terms MuJoCo adds: armature, damping, a hinge spring
# (stiffness about springref), springdamper (stiffness and damping from the joint's inertia),
# a slide and a ball joint, on a fixed base.
KINDS = """
<mujoco model="kinds">
  <compiler angle="radian"/>
  <option gravity="0.3 -0.2 -9.81"/>
  <worldbody>
    <body name="a" pos="0 0 1">
      <joint name="hinge" type="hinge" axis="0.3 1 0.2" armature="0.05" damping="0.7"
             stiffness="3" springref="0.2"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 -0.1" size="0.04" mass="1.3"/>
      <body name="b" pos="0.3 0 -0.1">
        <joint name="ball" type="ball" damping="0.2" armature="0.01"/>
        <geom type="box" size="0.05 0.08 0.12" pos="0.02 0 -0.1" mass="0.9"/>
        <body name="c" pos="0 0 -0.25">
          <joint name="slide" type="slide" axis="1 0.2 -0.1" damping="1.5" armature="0.1"/>
          <geom type="sphere" size="0.06" mass="0.4"/>
          <body name="d" pos="0.1 0 0">
            <joint name="spring" type="hinge" axis="0 0 1" springdamper="0.5 0.8"/>
            <geom type="cylinder" fromto="0 0 0 0.2 0 0" size="0.03" mass="0.3"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def rel_err(x, ref):
    x, ref = np.asarray(x), np.asarray(ref)
    return float(np.max(np.abs(x - ref)) / max(1.0, float(np.max(np.abs(ref)))))


def quat_to_matrix(w, x, y, z):
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


class Map:
    """articula's coordinates to MuJoCo's, joint by joint (matched by name)."""

    def __init__(self, model, mj):
        self.nq, self.nv = model.nq, model.nv
        self.parts = []
        names = set()
        for j in range(mj.njnt):
            name = mujoco.mj_id2name(mj, mujoco.mjtObj.mjOBJ_JOINT, j)
            names.add(name)
            kind = int(mj.jnt_type[j])
            nq, nv = model.joint_size(name)
            expected = {0: (7, 6), 1: (4, 3), 2: (1, 1), 3: (1, 1)}[kind]
            assert (nq, nv) == expected, f"{name}: articula {nq, nv}, MuJoCo type {kind}"
            self.parts.append((model.idx_q(name), model.idx_v(name), int(mj.jnt_qposadr[j]),
                               int(mj.jnt_dofadr[j]), kind))
        assert sum(model.joint_size(n)[1] for n in names) == model.nv == mj.nv

    def qpos(self, q):
        out = np.empty(self.nq)
        for qo, _, qa, _, kind in self.parts:
            n = {0: 7, 1: 4}.get(kind, 1)
            out[qa:qa + n] = q[qo:qo + n]
        return out

    def p(self, q):
        """P (nv × nv): MuJoCo's qvel = P v."""
        p = np.zeros((self.nv, self.nv))
        for qo, vo, _, da, kind in self.parts:
            if kind == 0:
                r = quat_to_matrix(*q[qo + 3:qo + 7])
                p[da:da + 3, vo + 3:vo + 6] = r
                p[da + 3:da + 6, vo:vo + 3] = np.eye(3)
            else:
                n = 3 if kind == 1 else 1
                p[da:da + n, vo:vo + n] = np.eye(n)
        return p

    def qacc(self, q, v, a):
        """MuJoCo's qacc of our acceleration a at (q, v)."""
        out = self.p(q) @ a
        for qo, vo, _, da, kind in self.parts:
            if kind == 0:
                r = quat_to_matrix(*q[qo + 3:qo + 7])
                out[da:da + 3] += r @ np.cross(v[vo:vo + 3], v[vo + 3:vo + 6])
        return out


def compare(model, mj, seeds=(1, 2, 3)):
    mjd = mujoco.MjData(mj)
    data = articula.Data(model)
    m = Map(model, mj)
    rng = np.random.default_rng(7)
    worst = {"M": 0.0, "dca": 0.0, "aba": 0.0, "crba": 0.0}
    for _ in seeds:
        q = model.neutral()
        for qo, _, _, _, kind in m.parts:
            if kind in (0, 1):
                o = qo + (3 if kind == 0 else 0)
                quat = rng.normal(size=4)
                q[o:o + 4] = quat / np.linalg.norm(quat)
                if kind == 0:
                    q[qo:qo + 3] = rng.uniform(-1, 1, 3)
            else:
                q[qo] = rng.uniform(-1, 1)
        v = rng.uniform(-1, 1, model.nv)
        p = m.p(q)
        mjd.qpos[:] = m.qpos(q)
        mjd.qvel[:] = p @ v
        mujoco.mj_forward(mj, mjd)
        full = np.zeros((mj.nv, mj.nv))
        mujoco.mj_fullM(mj, mjd, full)
        worst["M"] = max(worst["M"], rel_err(p @ articula.mass_matrix(model, data, q) @ p.T, full))
        tau = articula.passive_forces(model, q, v)
        for method in ("dca", "aba", "crba"):
            a = articula.forward_dynamics(model, data, q, v, tau, method=method)
            worst[method] = max(worst[method], rel_err(m.qacc(q, v, a), mjd.qacc_smooth))
    return worst


def test_every_joint_kind_with_passive_forces_matches_mujoco():
    model = articula.Model.from_mjcf(KINDS)
    mj = mujoco.MjModel.from_xml_string(KINDS)
    # The passive terms are not zero here: the comparison includes them.
    q = model.neutral()
    q[model.idx_q("hinge")] = 0.5
    assert np.max(np.abs(articula.passive_forces(model, q, np.ones(model.nv)))) > 0.1
    worst = compare(model, mj)
    print("kinds:", worst)
    assert all(e < TOL for e in worst.values()), worst


def test_ball_humanoid_with_its_free_joint_matches_mujoco():
    path = model_path("humanoid_ball.xml")
    model = articula.Model.from_mjcf(path)
    assert model.floating_base and model.nv == mujoco.MjModel.from_xml_path(path).nv
    worst = compare(model, mujoco.MjModel.from_xml_path(path))
    print("humanoid_ball:", worst)
    assert all(e < TOL for e in worst.values()), worst


def test_from_file_reads_either_format():
    urdf = articula.Model.from_file(model_path("humanoid.urdf"), floating_base=True)
    mjcf = articula.Model.from_file(model_path("humanoid_ball.xml"))
    assert (urdf.nq, urdf.nv) == (41, 40)
    assert mjcf.nv == articula.Model.from_mjcf(model_path("humanoid_ball.xml")).nv
    with pytest.raises(articula.ModelError, match="expected <robot>"):
        articula.Model.from_urdf(model_path("humanoid_ball.xml"))
    with pytest.raises(articula.ModelError):
        articula.Model.from_mjcf(model_path("humanoid.urdf"))
    with pytest.raises(articula.ModelError):
        articula.Model.from_mjcf("<mujoco><worldbody><body><joint type='nope'/></body>"
                                 "</worldbody></mujoco>")
