#!/usr/bin/env python3
"""MuJoCo's side of `cargo xtask contact-peers`: robots on the floor, articula beside MuJoCo.

Run by xtask (which builds `target/release/articula` and writes the crowd's states and
springs); by hand, from the workspace root:

    target/peers-venv/bin/python peers/contact_peers.py --articula target/release/articula \\
        --crowd target/contact-peers/crowd200.json [--rounds 3] [--json OUT]

One thread everywhere. Each round runs every case once in articula (a child process of the
`articula` command line, whose own summary gives its time per step) and once in MuJoCo (in
this process, `mj_step` timed call by call), alternated, so both see the same machine load;
the table gives the fastest and slowest round of each.

Cases (dt = 1 ms unless said, ground z = 0, friction 1, no restitution):

- `humanoid drop`: models/humanoid.urdf, floating, limp, dropped so that its lowest contact
  point is 0.1 m above the floor, 2,000 steps (`articula simulate --ground 0 --drop 0.1`).
  MuJoCo is given the same humanoid by `urdf_to_mjcf`: each chain of massless links (the
  composed hips, shoulders, lumbar and neck) folded into its child body as several hinges on
  one body (exact: the massless links' frames coincide), fixed joints as welded bodies, the
  `<collision>` shapes as geoms, the URDF limits as joint ranges; its default solver (Newton,
  pyramidal cone, soft contact), only floor–body contacts (articula has no self-collision).
- `anymal drop` / `anymal stand`: example-robot-data's anymal_b_simple (`anymal.urdf`,
  primitive collision shapes, sphere feet), floating, limp, dropped from 0.1 m and started
  standing (its lowest point 1 mm above the floor), 5,000 steps. MuJoCo loads the URDF
  itself (`MjSpec.from_file`, visuals discarded, a free joint added to the root, a floor
  plane); no `boundmass`/`boundinertia`: the one change is the base link's inertial
  (1e-6 kg, every inertia entry 1e-6, a singular matrix MuJoCo refuses), given zero
  off-diagonals (the 16.8 kg `base_inertia` link welded to it carries the torso). The torso height is reported at 1 s and at the end.
- `crowd200`: models/scenes/crowd200.json (200 humanoids, dt = 1/600 s, 2 Hz pose springs,
  the chest pushes), 400 steps: articula's scene (adaptive, then exact DCA: `--method dca`)
  and MuJoCo on 200 copies of the humanoid above at the scene's start states, with the
  scene's spring stiffness and damping per coordinate (written by xtask from the scene's own
  computation) as joint `stiffness`/`damping`, the same pushes as `xfrc_applied`, only
  floor–body contacts.

Per case: time per step (µs; articula's "steady" figure, steps 2..N, or the scene's mean
over its steps; MuJoCo's mean of its `mj_step` calls), deepest penetration (m), contacts
per step (mean: articula's contact points pushed; MuJoCo's `ncon`), energy at the end
(kinetic + potential, J; MuJoCo's `mjENBL_ENERGY`), and articula's solves at the iteration
cap.
"""

import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HUMANOID = os.path.join(ROOT, "models", "humanoid.urdf")


# ---------------------------------------------------------------- URDF -> MJCF (humanoid)

def _floats(s, default="0 0 0"):
    return [float(x) for x in (s or default).split()]


def _rpy_matrix(rpy):
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr]]


def _quat(rpy):
    """(w, x, y, z) of URDF's fixed-axis roll-pitch-yaw."""
    r, p, y = [a * 0.5 for a in rpy]
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return (cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy)


def _origin(el):
    o = el.find("origin") if el is not None else None
    if o is None:
        return [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
    return _floats(o.get("xyz")), _floats(o.get("rpy"))


def _fmt(v):
    return " ".join(f"{x:.12g}" for x in v)


def urdf_to_mjcf(path, timestep=1e-3, floor=True, name_prefix="", free=True):
    """The MJCF body tree of a URDF (see the module documentation): returns the `<body>`
    element text of its root. Massless links (no mass, no shape) with one moving child joint
    at their own origin are folded into that child as extra hinges."""
    robot = ET.parse(path).getroot()
    links = {l.get("name"): l for l in robot.findall("link")}
    joints = robot.findall("joint")
    children = {}
    parent_of = {}
    for j in joints:
        p, c = j.find("parent").get("link"), j.find("child").get("link")
        children.setdefault(p, []).append(j)
        parent_of[c] = j
    root = next(n for n in links if n not in parent_of)

    def massless(name):
        l = links[name]
        inertial = l.find("inertial")
        m = float(inertial.find("mass").get("value")) if inertial is not None else 0.0
        return m == 0.0 and l.find("collision") is None and l.find("visual") is None

    def inertial_xml(l):
        inertial = l.find("inertial")
        if inertial is None:
            return ""
        m = float(inertial.find("mass").get("value"))
        if m == 0.0:
            return ""
        xyz, rpy = _origin(inertial)
        i = inertial.find("inertia")
        g = lambda k: float(i.get(k))
        I = [[g("ixx"), g("ixy"), g("ixz")], [g("ixy"), g("iyy"), g("iyz")], [g("ixz"), g("iyz"), g("izz")]]
        R = _rpy_matrix(rpy)
        # R I Rᵀ: the inertia in the link frame.
        J = [[sum(R[a][p] * I[p][q] * R[b][q] for p in range(3) for q in range(3)) for b in range(3)]
             for a in range(3)]
        full = [J[0][0], J[1][1], J[2][2], J[0][1], J[0][2], J[1][2]]
        return f'<inertial pos="{_fmt(xyz)}" mass="{m:.12g}" fullinertia="{_fmt(full)}"/>'

    def geoms_xml(l):
        out = []
        for c in l.findall("collision"):
            xyz, rpy = _origin(c)
            g = c.find("geometry")
            pose = f'pos="{_fmt(xyz)}" quat="{_fmt(_quat(rpy))}"'
            common = 'contype="1" conaffinity="0" friction="1 0 0" condim="3"'
            if g.find("box") is not None:
                size = [0.5 * x for x in _floats(g.find("box").get("size"))]
                out.append(f'<geom type="box" size="{_fmt(size)}" {pose} {common} mass="0"/>')
            elif g.find("cylinder") is not None:
                cy = g.find("cylinder")
                out.append(f'<geom type="cylinder" size="{cy.get("radius")} {0.5 * float(cy.get("length")):.12g}" '
                           f'{pose} {common} mass="0"/>')
            elif g.find("sphere") is not None:
                out.append(f'<geom type="sphere" size="{g.find("sphere").get("radius")}" {pose} {common} mass="0"/>')
            else:
                raise ValueError(f"{path}: link {l.get('name')}: only box, cylinder and sphere shapes are converted")
        return "".join(out)

    def joint_xml(j, prefix):
        kind = j.get("type")
        if kind == "fixed":
            return ""
        axis = _floats(j.find("axis").get("xyz") if j.find("axis") is not None else "1 0 0")
        lim = j.find("limit")
        rng = ""
        if kind in ("revolute", "prismatic") and lim is not None:
            rng = f' range="{lim.get("lower")} {lim.get("upper")}" limited="true"'
        t = "slide" if kind == "prismatic" else "hinge"
        return f'<joint name="{prefix}{j.get("name")}" type="{t}" axis="{_fmt(axis)}"{rng}/>'

    def body(name, via, prefix, pos, quat, extra_joints):
        # Fold a massless link with exactly one child joint at the link's origin.
        l = links[name]
        if via is not None and massless(name) and len(children.get(name, [])) == 1:
            j = children[name][0]
            xyz, rpy = _origin(j)
            if max(abs(x) for x in xyz + rpy) > 0.0:
                raise ValueError(f"{path}: massless link {name}'s child joint is not at its origin")
            return body(j.find("child").get("link"), j, prefix, pos, quat,
                        extra_joints + [joint_xml(via, prefix)])
        own = [] if via is None else [joint_xml(via, prefix)]
        parts = [f'<body name="{prefix}{name}" pos="{_fmt(pos)}" quat="{_fmt(quat)}">']
        parts += extra_joints + own
        parts.append(inertial_xml(l))
        parts.append(geoms_xml(l))
        for j in children.get(name, []):
            xyz, rpy = _origin(j)
            parts.append(body(j.find("child").get("link"), j, prefix, xyz, _quat(rpy), []))
        parts.append("</body>")
        return "".join(parts)

    return body(root, None, name_prefix, [0.0, 0.0, 0.0], (1.0, 0.0, 0.0, 0.0), [])


def humanoid_model(mujoco, bodies, timestep, springs=None):
    """MuJoCo model of `bodies` humanoids (each a free body named `h{i}_...`) on a floor."""
    parts = []
    for i in range(bodies):
        b = urdf_to_mjcf(HUMANOID, name_prefix=f"h{i}_")
        b = b.replace(f'<body name="h{i}_pelvis" pos="0 0 0" quat="1 0 0 0">',
                      f'<body name="h{i}_pelvis" pos="0 0 0" quat="1 0 0 0"><freejoint name="h{i}_root"/>', 1)
        parts.append(b)
    xml = (f'<mujoco><option timestep="{timestep!r}" gravity="0 0 -9.81"><flag energy="enable" eulerdamp="disable"/></option>'
           '<compiler angle="radian" autolimits="true"/>'
           '<worldbody><geom name="floor" type="plane" size="0 0 1" contype="0" conaffinity="1" '
           'friction="1 0 0" condim="3"/>' + "".join(parts) + "</worldbody></mujoco>")
    m = mujoco.MjModel.from_xml_string(xml)
    if springs:
        for (name, k, c) in springs:
            j = m.joint(name).id
            m.jnt_stiffness[j] = k
            m.dof_damping[m.jnt_dofadr[j]] = c
    return m


def lowest_geom_point(m, d):
    """Lowest world z over the model's box, cylinder and sphere geoms (the floor excluded)."""
    import numpy as np
    low = math.inf
    for g in range(m.ngeom):
        t = m.geom_type[g]
        z = d.geom_xpos[g][2]
        R = d.geom_xmat[g].reshape(3, 3)
        s = m.geom_size[g]
        if t == 6:  # box
            low = min(low, z - float(np.abs(R[2]) @ s))
        elif t == 5:  # cylinder: axis R[:, 2]
            az = abs(R[2, 2])
            low = min(low, z - az * s[1] - s[0] * math.sqrt(max(0.0, 1 - az * az)))
        elif t == 2:  # sphere
            low = min(low, z - s[0])
    return low


def run_mujoco(mujoco, m, steps, prepare=None, z_body=None, sample_at=()):
    """Steps `m` from its qpos0 (after `prepare(m, d)`), timing each `mj_step`."""
    d = mujoco.MjData(m)
    if prepare:
        prepare(m, d)
    mujoco.mj_forward(m, d)
    t_total = 0.0
    pen = 0.0
    ncon = 0
    heights = {}
    for k in range(steps):
        if callable(getattr(prepare, "push", None)):
            prepare.push(m, d, k)
        t0 = time.perf_counter()
        mujoco.mj_step(m, d)
        t_total += time.perf_counter() - t0
        if d.ncon:
            pen = max(pen, -float(min(d.contact.dist[: d.ncon])))
        ncon += d.ncon
        if z_body is not None and (k + 1) in sample_at:
            heights[k + 1] = float(d.xpos[z_body][2])
    mujoco.mj_forward(m, d)
    return {"us_per_step": 1e6 * t_total / steps, "penetration_m": max(0.0, pen),
            "contacts_mean": ncon / steps, "energy_end_j": float(d.energy[0] + d.energy[1]),
            "kinetic_end_j": float(d.energy[1]), "heights": heights}


def run_articula(cmd):
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {out.returncode}: {out.stderr.strip()}")
    return out.stdout


def parse_simulate(text):
    g = lambda pat: re.search(pat, text, re.M)
    r = {"us_per_step": float(g(r"steady ([0-9.]+) µs per step").group(1)),
         "penetration_m": float(g(r"^max_penetration_m (\S+)").group(1)),
         "contacts_mean": float(g(r"^contacts\s+([0-9.]+) per step").group(1)),
         "rows_mean": float(g(r"per step \(mean\), ([0-9.]+) rows").group(1)),
         "capped": int(g(r"(\d+) step\(s\) not converged").group(1)),
         "energy_end_j": float(g(r"^energy end\s+(\S+) J").group(1)),
         "kinetic_end_j": float(g(r"^kinetic end\s+(\S+) J").group(1))}
    return r


# ---------------------------------------------------------------- cases

def case_humanoid(mujoco, exe, steps=2000):
    m = humanoid_model(mujoco, 1, 1e-3)

    def prepare(m, d):
        mujoco.mj_forward(m, d)
        d.qpos[2] += 0.1 - lowest_geom_point(m, d)

    def mj():
        return run_mujoco(mujoco, m, steps, prepare)

    cmd = [exe, "simulate", HUMANOID, "--floating-base", "--ground", "0", "--drop", "0.1",
           "--steps", str(steps), "--dt", "1e-3"]
    return mj, lambda: parse_simulate(run_articula(cmd))


def anymal_urdf():
    import sysconfig
    for key in ("purelib", "platlib"):
        p = os.path.join(sysconfig.get_paths()[key], "cmeel.prefix", "share", "example-robot-data",
                         "robots", "anymal_b_simple_description", "robots", "anymal.urdf")
        if os.path.exists(p):
            return p
    raise FileNotFoundError("example-robot-data's anymal_b_simple_description/robots/anymal.urdf")


def anymal_model(mujoco):
    path = anymal_urdf()
    text = open(path).read()
    start = text.index("<robot")
    end = text.index(">", start) + 1
    text = text[:end] + '<mujoco><compiler discardvisual="true"/></mujoco>' + text[end:]
    with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as f:
        f.write(text)
        tmp = f.name
    try:
        spec = mujoco.MjSpec.from_file(tmp)
    finally:
        os.unlink(tmp)
    spec.option.timestep = 1e-3
    spec.option.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    root = spec.worldbody.first_body()
    # The URDF's base inertial is 1e-6 kg with every inertia entry 1e-6 (off-diagonals too),
    # singular (eigenvalues 3e-6, 0, 0): MuJoCo refuses it. Its off-diagonals are dropped;
    # the 16.8 kg base_inertia link welded to it carries the torso's inertia.
    fi = list(root.fullinertia)
    if fi[3:] == [1e-6, 1e-6, 1e-6]:
        root.fullinertia = fi[:3] + [0.0, 0.0, 0.0]
    root.add_freejoint()
    for g in spec.geoms:
        g.contype, g.conaffinity, g.friction = 1, 0, [1.0, 0.0, 0.0]
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], contype=0,
                            conaffinity=1, friction=[1.0, 0.0, 0.0])
    return spec.compile(), path, root.name


def case_anymal(mujoco, exe, drop, steps=5000):
    m, path, root = anymal_model(mujoco)
    body = m.body(root).id

    def prepare(m, d):
        mujoco.mj_forward(m, d)
        d.qpos[2] += drop - lowest_geom_point(m, d)

    def mj():
        return run_mujoco(mujoco, m, steps, prepare, z_body=body, sample_at=(1000, steps))

    cmd = [exe, "simulate", path, "--floating-base", "--ground", "0", "--drop", str(drop),
           "--steps", str(steps), "--dt", "1e-3", "--out", "-"]

    def art():
        r = parse_simulate(run_articula(cmd[:-2]))
        # The torso height from a second run writing its trajectory (not timed).
        with tempfile.NamedTemporaryFile(suffix=".csv", delete=False) as f:
            csv = f.name
        try:
            run_articula(cmd[:-1] + [csv])
            rows = open(csv).read().splitlines()
            z = rows[0].split(",").index("floating_base[2]")
            r["heights"] = {k: float(rows[k].split(",")[z]) for k in (1000, steps)}
        finally:
            os.unlink(csv)
        return r
    return mj, art


def case_crowd(mujoco, exe, crowd_path, steps=400):
    spec = json.load(open(crowd_path))
    n = len(spec["bodies"])
    springs = [(f"h{i}_{name}", k, c) for i in range(n) for (name, k, c) in spec["springs"]]
    m = humanoid_model(mujoco, n, spec["dt"], springs)
    chest = [m.body(f"h{i}_chest").id for i in range(n)]
    pushes = spec["pushes"]  # [{"bodies": [i...], "point": [3], "force": [3], "t0", "t1"}]

    def prepare(m, d):
        for i, b in enumerate(spec["bodies"]):
            adr = m.jnt_qposadr[m.joint(f"h{i}_root").id]
            d.qpos[adr: adr + 3] = b["position"]
            d.qpos[adr + 3: adr + 7] = b["quaternion_wxyz"]

    def push(m, d, k):
        import numpy as np
        t = k * spec["dt"]
        d.xfrc_applied[:] = 0.0
        for p in pushes:
            if not (p["t0"] <= t < p["t1"]):
                continue
            f = np.array(p["force"])
            for i in p["bodies"]:
                b = chest[i]
                at = d.xpos[b] + d.xmat[b].reshape(3, 3) @ np.array(p["point"])
                d.xfrc_applied[b, :3] += f
                d.xfrc_applied[b, 3:] += np.cross(at - d.xipos[b], f)
    prepare.push = push

    def mj():
        return run_mujoco(mujoco, m, steps, prepare)

    def art(method):
        cmd = [exe, "scene", os.path.join(ROOT, "models", "scenes", "crowd200.json"),
               "--steps", str(steps), "--threads", "1"] + (["--method", method] if method else [])
        out = json.loads(run_articula(cmd).strip().splitlines()[-1])
        return {"us_per_step": 1e3 * out["ms_per_step"], "penetration_m": out["max_penetration_m"],
                "contacts_mean": out["contacts_mean"], "rows_mean": out["contact_rows_mean"],
                "capped_fraction": out["contact_capped_fraction"],
                "energy_end_j": out["energy_end"]}
    return mj, (lambda: art(None)), (lambda: art("dca"))


def alone(mujoco, crowd_path, n, forces, seconds=4.0):
    """Each of the first `n` crowd200 characters alone in MuJoCo (its start state, the
    scene's springs and floor, dt 1/600 s), pushed at the chest point of the scene's first
    push by each force along its direction for its t0..t1: how many are down (pelvis below
    0.5 m) at each whole second. The MuJoCo side of docs/view.md's one-character figures."""
    import numpy as np
    spec = json.load(open(crowd_path))
    springs = [(f"h0_{name}", k, c) for (name, k, c) in spec["springs"]]
    m = humanoid_model(mujoco, 1, spec["dt"], springs)
    chest = m.body("h0_chest").id
    push = spec["pushes"][0]
    direction = np.array(push["force"]) / np.linalg.norm(push["force"])
    steps = int(round(seconds / spec["dt"]))
    per_second = int(round(1.0 / spec["dt"]))
    for force in forces:
        down = [0] * int(seconds)
        for i in range(n):
            d = mujoco.MjData(m)
            b = spec["bodies"][i]
            d.qpos[0:3] = b["position"]
            d.qpos[3:7] = b["quaternion_wxyz"]
            mujoco.mj_forward(m, d)
            for k in range(steps):
                t = k * spec["dt"]
                d.xfrc_applied[:] = 0.0
                if push["t0"] <= t < push["t1"]:
                    f = force * direction
                    at = d.xpos[chest] + d.xmat[chest].reshape(3, 3) @ np.array(push["point"])
                    d.xfrc_applied[chest, :3] = f
                    d.xfrc_applied[chest, 3:] = np.cross(at - d.xipos[chest], f)
                mujoco.mj_step(m, d)
                if (k + 1) % per_second == 0:
                    down[(k + 1) // per_second - 1] += d.qpos[2] < 0.5
        print(f"MuJoCo, {force:g} N for {push['t0']:g}..{push['t1']:g} s, each of {n} characters "
              f"alone: down at " + ", ".join(f"{s + 1} s {c}" for s, c in enumerate(down)), flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--articula", required=True)
    ap.add_argument("--crowd", help="the crowd's states and springs (written by xtask)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--only", default="", help="comma-separated case names")
    ap.add_argument("--json")
    ap.add_argument("--alone", nargs="+", type=float, metavar=("N", "FORCE"),
                    help="only: the first N crowd characters alone under each FORCE (N)")
    a = ap.parse_args()
    import mujoco
    if a.alone:
        return alone(mujoco, a.crowd, int(a.alone[0]), a.alone[1:])
    cases = {}
    mj, art = case_humanoid(mujoco, a.articula)
    cases["humanoid drop"] = {"mujoco": mj, "articula": art}
    for name, drop in (("anymal stand", 0.001), ("anymal drop", 0.1)):
        mj, art = case_anymal(mujoco, a.articula, drop)
        cases[name] = {"mujoco": mj, "articula": art}
    if a.crowd:
        mj, ad, ex = case_crowd(mujoco, a.articula, a.crowd)
        cases["crowd200"] = {"mujoco": mj, "articula adaptive": ad, "articula exact DCA": ex}
    only = [s for s in a.only.split(",") if s]
    results = {}
    for r in range(a.rounds):
        for name, runs in cases.items():
            if only and not any(o in name for o in only):
                continue
            for who, run in runs.items():
                res = run()
                results.setdefault(name, {}).setdefault(who, []).append(res)
                print(f"round {r + 1} {name:14} {who:20} {res['us_per_step']:10.1f} µs/step  "
                      f"pen {res['penetration_m']:.2e} m  contacts {res['contacts_mean']:.2f}"
                      + (f"  capped {res['capped']}" if "capped" in res else "")
                      + (f"  capped {res['capped_fraction']:.3f}" if "capped_fraction" in res else "")
                      + (f"  heights {res['heights']}" if res.get("heights") else ""),
                      flush=True)
    out = {"mujoco": mujoco.__version__, "rounds": a.rounds, "results": results}
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1)
    print_table(out)


def print_table(out):
    print(f"\nMuJoCo {out['mujoco']}, {out['rounds']} rounds alternated, one thread; times: "
          "fastest–slowest round; ratio: articula / MuJoCo within each round (min–max)")
    print("| case | engine | µs per step | ratio | penetration (mm) | contacts per step | "
          "energy end (J) | torso z at 1 s, end (m) | at the cap |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, by in out["results"].items():
        base = [r["us_per_step"] for r in by.get("mujoco", [])]
        for who, rs in by.items():
            t = sorted(r["us_per_step"] for r in rs)
            ratios = sorted(r["us_per_step"] / b for r, b in zip(rs, base)) if base else []
            ratio = "—" if who == "mujoco" or not ratios else f"{ratios[0]:.2f}–{ratios[-1]:.2f}"
            r = rs[-1]
            cap = (f"{r['capped']}" if "capped" in r else
                   f"{100 * r['capped_fraction']:.1f} %" if "capped_fraction" in r else "—")
            h = r.get("heights") or {}
            z = ", ".join(f"{v:.4f}" for _, v in sorted((int(k), v) for k, v in h.items())) or "—"
            print(f"| {name} | {who} | {t[0]:.1f}–{t[-1]:.1f} | {ratio} | {1e3 * r['penetration_m']:.3f} | "
                  f"{r['contacts_mean']:.2f} | {r['energy_end_j']:.4g} | {z} | {cap} |")


if __name__ == "__main__":
    sys.exit(main())
