"""articula: forward dynamics of articulated bodies from Python.

Featherstone's divide-and-conquer algorithm (DCA) with ABA and CRBA as references, inverse
dynamics, mass matrix, Jacobians, centre of mass, energies and momentum; time stepping with
ground contact and joint limits; adaptive dynamics; view-dependent crowd scenes; batches on
every core. The API follows Pinocchio's free functions::

    import articula, numpy as np
    model = articula.Model.from_urdf("models/humanoid.urdf", floating_base=True)
    data = articula.Data(model)
    q, v, tau = model.neutral(), np.zeros(model.nv), np.zeros(model.nv)
    qdd = articula.forward_dynamics(model, data, q, v, tau)

Conventions (docs/conventions.md, docs/python.md): a floating joint's q is
[x, y, z, qw, qx, qy, qz], its velocity [wx, wy, wz, vx, vy, vz] in the body's own frame
(angular first) and its force [n; f]; Jacobian rows are [angular; linear]; external wrenches
f_ext are (nbodies, 6) arrays of [n; f] in world coordinates about the world origin. Arrays
are float64; C-contiguous ones are read without a copy.
"""

import json as _json
import os as _os
from dataclasses import dataclass as _dataclass, field as _field
from typing import Optional as _Optional, Sequence as _Sequence

import numpy as _np

from ._errors import DivergenceError, DynamicsError, Error, ModelError, SceneError
from ._articula import (
    Adaptive,
    Data,
    Model,
    Scene,
    SceneShard,
    __version__,
    bias_forces,
    passive_forces,
    centroidal_momentum,
    com,
    com_jacobian,
    forward_dynamics,
    forward_dynamics_batch,
    forward_kinematics,
    inverse_dynamics,
    jacobian,
    kinetic_energy,
    link_pose,
    mass_matrix,
    momentum,
    potential_energy,
    rollout,
    simulate,
)
from . import _articula

__all__ = [
    "Adaptive", "Data", "DivergenceError", "DynamicsError", "Error", "Ground", "Model",
    "ModelError", "Scene", "SceneBuilder", "SceneShard", "SceneError", "State", "bias_forces", "passive_forces",
    "centroidal_momentum", "com", "com_jacobian", "forward_dynamics", "forward_dynamics_batch",
    "forward_kinematics", "inverse_dynamics", "jacobian", "kinetic_energy", "link_pose",
    "mass_matrix", "momentum", "potential_energy", "rollout", "simulate", "step",
]


class State:
    """A state of one model: q (nq), v (nv), tau (nv) as float64 arrays, f_ext (None or
    (nbodies, 6) wrenches [n; f] in world coordinates about the world origin) and the time t.
    `step` updates q, v and t in place (the arrays keep their identity)."""

    def __init__(self, model: Model, q=None, v=None, tau=None, f_ext=None, t: float = 0.0):
        self.q = _np.array(model.rest() if q is None else q, dtype=_np.float64)
        self.v = _np.zeros(model.nv) if v is None else _np.array(v, dtype=_np.float64)
        self.tau = _np.zeros(model.nv) if tau is None else _np.array(tau, dtype=_np.float64)
        self.f_ext = f_ext
        self.t = float(t)

    @classmethod
    def neutral(cls, model: Model) -> "State":
        """The neutral configuration at rest (every angle 0)."""
        return cls(model, q=model.neutral())

    @classmethod
    def rest(cls, model: Model) -> "State":
        """The rest configuration at rest (limited joints inside their limits)."""
        return cls(model, q=model.rest())

    def __repr__(self) -> str:
        return f"articula.State(t={self.t}, q={self.q!r}, v={self.v!r})"


@_dataclass
class Ground:
    """A ground plane: the half-space normal·(x − point) ≥ 0 is free. Coulomb friction
    `friction`, restitution `restitution` (0: inelastic impacts). `Ground(height=h)` is the
    horizontal floor z = h."""

    height: float = 0.0
    normal: _Sequence[float] = (0.0, 0.0, 1.0)
    friction: float = 1.0
    restitution: float = 0.0
    point: _Optional[_Sequence[float]] = None

    def __post_init__(self):
        if self.point is None:
            self.point = (0.0, 0.0, float(self.height))


def step(model: Model, data: Data, state: State, dt: float, integrator: _Optional[str] = None,
         method: str = "dca", ground=None, joint_limits: bool = False) -> State:
    """Advances `state` by dt in place and returns it.

    integrator: "rk4" (default without contact) or "euler" (semi-implicit; the only one with
    a ground or joint limits). method: "dca", "aba" or "crba". ground: None, a height (the
    floor z = height, friction 1) or an articula.Ground. joint_limits: enforce the URDF limits.
    Raises articula.DynamicsError (bad shapes, NaN, non-unit quaternions, a singular body).
    """
    q, v = _articula.step_arrays(model, data, state.q, state.v, state.tau, state.f_ext, dt,
                                 integrator, method, ground, joint_limits)
    state.q[...] = q
    state.v[...] = v
    state.t += dt
    return state


class SceneBuilder:
    """Builds a scene spec (the JSON of docs/view.md) in code; `build()` returns a Scene.

    ::

        scene = (articula.SceneBuilder()
                 .model("humanoid", "models/humanoid.urdf")
                 .crowd("humanoid", rows=2, columns=3, origin=(4, -1, 1.021), spacing=(1.2, 0.9))
                 .camera(eye=(0, 0, 1.4), target=(12, 0, 1.1))
                 .budget(200).ground(0.0).joint_springs(2.0, 0.2)
                 .build())
    """

    def __init__(self):
        self.spec = {"models": {}, "bodies": [], "crowds": [], "pushes": []}

    def model(self, name: str, path) -> "SceneBuilder":
        """A model: a name and a URDF path (loaded with a floating base)."""
        self.spec["models"][name] = _os.fspath(_os.path.abspath(path))
        return self

    def body(self, model: str, position, name: _Optional[str] = None, rpy=None,
             velocity=None) -> "SceneBuilder":
        """One character at `position` (m), optional rpy (rad) and
        velocity {"linear": [..], "angular": [..]} (world frame)."""
        b = {"model": model, "position": list(map(float, position))}
        if name is not None:
            b["name"] = name
        if rpy is not None:
            b["rpy"] = list(map(float, rpy))
        if velocity is not None:
            b["velocity"] = velocity
        self.spec["bodies"].append(b)
        return self

    def crowd(self, model: str, rows: int, columns: int, origin, spacing, name: _Optional[str] = None,
              **extra) -> "SceneBuilder":
        """A grid of characters (rows along +x, columns along +y); extra keys: jitter, seed,
        yaw, yaw_jitter, velocity."""
        c = {"model": model, "rows": int(rows), "columns": int(columns),
             "origin": list(map(float, origin)), "spacing": list(map(float, spacing)), **extra}
        if name is not None:
            c["name"] = name
        self.spec["crowds"].append(c)
        return self

    def camera(self, eye, target, **extra) -> "SceneBuilder":
        """A fixed camera; extra keys: up, fov_y_deg, near, far."""
        self.spec["camera"] = {"eye": list(map(float, eye)), "target": list(map(float, target)),
                               **extra}
        return self

    def push(self, link: str, force, t0: float, t1: float, bodies="all", point=None) -> "SceneBuilder":
        """A force (world, N) at a point of `link` (link frame, m) during t0 <= t < t1."""
        p = {"bodies": bodies, "link": link, "force": list(map(float, force)),
             "t0": float(t0), "t1": float(t1)}
        if point is not None:
            p["point"] = list(map(float, point))
        self.spec["pushes"].append(p)
        return self

    def budget(self, joints: int) -> "SceneBuilder":
        """The scene-wide joint budget per step."""
        self.spec["budget"] = int(joints)
        return self

    def dt(self, dt: float) -> "SceneBuilder":
        """The time step (s)."""
        self.spec["dt"] = float(dt)
        return self

    def reselect_every(self, steps: int) -> "SceneBuilder":
        """Steps between re-selections."""
        self.spec["reselect_every"] = int(steps)
        return self

    def ground(self, height: float = 0.0, friction: float = 1.0, restitution: float = 0.0) -> "SceneBuilder":
        """The floor z = height (contact and joint limits on)."""
        self.spec["ground"] = {"height": float(height), "friction": float(friction),
                               "restitution": float(restitution)}
        return self

    def joint_springs(self, frequency_hz: float, damping_ratio: float) -> "SceneBuilder":
        """Pose springs holding every character's rest pose."""
        self.spec["joint_springs"] = {"frequency_hz": float(frequency_hz),
                                      "damping_ratio": float(damping_ratio)}
        return self

    def image(self, width: int, height: int) -> "SceneBuilder":
        """The frame size in pixels."""
        self.spec["image"] = {"width": int(width), "height": int(height)}
        return self

    def set(self, key: str, value) -> "SceneBuilder":
        """Any other key of the scene file (gravity, tolerance, visibility, ...)."""
        self.spec[key] = value
        return self

    def to_json(self) -> str:
        """The scene file's text."""
        return _json.dumps(self.spec, indent=2)

    def build(self, inertia: str = "accept", threads: _Optional[int] = None) -> Scene:
        """The scene, ready to step (raises articula.SceneError naming the field)."""
        return Scene.from_json(self.to_json(), base=_os.getcwd(), inertia=inertia,
                               threads=threads)
