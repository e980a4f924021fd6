"""Pinocchio's `pin.aba` (default convention: local frames) at one state, for the accuracy
table of `cargo xtask stability` (section 5):

    target/peers-venv/bin/python peers/pin_qdd.py MODEL.urdf < state.json

state.json: {"q": [...], "qd": [...], "tau": [...]}; prints q̈ as a JSON list. Gravity
(0, 0, -9.81), Pinocchio's default, as articula's.
"""
import sys, json, numpy as np, pinocchio as pin
m = pin.buildModelFromUrdf(sys.argv[1]); d = m.createData()
st = json.load(sys.stdin)
q, v, tau = (np.array(st[k], dtype=float) for k in ("q", "qd", "tau"))
json.dump([float(x) for x in pin.aba(m, d, q, v, tau)], sys.stdout)
