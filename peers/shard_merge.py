#!/usr/bin/env python3
"""The driver's side of a sharded crowd's re-selection, without Ray: a scene split into M
shards in this process (articula.SceneShard), one re-selection's messages, and the time of the
driver's two merges (depth buffers, candidates), decoding included — the figures the
projection of docs/scaling.md scales up. Also checks that the merged choice gives every body
the share the one-process scene gives it.

    target/py-venv/bin/python peers/shard_merge.py [--scene models/scenes/crowd2000.json]
                                                   [--shards 2 5 10 20] [--reps 20]
"""

import argparse
import os
import statistics
import time

import articula
from articula import _articula

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))


def timed(f, reps):
    xs = []
    for _ in range(reps):
        t0 = time.perf_counter()
        f()
        xs.append(time.perf_counter() - t0)
    return statistics.median(xs)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=os.path.join(ROOT, "models/scenes/crowd2000.json"))
    ap.add_argument("--shards", type=int, nargs="+", default=[2, 5, 10, 20])
    ap.add_argument("--reps", type=int, default=20)
    args = ap.parse_args()
    whole = articula.Scene.from_file(args.scene, threads=1)
    t0 = time.perf_counter()
    whole.step()
    one_step = time.perf_counter() - t0
    shares = whole.selection()
    n = whole.nbodies
    s = whole.summary()
    print(f"{os.path.relpath(args.scene, ROOT)}: {n} bodies, budget {s['budget']}, "
          f"first step (a re-selection) {1e3 * one_step:.0f} ms in one process\n")
    print("| shards | depth up (sum) | candidates up (sum) | pops sent | pops taken "
          "| merge depths ms | merge candidates ms |\n|--:|--:|--:|--:|--:|--:|--:|")
    for m in args.shards:
        shards = [articula.SceneShard.from_file(args.scene, k, m, threads=1) for k in range(m)]
        depths = [sh.begin() for sh in shards]
        merged = _articula.shard_merge_depths(depths)
        cands = [sh.weigh(merged) for sh in shards]
        taken = _articula.shard_merge_candidates(cands)
        for sh, k in zip(shards, taken):
            sh.apply(k)
        got = [x for sh in shards for x in sh.selection()]
        assert got == shares, f"{m} shards: the shares differ from the one-process scene's"
        td = timed(lambda: _articula.shard_merge_depths(depths), args.reps)
        tc = timed(lambda: _articula.shard_merge_candidates(cands), args.reps)
        # 24 bytes a pop after an 84-byte header (no tolerance).
        sent = sum((len(c) - 84) // 24 for c in cands)
        print(f"| {m} | {sum(map(len, depths)):,} B | {sum(map(len, cands)):,} B | {sent:,} "
              f"| {sum(taken):,} | {1e3 * td:.2f} | {1e3 * tc:.2f} |")
        del shards
    print("\nevery shard count gives every body the one-process share and error")


if __name__ == "__main__":
    main()
