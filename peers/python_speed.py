#!/usr/bin/env python3
"""articula from Python against Pinocchio and MuJoCo from Python, side by side in one run.

    target/py-venv/bin/python peers/python_speed.py [--quick]

(the venv of `cargo xtask test`, which has articula, pin and mujoco). Prints a Markdown table
(docs/python.md#performance).

1. Per call, on the bundled humanoid with a floating base (40 DOF): articula.forward_dynamics
   (DCA), pinocchio.aba and MuJoCo's mj_forward (contacts disabled), each at one random state,
   and the same three on a one-link pendulum, whose time is almost all binding overhead; the
   last column is the same DCA call looped inside Rust (articula._articula._time_forward_dynamics),
   so that the difference is what the bindings add to each call.
2. Batches, 2 threads: articula.rollout against mujoco.rollout (one MjData per thread) on the
   same humanoid, 64 rollouts of 200 steps of 1 ms from the rest pose with random joint
   velocities, semi-implicit Euler on both sides, without and with a floor at z = 0.

MuJoCo compiles our URDF with two changes, stated here: `<mujoco><compiler boundmass="1e-6"
boundinertia="1e-9" .../>` (MuJoCo refuses the massless links between the parts of the
humanoid's composed joints: each gets 1 µg and 1e-9 kg·m²), and a free joint on the root body
(MjSpec.add_freejoint). Its collision boxes are the URDF's; only body-floor pairs collide
(contype 1 / conaffinity 0 on the body, 0 / 1 on the floor), as articula's ground contact has
no self-collision. States/s counts one rollout step of one state.

The rounds alternate the sides and the table gives the median of the rounds and the spread
(min–max) of the per-round figures: the machine may be shared.
"""

import argparse
import os
import sys
import time

import numpy as np

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peers import timed  # noqa: E402

import articula  # noqa: E402
from articula import _articula  # noqa: E402
import mujoco  # noqa: E402
import pinocchio as pin  # noqa: E402
from mujoco import rollout as mj_rollout  # noqa: E402

HUMANOID = os.path.join(ROOT, "models", "humanoid.urdf")
PENDULUM = """<robot name="pendulum"><link name="base"/>
  <link name="bob"><inertial><origin xyz="0 0 -1"/><mass value="1"/>
    <inertia ixx="1e-2" iyy="1e-2" izz="1e-2" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 -1"/><geometry><sphere radius="0.05"/></geometry></collision></link>
  <joint name="swing" type="continuous"><parent link="base"/><child link="bob"/>
    <axis xyz="0 1 0"/></joint></robot>"""
MJ_COMPILER = ('<mujoco><compiler boundmass="1e-6" boundinertia="1e-9" discardvisual="true" '
               'balanceinertia="false" fusestatic="false"/></mujoco>')


def mujoco_model(urdf_text, floating, floor):
    text = urdf_text.replace("</robot>", MJ_COMPILER + "</robot>", 1)
    spec = mujoco.MjSpec.from_string(text)
    if floating:
        spec.worldbody.first_body().add_freejoint()
    for g in spec.geoms:
        g.contype, g.conaffinity = 1, 0
    if floor:
        spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1],
                                contype=0, conaffinity=1)
    m = spec.compile()
    m.opt.timestep = 1e-3
    if not floor:
        m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    return m


def per_call(budget, rounds):
    rows = []
    for label, urdf_text, floating in (("humanoid (floating, 40 DOF)", open(HUMANOID).read(), True),
                                      ("pendulum (1 DOF)", PENDULUM, False)):
        a = articula.Model.from_urdf(urdf_text, floating_base=floating)
        ad = articula.Data(a)
        q, v, tau = a.random_state(1)
        if floating:
            p = pin.buildModelFromXML(urdf_text, pin.JointModelFreeFlyer())
        else:
            p = pin.buildModelFromXML(urdf_text)
        pd = p.createData()
        qp = pin.neutral(p)
        if floating:  # the same pose, Pinocchio's quaternion order
            qp[:3], qp[3:6], qp[6] = q[:3], q[4:7], q[3]
        vp, taup = np.zeros(p.nv), np.zeros(p.nv)
        vp[:] = 0.1
        m = mujoco_model(urdf_text, floating, floor=False)
        md = mujoco.MjData(m)
        md.qvel[:] = 0.1
        calls = {
            "articula.forward_dynamics": lambda: articula.forward_dynamics(a, ad, q, v, tau),
            "pinocchio.aba": lambda: pin.aba(p, pd, qp, vp, taup),
            "mujoco.mj_forward": lambda: mujoco.mj_forward(m, md),
        }
        got = {k: [] for k in calls}
        inside = []
        for r in range(rounds):
            order = list(calls) if r % 2 == 0 else list(reversed(calls))
            for k in order:
                got[k].append(timed(budget, calls[k])[0])
            # Batches of >= 200 µs inside Rust, the median of them (as `timed` does).
            per = _articula._time_forward_dynamics(a, ad, q, v, tau, 1000)
            k = max(1, int(200e-6 / per))
            samples = [_articula._time_forward_dynamics(a, ad, q, v, tau, k)
                       for _ in range(max(11, int(budget * 0.9 / (k * per))))]
            inside.append(1e6 * sorted(samples)[len(samples) // 2])
        rows.append((label, got, inside))
    return rows


def batch(rounds, n, steps):
    a = articula.Model.from_urdf(HUMANOID, floating_base=True)
    rng = np.random.default_rng(0)
    Q0 = np.tile(a.rest(), (n, 1))
    Q0[:, 2] = 1.1
    V0 = np.zeros((n, a.nv))
    V0[:, 6:] = rng.uniform(-1.0, 1.0, (n, a.nv - 6))
    out = []
    for floor in (False, True):
        m = mujoco_model(open(HUMANOID).read(), True, floor)
        datas = [mujoco.MjData(m) for _ in range(2)]
        d0 = datas[0]
        d0.qpos[:] = m.qpos0
        d0.qpos[2] = 1.1
        nstate = mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        init = np.zeros((n, nstate))
        for i in range(n):
            d0.qvel[:] = 0
            d0.qvel[6:] = rng.uniform(-1.0, 1.0, m.nv - 6)
            mujoco.mj_getState(m, d0, init[i], mujoco.mjtState.mjSTATE_FULLPHYSICS)
        sides = {
            "articula.rollout": lambda: articula.rollout(a, Q0, V0, steps=steps, dt=1e-3,
                                                         integrator="euler",
                                                         ground=0.0 if floor else None,
                                                         threads=2),
            "mujoco.rollout": lambda: mj_rollout.rollout(m, datas, init, nstep=steps,
                                                         persistent_pool=True),
        }
        got = {k: [] for k in sides}
        for k in sides:
            sides[k]()  # warm-up (and thread pools)
        for r in range(rounds):
            order = list(sides) if r % 2 == 0 else list(reversed(sides))
            for k in order:
                t0 = time.perf_counter()
                sides[k]()
                got[k].append(n * steps / (time.perf_counter() - t0))
        out.append(("with a floor" if floor else "no floor", got))
    return out


def fmt(xs, unit):
    xs = sorted(xs)
    med = xs[len(xs) // 2]
    if unit == "us":
        return f"{med:.2f} µs ({xs[0]:.2f}–{xs[-1]:.2f})"
    return f"{med:,.0f} ({xs[0]:,.0f}–{xs[-1]:,.0f})"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    budget, rounds, n, steps = (0.05, 3, 16, 50) if args.quick else (0.3, 7, 64, 200)
    import importlib.metadata as md
    print(f"python {sys.version.split()[0]}, articula {articula.__version__}, "
          f"pin {md.version('pin')}, mujoco {md.version('mujoco')}, numpy {np.__version__}; "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores\n")
    print("| per call, from Python | " + " | ".join(
        ["articula.forward_dynamics", "pinocchio.aba", "mujoco.mj_forward",
         "articula's DCA inside Rust"]) + " |")
    print("|---|--:|--:|--:|--:|")
    for label, got, inside in per_call(budget, rounds):
        print(f"| {label} | " + " | ".join(fmt(v, "us") for v in got.values())
              + f" | {fmt(inside, 'us')} |")
    print()
    print(f"| {n} rollouts × {steps} steps, 2 threads, states/s | articula.rollout | "
          "mujoco.rollout |")
    print("|---|--:|--:|")
    for label, got in batch(rounds, n, steps):
        print(f"| humanoid, {label} | " + " | ".join(fmt(v, "n") for v in got.values()) + " |")


if __name__ == "__main__":
    main()
