#!/usr/bin/env python3
"""Minimum and median time of Pinocchio's `pin.aba` on one URDF, for the interleaved
comparisons with `cargo xtask time dca 300 20 100`:

    cargo xtask models --chain 300 > /tmp/c300.urdf
    target/peers-venv/bin/python peers/pin300.py /tmp/c300.urdf

(Pinocchio from `target/peers-venv`, see peers/peers.py.) A seeded random state (q, v, tau
uniform in [-1, 1]), 200 warm-up calls, then 20 batches of 100 calls, for the default
convention and `pin.Convention.WORLD`; prints the minimum and median time per call.
"""
import sys, time, numpy as np, pinocchio as pin
m = pin.buildModelFromUrdf(sys.argv[1]); d = m.createData()
rng = np.random.default_rng(42)
q = pin.neutral(m); q[:] = rng.uniform(-1, 1, m.nq); v = rng.uniform(-1, 1, m.nv); tau = rng.uniform(-1, 1, m.nv)
for conv, name in ((None, "default"), (pin.Convention.WORLD, "WORLD")):
    call = (lambda: pin.aba(m, d, q, v, tau)) if conv is None else (lambda: pin.aba(m, d, q, v, tau, conv))
    for _ in range(200): call()
    ts = []
    for _ in range(20):
        t = time.perf_counter()
        for _ in range(100): call()
        ts.append((time.perf_counter() - t) * 1e4)
    ts.sort(); print(f"pin {name}: min {ts[0]:.1f} us, median {ts[10]:.1f} us")
