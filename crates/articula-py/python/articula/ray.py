"""Rollouts sharded over a Ray cluster (optional: ``pip install ray``; importing ``articula``
does not need it).

::

    import ray, articula.ray
    ray.init()                                           # or ray.init(address="auto")
    Q, V = articula.ray.rollouts("models/humanoid.urdf", Q0, V0, TAU, steps=200, dt=1e-3,
                                 floating_base=True, num_workers=8)

The initial states are split into ``num_workers`` contiguous shards, each rolled out by one Ray
actor with ``articula.rollout`` on that actor's cores; the results come back in the caller's
order. Each actor builds its ``Model`` once from the URDF text (sent once, not per call) and is
kept for the following calls with the same model, options and worker count (``shutdown()``
drops them). Every trajectory is stepped with a fresh workspace, so the result equals the local
``articula.rollout`` bit for bit on machines of the same CPU features (DCA picks a fused
multiply–add kernel where the CPU has one: docs/python.md).

A worker that dies mid-call (a killed actor, a lost node) raises :class:`WorkerError` naming its
shard; the pool is dropped and the next call starts new workers. Nothing is retried silently.
"""

import hashlib
import os

import numpy as np

from . import Error, Model, rollout

__all__ = ["WorkerError", "rollouts", "shutdown"]


class WorkerError(Error, RuntimeError):
    """A Ray worker died or failed during a sharded call; the message names the shard."""


_POOLS = {}


def _ray():
    try:
        import ray
    except ImportError as e:  # pragma: no cover - exercised only without ray
        raise ImportError("articula.ray needs Ray: pip install ray") from e
    if not ray.is_initialized():
        raise RuntimeError("Ray is not initialised: call ray.init() (or ray.init(address=...)) first")
    return ray


def _urdf_text(source):
    text = source if isinstance(source, str) and source.lstrip().startswith("<") else None
    if text is None:
        with open(os.fspath(source), encoding="utf-8") as f:
            text = f.read()
    return text


def _worker_class(ray):
    @ray.remote
    class RolloutWorker:
        """Holds one Model, built once from the URDF text."""

        def __init__(self, urdf_text, options):
            self.model = Model.from_urdf(urdf_text, **options)

        def rollout(self, Q0, V0, TAU, kwargs):
            return rollout(self.model, Q0, V0, TAU, **kwargs)

        def pid(self):
            return os.getpid()

    return RolloutWorker


def _pool(ray, text, options, num_workers):
    key = (hashlib.sha256(text.encode()).hexdigest(), tuple(sorted(options.items())), num_workers)
    pool = _POOLS.get(key)
    if pool is None:
        cls = _worker_class(ray)
        ref = ray.put(text)
        pool = [cls.remote(ref, options) for _ in range(num_workers)]
        _POOLS[key] = pool
    return key, pool


def workers(model_source, num_workers=2, **options):
    """The actors ``rollouts`` would use for this model (made if needed): for tests and for
    ``ray.kill``."""
    ray = _ray()
    return _pool(ray, _urdf_text(model_source), options, num_workers)[1]


def shutdown():
    """Kills every worker this module started."""
    try:
        import ray
    except ImportError:  # pragma: no cover
        _POOLS.clear()
        return
    for pool in _POOLS.values():
        for actor in pool:
            try:
                ray.kill(actor)
            except Exception:  # an actor already gone
                pass
    _POOLS.clear()


def rollouts(model_source, Q0, V0, TAU=None, steps=100, dt=1e-3, num_workers=2,
             floating_base=False, inertia="accept", timeout=None, **step_options):
    """``articula.rollout`` sharded over ``num_workers`` Ray actors.

    model_source: a URDF path or URDF text (the workers load it with ``floating_base`` and
    ``inertia``). Q0 (n, nq), V0 (n, nv), TAU None, (n, nv) or (n, steps, nv); the other keyword
    arguments are rollout's (integrator, method, ground, joint_limits, threads). Returns
    (Q (n, steps, nq), V (n, steps, nv)) in the caller's order. Raises WorkerError when a
    worker dies, articula's own exceptions when a shard's inputs are wrong, and
    ``ray.exceptions.GetTimeoutError`` after ``timeout`` seconds.
    """
    ray = _ray()
    if num_workers < 1:
        raise ValueError(f"num_workers must be at least 1, got {num_workers}")
    options = {"floating_base": bool(floating_base), "inertia": inertia}
    key, pool = _pool(ray, _urdf_text(model_source), options, num_workers)
    Q0 = np.ascontiguousarray(Q0, dtype=np.float64)
    V0 = np.ascontiguousarray(V0, dtype=np.float64)
    if Q0.ndim != 2 or V0.ndim != 2 or len(Q0) != len(V0):
        raise ValueError(f"Q0 and V0 must be (n, nq) and (n, nv), got {Q0.shape} and {V0.shape}")
    n = len(Q0)
    bounds = np.linspace(0, n, num_workers + 1).round().astype(int)
    kwargs = dict(steps=steps, dt=dt, **step_options)
    refs = []
    for w, (a, b) in enumerate(zip(bounds[:-1], bounds[1:])):
        tau = None if TAU is None else np.ascontiguousarray(np.asarray(TAU, dtype=np.float64)[a:b])
        refs.append((w, a, b, pool[w].rollout.remote(Q0[a:b], V0[a:b], tau, kwargs)))
    parts = []
    for w, a, b, ref in refs:
        try:
            parts.append(ray.get(ref, timeout=timeout))
        except ray.exceptions.RayActorError as e:
            _POOLS.pop(key, None)
            for actor in pool:
                try:
                    ray.kill(actor)
                except Exception:
                    pass
            raise WorkerError(f"worker {w} of {num_workers} (states {a}..{b}) died: {e}; "
                              "the pool is dropped, the next call starts new workers") from e
        except ray.exceptions.RayTaskError as e:
            cause = e.as_instanceof_cause() if hasattr(e, "as_instanceof_cause") else e
            if isinstance(cause, Error):
                raise cause from None
            raise WorkerError(f"worker {w} of {num_workers} (states {a}..{b}) failed: {e}") from e
    Q = np.concatenate([p[0] for p in parts], axis=0)
    V = np.concatenate([p[1] for p in parts], axis=0)
    return Q, V
