#!/usr/bin/env python3
"""MuJoCo's side of `cargo xtask mjcf-corpus`: every MJCF file of the PyPI packages dm-control
and gymnasium, and of the workspace's models/ directory, compiled by MuJoCo; `mj_fullM` and `qacc_smooth` on the states xtask sends.

Install it once (from the workspace root):

    python3 -m venv target/peers-venv && \
        target/peers-venv/bin/pip install mujoco dm-control gymnasium

Usage:
    mjcf_corpus.py --list         -> {"versions": {...}, "models": [...]}
        Every *.xml under the two packages, with "tree": true for the kinematic-tree models:
        MuJoCo compiles the file alone and it has degrees of freedom (nv > 0). The others are
        listed with the reason they are not: the file does not compile alone (an include
        fragment, a schema, a file whose assets are elsewhere) or has no degree of freedom
        (an arena, a static prop, a file of assets or defaults).
        A tree model also lists its joints as articula names them ("name", else
        "<body>:joint<k>", an unnamed body being "body<id>"), with type, qposadr, dofadr;
        its gravity; and what its passive force has that articula does not model (tendon
        springs, dampers or armature; fluid forces), which is switched off here.
    mjcf_corpus.py CONFIG.json    -> {"results": [...]}
        CONFIG: {"budget_s": 0.2, "models": [{"path": P, "states": [{"qpos": [...],
        "qvel": [...]}]}]}. For each state: M (row-major, nv×nv) and qacc_smooth, with
        actuation, contacts and constraints off; then the time of one mj_forward (µs,
        Python call included) with constraints, contacts, actuation and sensors off.
"""

import glob
import json
import os
import sys
import time

import mujoco
import numpy as np


def packages():
    import dm_control
    import gymnasium

    return {
        "dm_control": os.path.dirname(dm_control.__file__),
        "gymnasium": os.path.dirname(gymnasium.__file__),
        # articula's own MJCF models (the ball-joint humanoid).
        "models": os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "models"),
    }


def versions():
    from importlib.metadata import version

    return {p: version(p) for p in ["mujoco", "dm-control", "gymnasium"]}


def joint_names(m):
    out = []
    for b in range(m.nbody):
        body = m.body(b).name or f"body{b}"
        start, n = m.body_jntadr[b], m.body_jntnum[b]
        for k in range(n):
            j = start + k
            name = m.joint(j).name or f"{body}:joint{k}"
            out.append(
                {
                    "name": name,
                    "type": ["free", "ball", "slide", "hinge"][m.jnt_type[j]],
                    "qposadr": int(m.jnt_qposadr[j]),
                    "dofadr": int(m.jnt_dofadr[j]),
                }
            )
    return out


def gravity(m):
    """The gravity dynamics sees: zero when the model disables it (`<flag gravity=...>`)."""
    if m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY):
        return [0.0, 0.0, 0.0]
    return [float(x) for x in m.opt.gravity]


def unmodelled(m):
    out = []
    if m.ntendon and (
        np.any(m.tendon_stiffness) or np.any(m.tendon_damping) or np.any(m.tendon_armature)
    ):
        out.append("tendon springs, dampers or armature")
    if m.opt.density or m.opt.viscosity:
        out.append("fluid forces")
    if np.any(m.body_gravcomp):
        out.append("gravity compensation")
    return out


def strip(m):
    """Switches off what articula does not model (see `unmodelled`) and actuation."""
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_ACTUATION)
    m.opt.density = 0.0
    m.opt.viscosity = 0.0
    if m.ntendon:
        m.tendon_stiffness[:] = 0.0
        m.tendon_damping[:] = 0.0
        m.tendon_armature[:] = 0.0
    m.body_gravcomp[:] = 0.0


def list_models():
    models = []
    for pkg, root in packages().items():
        for path in sorted(glob.glob(os.path.join(root, "**", "*.xml"), recursive=True)):
            rel = os.path.relpath(path, root)
            entry = {"path": path, "package": pkg, "rel": rel, "tree": False}
            try:
                m = mujoco.MjModel.from_xml_path(path)
            except Exception as e:  # noqa: BLE001 (MuJoCo raises ValueError and others)
                msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
                # Paths in MuJoCo's message as the table names files (from the package).
                msg = msg.replace(os.path.dirname(root) + os.sep, "")
                entry["reason"] = f"does not compile alone: {msg}"
                models.append(entry)
                continue
            if m.nv == 0:
                entry["reason"] = "no degree of freedom (arena, prop or asset file)"
                models.append(entry)
                continue
            entry.update(
                {
                    "tree": True,
                    "nq": int(m.nq),
                    "nv": int(m.nv),
                    "joints": joint_names(m),
                    "gravity": gravity(m),
                    "unmodelled": unmodelled(m),
                }
            )
            models.append(entry)
    return {"versions": versions(), "models": models}


def time_forward(m, d, budget):
    m.opt.disableflags |= int(
        mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
        | mujoco.mjtDisableBit.mjDSBL_CONTACT
        | mujoco.mjtDisableBit.mjDSBL_SENSOR
    )
    forward = mujoco.mj_forward
    best = float("inf")
    end = time.perf_counter() + budget
    while time.perf_counter() < end:
        t0 = time.perf_counter()
        for _ in range(100):
            forward(m, d)
        best = min(best, (time.perf_counter() - t0) / 100)
    return best * 1e6


def run(config):
    results = []
    for model in config["models"]:
        m = mujoco.MjModel.from_xml_path(model["path"])
        strip(m)
        d = mujoco.MjData(m)
        states = []
        for s in model["states"]:
            d.qpos[:] = s["qpos"]
            d.qvel[:] = s["qvel"]
            d.ctrl[:] = 0.0
            mujoco.mj_forward(m, d)
            full = np.zeros((m.nv, m.nv))
            mujoco.mj_fullM(m, d, full)
            states.append(
                {"M": full.ravel().tolist(), "qacc_smooth": d.qacc_smooth.tolist()}
            )
        us = time_forward(m, d, config["budget_s"])
        results.append({"path": model["path"], "states": states, "forward_us": us})
    return {"results": results}


def main():
    if len(sys.argv) == 2 and sys.argv[1] == "--list":
        json.dump(list_models(), sys.stdout)
    elif len(sys.argv) == 2:
        with open(sys.argv[1]) as f:
            json.dump(run(json.load(f)), sys.stdout)
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main()
