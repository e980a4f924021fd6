#!/usr/bin/env python3
"""MuJoCo's cost per simulated second for a crowd like a scene file's, for the vertical line
of `cargo xtask crowd-chart` (docs/view.md#crowd-chart):

    target/peers-venv/bin/python peers/mujoco_crowd.py models/scenes/crowd200.json [SECONDS]

The scene's humanoid URDF (its collision geometry; MuJoCo's compiler) with a free joint,
one copy per character of the scene's crowd grid (rows x columns at its spacing, standing
at its origin height), on a plane, under the scene's gravity, at the scene's time step,
massless links given 1e-5 kg and 1e-8 kg m², MuJoCo's defaults otherwise (soft contacts, Euler, no pose springs, no pushes): the same
number of bodies and joints standing on a floor, not the same motion. Prints one JSON line:
{"ms_per_sim_s": ..., "note": ...}, the CPU time (one thread) of `mj_step` over SECONDS
(default 2) simulated seconds.
"""
import json, os, sys, time
import mujoco

scene_path = sys.argv[1]
seconds = float(sys.argv[2]) if len(sys.argv) > 2 else 2.0
scene = json.load(open(scene_path))
here = os.path.dirname(os.path.abspath(scene_path))
crowd = scene["crowds"][0]
urdf = os.path.join(here, scene["models"][crowd["model"]])

world = mujoco.MjSpec()
world.option.timestep = scene["dt"]
# The URDF's composed joints (a ball joint as three revolutes) have massless links between
# them: MuJoCo needs a small mass and inertia on every moving body.
world.compiler.boundmass = 1e-5
world.compiler.boundinertia = 1e-8
world.option.gravity = scene.get("gravity", [0, 0, -9.81])
world.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[100, 100, 0.1])
ox, oy, oz = crowd["origin"]
sx, sy = crowd["spacing"]
n = 0
for r in range(crowd["rows"]):
    for c in range(crowd["columns"]):
        person = mujoco.MjSpec.from_file(urdf)
        person.compiler.boundmass = 1e-5
        person.compiler.boundinertia = 1e-8
        root = person.worldbody.first_body()
        root.add_freejoint()
        frame = world.worldbody.add_frame(pos=[ox + r * sx, oy + c * sy, oz])
        frame.attach_body(root, f"c{n}_", "")
        n += 1
m = world.compile()
d = mujoco.MjData(m)
steps = int(round(seconds / m.opt.timestep))
mujoco.mj_forward(m, d)
t = time.thread_time()
for _ in range(steps):
    mujoco.mj_step(m, d)
cpu = time.thread_time() - t
print(json.dumps({
    "ms_per_sim_s": cpu * 1e3 / (steps * m.opt.timestep),
    "note": f"MuJoCo {mujoco.__version__}, {n} humanoids from the URDF with free joints on a "
            f"plane, nv = {m.nv}, dt = {m.opt.timestep:.5f} s, {steps} mj_step calls, "
            f"CPU time of one thread (peers/mujoco_crowd.py)",
    "ncon_last": int(d.ncon),
}))
