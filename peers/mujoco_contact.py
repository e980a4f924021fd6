"""MuJoCo's answers to two of articula's contact known-answer tests (docs/contact.md).

Run with the peers venv (it has `mujoco`):

    target/peers-venv/bin/python peers/mujoco_contact.py

- drop: a sphere r = 0.1 m, 1 kg, dropped from 0.5 m (centre height) onto the plane z = 0,
  dt = 1 ms, 2 s: its resting centre height (articula: 0.1000000 m) and the penetration.
- slide: a 0.2 m cube on a 30° incline with μ = 0.3 (elliptic friction cone, as articula's
  Coulomb disc), dt = 1 ms: its acceleration down the slope over 0.5-1.0 s against
  g (sin θ − μ cos θ) = 2.356287 m/s² (articula: relative error 2e-13).

MuJoCo's contacts are soft (solref/solimp): the body rests slightly inside the plane and the
slide's acceleration carries the compliance's error; both are printed, with MuJoCo's defaults
and nothing tuned.
"""

import math

import mujoco

G = 9.81


def drop():
    xml = """
    <mujoco><option timestep="0.001" gravity="0 0 -9.81"/>
      <worldbody><geom type="plane" size="5 5 0.1"/>
        <body pos="0 0 0.5"><freejoint/>
          <geom type="sphere" size="0.1" mass="1"/></body>
      </worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    for _ in range(2000):
        mujoco.mj_step(m, d)
    z = d.qpos[2]
    print(f"drop: rest height {z:.7f} m (exact 0.1), penetration {max(0.0, 0.1 - z) * 1e3:.3f} mm, speed {abs(d.qvel[2]):.2e} m/s")


def slide(theta=math.radians(30.0), mu=0.3):
    # euler="0 -θ 0" turns the plane about y: normal (−sin θ, 0, cos θ), and gravity's
    # component along the plane points along (−cos θ, 0, −sin θ).
    n = (-math.sin(theta), 0.0, math.cos(theta))
    xml = f"""
    <mujoco><option timestep="0.001" gravity="0 0 -9.81" cone="elliptic"/>
      <worldbody>
        <geom type="plane" size="50 50 0.1" euler="0 {-math.degrees(theta)} 0" friction="{mu} 0.005 0.0001"/>
        <body pos="{0.1 * n[0]:.9f} 0 {0.1 * n[2]:.9f}" euler="0 {-math.degrees(theta)} 0"><freejoint/>
          <geom type="box" size="0.1 0.1 0.1" mass="1" friction="{mu} 0.005 0.0001"/></body>
      </worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    down = (-math.cos(theta), 0.0, -math.sin(theta))
    speed = lambda: sum(v * u for v, u in zip(d.qvel[:3], down))
    v = {}
    for k in range(1001):
        if k in (500, 1000):
            v[k] = speed()
        mujoco.mj_step(m, d)
    a = (v[1000] - v[500]) / 0.5
    exact = G * (math.sin(theta) - mu * math.cos(theta))
    print(f"slide: a = {a:.6f} m/s² against g(sin θ − μ cos θ) = {exact:.6f}, relative error {abs(a - exact) / exact:.1e}")


if __name__ == "__main__":
    print(f"mujoco {mujoco.__version__}")
    drop()
    slide()
