"""Pinocchio's quantities for `cargo xtask pinocchio`, in articula's coordinates.

Reads a JSON request on stdin: {"urdf": path, "floating_base": bool,
"joints": [{"name", "kind", "q_offset", "v_offset"}...] (articula's joint parts in order),
"nq", "nv", "links": [names], "points": [[x, y, z] per link],
"states": [{"q", "qd", "qdd"}...]} in articula's coordinates. Writes JSON on stdout: per state
the RNEA joint forces, the mass matrix (CRBA), the bias forces, the centre of mass and its
Jacobian, the kinetic and potential energies, the centroidal momentum [n; p] and, per link,
its world pose and its Jacobians in the three reference frames (rows [w; v]) and the point
Jacobian, all mapped to articula's order.

Conventions mapped here (docs/conventions.md):
- floating base: articula q = [x, y, z, qw, qx, qy, qz], qd = [w; v] (body frame);
  Pinocchio's free flyer q = [x, y, z, qx, qy, qz, qw], v = [v; w] (body frame);
- continuous joints: articula q = angle, Pinocchio q = (cos, sin);
- spatial vectors: articula [angular; linear], Pinocchio [linear; angular].
"""

import json
import sys

import numpy as np
import pinocchio as pin


def main():
    req = json.load(sys.stdin)
    if req["floating_base"]:
        model = pin.buildModelFromUrdf(req["urdf"], pin.JointModelFreeFlyer())
    else:
        model = pin.buildModelFromUrdf(req["urdf"])
    data = model.createData()
    nv = req["nv"]
    # perm[i]: Pinocchio's velocity index of articula's velocity index i.
    perm = np.zeros(nv, dtype=int)
    qmap = []  # (articula q index, Pinocchio q index)
    rub = []  # the same for continuous joints, (cos, sin) in Pinocchio
    for j in req["joints"]:
        vo, qo = j["v_offset"], j["q_offset"]
        if j["kind"] == "floating":
            jid = model.getJointId("root_joint")
            pv, pq = model.joints[jid].idx_v, model.joints[jid].idx_q
            perm[vo:vo + 3] = np.arange(pv + 3, pv + 6)  # w
            perm[vo + 3:vo + 6] = np.arange(pv, pv + 3)  # v
            qmap += [(qo + k, pq + k) for k in range(3)]
            qmap += [(qo + 3, pq + 6), (qo + 4, pq + 3), (qo + 5, pq + 4), (qo + 6, pq + 5)]
        else:
            jid = model.getJointId(j["name"])
            if jid >= model.njoints:
                raise SystemExit(f"Pinocchio has no joint {j['name']}")
            perm[vo] = model.joints[jid].idx_v
            if model.joints[jid].nq == 2:
                # An unbounded revolute joint (URDF continuous): q = (cos, sin).
                rub.append((qo, model.joints[jid].idx_q))
            else:
                qmap.append((qo, model.joints[jid].idx_q))
    if sorted(perm) != list(range(nv)):
        raise SystemExit("the velocity coordinates do not map one to one")
    if model.nv != nv:
        raise SystemExit(f"Pinocchio has nv = {model.nv}, articula {nv}")
    six = [3, 4, 5, 0, 1, 2]  # articula row r is Pinocchio row six[r]

    def vec(x):
        return [float(x[perm[i]]) for i in range(nv)]

    def spatial(m):
        # Pinocchio 6 x nv [lin; ang] -> articula [ang; lin], columns in articula order.
        return [[float(m[six[r], perm[c]]) for c in range(nv)] for r in range(6)]

    out = []
    for s in req["states"]:
        q = np.zeros(model.nq)
        for a, p in qmap:
            q[p] = s["q"][a]
        for a, p in rub:
            q[p], q[p + 1] = np.cos(s["q"][a]), np.sin(s["q"][a])
        v = np.zeros(nv)
        a = np.zeros(nv)
        for i in range(nv):
            v[perm[i]] = s["qd"][i]
            a[perm[i]] = s["qdd"][i]
        tau = pin.rnea(model, data, q, v, a)
        m = pin.crba(model, data, q)
        m = np.triu(m) + np.triu(m, 1).T
        b = pin.nonLinearEffects(model, data, q, v)
        com = pin.centerOfMass(model, data, q, v)
        jcom = pin.jacobianCenterOfMass(model, data, q)
        t = pin.computeKineticEnergy(model, data, q, v)
        u = pin.computePotentialEnergy(model, data, q)
        pin.computeCentroidalMomentum(model, data, q, v)
        hg = data.hg.vector  # [p; n_G]
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        links = []
        for name, point in zip(req["links"], req["points"]):
            fid = model.getFrameId(name)
            if fid >= len(model.frames):
                raise SystemExit(f"Pinocchio has no frame {name}")
            om = data.oMf[fid]
            frames = {}
            for key, rf in [("world", pin.WORLD), ("local", pin.LOCAL),
                            ("local_world_aligned", pin.LOCAL_WORLD_ALIGNED)]:
                frames[key] = spatial(pin.getFrameJacobian(model, data, fid, rf))
            # The point Jacobian: a frame at the point, LOCAL_WORLD_ALIGNED, linear rows.
            jl = pin.getFrameJacobian(model, data, fid, pin.LOCAL)
            pl = np.array(point)
            jlin_local = jl[:3, :] - np.cross(pl, jl[3:, :].T).T  # v_p = v + w x p (link axes)
            jpoint = om.rotation @ jlin_local
            links.append({
                "rotation": om.rotation.tolist(),
                "translation": om.translation.tolist(),
                "jacobian": frames,
                "point_jacobian": [[float(jpoint[r, perm[c]]) for c in range(nv)]
                                   for r in range(3)],
            })
        out.append({
            "tau": vec(tau),
            "mass_matrix": [[float(m[perm[r], perm[c]]) for c in range(nv)]
                            for r in range(nv)],
            "bias_forces": vec(b),
            "com": com.tolist(),
            "com_jacobian": [[float(jcom[r, perm[c]]) for c in range(nv)] for r in range(3)],
            "kinetic_energy": float(t),
            "potential_energy": float(u),
            "centroidal_momentum": [float(x) for x in list(hg[3:]) + list(hg[:3])],
            "links": links,
        })
    json.dump({"pinocchio": pin.__version__, "states": out}, sys.stdout)


if __name__ == "__main__":
    main()
