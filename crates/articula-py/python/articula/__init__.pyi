"""Type stubs of articula (docs/python.md). Arrays are float64 numpy arrays; shapes in the
docstrings: nq, nv the model's sizes, nbodies its moving bodies."""

from os import PathLike
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from ._errors import (DivergenceError as DivergenceError, DynamicsError as DynamicsError,
                      Error as Error, ModelError as ModelError, SceneError as SceneError)

__version__: str

Array = npt.NDArray[np.float64]
ArrayLike = npt.ArrayLike
GroundLike = Union[None, float, "Ground"]


class Model:
    """An articulated model loaded from a URDF or an MJCF file (immutable)."""

    @staticmethod
    def from_urdf(source: Union[str, PathLike], floating_base: bool = False,
                  inertia: str = "accept", massless_leaf: str = "lock",
                  bound_mass: Optional[float] = None,
                  bound_inertia: Optional[float] = None) -> "Model":
        """Loads a URDF from a path or from URDF text; raises ModelError."""
    @staticmethod
    def from_mjcf(source: Union[str, PathLike], inertia: str = "accept",
                  massless_leaf: str = "lock", bound_mass: Optional[float] = None,
                  bound_inertia: Optional[float] = None) -> "Model":
        """Loads an MJCF (MuJoCo XML) model from a path or from MJCF text; the file decides
        its base; raises ModelError."""
    @staticmethod
    def from_file(path: Union[str, PathLike], floating_base: bool = False,
                  inertia: str = "accept", massless_leaf: str = "lock",
                  bound_mass: Optional[float] = None,
                  bound_inertia: Optional[float] = None) -> "Model":
        """Loads a URDF or an MJCF file, by its content; raises ModelError."""
    @property
    def name(self) -> str: ...
    @property
    def nq(self) -> int: ...
    @property
    def nv(self) -> int: ...
    @property
    def floating_base(self) -> bool: ...
    @property
    def nbodies(self) -> int: ...
    @property
    def body_names(self) -> List[str]: ...
    @property
    def link_names(self) -> List[str]: ...
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def locked_joints(self) -> List[str]: ...
    @property
    def warnings(self) -> List[str]: ...
    @property
    def mass(self) -> float: ...
    @property
    def lower_limits(self) -> Array:
        """(nq,), -inf where none."""
    @property
    def upper_limits(self) -> Array:
        """(nq,), +inf where none."""
    def idx_q(self, name: str) -> int: ...
    def idx_v(self, name: str) -> int: ...
    def joint_size(self, name: str) -> Tuple[int, int]: ...
    def neutral(self) -> Array:
        """(nq,) every angle 0, identity orientations."""
    def rest(self) -> Array:
        """(nq,) neutral, limited coordinates moved inside their limits."""
    def random_state(self, seed: int, tau_scale: float = 1.0) -> Tuple[Array, Array, Array]:
        """(q, v, tau), reproducible."""
    def body_inertias(self) -> List[Tuple[float, Array, Array]]:
        """(mass, centre of mass (3,), inertia about it (3, 3)) per body, body frame."""


class Data:
    """The workspace of one model's dynamics calls."""

    def __init__(self, model: Model) -> None: ...
    gravity: Array


class State:
    """q (nq,), v (nv,), tau (nv,), f_ext None or (nbodies, 6), time t; step updates it."""

    q: Array
    v: Array
    tau: Array
    f_ext: Optional[Array]
    t: float

    def __init__(self, model: Model, q: Optional[ArrayLike] = None, v: Optional[ArrayLike] = None,
                 tau: Optional[ArrayLike] = None, f_ext: Optional[ArrayLike] = None,
                 t: float = 0.0) -> None: ...
    @classmethod
    def neutral(cls, model: Model) -> "State": ...
    @classmethod
    def rest(cls, model: Model) -> "State": ...


class Ground:
    """A ground plane (horizontal at `height` unless `normal`/`point` say otherwise)."""

    height: float
    normal: Sequence[float]
    friction: float
    restitution: float
    point: Optional[Sequence[float]]

    def __init__(self, height: float = 0.0, normal: Sequence[float] = (0.0, 0.0, 1.0),
                 friction: float = 1.0, restitution: float = 0.0,
                 point: Optional[Sequence[float]] = None) -> None: ...


def forward_dynamics(model: Model, data: Data, q: ArrayLike, v: ArrayLike, tau: ArrayLike,
                     f_ext: Optional[ArrayLike] = None, method: str = "dca") -> Array:
    """q̈ (nv,) by "dca", "aba" or "crba"."""
def inverse_dynamics(model: Model, data: Data, q: ArrayLike, v: ArrayLike, a: ArrayLike,
                     f_ext: Optional[ArrayLike] = None) -> Array:
    """tau (nv,) by the recursive Newton–Euler algorithm."""
def mass_matrix(model: Model, data: Data, q: ArrayLike) -> Array:
    """M(q) (nv, nv), symmetric."""
def bias_forces(model: Model, data: Data, q: ArrayLike, v: ArrayLike) -> Array:
    """b(q, v) (nv,): M q̈ + b = tau."""
def forward_kinematics(model: Model, data: Data, q: ArrayLike,
                       v: Optional[ArrayLike] = None) -> None: ...
def link_pose(model: Model, data: Data, link: str) -> Tuple[Array, Array]:
    """(R (3, 3), p (3,)) of a URDF link in the world."""
def jacobian(model: Model, data: Data, link: str, frame: str = "local_world_aligned") -> Array:
    """(6, nv), rows [ω; v]; frame "world", "local" or "local_world_aligned"."""
def com(model: Model, data: Data) -> Array:
    """(3,) centre of mass, world."""
def com_jacobian(model: Model, data: Data) -> Array:
    """(3, nv)."""
def kinetic_energy(model: Model, data: Data) -> float: ...
def potential_energy(model: Model, data: Data) -> float: ...
def momentum(model: Model, data: Data) -> Array:
    """(6,) [angular; linear] about the world origin."""
def centroidal_momentum(model: Model, data: Data) -> Array:
    """(6,) [angular; linear] about the centre of mass."""
def step(model: Model, data: Data, state: State, dt: float, integrator: Optional[str] = None,
         method: str = "dca", ground: GroundLike = None, joint_limits: bool = False) -> State:
    """Advances state by dt in place."""
def simulate(model: Model, q0: ArrayLike, v0: ArrayLike, tau: Optional[ArrayLike] = None,
             steps: int = 1000, dt: float = 1e-3, integrator: Optional[str] = None,
             method: str = "dca", ground: GroundLike = None, joint_limits: bool = False,
             max_energy_growth: Optional[float] = 0.5) -> Dict[str, Array]:
    """{"t": (steps+1,), "q": (steps+1, nq), "v": (steps+1, nv), "energy": (steps+1,)}."""
def forward_dynamics_batch(model: Model, Q: ArrayLike, V: ArrayLike, TAU: ArrayLike,
                           method: str = "dca", threads: Optional[int] = None) -> Array:
    """q̈ (n, nv) of n states, across cores."""
def rollout(model: Model, Q0: ArrayLike, V0: ArrayLike, TAU: Optional[ArrayLike] = None,
            steps: int = 100, dt: float = 1e-3, integrator: Optional[str] = None,
            method: str = "dca", ground: GroundLike = None, joint_limits: bool = False,
            threads: Optional[int] = None) -> Tuple[Array, Array]:
    """(Q (n, steps, nq), V (n, steps, nv)), across cores."""

def passive_forces(model: Model, q: ArrayLike, v: ArrayLike) -> Array:
    """Passive joint forces -damping v - stiffness (q - springref) (MuJoCo's qfrc_passive)."""


class Adaptive:
    """Adaptive dynamics of one model, owning its state."""

    def __init__(self, model: Model, q0: Optional[ArrayLike] = None,
                 v0: Optional[ArrayLike] = None, budget: Optional[int] = None,
                 tolerance: Optional[float] = None, reselect_every: int = 0,
                 velocity_tolerance: Optional[float] = None) -> None: ...
    def step(self, dt: float, integrator: str = "euler") -> Dict[str, Any]: ...
    q: Array
    v: Array
    tau: Array
    @property
    def qdd(self) -> Array: ...
    @property
    def selection(self) -> Dict[str, Any]: ...
    @property
    def active_dofs(self) -> int: ...


class Scene:
    """A view-dependent crowd scene."""

    @staticmethod
    def from_file(path: Union[str, PathLike], inertia: str = "accept",
                  threads: Optional[int] = None) -> "Scene": ...
    @staticmethod
    def from_json(text: str, base: Optional[Union[str, PathLike]] = None,
                  inertia: str = "accept", threads: Optional[int] = None) -> "Scene": ...
    def step(self) -> Dict[str, Any]: ...
    @property
    def steps(self) -> int: ...
    @property
    def time(self) -> float: ...
    @property
    def dt(self) -> float: ...
    @property
    def nbodies(self) -> int: ...
    def body_name(self, b: int) -> str: ...
    def q(self, b: int) -> Array: ...
    def v(self, b: int) -> Array: ...
    def summary(self) -> Dict[str, Any]: ...
    def save_frame(self, dir: Union[str, PathLike], index: int) -> Tuple[str, str]: ...
    def state_hash(self) -> int: ...
    def selection(self) -> List[Tuple[int, float]]: ...


class SceneShard:
    """One shard of a scene split by body (articula.ray.ShardedScene drives them)."""

    @staticmethod
    def from_file(path: Union[str, PathLike], index: int, count: int, inertia: str = "accept",
                  threads: Optional[int] = None) -> "SceneShard": ...
    @property
    def range(self) -> Tuple[int, int, int, int, int]: ...
    @property
    def reselect_every(self) -> int: ...
    @property
    def steps(self) -> int: ...
    def reselects_next(self) -> bool: ...
    def begin(self) -> bytes: ...
    def weigh(self, merged: bytes) -> bytes: ...
    def apply(self, taken: int, then: int = 0) -> List[bytes]: ...
    def advance(self, max: int) -> List[bytes]: ...
    def state_hash(self) -> Tuple[int, int]: ...
    def states(self) -> Tuple[List[Array], List[Array]]: ...
    def selection(self) -> List[Tuple[int, float]]: ...


class SceneBuilder:
    """Builds a scene spec (docs/view.md) in code."""

    spec: Dict[str, Any]

    def __init__(self) -> None: ...
    def model(self, name: str, path: Union[str, PathLike]) -> "SceneBuilder": ...
    def body(self, model: str, position: Sequence[float], name: Optional[str] = None,
             rpy: Optional[Sequence[float]] = None, velocity: Optional[dict] = None) -> "SceneBuilder": ...
    def crowd(self, model: str, rows: int, columns: int, origin: Sequence[float],
              spacing: Sequence[float], name: Optional[str] = None, **extra: Any) -> "SceneBuilder": ...
    def camera(self, eye: Sequence[float], target: Sequence[float], **extra: Any) -> "SceneBuilder": ...
    def push(self, link: str, force: Sequence[float], t0: float, t1: float,
             bodies: Union[str, List[str]] = "all",
             point: Optional[Sequence[float]] = None) -> "SceneBuilder": ...
    def budget(self, joints: int) -> "SceneBuilder": ...
    def dt(self, dt: float) -> "SceneBuilder": ...
    def reselect_every(self, steps: int) -> "SceneBuilder": ...
    def ground(self, height: float = 0.0, friction: float = 1.0,
               restitution: float = 0.0) -> "SceneBuilder": ...
    def joint_springs(self, frequency_hz: float, damping_ratio: float) -> "SceneBuilder": ...
    def image(self, width: int, height: int) -> "SceneBuilder": ...
    def set(self, key: str, value: Any) -> "SceneBuilder": ...
    def to_json(self) -> str: ...
    def build(self, inertia: str = "accept", threads: Optional[int] = None) -> Scene: ...
