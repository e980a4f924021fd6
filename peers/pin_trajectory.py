#!/usr/bin/env python3
"""Pinocchio's `pin.aba` with a plain integrator in Python, for the trajectory chart of
`cargo xtask bench --peers` (docs/bench-report.md):

    target/peers-venv/bin/python peers/pin_trajectory.py CHAIN.urdf START.json

START.json: {"q0": [...], "horizon": 0.1, "runs": [["euler", 0.001], ["rk4", 0.002], ...]}
(the crumpled start of xtask/src/trajectory.rs, at rest, no torque). Semi-implicit Euler is
v += h aba(q, v), q = integrate(q, h v) — articula's `Integrator::SemiImplicitEuler`; RK4 the
classic four stages on (q, v) with `pin.integrate` for the positions — articula's
`Integrator::Rk4`. Prints one JSON line a run: its final q and the minimum over 3 runs of the
mean time per step (µs; the Python loop's overhead included: this is what a user of
Pinocchio's Python bindings pays).
"""
import json, sys, time
import numpy as np
import pinocchio as pin

m = pin.buildModelFromUrdf(sys.argv[1])
d = m.createData()
spec = json.load(open(sys.argv[2]))
q0 = np.array(spec["q0"], dtype=float)
zero = np.zeros(m.nv)


def euler(q, v, h):
    v = v + h * pin.aba(m, d, q, v, zero)
    return pin.integrate(m, q, h * v), v


def rk4(q, v, h):
    a1 = pin.aba(m, d, q, v, zero).copy()
    q2, v2 = pin.integrate(m, q, 0.5 * h * v), v + 0.5 * h * a1
    a2 = pin.aba(m, d, q2, v2, zero).copy()
    q3, v3 = pin.integrate(m, q, 0.5 * h * v2), v + 0.5 * h * a2
    a3 = pin.aba(m, d, q3, v3, zero).copy()
    q4, v4 = pin.integrate(m, q, h * v3), v + h * a3
    a4 = pin.aba(m, d, q4, v4, zero).copy()
    dq = (v + 2 * v2 + 2 * v3 + v4) / 6
    return pin.integrate(m, q, h * dq), v + h * (a1 + 2 * a2 + 2 * a3 + a4) / 6


for kind, h in spec["runs"]:
    step = euler if kind == "euler" else rk4
    n = int(round(spec["horizon"] / h))
    best, qf = float("inf"), None
    for _ in range(3):
        q, v = q0.copy(), np.zeros(m.nv)
        t = time.perf_counter()
        for _ in range(n):
            q, v = step(q, v, h)
        best = min(best, (time.perf_counter() - t) * 1e6 / n)
        qf = q
    print(json.dumps({"integrator": kind, "dt": h, "us_per_step": best, "q": list(qf),
                      "pinocchio": pin.__version__}), flush=True)
