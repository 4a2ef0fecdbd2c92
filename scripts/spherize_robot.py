#!/usr/bin/env python3
"""Sphere-model URDFs and SRDFs for the robot benchmarks (problems/robots/).

For a robot of example-robot-data (installed in python_ref/.venv) this
writes a URDF with the same kinematics (links, joints, limits; no visuals,
no meshes) whose collision geometry is spheres only, and an SRDF with the
planning groups and the link pairs MoveIt's setup assistant would disable:

- spheres: along each link's segments from its origin to its children's
  joint origins (the robot's radius, one sphere per radius of length),
  every primitive collision element (box, cylinder, sphere) filled with
  spheres, plus the extra spheres listed per robot below (bases, torsos,
  grippers whose geometry is a mesh);
- disabled pairs, from seeded random configurations, by Pinocchio forward
  kinematics: "Adjacent" (a joint links them, through fixed joints),
  "Default" (touching at the default configuration), "Always" (touching in
  more than 95 % of samples) and "Never" (apart in every sample).

    python_ref/.venv/bin/python scripts/spherize_robot.py ur5 problems/robots/ur5

The committed files under problems/robots/{ur5,tiago,baxter} come from
this script with the default seed and sample count.
"""

import argparse
import itertools
import math
import os
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin

ERD = None
for p in sys.path:
    candidate = os.path.join(p, "cmeel.prefix", "share", "example-robot-data", "robots")
    if os.path.isdir(candidate):
        ERD = candidate

# Per robot: source URDF, the links kept (their joints and every ancestor
# joint), the segment radius (m), extra spheres (link, centre in the link
# frame, radius), planning groups (name -> SRDF XML body), joints held
# (value) and the default configuration for the "Default" pairs.
ROBOTS = {
    "ur5": {
        "urdf": "ur_description/urdf/ur5_joint_limited_robot.urdf",
        "tips": ["tool0"],
        "radius": {"shoulder_link": 0.075, "upper_arm_link": 0.065, "forearm_link": 0.055, "default": 0.045},
        "extra": [
            ("base_link", (0, 0, 0.04), 0.08),
            ("upper_arm_link", (0, 0.14, 0), 0.065),
            ("forearm_link", (0, 0.03, 0), 0.055),
            ("wrist_3_link", (0, 0.09, 0), 0.045),
            ("wrist_3_link", (0, 0.14, 0), 0.04),
        ],
        "groups": {"manipulator": '<chain base_link="base_link" tip_link="tool0"/>'},
    },
    "tiago": {
        "urdf": "tiago_description/robots/tiago_no_hand.urdf",
        "tips": ["arm_tool_link", "head_2_link", "torso_fixed_column_link"],
        "radius": {
            "default": 0.06,
            "torso_fixed_link": 0.0,
            "torso_lift_link": 0.0,
            "base_link": 0.0,
            "base_footprint": 0.0,
            "head_1_link": 0.0,
            "head_2_link": 0.0,
        },
        "fill": ["torso_fixed_column_link"],
        "extra": [
            ("base_link", (0.0, 0.0, 0.12), 0.27),
            ("torso_fixed_link", (0.085, 0.0, 0.02), 0.1),
            ("torso_lift_link", (-0.03, 0.0, -0.05), 0.13),
            ("torso_lift_link", (0.05, 0.0, -0.15), 0.09),
            ("torso_lift_link", (0.12, 0.0, -0.15), 0.07),
            ("head_2_link", (0.03, 0.0, 0.0), 0.11),
            ("arm_7_link", (0.0, 0.0, 0.08), 0.05),
            ("arm_7_link", (0.0, 0.0, 0.16), 0.05),
        ],
        "groups": {
            "arm": '<chain base_link="torso_lift_link" tip_link="arm_tool_link"/>',
            "arm_torso": '<joint name="torso_lift_joint"/><group name="arm"/>',
        },
    },
    "baxter": {
        "urdf": "baxter_description/urdf/baxter.urdf",
        "tips": [
            "left_gripper",
            "right_gripper",
            "left_upper_elbow_visual",
            "right_upper_elbow_visual",
            "left_upper_forearm_visual",
            "right_upper_forearm_visual",
            "collision_head_link_1",
            "collision_head_link_2",
        ],
        "radius": {"default": 0.0},
        "extra": [
            ("torso", (0.0, 0.0, 0.25), 0.16),
            ("torso", (-0.05, 0.0, 0.05), 0.17),
            ("torso", (-0.05, 0.0, -0.2), 0.17),
            ("torso", (-0.05, 0.0, -0.45), 0.17),
            ("left_gripper", (0.0, 0.0, -0.05), 0.04),
            ("left_gripper", (0.0, 0.0, 0.0), 0.03),
            ("right_gripper", (0.0, 0.0, -0.05), 0.04),
            ("right_gripper", (0.0, 0.0, 0.0), 0.03),
        ],
        "groups": {
            "left_arm": '<chain base_link="torso" tip_link="left_gripper"/>',
            "right_arm": '<chain base_link="torso" tip_link="right_gripper"/>',
            "both_arms": '<group name="left_arm"/><group name="right_arm"/>',
        },
    },
}


def floats(text, n=3):
    values = [float(v) for v in (text or "").split()]
    return values if values else [0.0] * n


def rpy_matrix(rpy):
    return pin.rpy.rpyToMatrix(*rpy)


def kept_joints(root, tips):
    """Joints on the paths from the root to the tip links (and the tips)."""
    parent_joint = {j.find("child").get("link"): j for j in root.findall("joint")}
    keep = []
    for tip in tips:
        link = tip
        while link in parent_joint:
            j = parent_joint[link]
            if j not in keep:
                keep.append(j)
            link = j.find("parent").get("link")
    return keep


def segment_spheres(offset, radius):
    """Spheres of `radius` covering the segment from 0 to `offset`."""
    length = float(np.linalg.norm(offset))
    if length < 1e-6:
        return []
    n = max(1, int(math.ceil(length / radius))) if radius > 0 else 0
    return [tuple(float(x) for x in np.asarray(offset) * (k / n)) for k in range(n + 1)] if n else []


def primitive_spheres(collision):
    """Spheres filling a primitive collision element (in its link frame)."""
    origin = collision.find("origin")
    xyz = np.array(floats(origin.get("xyz") if origin is not None else None))
    rot = rpy_matrix(floats(origin.get("rpy") if origin is not None else None))
    g = collision.find("geometry")[0]
    if g.tag == "sphere":
        return [(tuple(xyz), float(g.get("radius")))]
    if g.tag == "box":
        half = np.array(floats(g.get("size"))) / 2
        r = float(half.min())
        axes = [np.linspace(-h + r, h - r, max(1, int(math.ceil((2 * h - 2 * r) / r)) + 1)) for h in half]
        return [(tuple(xyz + rot @ np.array(p)), r) for p in itertools.product(*axes)]
    if g.tag == "cylinder":
        radius, half = float(g.get("radius")), float(g.get("length")) / 2
        r = min(radius, half) if half > 0 else radius
        zs = np.linspace(-half + r, half - r, max(1, int(math.ceil((2 * half - 2 * r) / r)) + 1))
        return [(tuple(xyz + rot @ np.array([0, 0, z])), r * math.sqrt(2) if r < radius else r) for z in zs]
    return []


def build(name, seed, samples):
    cfg = ROBOTS[name]
    root = ET.parse(os.path.join(ERD, cfg["urdf"])).getroot()
    joints = kept_joints(root, cfg["tips"])
    links = {root_link(root)} | {j.find("child").get("link") for j in joints}
    spheres = {link: [] for link in links}
    children = {}
    for j in joints:
        o = j.find("origin")
        children.setdefault(j.find("parent").get("link"), []).append(np.array(floats(o.get("xyz") if o is not None else None)))
    for link in root.findall("link"):
        lname = link.get("name")
        if lname not in links:
            continue
        radius = cfg["radius"].get(lname, cfg["radius"]["default"])
        for offset in children.get(lname, []):
            spheres[lname] += [(c, radius) for c in segment_spheres(offset, radius)]
        if cfg.get("fill") is None or lname in cfg["fill"]:
            for c in link.findall("collision"):
                spheres[lname] += [(c, r) for c, r in primitive_spheres(c) if r >= 0.005]
    for lname, c, r in cfg["extra"]:
        spheres[lname].append((tuple(float(x) for x in c), r))
    return root, joints, links, spheres


def root_link(root):
    children = {j.find("child").get("link") for j in root.findall("joint")}
    return next(link.get("name") for link in root.findall("link") if link.get("name") not in children)


def write_urdf(path, name, joints, links, spheres):
    out = [f'<?xml version="1.0"?>\n<!-- Sphere model of example-robot-data\'s {name} (scripts/spherize_robot.py) -->',
           f'<robot name="{name}">']
    for lname in sorted(links):
        if not spheres[lname]:
            out.append(f'  <link name="{lname}"/>')
            continue
        out.append(f'  <link name="{lname}">')
        for c, r in spheres[lname]:
            out.append(f'    <collision><origin xyz="{c[0]:.4f} {c[1]:.4f} {c[2]:.4f}"/>'
                       f'<geometry><sphere radius="{r:.4f}"/></geometry></collision>')
        out.append("  </link>")
    for j in joints:
        attrs = f'name="{j.get("name")}" type="{j.get("type")}"'
        body = [f'<parent link="{j.find("parent").get("link")}"/>', f'<child link="{j.find("child").get("link")}"/>']
        o = j.find("origin")
        if o is not None:
            body.append(f'<origin xyz="{o.get("xyz", "0 0 0")}" rpy="{o.get("rpy", "0 0 0")}"/>')
        for tag in ["axis", "limit", "mimic"]:
            e = j.find(tag)
            if e is not None:
                body.append(ET.tostring(e, encoding="unicode").strip())
        out.append(f'  <joint {attrs}>' + "".join(body) + "</joint>")
    out.append("</robot>\n")
    with open(path, "w") as f:
        f.write("\n".join(out))


def disabled_pairs(urdf_path, links, spheres, joints, seed, samples):
    model = pin.buildModelFromUrdf(urdf_path)
    data = model.createData()
    named = sorted(l for l in links if spheres[l])
    frame = {l: model.getFrameId(l) for l in named}
    # Adjacent: a joint links them, through links without spheres and fixed joints.
    parent = {j.find("child").get("link"): (j.find("parent").get("link"), j.get("type")) for j in joints}

    def body_of(link):
        while link in parent and parent[link][1] == "fixed":
            link = parent[link][0]
        return link

    def geometric_parent(link):
        link = body_of(link)
        if link not in parent:
            return None
        p = parent[link][0]
        # Skip sphere-less links between bodies.
        while not spheres.get(p) and p in parent:
            p = parent[p][0]
        return body_of(p)

    pairs = list(itertools.combinations(named, 2))
    reason = {}
    for a, b in pairs:
        if body_of(a) == body_of(b) or geometric_parent(a) == body_of(b) or geometric_parent(b) == body_of(a):
            reason[(a, b)] = "Adjacent"

    def touching(q):
        pin.framesForwardKinematics(model, data, q)
        world = {}
        for l in named:
            m = data.oMf[frame[l]]
            world[l] = [(m.rotation @ np.array(c) + m.translation, r) for c, r in spheres[l]]
        hits = set()
        for a, b in pairs:
            if (a, b) in reason:
                continue
            if any(np.linalg.norm(ca - cb) < ra + rb for ca, ra in world[a] for cb, rb in world[b]):
                hits.add((a, b))
        return hits

    lo, hi = model.lowerPositionLimit.copy(), model.upperPositionLimit.copy()
    lo[~np.isfinite(lo)], hi[~np.isfinite(hi)] = -math.pi, math.pi
    default = np.clip(np.zeros(model.nq), lo, hi)
    for p in touching(default):
        reason[p] = "Default"
    rng = np.random.default_rng(seed)
    counts = {p: 0 for p in pairs}
    for _ in range(samples):
        for p in touching(rng.uniform(lo, hi)):
            counts[p] += 1
    for p in pairs:
        if p in reason:
            continue
        if counts[p] > 0.95 * samples:
            reason[p] = "Always"
        elif counts[p] == 0:
            reason[p] = "Never"
    return sorted(reason.items())


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("robot", choices=sorted(ROBOTS))
    ap.add_argument("out", help="output folder")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--samples", type=int, default=2000)
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    root, joints, links, spheres = build(args.robot, args.seed, args.samples)
    urdf = os.path.join(args.out, f"{args.robot}_spheres.urdf")
    write_urdf(urdf, args.robot, joints, links, spheres)
    pairs = disabled_pairs(urdf, links, spheres, joints, args.seed, args.samples)
    lines = [f'<?xml version="1.0"?>\n<!-- made by scripts/spherize_robot.py {args.robot}, seed {args.seed}, '
             f'{args.samples} samples -->', f'<robot name="{args.robot}">']
    for g, body in ROBOTS[args.robot]["groups"].items():
        lines.append(f'  <group name="{g}">{body}</group>')
    for (a, b), why in pairs:
        lines.append(f'  <disable_collisions link1="{a}" link2="{b}" reason="{why}"/>')
    lines.append("</robot>\n")
    with open(os.path.join(args.out, f"{args.robot}.srdf"), "w") as f:
        f.write("\n".join(lines))
    n = sum(len(s) for s in spheres.values())
    print(f"{args.robot}: {len(joints)} joints, {len(links)} links, {n} spheres, {len(pairs)} disabled pairs")


if __name__ == "__main__":
    main()
