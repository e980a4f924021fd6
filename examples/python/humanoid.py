#!/usr/bin/env python3
"""A floating humanoid: forward and inverse dynamics, the mass matrix, a foot's Jacobian and the
centre of mass, checked against each other.

    python examples/python/humanoid.py          (from the repository root)
"""

import argparse
import os

import numpy as np

import articula

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="(no effect: this example is quick)")
    ap.parse_args()
    model = articula.Model.from_urdf(os.path.join(ROOT, "models", "humanoid.urdf"),
                                     floating_base=True)
    data = articula.Data(model)
    print(model)
    print(f"mass {model.mass:.2f} kg, joints {model.joint_names[:4]} ...")

    q, v, tau = model.random_state(seed=7)
    qdd = articula.forward_dynamics(model, data, q, v, tau)               # DCA
    qdd_aba = articula.forward_dynamics(model, data, q, v, tau, method="aba")
    print(f"forward dynamics: |q̈| = {np.linalg.norm(qdd):.6f}, "
          f"DCA − ABA = {np.max(np.abs(qdd - qdd_aba)):.1e}")

    tau_back = articula.inverse_dynamics(model, data, q, v, qdd)
    print(f"inverse dynamics of it: max |τ − ID(q, v, FD(q, v, τ))| = "
          f"{np.max(np.abs(tau_back - tau)):.1e}")

    M = articula.mass_matrix(model, data, q)
    b = articula.bias_forces(model, data, q, v)
    print(f"M is {M.shape}, symmetric, min eigenvalue {np.linalg.eigvalsh(M).min():.3e}; "
          f"max |M q̈ + b − τ| = {np.max(np.abs(M @ qdd + b - tau)):.1e}")

    articula.forward_kinematics(model, data, q, v)
    foot = "l_foot"
    R, p = articula.link_pose(model, data, foot)
    J = articula.jacobian(model, data, foot, frame="local_world_aligned")   # rows [ω; v]
    print(f"{foot} at {np.round(p, 4)}; its velocity [ω; v] = J v = {np.round(J @ v, 4)}")
    c = articula.com(model, data)
    Jc = articula.com_jacobian(model, data)
    print(f"centre of mass {np.round(c, 4)}, its velocity {np.round(Jc @ v, 4)}")
    h = articula.momentum(model, data)
    print(f"linear momentum {np.round(h[3:], 4)} = mass × ċ: "
          f"{np.allclose(h[3:], model.mass * (Jc @ v))}")
    print(f"kinetic energy {articula.kinetic_energy(model, data):.6f} J = ½ vᵀ M v = "
          f"{0.5 * v @ M @ v:.6f} J")


if __name__ == "__main__":
    main()
