#!/usr/bin/env python3
"""Times Pinocchio's ABA (`pin.aba`) and MuJoCo's `mj_forward` on URDF models, for
`cargo xtask bench --peers`.

Install the peers once (from the workspace root):

    python3 -m venv target/peers-venv && target/peers-venv/bin/pip install pin mujoco

Usage: peers.py CONFIG.json  (written by xtask) -> JSON on stdout:
    {"versions": {...}, "results": [{"model", "peer", "us_per_call", "samples", "batch",
                                     "passes", "qdd": {joint: value} | null, "note",
                                     "peak_rss_mib"}], "errors": [...]}

CONFIG.json: {"budget_s": 0.3, "passes": 4,
              "models": [{"name", "urdf", "joints": {name: [q, qd, tau]},
                          "skip": ["mujoco" | "pinocchio", ...]}]}
Joints absent from "joints" are left at zero. The state is set by URDF joint name in both
libraries; a joint's q is its angle (revolute, continuous) or displacement (prismatic).

Timing: a warm-up of a tenth of the budget, then batches of calls lasting >= 200 us each,
11..201 batches; the figure is the median time per call over batches (the same harness as
xtask's in-process timings). With "passes" P > 1 (as xtask's speed table), every (model, peer)
is timed P times, in P passes over the whole list, each with budget / P and at least
ceil(11 / P) batches, and the figure is the median over the batches of all passes: a shared
host's slow phases last seconds, and one window would let a phase set a figure alone ("samples"
counts the batches of all passes, "batch" is the first pass's batch size). Each call goes
through the Python bindings, which costs about a microsecond more than calling the C/C++
library directly: it matters only on small models.
"""

import json
import os
import sys
import tempfile
import time


def timed(budget_s, call, min_batches=11):
    warm_until = time.perf_counter() + budget_s / 10
    calls = 0
    start = time.perf_counter()
    while calls < 3 or time.perf_counter() < warm_until:
        call()
        calls += 1
    per_call = (time.perf_counter() - start) / calls
    batch = max(1, int(-(-200e-6 // per_call)))
    samples = min(201, max(min_batches, int(budget_s * 0.9 / (per_call * batch))))
    times = []
    for _ in range(samples):
        t = time.perf_counter()
        for _ in range(batch):
            call()
        times.append((time.perf_counter() - t) * 1e6 / batch)
    return median(times), samples, batch, times


def median(xs):
    xs = sorted(xs)
    n = len(xs)
    return xs[n // 2] if n % 2 else 0.5 * (xs[n // 2 - 1] + xs[n // 2])


def run_pinocchio(pin, np, spec, budget_s, world=False, min_batches=11):
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
        med, samples, batch, times = timed(
            budget_s, lambda: pin.aba(model, data, q, v, tau, conv), min_batches)
        a = pin.aba(model, data, q, v, tau, conv)
    else:
        med, samples, batch, times = timed(
            budget_s, lambda: pin.aba(model, data, q, v, tau), min_batches)
        a = pin.aba(model, data, q, v, tau)
    qdd = {model.names[jid]: float(a[model.joints[jid].idx_v])
           for jid in range(1, model.njoints) if model.joints[jid].nv == 1}
    if world:
        return {"peer": "Pinocchio ABA (WORLD)", "us_per_call": med, "samples": samples,
                "batch": batch, "times": times, "qdd": qdd,
                "note": "pin.aba(model, data, q, v, tau, pin.Convention.WORLD)"}
    return {"peer": "Pinocchio ABA", "us_per_call": med, "samples": samples, "batch": batch,
            "times": times, "qdd": qdd,
            "note": "pin.aba(model, data, q, v, tau) (default convention)"}


MUJOCO_EXT = ('<mujoco><compiler discardvisual="true" fusestatic="false" '
              'boundmass="{m}" boundinertia="{i}"/></mujoco>')


def run_mujoco(mujoco, np, spec, budget_s, min_batches=11):
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
    med, samples, batch, times = timed(
        budget_s, lambda: mujoco.mj_forward(model, data), min_batches)
    mujoco.mj_forward(model, data)
    qdd = {model.joint(j).name: float(data.qacc[model.jnt_dofadr[j]])
           for j in range(model.njnt)
           if model.jnt_type[j] in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))}
    return {"peer": "MuJoCo mj_forward", "us_per_call": med, "samples": samples, "batch": batch,
            "times": times, "qdd": qdd if bound == (0, 0) else None, "note": note}


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


def passes_of(config):
    return max(1, int(config.get("passes", 1)))


def one(config_path, index, peer):
    """Child: runs one peer on one model for one pass, prints its result as JSON."""
    import resource
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    config = json.load(open(config_path))
    passes = passes_of(config)
    budget = float(config.get("budget_s", 0.3)) / passes
    min_batches = -(-11 // passes)
    spec = config["models"][index]
    import numpy as np
    if peer in ("pinocchio", "pinocchio-world"):
        import pinocchio as pin
        r = run_pinocchio(pin, np, spec, budget, world=peer == "pinocchio-world",
                          min_batches=min_batches)
    else:
        import mujoco
        r = run_mujoco(mujoco, np, spec, budget, min_batches)
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
    passes = passes_of(config)
    merged = {}  # (index, key) -> result, its "times" gathered over the passes
    failed = set()
    for p in range(passes):
        for index, spec in enumerate(config["models"]):
            for name, key in peers:
                if key in spec.get("skip", []) or (index, key) in failed:
                    continue
                child = subprocess.run(
                    [sys.executable, __file__, "--one", sys.argv[1], str(index), key],
                    capture_output=True, text=True)
                if child.returncode == 0:
                    r = json.loads(child.stdout)
                    m = merged.setdefault((index, key), r)
                    if m is not r:
                        m["times"] += r["times"]
                        m["peak_rss_mib"] = max(m["peak_rss_mib"], r["peak_rss_mib"])
                    status = "done"
                else:
                    last = (child.stderr.strip().splitlines() or [f"exit {child.returncode}"])[-1]
                    out["errors"].append(f"{name} on {spec['name']}: {last} "
                                         f"(memory limit {MEMORY_LIMIT >> 30} GiB per run)")
                    failed.add((index, key))
                    merged.pop((index, key), None)
                    status = "failed"
                print(f"  peers: pass {p + 1}/{passes}: {name} on {spec['name']} {status}",
                      file=sys.stderr, flush=True)
    for r in merged.values():
        times = r.pop("times")
        r["us_per_call"] = median(times)
        r["samples"] = len(times)
        r["passes"] = passes
        out["results"].append(r)
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
