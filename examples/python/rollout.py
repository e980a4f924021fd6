#!/usr/bin/env python3
"""A batch of humanoid rollouts on every core, with and without a floor, and a plot of their
energy over time saved as PNG.

    python examples/python/rollout.py [--quick] [--out target/py-rollout-energy.png]
"""

import argparse
import os
import time

import numpy as np

import articula

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))


def energy(model, data, Q, V):
    """Kinetic + potential energy of every state of a trajectory."""
    out = np.empty(len(Q))
    for k, (q, v) in enumerate(zip(Q, V)):
        articula.forward_kinematics(model, data, q, v)
        out[k] = articula.kinetic_energy(model, data) + articula.potential_energy(model, data)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="16 rollouts of 200 steps")
    ap.add_argument("--out", default=os.path.join(ROOT, "target", "py-rollout-energy.png"))
    args = ap.parse_args()
    n, steps, dt = (16, 200, 1e-3) if args.quick else (64, 500, 1e-3)
    model = articula.Model.from_urdf(os.path.join(ROOT, "models", "humanoid.urdf"),
                                     floating_base=True)
    rng = np.random.default_rng(0)
    Q0 = np.tile(model.rest(), (n, 1))
    Q0[:, 2] = 1.1
    V0 = np.zeros((n, model.nv))
    V0[:, 6:] = rng.uniform(-0.5, 0.5, (n, model.nv - 6))      # joints swinging, base at rest
    data = articula.Data(model)
    runs = {}
    for label, ground in (("no floor (RK4)", None), ("floor z = 0 (semi-implicit Euler)", 0.0)):
        t0 = time.perf_counter()
        Q, V = articula.rollout(model, Q0, V0, steps=steps, dt=dt, ground=ground)
        wall = time.perf_counter() - t0
        print(f"{label}: {n} × {steps} steps in {wall:.3f} s "
              f"({n * steps / wall:,.0f} states/s)")
        runs[label] = np.array([energy(model, data, Q[i], V[i]) for i in range(n)])
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    t = dt * np.arange(1, steps + 1)
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=False)
    for ax, (label, E) in zip(axes, runs.items()):
        for e in E:
            ax.plot(t, e - e[0], lw=0.6, alpha=0.6)
        ax.set_title(label, fontsize=10)
        ax.set_xlabel("time (s)")
    axes[0].set_ylabel("E(t) − E(first step) (J)")
    fig.suptitle(f"{n} humanoid rollouts, articula.rollout, dt = {dt} s", fontsize=11)
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    fig.savefig(args.out, dpi=110)
    drift = np.max(np.abs(runs["no floor (RK4)"] - runs["no floor (RK4)"][:, :1]))
    lost = np.mean(runs["floor z = 0 (semi-implicit Euler)"][:, -1]
                   - runs["floor z = 0 (semi-implicit Euler)"][:, 0])
    print(f"no floor: largest energy drift {drift:.2e} J; floor: mean energy change {lost:.2f} J "
          f"(falls and impacts dissipate)")
    print(f"plot: {args.out}")


if __name__ == "__main__":
    main()
