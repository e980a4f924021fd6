#!/usr/bin/env python3
"""Rollouts per second: local articula.rollout against articula.ray.rollouts over 1 and 2
Ray workers on this machine (a local cluster of 2 CPUs), alternated rounds, median and range.

    target/py-venv/bin/python peers/ray_rollouts.py [--quick]
"""

import argparse
import os
import time

import numpy as np
import ray

import articula
import articula.ray as aray

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
HUMANOID = os.path.join(ROOT, "models", "humanoid.urdf")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    n, steps, rounds = (32, 50, 3) if args.quick else (64, 200, 5)
    model = articula.Model.from_urdf(HUMANOID, floating_base=True)
    rng = np.random.default_rng(0)
    Q0 = np.tile(model.rest(), (n, 1))
    Q0[:, 2] = 1.1
    V0 = np.zeros((n, model.nv))
    V0[:, 6:] = rng.uniform(-0.5, 0.5, (n, model.nv - 6))
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    kw = dict(steps=steps, dt=1e-3, integrator="euler")
    sides = {
        "local rollout, 2 threads": lambda: articula.rollout(model, Q0, V0, threads=2, **kw),
        "ray, 1 worker × 2 threads": lambda: aray.rollouts(HUMANOID, Q0, V0, num_workers=1,
                                                           floating_base=True, threads=2, **kw),
        "ray, 2 workers × 1 thread": lambda: aray.rollouts(HUMANOID, Q0, V0, num_workers=2,
                                                           floating_base=True, threads=1, **kw),
    }
    ref = sides["local rollout, 2 threads"]()
    got = {k: [] for k in sides}
    for k, f in sides.items():
        Q, V = f()  # warm-up: workers start, models load
        assert np.array_equal(Q, ref[0]) and np.array_equal(V, ref[1]), k
    for r in range(rounds):
        for k in (list(sides) if r % 2 == 0 else list(reversed(sides))):
            t0 = time.perf_counter()
            sides[k]()
            got[k].append(n * steps / (time.perf_counter() - t0))
    # One small call's round trip: what a sharded call costs beyond the work.
    lat = []
    for _ in range(20):
        t0 = time.perf_counter()
        aray.rollouts(HUMANOID, Q0[:2], V0[:2], num_workers=2, floating_base=True, steps=1)
        lat.append(1e3 * (time.perf_counter() - t0))
    print(f"ray {ray.__version__}; {n} humanoid rollouts × {steps} steps (semi-implicit Euler, "
          f"no floor); load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores\n")
    print("| | states/s (median of rounds, range) |\n|---|--:|")
    for k, xs in got.items():
        xs = sorted(xs)
        print(f"| {k} | {xs[len(xs) // 2]:,.0f} ({xs[0]:,.0f}–{xs[-1]:,.0f}) |")
    lat.sort()
    print(f"\nround trip of a 2-state, 1-step call over 2 workers: median {lat[10]:.1f} ms "
          f"(min {lat[0]:.1f} ms)")
    print("every sharded result equals the local rollout bit for bit")
    aray.shutdown()
    ray.shutdown()


if __name__ == "__main__":
    main()
