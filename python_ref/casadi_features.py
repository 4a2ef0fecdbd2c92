#!/usr/bin/env python3
"""casadi reference values and Jacobians of tandem's KOMO features, for the
gradient cross-check test (tests/komo_casadi.rs).

The forward kinematics are built symbolically in casadi (SX) from the URDF,
which this script parses itself (joint origins, axes, types, mimics and
collision spheres): nothing numeric comes from tandem or Pinocchio. Every
feature is a casadi expression of the active joint values and its Jacobian
is `casadi.jacobian` of that expression.

Usage:
  casadi_features.py features < request.json
      Request:
        {"urdf": path,
         "joints": [active joint names, the order of each configuration],
         "held": {joint name: value} for the other movable joints (a mimic
                 joint whose master is active follows it symbolically; the
                 held value is then ignored),
         "features": [feature, ...],
         "collision": {"robot_elements": [{"link": L, "index": k}] (k-th
                 <collision> of link L in URDF order; spheres only),
                 "obstacles": [{"shape": "sphere"|"box", "radius" |
                 "half_extents", "translation": [3], "rotation": [[3]x3]}],
                 "pairs": [[a, b]] indices into robot_elements ++ obstacles,
                 "padding": m (added to every robot element)}  (only for a
                 collision feature; the format of coal_reference.py),
         "configurations": [[q in `joints` order]],
         "output": path}
      A frame F is a link name (its URDF frame) or a world-fixed pose
      {"translation": [3], "rotation": [[3]x3] (rows)}. Features, with
      tandem's definitions (src/komo/feature.rs):
        {"type": "joint_state"}                          q
        {"type": "joint_limits", "margin": m}            per active joint with
            finite limits: q - (upper - m), (lower + m) - q
        {"type": "position", "frame": F}                 p_F
        {"type": "position_difference", "a": F, "b": F}  p_a - p_b
        {"type": "scalar_product", "a": F, "axis_a": i, "b": F, "axis_b": j}
                                                         (R_a e_i) . (R_b e_j)
        {"type": "vector", "a": F, "axis": i, "b": F}    R_b^T R_a e_i
        {"type": "orientation_difference", "a": F, "b": F}
                                                         log(R_b^T R_a)
            (rotation vector by atan2, valid for angles in (0, pi))
        {"type": "collision", "margin": m}               per pair: m - d, d
            the signed distance of the padded shapes: sphere-sphere
            |c_a - c_b| - r_a - r_b, sphere-box the distance of the centre
            to the box (minus the depth inside) minus the radius
      Writes to `output` little-endian f64: for each configuration, for each
      feature, its values (dim) then its Jacobian (dim x nq, row-major).
      Prints a JSON summary {"casadi_version", "configurations", "nq",
      "dims", "values", "seconds"} on stdout.
"""
import json
import sys
import time
import xml.etree.ElementTree as ET

import casadi as ca
import numpy as np


def fail(msg):
    raise SystemExit(f"casadi_features: {msg}")


def floats(text, default):
    return np.array([float(v) for v in text.split()]) if text is not None else np.array(default, dtype=float)


def rpy_matrix(rpy):
    """URDF fixed-axis roll-pitch-yaw: Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def origin(elem):
    o = elem.find("origin") if elem is not None else None
    if o is None:
        return np.eye(3), np.zeros(3)
    return rpy_matrix(floats(o.get("rpy"), [0, 0, 0])), floats(o.get("xyz"), [0, 0, 0])


class Urdf:
    """The URDF's tree: joints (type, parent, child, origin, axis, limits,
    mimic) and per link its collision elements."""

    def __init__(self, path):
        root = ET.parse(path).getroot()
        self.links = {}
        for link in root.findall("link"):
            self.links[link.get("name")] = [self.collision(c) for c in link.findall("collision")]
        self.joints = {}
        self.parent_joint = {}
        for j in root.findall("joint"):
            name = j.get("name")
            limit = j.find("limit")
            mimic = j.find("mimic")
            joint = {
                "name": name,
                "type": j.get("type"),
                "parent": j.find("parent").get("link"),
                "child": j.find("child").get("link"),
                "origin": origin(j),
                "axis": floats(j.find("axis").get("xyz") if j.find("axis") is not None else None, [1, 0, 0]),
                "lower": float(limit.get("lower", "nan")) if limit is not None else float("nan"),
                "upper": float(limit.get("upper", "nan")) if limit is not None else float("nan"),
                "mimic": None if mimic is None else (mimic.get("joint"), float(mimic.get("multiplier", "1")),
                                                     float(mimic.get("offset", "0"))),
            }
            self.joints[name] = joint
            self.parent_joint[joint["child"]] = name

    @staticmethod
    def collision(c):
        rot, xyz = origin(c)
        g = c.find("geometry")
        sphere = g.find("sphere") if g is not None else None
        if sphere is None:
            return {"shape": "other", "rotation": rot, "translation": xyz}
        return {"shape": "sphere", "radius": float(sphere.get("radius")), "rotation": rot, "translation": xyz}


def skew(v):
    return ca.vertcat(ca.horzcat(0, -v[2], v[1]), ca.horzcat(v[2], 0, -v[0]), ca.horzcat(-v[1], v[0], 0))


def axis_rotation(axis, angle):
    """Rodrigues' formula, symbolic in `angle`."""
    k = skew(ca.DM(axis))
    return ca.DM.eye(3) + ca.sin(angle) * k + (1 - ca.cos(angle)) * (k @ k)


class Kinematics:
    """Symbolic world poses (R, p) of the URDF's links as functions of `q`."""

    def __init__(self, urdf, joints, held):
        self.urdf = urdf
        self.q = ca.SX.sym("q", len(joints))
        self.values = {}
        for k, n in enumerate(joints):
            if n not in urdf.joints or urdf.joints[n]["type"] not in ("revolute", "continuous", "prismatic"):
                fail(f"active joint {n!r} is not a movable joint of the URDF")
            self.values[n] = self.q[k]
        for n, v in held.items():
            if n not in urdf.joints:
                fail(f"held joint {n!r} not in the URDF")
        for n, j in urdf.joints.items():
            if n in self.values or j["type"] not in ("revolute", "continuous", "prismatic"):
                continue
            if j["mimic"] is not None and j["mimic"][0] in self.values:
                master, mult, off = j["mimic"]
                self.values[n] = mult * self.values[master] + off
            elif n in held:
                self.values[n] = ca.SX(float(held[n]))
            else:
                fail(f"request gives no value for joint {n!r}")
        self.poses = {}

    def link(self, name):
        if name in self.poses:
            return self.poses[name]
        if name not in self.urdf.links:
            fail(f"no link named {name!r} in the URDF (frames are link names or fixed poses)")
        if name not in self.urdf.parent_joint:
            pose = (ca.SX.eye(3), ca.SX.zeros(3))
        else:
            j = self.urdf.joints[self.urdf.parent_joint[name]]
            rp, pp = self.link(j["parent"])
            ro, po = j["origin"]
            r = rp @ ca.DM(ro)
            p = pp + rp @ ca.DM(po)
            if j["type"] in ("revolute", "continuous"):
                r = r @ axis_rotation(j["axis"], self.values[j["name"]])
            elif j["type"] == "prismatic":
                p = p + r @ ca.DM(j["axis"]) * self.values[j["name"]]
            elif j["type"] != "fixed":
                fail(f"joint type {j['type']!r} of {j['name']!r} is not supported")
            pose = (r, p)
        self.poses[name] = pose
        return pose

    def frame(self, f):
        if isinstance(f, str):
            return self.link(f)
        return ca.SX(ca.DM(np.array(f["rotation"], dtype=float))), ca.SX(ca.DM(np.array(f["translation"], dtype=float)))


def so3_log(r):
    """Rotation vector of r by atan2: exact for angles in (0, pi)."""
    v = 0.5 * ca.vertcat(r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1])
    s = ca.norm_2(v)
    c = 0.5 * (ca.trace(r) - 1)
    return v * (ca.atan2(s, c) / s)


def collision_distances(kin, urdf, scene):
    pad = float(scene.get("padding", 0.0))
    shapes = []  # (kind, centre or (R, t), size, padding)
    for el in scene["robot_elements"]:
        elements = urdf.links.get(el["link"])
        if elements is None or not (0 <= el["index"] < len(elements)):
            fail(f"no collision element {el['index']} on link {el['link']!r}")
        e = elements[el["index"]]
        if e["shape"] != "sphere":
            fail(f"collision element {el['index']} of {el['link']!r} is not a sphere")
        r, p = kin.link(el["link"])
        shapes.append(("sphere", p + r @ ca.DM(e["translation"]), e["radius"], pad))
    for ob in scene.get("obstacles", []):
        rot = np.array(ob.get("rotation", np.eye(3)), dtype=float)
        t = np.array(ob.get("translation", [0, 0, 0]), dtype=float)
        if ob["shape"] == "sphere":
            shapes.append(("sphere", ca.SX(ca.DM(t)), float(ob["radius"]), 0.0))
        elif ob["shape"] == "box":
            shapes.append(("box", (rot, t), np.array(ob["half_extents"], dtype=float), 0.0))
        else:
            fail(f"obstacle shape {ob['shape']!r} is not supported (sphere, box)")
    out = []
    for a, b in scene["pairs"]:
        sa, sb = shapes[a], shapes[b]
        if sa[0] != "sphere":
            sa, sb = sb, sa
        if sa[0] != "sphere":
            fail(f"pair {[a, b]}: box-box pairs are not supported")
        if sb[0] == "sphere":
            d = ca.norm_2(sa[1] - sb[1]) - sa[2] - sb[2]
        else:
            rot, t = sb[1]
            local = ca.DM(rot.T) @ (sa[1] - ca.DM(t))
            excess = ca.fabs(local) - ca.DM(sb[2])
            deepest = ca.mmax(excess)
            d = ca.if_else(deepest > 0, ca.norm_2(ca.fmax(excess, 0)), deepest) - sa[2]
        out.append(d - sa[3] - sb[3])
    return ca.vertcat(*out) if out else ca.SX.zeros(0)


def feature_expression(kin, urdf, joints, spec, scene):
    kind = spec["type"]
    if kind == "joint_state":
        return kin.q
    if kind == "joint_limits":
        m = float(spec["margin"])
        rows = []
        for k, n in enumerate(joints):
            lo, hi = urdf.joints[n]["lower"], urdf.joints[n]["upper"]
            if urdf.joints[n]["type"] == "continuous" or not (np.isfinite(lo) and np.isfinite(hi)):
                continue
            rows += [kin.q[k] - (hi - m), (lo + m) - kin.q[k]]
        return ca.vertcat(*rows)
    if kind == "position":
        return kin.frame(spec["frame"])[1]
    if kind == "collision":
        if scene is None:
            fail("a collision feature needs the request's \"collision\" scene")
        return float(spec["margin"]) - collision_distances(kin, urdf, scene)
    (ra, pa), (rb, pb) = kin.frame(spec["a"]), kin.frame(spec["b"])
    if kind == "position_difference":
        return pa - pb
    if kind == "scalar_product":
        return ca.dot(ra[:, int(spec["axis_a"])], rb[:, int(spec["axis_b"])])
    if kind == "vector":
        return rb.T @ ra[:, int(spec["axis"])]
    if kind == "orientation_difference":
        return so3_log(rb.T @ ra)
    fail(f"unknown feature type {kind!r}")


def features(req):
    t0 = time.perf_counter()
    urdf = Urdf(req["urdf"])
    joints = list(req["joints"])
    kin = Kinematics(urdf, joints, dict(req.get("held", {})))
    exprs = [feature_expression(kin, urdf, joints, spec, req.get("collision")) for spec in req["features"]]
    outputs = []
    for e in exprs:
        outputs += [e, ca.jacobian(e, kin.q)]
    f = ca.Function("features", [kin.q], outputs)
    dims = [int(e.numel()) for e in exprs]
    nq = len(joints)
    chunks = []
    for values in req["configurations"]:
        if len(values) != nq:
            fail(f"configuration has {len(values)} values, {nq} joints")
        res = f(np.array(values, dtype=float))
        for k, dim in enumerate(dims):
            chunks.append(np.array(res[2 * k], dtype=float).reshape(dim))
            chunks.append(np.array(res[2 * k + 1], dtype=float).reshape(dim, nq).ravel())
    arr = np.concatenate(chunks) if chunks else np.zeros(0)
    arr.astype("<f8").tofile(req["output"])
    return {"casadi_version": ca.__version__, "configurations": len(req["configurations"]), "nq": nq,
            "dims": dims, "values": int(arr.size), "seconds": time.perf_counter() - t0}


def main():
    commands = {"features": lambda: features(json.load(sys.stdin))}
    if len(sys.argv) != 2 or sys.argv[1] not in commands:
        raise SystemExit(__doc__)
    json.dump(commands[sys.argv[1]](), sys.stdout)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
