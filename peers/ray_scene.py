#!/usr/bin/env python3
"""A crowd scene sharded over Ray actors against the one-process scene: steps per second, and
per re-selection the bytes each exchange sends and its latency (wall time beyond the shards'
own compute), over 1, 2 and 3 shards on a local cluster; every sharded run checked bit for bit
against the one-process run.

    target/py-venv/bin/python peers/ray_scene.py [--scene models/scenes/crowd200.json]
                                                 [--steps 300] [--rounds 3] [--shards 1 2 3]
"""

import argparse
import os
import statistics
import time

import ray

import articula
import articula.ray as aray

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))


def one_process(path, steps):
    scene = articula.Scene.from_file(path, threads=1)
    t0 = time.perf_counter()
    for _ in range(steps):
        scene.step()
    return time.perf_counter() - t0, scene.state_hash()


def sharded(path, steps, shards):
    scene = aray.ShardedScene(path, num_shards=shards, threads=1, timeout=600)
    try:
        t0 = time.perf_counter()
        scene.run(steps)
        wall = time.perf_counter() - t0
        return wall, scene.state_hash(), scene.exchanges
    finally:
        scene.shutdown()


def med(xs):
    return statistics.median(xs)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=os.path.join(ROOT, "models/scenes/crowd200.json"))
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--shards", type=int, nargs="+", default=[1, 2, 3])
    args = ap.parse_args()
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    rate = {"one process": []}
    rate.update({n: [] for n in args.shards})
    ex_all = {n: [] for n in args.shards}
    ref = None
    for r in range(args.rounds):
        order = ["one process"] + list(args.shards)
        for k in (order if r % 2 == 0 else order[::-1]):
            if k == "one process":
                wall, h = one_process(args.scene, args.steps)
            else:
                wall, h, ex = sharded(args.scene, args.steps, k)
                ex_all[k].extend(ex[1:])  # the first re-selection also starts every body
            ref = h if ref is None else ref
            assert h == ref, f"{k}: state hash {h:016x} != {ref:016x}"
            rate[k].append(args.steps / wall)
    scene = articula.Scene.from_file(args.scene, threads=1)
    print(f"ray {ray.__version__}; {os.path.relpath(args.scene, ROOT)}: {scene.nbodies} bodies, "
          f"{args.steps} steps, re-selection every {scene.summary()['reselect_every']} steps; "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}; one thread per shard; "
          f"state hash {ref:016x} in every run\n")
    print("| | steps/s (median of rounds, range) |\n|---|--:|")
    for k, xs in rate.items():
        name = k if isinstance(k, str) else f"{k} shard{'s' if k > 1 else ''}"
        print(f"| {name} | {med(xs):,.0f} ({min(xs):,.0f}–{max(xs):,.0f}) |")
    print("\nper re-selection (medians over the re-selections after the first):\n")
    print("| shards | depth up | depth down | candidates up | counts down | exchange wall ms "
          "| slowest shard compute ms | latency ms |\n|--:|--:|--:|--:|--:|--:|--:|--:|")
    for n, ex in ex_all.items():
        if not ex:
            continue
        wall = [1e3 * sum(e["seconds"]) for e in ex]
        comp = [1e3 * sum(max(x) for x in e["shard_seconds"]) for e in ex]
        lat = [w - c for w, c in zip(wall, comp)]
        print(f"| {n} | {med([e['bytes_depth_up'] for e in ex]):,.0f} B "
              f"| {med([e['bytes_depth_down'] for e in ex]):,.0f} B "
              f"| {med([e['bytes_candidates_up'] for e in ex]):,.0f} B "
              f"| {med([e['bytes_counts_down'] for e in ex]):,.0f} B "
              f"| {med(wall):.2f} | {med(comp):.2f} | {med(lat):.2f} ({min(lat):.2f}–{max(lat):.2f}) |")
    print("\n(exchange wall: the three exchanges of a re-selection as the driver sees them, "
          "the merges included, the third carrying the steps up to the next re-selection; "
          "latency: that minus the slowest shard's compute in each exchange.)")
    ray.shutdown()


if __name__ == "__main__":
    main()
