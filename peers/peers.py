#!/usr/bin/env python3
"""Times Pinocchio's ABA (`pin.aba`) and MuJoCo's `mj_forward` on URDF models, for
`cargo xtask bench --peers`.

Install the peers once (from the workspace root):

    python3 -m venv target/peers-venv && target/peers-venv/bin/pip install pin mujoco

Usage: peers.py CONFIG.json  (written by xtask) -> JSON on stdout:
    {"versions": {...}, "results": [{"model", "peer", "us_per_call", "samples", "batch",
                                     "qdd": {joint: value} | null, "note"}], "errors": [...]}

CONFIG.json: {"budget_s": 0.3, "models": [{"name", "urdf", "joints": {name: [q, qd, tau]},
                                           "skip": ["mujoco" | "pinocchio", ...]}]}
Joints absent from "joints" are left at zero. The state is set by URDF joint name in both
libraries; a joint's q is its angle (revolute, continuous) or displacement (prismatic).

Timing: a warm-up of a tenth of the budget, then batches of calls lasting >= 200 us each,
11..201 batches; the figure is the median time per call over batches (the same harness as
xtask's in-process timings). Each call goes through the Python bindings, which costs about a
microsecond more than calling the C/C++ library directly: it matters only on small models.
"""

import json
import os
import sys
import tempfile
import time


def timed(budget_s, call):
    warm_until = time.perf_counter() + budget_s / 10
    calls = 0
    start = time.perf_counter()
    while calls < 3 or time.perf_counter() < warm_until:
        call()
        calls += 1
    per_call = (time.perf_counter() - start) / calls
    batch = max(1, int(-(-200e-6 // per_call)))
    samples = min(201, max(11, int(budget_s * 0.9 / (per_call * batch))))
    times = []
    for _ in range(samples):
        t = time.perf_counter()
        for _ in range(batch):
            call()
        times.append((time.perf_counter() - t) * 1e6 / batch)
    times.sort()
    n = len(times)
    med = times[n // 2] if n % 2 else 0.5 * (times[n // 2 - 1] + times[n // 2])
    return med, samples, batch


def run_pinocchio(pin, np, spec, budget_s, world=False):
    model = pin.buildModelFromUrdf(spec["urdf"])
    data = model.createData()
    q = pin.neutral(model)
    v = np.zeros(model.nv)
    tau = np.zeros(model.nv)
    joints = spec["joints"]
    for jid in range(1, model.njoints):
        name = model.names[jid]
        if name not in joints:
            continue
        jq, jqd, jtau = joints[name]
        j = model.joints[jid]
        if j.nq == 2 and j.nv == 1:  # continuous: (cos, sin)
            q[j.idx_q] = np.cos(jq)
            q[j.idx_q + 1] = np.sin(jq)
        else:
            q[j.idx_q] = jq
        v[j.idx_v] = jqd
        tau[j.idx_v] = jtau
    if world:
        # Pinocchio 3+: ABA with its quantities in the world frame (faster on long chains).
        conv = pin.Convention.WORLD
        med, samples, batch = timed(budget_s, lambda: pin.aba(model, data, q, v, tau, conv))
        a = pin.aba(model, data, q, v, tau, conv)
    else:
        med, samples, batch = timed(budget_s, lambda: pin.aba(model, data, q, v, tau))
        a = pin.aba(model, data, q, v, tau)
    qdd = {model.names[jid]: float(a[model.joints[jid].idx_v])
           for jid in range(1, model.njoints) if model.joints[jid].nv == 1}
    if world:
        return {"peer": "Pinocchio ABA (WORLD)", "us_per_call": med, "samples": samples,
                "batch": batch, "qdd": qdd,
                "note": "pin.aba(model, data, q, v, tau, pin.Convention.WORLD)"}
    return {"peer": "Pinocchio ABA", "us_per_call": med, "samples": samples, "batch": batch,
            "qdd": qdd, "note": "pin.aba(model, data, q, v, tau) (default convention)"}


MUJOCO_EXT = ('<mujoco><compiler discardvisual="true" fusestatic="false" '
              'boundmass="{m}" boundinertia="{i}"/></mujoco>')


def run_mujoco(mujoco, np, spec, budget_s):
    text = open(spec["urdf"]).read()
    note = "mj_forward, contacts disabled"
    bound = (0, 0)
    try:
        model = load_mujoco(mujoco, text, bound)
    except Exception as e:  # MuJoCo refuses massless moving links
        if "mass and inertia" not in str(e):
            raise
        bound = (1e-9, 1e-12)
        model = load_mujoco(mujoco, text, bound)
        note += (f"; massless links given mass {bound[0]:g} kg and inertia {bound[1]:g} kg m^2 "
                 "(MuJoCo refuses massless moving bodies)")
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    data = mujoco.MjData(model)
    joints = spec["joints"]
    for j in range(model.njnt):
        name = model.joint(j).name
        if name not in joints:
            continue
        jq, jqd, jtau = joints[name]
        data.qpos[model.jnt_qposadr[j]] = jq
        data.qvel[model.jnt_dofadr[j]] = jqd
        data.qfrc_applied[model.jnt_dofadr[j]] = jtau
    med, samples, batch = timed(budget_s, lambda: mujoco.mj_forward(model, data))
    mujoco.mj_forward(model, data)
    qdd = {model.joint(j).name: float(data.qacc[model.jnt_dofadr[j]])
           for j in range(model.njnt)
           if model.jnt_type[j] in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))}
    return {"peer": "MuJoCo mj_forward", "us_per_call": med, "samples": samples, "batch": batch,
            "qdd": qdd if bound == (0, 0) else None, "note": note}


def load_mujoco(mujoco, text, bound):
    ext = MUJOCO_EXT.format(m=bound[0], i=bound[1])
    start = text.index("<robot")
    end = text.index(">", start) + 1
    patched = text[:end] + ext + text[end:]
    with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as f:
        f.write(patched)
        path = f.name
    try:
        return mujoco.MjModel.from_xml_path(path)
    finally:
        os.unlink(path)


# Each (peer, model) runs in its own child process under this address-space limit, so a peer
# that needs more memory than the machine has fails with an error (reported) instead of
# waking the kernel's OOM killer: Pinocchio's Data for long chains grows quadratically.
MEMORY_LIMIT = 4 << 30


def one(config_path, index, peer):
    """Child: runs one peer on one model, prints its result as JSON."""
    import resource
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    config = json.load(open(config_path))
    budget = float(config.get("budget_s", 0.3))
    spec = config["models"][index]
    import numpy as np
    if peer in ("pinocchio", "pinocchio-world"):
        import pinocchio as pin
        r = run_pinocchio(pin, np, spec, budget, world=peer == "pinocchio-world")
    else:
        import mujoco
        r = run_mujoco(mujoco, np, spec, budget)
    r["model"] = spec["name"]
    r["peak_rss_mib"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    json.dump(r, sys.stdout)


def main():
    if sys.argv[1] == "--one":
        one(sys.argv[2], int(sys.argv[3]), sys.argv[4])
        return
    import subprocess
    config = json.load(open(sys.argv[1]))
    out = {"versions": {"python": sys.version.split()[0]}, "results": [], "errors": []}
    import numpy as np
    out["versions"]["numpy"] = np.__version__
    peers = []
    try:
        import pinocchio as pin
        out["versions"]["pin"] = pin.__version__
        peers.append(("Pinocchio ABA", "pinocchio"))
        if hasattr(pin, "Convention"):
            peers.append(("Pinocchio ABA (WORLD)", "pinocchio-world"))
    except ImportError as e:
        out["errors"].append(f"pinocchio: {e}")
    try:
        import mujoco
        out["versions"]["mujoco"] = mujoco.__version__
        peers.append(("MuJoCo mj_forward", "mujoco"))
    except ImportError as e:
        out["errors"].append(f"mujoco: {e}")
    for index, spec in enumerate(config["models"]):
        for name, key in peers:
            if key in spec.get("skip", []):
                continue
            child = subprocess.run(
                [sys.executable, __file__, "--one", sys.argv[1], str(index), key],
                capture_output=True, text=True)
            if child.returncode == 0:
                out["results"].append(json.loads(child.stdout))
                status = "done"
            else:
                last = (child.stderr.strip().splitlines() or [f"exit {child.returncode}"])[-1]
                out["errors"].append(f"{name} on {spec['name']}: {last} "
                                     f"(memory limit {MEMORY_LIMIT >> 30} GiB per run)")
                status = "failed"
            print(f"  peers: {name} on {spec['name']} {status}", file=sys.stderr, flush=True)
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
