#!/usr/bin/env python3
"""Pinocchio's side of `cargo xtask corpus`: `pin.aba` on the URDFs of example-robot-data.

Install it once (from the workspace root):

    python3 -m venv target/peers-venv && \
        target/peers-venv/bin/pip install pin mujoco example-robot-data

Usage:
    corpus.py --locate       -> {"robots": DIR, "versions": {...}}
        DIR is example-robot-data's `robots/` directory in this Python's site-packages.
    corpus.py CONFIG.json    -> {"versions": {...}, "results": [...]}

CONFIG.json (written by xtask):
    {"budget_s": 0.1, "min_batches": 4, "compare": true,
     "robots": [{"key": "ur5_robot/fixed", "urdf": PATH, "root": null | "floating_base",
                 "locked": [joint, ...], "inertias": null | {joint: [m, cx, cy, cz,
                 Ixx, Ixy, Ixz, Iyy, Iyz, Izz]},
                 "states": [{joint: [q, qd, tau] | {"q": [7], "v": [6], "tau": [6]}}, ...]}]}

- "root": null welds the root link to the world; a name adds a free-flyer root joint of that
  name (`pin.JointModelFreeFlyer()`).
- A 1-DOF joint's state is its angle (revolute, continuous) or displacement (prismatic), rate
  and force; a continuous joint's Pinocchio coordinates (cos q, sin q) are made here. A 6-DOF
  joint's state is already in Pinocchio's coordinates: q = [x, y, z, qx, qy, qz, qw],
  v = [v; w] and tau = [f; n] in the joint's child frame (xtask converts).
- "locked" joints are removed with `pin.buildReducedModel` at the state's configuration
  (the loader locks a massless moving leaf, whose acceleration is undetermined: Pinocchio
  returns NaN there).
- "inertias" replaces the inertia of the body each named joint moves (centre of mass and
  rotational inertia about it, in the joint's child frame): xtask sends its own bodies'
  under `--inertia repair`, when they are not the URDF's numbers.
- Joints absent from a state stay at Pinocchio's neutral configuration, at rest, unforced.

Each result: {"key", "nq", "nv", "qdd": [{joint: [a, ...]}, ...] (one per state, with
"compare"), "times": [us, ...], "batch"} or {"key", "error": message}. Accelerations of a
6-DOF joint are [a_lin; a_ang] in its child frame, Pinocchio's order.

Timing: `pin.aba(model, data, q, v, tau)` (default convention) at the first state, with the
harness of peers.py (`timed`: a warm-up of a tenth of the budget, batches of >= 200 us,
at least "min_batches" of them); "times" are the per-call times of the batches, which xtask
gathers over its passes. Each call goes through the Python bindings, which costs about a
microsecond more than calling the C++ library directly: it matters only on small models.
"""

import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peers import timed  # noqa: E402  (the same harness as `cargo xtask bench --peers`)


def robots_dir():
    import sysconfig
    for key in ("purelib", "platlib"):
        d = os.path.join(sysconfig.get_paths()[key],
                         "cmeel.prefix", "share", "example-robot-data", "robots")
        if os.path.isdir(d):
            return d
    return None


def versions():
    import importlib.metadata as md
    out = {"python": sys.version.split()[0]}
    for dist in ("pin", "example-robot-data", "numpy"):
        try:
            out[dist] = md.version(dist)
        except md.PackageNotFoundError:
            pass
    return out


def fill(pin, np, model, state):
    """Pinocchio's (q, v, tau) for a state given by joint name."""
    q = pin.neutral(model)
    v = np.zeros(model.nv)
    tau = np.zeros(model.nv)
    for jid in range(1, model.njoints):
        name = model.names[jid]
        if name not in state:
            continue
        j = model.joints[jid]
        s = state[name]
        if isinstance(s, dict):
            if (j.nq, j.nv) != (len(s["q"]), len(s["v"])):
                raise ValueError(f"joint {name}: Pinocchio has nq={j.nq} nv={j.nv}, "
                                 f"the state nq={len(s['q'])} nv={len(s['v'])}")
            q[j.idx_q:j.idx_q + j.nq] = s["q"]
            v[j.idx_v:j.idx_v + j.nv] = s["v"]
            tau[j.idx_v:j.idx_v + j.nv] = s["tau"]
            continue
        jq, jqd, jtau = s
        if j.nv != 1:
            raise ValueError(f"joint {name}: Pinocchio has nv={j.nv}, the state one coordinate")
        if j.nq == 2:  # continuous: (cos, sin)
            q[j.idx_q] = np.cos(jq)
            q[j.idx_q + 1] = np.sin(jq)
        else:
            q[j.idx_q] = jq
        v[j.idx_v] = jqd
        tau[j.idx_v] = jtau
    return q, v, tau


def build(pin, np, spec):
    if spec.get("root"):
        model = pin.buildModelFromUrdf(spec["urdf"], pin.JointModelFreeFlyer(), spec["root"])
    else:
        model = pin.buildModelFromUrdf(spec["urdf"])
    if model.nv and max(abs(model.armature)) != 0.0:
        # URDF has no armature; aba would add it to the joint-space inertia.
        raise ValueError("the model has a non-zero armature")
    for name, x in (spec.get("inertias") or {}).items():
        if not model.existJointName(name):
            raise ValueError(f"inertia given for {name}, not a joint of Pinocchio's model")
        m, c, i = x[0], np.array(x[1:4]), x[4:10]
        rot = np.array([[i[0], i[1], i[2]], [i[1], i[3], i[4]], [i[2], i[4], i[5]]])
        model.inertias[model.getJointId(name)] = pin.Inertia(m, c, rot)
    return model


def at_state(pin, np, full, spec, state):
    """The model to run at `state` (reduced when joints are locked) and its (q, v, tau)."""
    locked = spec.get("locked", [])
    if not locked:
        return (full,) + fill(pin, np, full, state)
    ids = []
    for name in locked:
        if not full.existJointName(name):
            raise ValueError(f"locked joint {name} is not a joint of Pinocchio's model")
        ids.append(full.getJointId(name))
    q_ref = fill(pin, np, full, state)[0]
    model = pin.buildReducedModel(full, ids, q_ref)
    return (model,) + fill(pin, np, model, state)


def run(pin, np, spec, budget_s, min_batches, compare):
    full = build(pin, np, spec)
    out = {"key": spec["key"], "nq": full.nq, "nv": full.nv}
    if compare:
        out["qdd"] = []
        for state in spec["states"]:
            model, q, v, tau = at_state(pin, np, full, spec, state)
            a = pin.aba(model, model.createData(), q, v, tau)
            out["qdd"].append({
                model.names[jid]: [float(x) for x in
                                   a[model.joints[jid].idx_v:
                                     model.joints[jid].idx_v + model.joints[jid].nv]]
                for jid in range(1, model.njoints)})
    if budget_s > 0:
        model, q, v, tau = at_state(pin, np, full, spec, spec["states"][0])
        data = model.createData()
        _, _, batch, times = timed(budget_s, lambda: pin.aba(model, data, q, v, tau),
                                   min_batches)
        out["times"] = times
        out["batch"] = batch
    return out


def main():
    if sys.argv[1:] == ["--locate"]:
        try:
            import pinocchio  # noqa: F401
        except ImportError as e:
            print(f"Pinocchio is not installed in this Python ({sys.executable}): {e}",
                  file=sys.stderr)
            sys.exit(1)
        d = robots_dir()
        if d is None:
            print("example-robot-data is not installed in this Python "
                  f"({sys.executable}): pip install example-robot-data", file=sys.stderr)
            sys.exit(1)
        json.dump({"robots": d, "versions": versions()}, sys.stdout)
        return
    import numpy as np
    import pinocchio as pin
    config = json.load(open(sys.argv[1]))
    budget = float(config.get("budget_s", 0.0))
    min_batches = int(config.get("min_batches", 11))
    compare = bool(config.get("compare", True))
    results = []
    for spec in config["robots"]:
        try:
            results.append(run(pin, np, spec, budget, min_batches, compare))
        except Exception as e:  # a refusal by Pinocchio is a result, not a failure
            results.append({"key": spec["key"], "error": f"{type(e).__name__}: {e}".strip()})
    json.dump({"versions": versions(), "results": results}, sys.stdout)


if __name__ == "__main__":
    main()
