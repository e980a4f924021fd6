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

A crowd scene split by character over Ray actors, with the scene-wide joint budget exact::

    scene = articula.ray.ShardedScene("models/scenes/crowd200.json", num_shards=2)
    summaries = scene.run(300)                           # as articula.Scene.step, per step
    Q, V = scene.states()                                # every body's, in the scene's order
    scene.shutdown()

Each actor (:class:`articula.SceneShard`) steps its contiguous run of the characters on its own
threads; at each re-selection the driver merges the shards' depth buffers and their candidate
pops (the merge of the one-process queue) and sends each shard its share: the states, the
shares and the step summaries equal the one-process ``articula.Scene``'s bit for bit
(docs/scaling.md). The scene file and its models must be readable at the same path on every
node.
"""

import hashlib
import os
import time

import numpy as np

from . import Error, Model, _articula, rollout

__all__ = ["ShardedScene", "WorkerError", "rollouts", "shutdown"]


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


def _shard_class(ray):
    @ray.remote
    class ShardWorker:
        """Holds one articula.SceneShard; the stepping calls return their result and the
        seconds they computed."""

        def __init__(self, path, index, count, inertia, threads):
            from . import SceneShard
            # A scene or shard count that cannot be used is raised by info(), as the
            # library's exception (a failing constructor would read as a dead actor).
            self.shard, self.error = None, None
            try:
                self.shard = SceneShard.from_file(path, index, count, inertia=inertia,
                                                  threads=threads)
            except Error as e:
                self.error = e

        def info(self):
            if self.error is not None:
                raise self.error
            return self.shard.range, self.shard.reselect_every, os.getpid()

        def _timed(self, f, *args):
            t0 = time.perf_counter()
            out = f(*args)
            return out, time.perf_counter() - t0

        def begin(self):
            return self._timed(self.shard.begin)

        def weigh(self, merged):
            return self._timed(self.shard.weigh, merged)

        def apply(self, taken, then):
            return self._timed(self.shard.apply, taken, then)

        def advance(self, n):
            return self._timed(self.shard.advance, n)

        def state_hash(self):
            return self.shard.state_hash()

        def states(self):
            return self.shard.states()

        def selection(self):
            return self.shard.selection()

    return ShardWorker


class ShardedScene:
    """A crowd scene split by character over ``num_shards`` Ray actors (each an
    ``articula.SceneShard`` on ``threads`` threads), with the scene-wide joint budget exact.

    scene: a scene file's path (every node reads it and its models at that path). ``step()``
    returns what ``articula.Scene.step`` returns, the same numbers. ``exchanges`` records, per
    re-selection, the bytes sent each way and the times (docs/scaling.md). A shard that dies
    raises :class:`WorkerError` naming it; the scene cannot continue (the shard's bodies are
    lost) and every later call raises it again. ``timeout`` (s) bounds every wait.
    """

    def __init__(self, scene, num_shards=2, threads=1, inertia="accept", timeout=None):
        self._ray = ray = _ray()
        if not isinstance(num_shards, int) or num_shards < 1:
            raise ValueError(f"num_shards must be a positive integer, got {num_shards!r}")
        self.path = os.path.abspath(os.fspath(scene))
        self.num_shards = num_shards
        self.timeout = timeout
        self._dead = None
        self.steps = 0
        self._last_error = 0.0
        self.exchanges = []
        cls = _shard_class(ray)
        self._actors = [cls.remote(self.path, k, num_shards, inertia, threads)
                        for k in range(num_shards)]
        try:
            info = self._get([a.info.remote() for a in self._actors], "starting")
        except Error:
            self.shutdown()
            raise
        self.ranges = [r for r, _, _ in info]
        self.total = self.ranges[0][4]
        self.reselect_every = info[0][1]
        self.pids = [p for _, _, p in info]

    def _get(self, refs, what):
        if self._dead is not None:
            raise WorkerError(self._dead)
        ray = self._ray
        out = []
        for k, ref in enumerate(refs):
            try:
                out.append(ray.get(ref, timeout=self.timeout))
            except ray.exceptions.RayActorError as e:
                self._dead = (f"shard {k} of {self.num_shards} died while {what} at step "
                              f"{self.steps}: {e}; the sharded scene cannot continue (its "
                              "bodies' states are lost): start a new ShardedScene")
                self.shutdown()
                raise WorkerError(self._dead) from e
            except ray.exceptions.RayTaskError as e:
                cause = e.as_instanceof_cause() if hasattr(e, "as_instanceof_cause") else e
                if isinstance(cause, Error):
                    raise cause from None
                raise WorkerError(f"shard {k} of {self.num_shards} failed while {what}: {e}") from e
        return out

    def _combine(self, parts):
        d = _articula.shard_combine_steps(parts, self.total, self._last_error)
        self._last_error = d["weighted_error"]
        return d

    def _reselect(self, left):
        """One re-selection's three exchanges, then up to the next re-selection or ``left``
        steps; their summaries."""
        t0 = time.perf_counter()
        depths = self._get([a.begin.remote() for a in self._actors], "solving")
        t1 = time.perf_counter()
        merged = _articula.shard_merge_depths([d for d, _ in depths])
        cands = self._get([a.weigh.remote(merged) for a in self._actors], "weighing")
        t2 = time.perf_counter()
        taken = _articula.shard_merge_candidates([c for c, _ in cands])
        then = min(left, self.reselect_every) - 1
        applied = self._get([a.apply.remote(k, then) for a, k in zip(self._actors, taken)],
                            "stepping")
        t3 = time.perf_counter()
        self.exchanges.append({
            "step": self.steps,
            "bytes_depth_up": sum(len(d) for d, _ in depths),
            "bytes_depth_down": len(merged) * self.num_shards,
            "bytes_candidates_up": sum(len(c) for c, _ in cands),
            "bytes_counts_down": 8 * self.num_shards,
            "seconds": [t1 - t0, t2 - t1, t3 - t2],
            "shard_seconds": [[d[1] for d in depths], [c[1] for c in cands],
                              [a[1] for a in applied]],
            "steps": then + 1,
            "taken": taken,
        })
        steps = [s for s, _ in applied]
        return [self._combine([p[i] for p in steps]) for i in range(len(steps[0]))]

    def step(self):
        """Advances every body by the scene's dt; returns the step's summary (as
        ``articula.Scene.step``)."""
        return self.run(1)[-1]

    def run(self, steps):
        """Advances ``steps`` steps; returns their summaries."""
        out = []
        while len(out) < steps:
            left = steps - len(out)
            if self.steps % self.reselect_every == 0:
                new = self._reselect(left)
            else:
                n = min(left, self.reselect_every - self.steps % self.reselect_every)
                runs = [r for r, _ in self._get([a.advance.remote(n) for a in self._actors],
                                                "stepping")]
                new = [self._combine([r[i] for r in runs]) for i in range(len(runs[0]))]
            out.extend(new)
            self.steps += len(new)
        return out

    def states(self):
        """(Q, V): every body's positions and velocities (lists of arrays, the scene's body
        order), gathered from the shards."""
        parts = self._get([a.states.remote() for a in self._actors], "gathering states")
        return [q for p in parts for q in p[0]], [v for p in parts for v in p[1]]

    def selection(self):
        """Per body: (its share of the budget, its weighted error) at the last re-selection."""
        parts = self._get([a.selection.remote() for a in self._actors], "gathering shares")
        return [x for p in parts for x in p]

    def state_hash(self):
        """The state hash of the whole scene (as ``articula.Scene.state_hash``)."""
        parts = self._get([a.state_hash.remote() for a in self._actors], "hashing")
        return _articula.shard_combine_hashes(parts)

    def actors(self):
        """The shards' actors (for tests and ``ray.kill``)."""
        return list(self._actors)

    def shutdown(self):
        """Kills the shards' actors."""
        for a in self._actors:
            try:
                self._ray.kill(a)
            except Exception:  # an actor already gone
                pass
        self._actors = []
