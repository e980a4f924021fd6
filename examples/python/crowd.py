#!/usr/bin/env python3
"""A crowd scene built in code: 12 humanoids on the floor, one joint budget spent where the
camera looks, frames written as `articula scene --out` writes them.

    python examples/python/crowd.py [--quick] [--out target/py-crowd]
"""

import argparse
import os

import articula

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="60 steps instead of 600")
    ap.add_argument("--out", default=os.path.join(ROOT, "target", "py-crowd"))
    args = ap.parse_args()
    steps, every = (60, 30) if args.quick else (600, 60)
    scene = (articula.SceneBuilder()
             .model("humanoid", os.path.join(ROOT, "models", "humanoid.urdf"))
             .crowd("humanoid", rows=3, columns=4, origin=(4.0, -1.5, 1.021), spacing=(1.2, 0.9),
                    jitter=0.2, seed=7, yaw=3.14159, name="crowd")
             .camera(eye=(0.0, 0.0, 1.4), target=(8.0, 0.0, 1.0))
             .push("chest", force=(60.0, 0.0, 0.0), t0=0.0, t1=0.3, point=(0.0, 0.0, 0.2))
             .budget(120).dt(1 / 600).reselect_every(10)
             .ground(0.0).joint_springs(2.0, 0.2).image(480, 270)
             .build())
    print(scene)
    frames = []
    for k in range(steps):
        if k % every == 0:
            frames.append(scene.save_frame(args.out, k)[0])
        s = scene.step()
    frames.append(scene.save_frame(args.out, steps)[0])
    summary = scene.summary()
    print(f"{summary['steps']} steps of {summary['bodies']} characters ({summary['dof_total']} "
          f"joints), {summary['active_joints_mean']:.0f} active on average (budget "
          f"{summary['budget']}); visible {summary['visible']}, occluded {summary['occluded']}, "
          f"invisible {summary['invisible']}; last step {s['contacts']} contacts")
    print(f"body 0 ({scene.body_name(0)}) pelvis at {scene.q(0)[:3].round(3)}")
    print(f"{len(frames)} frames in {args.out}, last {frames[-1]}")


if __name__ == "__main__":
    main()
