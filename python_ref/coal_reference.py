#!/usr/bin/env python3
"""coal (through Pinocchio's collision module) reference distances for tandem's
collision cross-check tests.

Usage:
  coal_reference.py distances < request.json
      Request: a "collision scene exchange" object:
        {"urdf": path, "package_dirs": [paths],
         "joints": [active joint names, the order of each configuration],
         "held": {joint name: value} for every other movable joint (Pinocchio
                 builds mimic joints as independent joints),
         "robot_elements": [{"link": L, "index": k}]  (k-th <collision> of L in
                 URDF order = Pinocchio geometry "L_k"),
         "obstacles": [{"name"?, "shape": "box"|"sphere"|"cylinder"|"capsule",
                 "half_extents" (box) | "radius" (+ "length" for cylinder and
                 capsule: along z, centred; for the capsule the length of the
                 cylindrical part), "translation": [3], "rotation": [[3]x3]}],
         "pairs": [[a, b]] indices into robot_elements ++ obstacles,
         "configurations": [[q in `joints` order]],
         "output": path (optional), "timing": bool (optional)}
      For every configuration and every pair, computes coal's signed distance
      with pin.computeDistances and writes to `output` little-endian f64, per
      configuration, per pair, 10 values: distance, point on a (world, 3),
      point on b (world, 3), unit normal (world, 3) from a to b, with
      p_b - p_a = distance * normal both when separated and when penetrating
      (distance < 0).
      With "timing": true, also measures in Python the time of one
      pin.computeCollisions(..., stop_at_first_collision=True) and of one
      pin.computeDistances over all pairs (both include FK and geometry
      placement updates), per configuration; the medians (ns, Python call
      overhead included) go into the summary.
      Prints a JSON summary {"coal_version", "pinocchio_version",
      "configurations", "pairs", "seconds", ...} on stdout.

coal's convention (coal 3.0, checked with two spheres, separated and
overlapping, and sphere/box both ways): DistanceRequest.enable_signed_distance
defaults to True, so penetrating shapes give min_distance < 0 (minus the
penetration depth); nearest points and normal are in the frame the transforms
are given in (world, here); the normal points from object 1 to object 2 and
p2 - p1 = min_distance * normal in both cases. That is tandem's convention
already; the only conversion needed is swapping the roles (points exchanged,
normal negated) when Pinocchio stores a pair as (b, a).

Known coal deviation (3.0.3, details::sphereCylinderDistance): when a sphere's
centre lies inside a cylinder and is nearer to a cap than to the side, coal
still pushes out radially, so it reports a deeper penetration than the true
signed distance (by up to a few cm in practice); the witness points then lie on
the side. Everything else checked against closed forms (sphere vs sphere, box,
capsule, and sphere vs cylinder otherwise) agrees to ~1e-15 m.
"""
import json
import sys
import time
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin

sys.path.insert(0, str(Path(__file__).resolve().parent))
from pin_reference import pin_config  # noqa: E402  (continuous joints as (cos, sin))


def fail(msg):
    raise SystemExit(f"coal_reference: {msg}")


def obstacle_geometry(ob):
    shape = ob["shape"]
    if shape == "box":
        # coal.Box takes full side lengths
        return coal.Box(*(2.0 * float(h) for h in ob["half_extents"]))
    if shape == "sphere":
        return coal.Sphere(float(ob["radius"]))
    if shape == "cylinder":
        return coal.Cylinder(float(ob["radius"]), float(ob["length"]))
    if shape == "capsule":
        # coal.Capsule(radius, lz): lz is the cylindrical part's length (halfLength = lz/2)
        return coal.Capsule(float(ob["radius"]), float(ob["length"]))
    fail(f"unknown obstacle shape {shape!r}")


def build_scene(req):
    """Model, geometry model with the requested robot elements, the obstacles and
    pairs, joint ids of `joints`, the held configuration, and per requested pair its
    index in geom_model.collisionPairs and whether Pinocchio stores it as (b, a)."""
    model = pin.buildModelFromUrdf(req["urdf"])
    geom = pin.buildGeomFromUrdf(model, req["urdf"], pin.GeometryType.COLLISION,
                                 package_dirs=list(req.get("package_dirs", [])))
    names = list(req["joints"])
    held = dict(req.get("held", {}))
    for n in names + list(held):
        if not model.existJointName(n):
            fail(f"joint {n!r} not in the Pinocchio model")
    missing = set(model.names[1:]) - set(names) - set(held)
    if missing:
        fail(f"request gives no value for joints {sorted(missing)}")
    joint_ids = [model.getJointId(n) for n in names]
    held_ids = [model.getJointId(n) for n in held]
    q_held = pin_config(model, held_ids, list(held.values()))

    ids = []
    for el in req["robot_elements"]:
        name = f"{el['link']}_{el['index']}"
        if not geom.existGeometryName(name):
            fail(f"no collision geometry {name!r} (link {el['link']!r}, element {el['index']})")
        ids.append(geom.getGeometryId(name))
    for k, ob in enumerate(req.get("obstacles", [])):
        placement = pin.SE3(np.array(ob.get("rotation", np.eye(3)), dtype=float),
                            np.array(ob.get("translation", [0, 0, 0]), dtype=float))
        name = f"obstacle_{k}_{ob.get('name', ob['shape'])}"
        # attached to the universe: joint 0, frame 0
        ids.append(geom.addGeometryObject(pin.GeometryObject(name, 0, 0, placement, obstacle_geometry(ob))))

    # Only the requested pairs (buildGeomFromUrdf adds none; clear in case).
    geom.removeAllCollisionPairs()
    pairs = []
    for a, b in req["pairs"]:
        if a == b or not (0 <= a < len(ids) and 0 <= b < len(ids)):
            fail(f"bad pair {[a, b]} ({len(ids)} elements)")
        cp = pin.CollisionPair(ids[a], ids[b])
        if not geom.existCollisionPair(cp):
            geom.addCollisionPair(cp)
        k = geom.findCollisionPair(cp)
        # CollisionPair equality ignores order: a repeated (b, a) maps onto (a, b).
        pairs.append((k, geom.collisionPairs[k].first != ids[a]))
    return model, geom, joint_ids, q_held, pairs


def distances(req):
    t0 = time.perf_counter()
    model, geom, joint_ids, q_held, pairs = build_scene(req)
    data = model.createData()
    gdata = pin.GeometryData(geom)
    for r in gdata.distanceRequests:
        r.enable_signed_distance = True  # coal 3's default, made explicit
        # coal's GJK/EPA stop at 1e-6 by default, which is the cross-check's
        # tolerance itself: tighten them so the reference is exact for curved
        # shapes (cylinders) too. Closed-form pairs are unaffected.
        r.gjk_tolerance = 1e-10
        r.epa_tolerance = 1e-8
        r.gjk_max_iterations = 1000
        r.epa_max_iterations = 1000
    configs = req["configurations"]
    qs = []
    for values in configs:
        if len(values) != len(joint_ids):
            fail(f"configuration has {len(values)} values, {len(joint_ids)} joints")
        q = q_held.copy()
        q_active = pin_config(model, joint_ids, values)
        for jid in joint_ids:
            jm = model.joints[jid]
            q[jm.idx_q:jm.idx_q + jm.nq] = q_active[jm.idx_q:jm.idx_q + jm.nq]
        qs.append(q)

    summary = {"coal_version": coal.__version__, "pinocchio_version": pin.__version__,
               "configurations": len(configs), "pairs": len(pairs)}
    if req.get("output"):
        out = np.zeros((len(qs), len(pairs), 10))
        for i, q in enumerate(qs):
            pin.computeDistances(model, data, geom, gdata, q)
            for j, (k, swapped) in enumerate(pairs):
                res = gdata.distanceResults[k]
                p1, p2 = np.array(res.getNearestPoint1()), np.array(res.getNearestPoint2())
                n = np.array(res.normal)
                if swapped:
                    p1, p2, n = p2, p1, -n
                out[i, j] = [res.min_distance, *p1, *p2, *n]
        out.astype("<f8").tofile(req["output"])
    if req.get("timing") and qs:
        summary["python_collision_ns_median"] = time_per_config(
            lambda q: pin.computeCollisions(model, data, geom, gdata, q, True), qs)
        summary["python_distance_ns_median"] = time_per_config(
            lambda q: pin.computeDistances(model, data, geom, gdata, q), qs)
    summary["seconds"] = time.perf_counter() - t0
    return summary


def time_per_config(call, qs, budget_s=1.0):
    """Median (ns) of single-call times, passes over all configurations repeated
    until ~budget_s (after one warm-up pass)."""
    for q in qs:
        call(q)
    samples = []
    start = time.perf_counter()
    while True:
        for q in qs:
            t = time.perf_counter_ns()
            call(q)
            samples.append(time.perf_counter_ns() - t)
        if time.perf_counter() - start > budget_s:
            break
    return float(np.median(samples))


def main():
    commands = {"distances": lambda: distances(json.load(sys.stdin))}
    if len(sys.argv) != 2 or sys.argv[1] not in commands:
        raise SystemExit(__doc__)
    json.dump(commands[sys.argv[1]](), sys.stdout)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
