#!/usr/bin/env python3
"""Generate tandem's embedded default robot: problems/robots/panda/panda.urdf (+ README.md).

Kinematics come from Franka Emika's published Craig (modified) DH table and
datasheet joint limits, written out as URDF joint origins in the franka_description
frame conventions.  Collision geometry is a small set of spheres per link, fitted so
that they enclose the example-robot-data (erd) Panda collision meshes.

Then the result is verified against the erd Panda with Pinocchio:
  * every frame present by name in both models agrees (R and p) on random configurations,
  * a direct DH forward-kinematics product reproduces panda_link8,
  * every collision-mesh vertex (and a dense surface sampling) lies inside a sphere.

Usage (from the repo root):
    python_ref/.venv/bin/python python_ref/make_panda_urdf.py
Writes problems/robots/panda/panda.urdf and problems/robots/panda/README.md, prints the
checks, exits non-zero if any check fails.  Deterministic (fixed seeds).
"""
from __future__ import annotations

import math
import os
import struct
import sys
from pathlib import Path

import numpy as np
from scipy.cluster.vq import kmeans2
from scipy.optimize import minimize
from scipy.spatial import ConvexHull, cKDTree

REPO = Path(__file__).resolve().parents[1]
OUT_DIR = REPO / "problems" / "robots" / "panda"
OUT_URDF = OUT_DIR / "panda.urdf"
OUT_README = OUT_DIR / "README.md"


def _erd_share() -> Path:
    hits = sorted(Path(sys.prefix).glob("lib/python3*/site-packages/cmeel.prefix/share"))
    if not hits:
        sys.exit("cannot find cmeel.prefix/share (run with python_ref/.venv/bin/python)")
    return hits[0]


ERD_PANDA = _erd_share() / "example-robot-data" / "robots" / "panda_description"
ERD_URDF = ERD_PANDA / "urdf" / "panda.urdf"
ERD_COLLISION = ERD_PANDA / "meshes" / "collision"

# ---------------------------------------------------------------------------------
# Published parameters
# ---------------------------------------------------------------------------------
HALF_PI = math.pi / 2  # 1.5707963267948966

# Franka Emika Panda, Craig (modified) DH convention, from Franka's documentation
# ("Robot and interface specifications" -> Denavit-Hartenberg parameters):
#   ^{i-1}T_i = RotX(alpha) * TransX(a) * RotZ(theta_i) * TransZ(d)
# Row = (joint name, a [m], d [m], alpha [rad]); the flange row has theta = 0 (fixed).
DH = [
    ("panda_joint1", 0.0, 0.333, 0.0),
    ("panda_joint2", 0.0, 0.0, -HALF_PI),
    ("panda_joint3", 0.0, 0.316, HALF_PI),
    ("panda_joint4", 0.0825, 0.0, HALF_PI),
    ("panda_joint5", -0.0825, 0.384, -HALF_PI),
    ("panda_joint6", 0.0, 0.0, HALF_PI),
    ("panda_joint7", 0.088, 0.0, HALF_PI),
    ("panda_joint8", 0.0, 0.107, 0.0),  # flange, fixed
]

# Franka datasheet joint limits: (lower, upper) [rad], velocity [rad/s], torque [Nm].
ARM_LIMITS = {
    "panda_joint1": (-2.8973, 2.8973, 2.175, 87.0),
    "panda_joint2": (-1.7628, 1.7628, 2.175, 87.0),
    "panda_joint3": (-2.8973, 2.8973, 2.175, 87.0),
    "panda_joint4": (-3.0718, -0.0698, 2.175, 87.0),
    "panda_joint5": (-2.8973, 2.8973, 2.61, 12.0),
    "panda_joint6": (-0.0175, 3.7525, 2.61, 12.0),
    "panda_joint7": (-2.8973, 2.8973, 2.61, 12.0),
}
# Franka Hand: each finger 0..40 mm (80 mm stroke), 0.2 m/s (franka_description values).
FINGER_LIMIT = (0.0, 0.04, 0.2, 70.0)  # 70 N: the Franka Hand's rated continuous force
FINGER_Z = 0.0584  # finger joint origin above panda_hand (franka_description)
HAND_YAW = -math.pi / 4  # panda_hand is rotated -45 deg about z w.r.t. the flange
TCP_Z = 0.1034  # Franka Hand TCP (fingertip centre) above panda_hand

# Inertial parameters (public data, copied verbatim from the erd / franka_description URDF):
# link: (mass, com xyz, (ixx, ixy, ixz, iyy, iyz, izz))
INERTIA = {
    "panda_link0": (0.629769, (-0.041018, -0.00014, 0.049974),
                    (0.00315, 8.2904e-07, 0.00015, 0.00388, 8.2299e-06, 0.004285)),
    "panda_link1": (4.970684, (0.003875, 0.002081, -0.04762),
                    (0.70337, -0.000139, 0.006772, 0.70661, 0.019169, 0.009117)),
    "panda_link2": (0.646926, (-0.003141, -0.02872, 0.003495),
                    (0.007962, -0.003925, 0.010254, 0.02811, 0.000704, 0.025995)),
    "panda_link3": (3.228604, (0.027518, 0.039252, -0.066502),
                    (0.037242, -0.004761, -0.011396, 0.036155, -0.012805, 0.01083)),
    "panda_link4": (3.587895, (-0.05317, 0.104419, 0.027454),
                    (0.025853, 0.007796, -0.001332, 0.019552, 0.008641, 0.028323)),
    "panda_link5": (1.225946, (-0.011953, 0.041065, -0.038437),
                    (0.035549, -0.002117, -0.004037, 0.029474, 0.000229, 0.008627)),
    "panda_link6": (1.666555, (0.060149, -0.014117, -0.010517),
                    (0.001964, 0.000109, -0.001158, 0.004354, 0.000341, 0.005433)),
    "panda_link7": (0.735522, (0.010517, -0.004252, 0.061597),
                    (0.012516, -0.000428, -0.001196, 0.010027, -0.000741, 0.004815)),
    "panda_hand": (0.73, (-0.01, 0.0, 0.03), (0.001, 0.0, 0.0, 0.0025, 0.0, 0.0017)),
    "panda_leftfinger": (0.015, (0.0, 0.0, 0.0),
                         (2.375e-06, 0.0, 0.0, 2.375e-06, 0.0, 7.5e-07)),
    "panda_rightfinger": (0.015, (0.0, 0.0, 0.0),
                          (2.375e-06, 0.0, 0.0, 2.375e-06, 0.0, 7.5e-07)),
}

# Sphere groups and their sphere counts (chosen by hand from the K-vs-excess trade-off; see
# README).  A group is a link's own spheres (`<link>_s<i>`) or, for the fingers, their pads:
# the inner layer of each finger, which a grasp lets come close to its object, as collision
# elements all named after the group (`panda_leftfinger_pad`).  The arm links keep their
# seeds (the index in this dict), so refitting the gripper leaves them unchanged.
N_SPHERES = {
    "panda_link0": 7,
    "panda_link1": 6,
    "panda_link2": 6,
    "panda_link3": 6,
    "panda_link4": 6,
    "panda_link5": 7,
    "panda_link6": 6,
    "panda_link7": 5,
    "panda_hand": 16,
    "panda_leftfinger": 5,
    "panda_rightfinger": 5,
    "panda_leftfinger_pad": 4,
    "panda_rightfinger_pad": 4,
}
# The link of each group that is not a link itself.
GROUP_LINK = {"panda_leftfinger_pad": "panda_leftfinger", "panda_rightfinger_pad": "panda_rightfinger"}
# Groups fitted as the mirror image (turned by pi about z) of another: the right finger is the
# left one turned by pi about z, in the erd URDF as here.
MIRRORED = {"panda_rightfinger": "panda_leftfinger", "panda_rightfinger_pad": "panda_leftfinger_pad"}
# A finger's pad is the part of it within PAD_DEPTH of its inner face (finger frame y <= PAD_DEPTH
# for the left finger; the inner face is y = 0, towards the other finger): the contact surface.
PAD_DEPTH = 5.0e-3
# Where a bulge of the model costs a grasp: below the palm (hand frame z beyond the lowest point of
# hand.stl, the palm face between the fingers) the hand's spheres would meet the top of the grasped
# object; past the inner face (y < 0) the fingers' outer spheres would meet its sides.  The fit
# weighs excess volume there BULGE_WEIGHT times more.
BULGE_WEIGHT = 30.0

FIT_SPACING = 4.0e-3  # surface sample spacing used for fitting [m]
SHELL_SPACING = 6.0e-3  # grid spacing of the outside-shell samples (excess volume) [m]
SHELL_WIDTH = 0.025  # shell thickness [m]
COVER_SPACING = 0.25e-3  # structured surface sample spacing for the final exact cover [m]
# Every surface point lies within 1.12 * COVER_SPACING of a structured sample (see
# sample_surface_grid), so adding this margin makes the spheres provably cover the whole
# mesh surface, not just the samples.
COVER_MARGIN = 1.12 * COVER_SPACING
SCHEDULE = [(3.0, 30.0), (1.0, 1e3), (0.5, 1e4)]  # (tau [mm], penalty weight)
MAXITER = 200
CHECK_SPACING = 0.2e-3  # dense surface sample spacing used for the coverage check [m]
EXCESS_SPACING = 1.5e-3  # sample spacing on the sphere-union boundary for excess stats [m]
DEPTH_SPACING = 1.0e-3  # sample spacing of mesh surface and union boundary for depth stats [m]
DECIMALS = 4  # sphere centres/radii written with 0.1 mm resolution (radii rounded up)
N_RESTARTS = 6
FK_SAMPLES = 2000
FK_TOL = 1e-9


# ---------------------------------------------------------------------------------
# Small helpers
# ---------------------------------------------------------------------------------
def fmt(x: float) -> str:
    """Shortest round-trip float text, no '-0'."""
    x = float(x)
    if x == 0.0:
        return "0"
    s = repr(x)
    return s[:-2] if s.endswith(".0") else s


def fmt_round(x: float, nd: int = DECIMALS) -> str:
    return fmt(round(float(x), nd))


def exact_cos_sin(alpha: float) -> tuple[float, float]:
    """cos/sin that are exact (0, +-1) at multiples of pi/2."""
    k = alpha / HALF_PI
    if abs(k - round(k)) < 1e-12:
        return [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][int(round(k)) % 4]
    return math.cos(alpha), math.sin(alpha)


def dh_origin(a: float, d: float, alpha: float) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """URDF origin (xyz, rpy) of RotX(alpha) TransX(a) TransZ(d); the joint then rotates about z."""
    c, s = exact_cos_sin(alpha)
    return (a, -s * d, c * d), (alpha, 0.0, 0.0)


def rot_x(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_z(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rpy_matrix(r, p, y):
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


# ---------------------------------------------------------------------------------
# Meshes
# ---------------------------------------------------------------------------------
def read_stl(path: Path) -> np.ndarray:
    """Triangles (T, 3, 3) from a binary or ASCII STL."""
    data = path.read_bytes()
    if len(data) >= 84:
        n = struct.unpack("<I", data[80:84])[0]
        if 84 + 50 * n == len(data):
            dt = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
            return np.frombuffer(data, dt, count=n, offset=84)["v"].astype(np.float64)
    verts = [
        [float(t) for t in line.split()[1:4]]
        for line in data.decode("ascii", "replace").splitlines()
        if line.strip().startswith("vertex")
    ]
    if not verts or len(verts) % 3:
        raise ValueError(f"cannot parse STL {path}")
    return np.asarray(verts, dtype=np.float64).reshape(-1, 3, 3)


def box_triangles(size, xyz=(0, 0, 0), rpy=(0, 0, 0)) -> np.ndarray:
    h = np.asarray(size, float) / 2
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * h
    corners = corners @ rpy_matrix(*rpy).T + np.asarray(xyz, float)
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
             (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    return corners[np.array(faces)]


# erd panda.urdf finger collision boxes (left finger; the right finger mirrors y).
ERD_FINGER_BOXES = [  # (size, xyz, roll)
    ((22e-3, 15e-3, 20e-3), (0, 18.5e-3, 11e-3), 0.0),  # screw mount
    ((22e-3, 8.8e-3, 3.8e-3), (0, 6.8e-3, 2.2e-3), 0.0),  # carriage sledge
    ((17.5e-3, 7e-3, 23.5e-3), (0, 15.9e-3, 28.35e-3), math.pi / 6),  # diagonal finger
    ((17.5e-3, 15.2e-3, 18.5e-3), (0, 7.58e-3, 45.25e-3), 0.0),  # rubber tip
]


def link_solids() -> dict[str, list[np.ndarray]]:
    """Per link, the closed triangle meshes (in link frame) the spheres must enclose."""
    solids = {}
    for i in range(8):
        solids[f"panda_link{i}"] = [read_stl(ERD_COLLISION / f"link{i}.stl")]
    solids["panda_hand"] = [read_stl(ERD_COLLISION / "hand.stl")]
    finger = read_stl(ERD_COLLISION / "finger.stl")
    left = [finger] + [box_triangles(s, xyz, (r, 0, 0)) for s, xyz, r in ERD_FINGER_BOXES]
    # Right finger: erd visual is the finger mesh rotated by pi about z; its boxes mirror y.
    rz = rot_z(math.pi)
    right = [finger @ rz.T] + [
        box_triangles(s, (xyz[0], -xyz[1], xyz[2]), (-r, 0, 0)) for s, xyz, r in ERD_FINGER_BOXES
    ]
    solids["panda_leftfinger"] = left
    solids["panda_rightfinger"] = right
    return solids


def group_solids() -> dict[str, list[np.ndarray]]:
    """Per sphere group, the closed convex pieces (link frame) its spheres must enclose: a finger's
    pieces split at y = PAD_DEPTH (left; -PAD_DEPTH right) into the outer part and the pad."""
    solids = link_solids()
    for side, sign in (("left", 1.0), ("right", -1.0)):
        pieces = solids[f"panda_{side}finger"]
        normal = np.array([0.0, sign, 0.0])  # inward normal of the pad layer is -normal
        solids[f"panda_{side}finger_pad"] = [c for t in pieces if (c := clip_convex(t, normal, PAD_DEPTH)) is not None]
        solids[f"panda_{side}finger"] = [c for t in pieces if (c := clip_convex(t, -normal, -PAD_DEPTH)) is not None]
    return solids


def group_link(name: str) -> str:
    return GROUP_LINK.get(name, name)


def palm_z() -> float:
    """Lowest point of the hand (largest hand-frame z of hand.stl): the palm face."""
    return float(read_stl(ERD_COLLISION / "hand.stl")[..., 2].max())


def clip_convex(tris: np.ndarray, normal: np.ndarray, offset: float):
    """The part of a convex closed mesh with x . normal <= offset, as a closed, consistently
    oriented triangle mesh (its convex hull); None when it has no volume."""
    v = np.unique(tris.reshape(-1, 3), axis=0)
    side = v @ normal - offset
    pts = [v[side <= 0]]
    for a, b in ((0, 1), (1, 2), (2, 0)):
        sa, sb = tris[:, a] @ normal - offset, tris[:, b] @ normal - offset
        cut = sa * sb < 0
        t = (sa[cut] / (sa[cut] - sb[cut]))[:, None]
        pts.append(tris[cut, a] + t * (tris[cut, b] - tris[cut, a]))
    p = np.unique(np.round(np.concatenate(pts), 12), axis=0)
    if len(p) < 4:
        return None
    try:
        hull = ConvexHull(p)
    except Exception:  # flat: no volume on this side
        return None
    if hull.volume < 1e-12:
        return None
    out = p[hull.simplices]
    centre = p[hull.vertices].mean(0)
    flip = (np.cross(out[:, 1] - out[:, 0], out[:, 2] - out[:, 0]) * (out[:, 0] - centre)).sum(1) < 0
    out[flip] = out[flip][:, [0, 2, 1]]
    return out


def bulge_weight(name: str):
    """Per shell point, how much its excess volume counts (see BULGE_WEIGHT)."""
    if name == "panda_hand":
        z = palm_z()
        return lambda S: 1.0 + BULGE_WEIGHT * (S[:, 2] > z)
    if name == "panda_leftfinger":
        return lambda S: 1.0 + BULGE_WEIGHT * (S[:, 1] < 0.0)
    return None


def mirrored(C: np.ndarray, R: np.ndarray):
    """Spheres turned by pi about z."""
    return C * np.array([-1.0, -1.0, 1.0]), R.copy()


def sample_surface_grid(tris: np.ndarray, spacing: float) -> np.ndarray:
    """Deterministic structured samples: per triangle, lines parallel to its longest edge AB
    at most `spacing` apart, each sampled every <= `spacing` (vertices and edges included).
    The angles at A and B are <= 90 deg, so any surface point projects onto the longer
    neighbouring line within its extent: it is within sqrt(1 + 1/4) * spacing < 1.12 * spacing
    of a sample.  Cheap on slivers (about 2 * area / spacing^2 points)."""
    out = []
    for tri in tris:
        e = [np.linalg.norm(tri[(i + 1) % 3] - tri[i]) for i in range(3)]
        i = int(np.argmax(e))
        A, B, Cc = tri[i], tri[(i + 1) % 3], tri[(i + 2) % 3]
        L = e[i]
        if L == 0:
            out.append(tri)
            continue
        H = np.linalg.norm(np.cross(B - A, Cc - A)) / L
        n2 = max(1, int(math.ceil(H / spacing)))
        for t in np.arange(n2 + 1) / n2:
            p0, p1 = (1 - t) * A + t * Cc, (1 - t) * B + t * Cc
            n1 = max(1, int(math.ceil((1 - t) * L / spacing)))
            out.append(p0 + np.outer(np.arange(n1 + 1) / n1, p1 - p0))
    return np.concatenate(out)


def sample_surface(tris: np.ndarray, spacing: float, rng) -> np.ndarray:
    """Vertices + points every `spacing` along edges + ~1 random point per spacing^2 of area."""
    out = [tris.reshape(-1, 3)]
    for x, y in ((0, 1), (1, 2), (2, 0)):
        e = tris[:, y] - tris[:, x]
        for t, (p, v) in enumerate(zip(tris[:, x], e)):
            m = int(math.ceil(np.linalg.norm(v) / spacing))
            out.append(p + np.outer(np.arange(1, m) / m, v))
    area = 0.5 * np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    cnt = rng.poisson(area / spacing ** 2)
    idx = np.repeat(np.arange(len(tris)), cnt)
    u, v = rng.random(len(idx)), rng.random(len(idx))
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    a = tris[idx, 0]
    out.append(a + u[:, None] * (tris[idx, 1] - a) + v[:, None] * (tris[idx, 2] - a))
    return np.unique(np.round(np.concatenate(out), 12), axis=0)


def point_triangle_distance(p: np.ndarray, tris: np.ndarray, chunk: int = 4000) -> np.ndarray:
    """Exact unsigned distance from each point to the nearest triangle."""
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    n = np.cross(b - a, c - a)
    nn = np.linalg.norm(n, axis=1)
    ok = nn > 1e-15
    nhat = np.where(ok[:, None], n / np.where(ok, nn, 1.0)[:, None], 0.0)
    out = np.empty(len(p))
    for s in range(0, len(p), chunk):
        q = p[s:s + chunk, None, :]
        best = np.full((q.shape[0], len(tris)), np.inf)
        # face interior
        h = ((q - a) * nhat).sum(-1)
        proj = q - h[..., None] * nhat
        inside = ok[None, :].copy()
        for x, y in ((a, b), (b, c), (c, a)):
            inside = inside & ((np.cross(y - x, proj - x) * n).sum(-1) >= 0)
        best = np.where(inside, np.abs(h), best)
        # edges
        for x, y in ((a, b), (b, c), (c, a)):
            e = y - x
            ee = (e * e).sum(-1)
            t = np.clip(((q - x) * e).sum(-1) / np.where(ee > 0, ee, 1.0), 0.0, 1.0)
            d = np.linalg.norm(q - (x + t[..., None] * e), axis=-1)
            best = np.minimum(best, d)
        out[s:s + chunk] = best.min(axis=1)
    return out


def winding_number(p: np.ndarray, tris: np.ndarray, chunk: int = 4000) -> np.ndarray:
    """Generalised winding number (|w|~1 inside a closed mesh, ~0 outside)."""
    out = np.empty(len(p))
    for s in range(0, len(p), chunk):
        q = p[s:s + chunk, None, :]
        A, B, C = tris[None, :, 0] - q, tris[None, :, 1] - q, tris[None, :, 2] - q
        la, lb, lc = (np.linalg.norm(v, axis=-1) for v in (A, B, C))
        num = (A * np.cross(B, C)).sum(-1)
        den = la * lb * lc + (A * B).sum(-1) * lc + (A * C).sum(-1) * lb + (B * C).sum(-1) * la
        out[s:s + chunk] = np.arctan2(num, den).sum(axis=1) / (2 * math.pi)
    return out


# ---------------------------------------------------------------------------------
# Sphere fitting
# ---------------------------------------------------------------------------------
def min_enclosing_ball(pts: np.ndarray) -> tuple[np.ndarray, float]:
    """Minimum enclosing ball (SLSQP on the hull vertices); radius = exact max distance."""
    cand = pts
    if len(pts) > 4:
        try:
            cand = pts[ConvexHull(pts).vertices]
        except Exception:  # degenerate (flat) cluster
            pass
    c0 = cand.mean(axis=0)
    x0 = np.r_[c0, ((cand - c0) ** 2).sum(1).max()]
    cons = {
        "type": "ineq",
        "fun": lambda x: x[3] - ((cand - x[:3]) ** 2).sum(1),
        "jac": lambda x: np.c_[2 * (cand - x[:3]), np.ones(len(cand))],
    }
    res = minimize(lambda x: x[3], x0, jac=lambda x: np.r_[0, 0, 0, 1.0], constraints=[cons],
                   method="SLSQP", options={"maxiter": 200, "ftol": 1e-14})
    c = res.x[:3] if np.all(np.isfinite(res.x)) else c0
    r = float(np.sqrt(((pts - c) ** 2).sum(1).max()))
    r0 = float(np.sqrt(x0[3]))
    return (c, r) if r <= r0 else (c0, r0)


def balls_for_assignment(pts, assign, k):
    cs, rs = [], []
    for i in range(k):
        sel = pts[assign == i]
        if len(sel) == 0:
            continue
        c, r = min_enclosing_ball(sel)
        cs.append(c)
        rs.append(r)
    return np.array(cs), np.array(rs)


def refine(pts, C, R, iters=30):
    """Monotone descent: give every point to the sphere where it has most slack, then
    replace each sphere by the minimum ball of its points (radii never grow)."""
    for _ in range(iters):
        slack = R[None] - np.linalg.norm(pts[:, None] - C[None], axis=2)
        C2, R2 = balls_for_assignment(pts, slack.argmax(1), len(C))
        if len(R2) == len(R) and (R2 ** 3).sum() >= (R ** 3).sum() * (1 - 1e-9):
            break
        C, R = C2, R2
    return C, R


def cover(pts, C, R, chunk=200000):
    """Keep the centres; give each point to the sphere it is closest to covering and set
    the radii to cover exactly their points (drops spheres that end up empty)."""
    R2 = np.full(len(C), -1.0)
    for s in range(0, len(pts), chunk):
        q = pts[s:s + chunk]
        d = np.sqrt(((q[:, None] - C[None]) ** 2).sum(-1))
        a = (d - R[None]).argmin(1)
        np.maximum.at(R2, a, d[np.arange(len(q)), a])
    keep = R2 >= 0
    return C[keep], R2[keep]


def shell_points(solids, spacing, width, rng):
    """Grid points outside the solid(s) but within `width` of their surface."""
    tris = np.concatenate(solids)
    v = tris.reshape(-1, 3)
    lo, hi = v.min(0) - width, v.max(0) + width
    g = np.stack(np.meshgrid(*[np.arange(l, h + 1e-12, spacing) for l, h in zip(lo, hi)], indexing="ij"), -1)
    g = g.reshape(-1, 3)
    g = g[cKDTree(sample_surface(tris, spacing / 3, rng)).query(g)[0] <= width]
    inside = np.zeros(len(g), bool)
    for s in solids:
        inside |= np.abs(winding_number(g, s)) > 0.5
    return g[~inside]


def smooth_fit(P, S, w, C0, R0, schedule):
    """Minimise (smoothed) volume of the sphere union outside the solid, sampled by the
    shell points S (weighing w, a number or one per point), plus a coverage penalty on surface points P.
    Units: mm.  Annealed over `schedule` = [(tau, lambda), ...]."""
    k = len(R0)
    x = np.r_[C0.ravel(), R0]
    iS, iP = np.arange(len(S)), np.arange(len(P))

    def f(x, tau, lam):
        C, R = x[:3 * k].reshape(k, 3), x[3 * k:]
        # smoothed count of shell points inside the union (deepest-sphere attribution)
        dvec = S[:, None] - C[None]
        d = np.sqrt(np.einsum("nkj,nkj->nk", dvec, dvec)) + 1e-12
        s = R[None] - d
        a = s.argmax(1)
        z = np.clip(s[iS, a] / tau, -60, 60)
        sig = 1 / (1 + np.exp(-z))
        val = (w * sig).sum()
        ds = w * sig * (1 - sig) / tau
        gR = np.bincount(a, ds, k)
        u = dvec[iS, a] * (ds / d[iS, a])[:, None]
        gC = np.stack([np.bincount(a, u[:, j], k) for j in range(3)], 1)
        # coverage penalty on surface points (closest-to-covering sphere)
        dvec = P[:, None] - C[None]
        d = np.sqrt(np.einsum("nkj,nkj->nk", dvec, dvec)) + 1e-12
        e = d - R[None]
        b = e.argmin(1)
        v = np.maximum(e[iP, b], 0)
        val += lam * (v * v).sum() / len(P)
        dp = 2 * lam * v / len(P)
        gR -= np.bincount(b, dp, k)
        u = dvec[iP, b] * (dp / d[iP, b])[:, None]
        gC -= np.stack([np.bincount(b, u[:, j], k) for j in range(3)], 1)
        return val, np.r_[gC.ravel(), gR]

    for tau, lam in schedule:
        x = minimize(f, x, args=(tau, lam), jac=True, method="L-BFGS-B", options={"maxiter": MAXITER}).x
    return x[:3 * k].reshape(k, 3), x[3 * k:]


def union_boundary_samples(C, R, spacing):
    """Uniform (Fibonacci) samples of the boundary of the union of spheres."""
    pts = []
    for i, (c, r) in enumerate(zip(C, R)):
        n = max(64, int(math.ceil(4 * math.pi * r * r / spacing ** 2)))
        k = np.arange(n) + 0.5
        z = 1 - 2 * k / n
        phi = math.pi * (1 + 5 ** 0.5) * k
        s = np.sqrt(1 - z * z)
        p = c + r * np.c_[s * np.cos(phi), s * np.sin(phi), z]
        others = [j for j in range(len(C)) if j != i]
        if others:
            dd = np.linalg.norm(p[:, None] - C[others][None], axis=2) - R[others][None]
            p = p[(dd >= -1e-12).all(axis=1)]
        pts.append(p)
    return np.concatenate(pts)


def excess_stats(C, R, solids, spacing, exact=True, tree=None, above_z=None, weigh=None):
    """Excess = distance from the sphere-union boundary to the enclosed solid (0 inside it).
    Returns (max, area-weighted mean); with above_z, only boundary points with z >= above_z;
    with weigh, each point's excess multiplied by weigh(points) (for choosing fits only)."""
    b = union_boundary_samples(C, R, spacing)
    tris = np.concatenate(solids)
    if exact:
        d = point_triangle_distance(b, tris)
        inside = np.zeros(len(b), bool)
        for s in solids:
            inside |= np.abs(winding_number(b, s)) > 0.5
        d[inside] = 0.0
    else:
        d = tree.query(b)[0]
    if above_z is not None:
        d = d[b[:, 2] >= above_z]
    if weigh is not None:
        d = d * weigh(b)
    return float(d.max()), float(d.mean())


def round_spheres(C, R, cover_pts):
    """Round centres to the output resolution, re-cover the points exactly, add COVER_MARGIN
    and round the radii up to the output resolution."""
    C, R = cover(cover_pts, np.round(C, DECIMALS), R)
    return C, np.ceil((R + COVER_MARGIN) * 10 ** DECIMALS) / 10 ** DECIMALS


def fit_link(name, solids, k, seed=0):
    """Best of N_RESTARTS: k-means++ init -> smooth fit -> exact cover -> monotone shrink.
    Excess volume where `bulge_weight(name)` says so counts more (fit and choice of restart)."""
    rng = np.random.default_rng(seed)
    tris = np.concatenate(solids)
    area = 0.5 * np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1).sum()
    P = sample_surface(tris, FIT_SPACING, rng)
    S = shell_points(solids, SHELL_SPACING, SHELL_WIDTH, rng)
    w = SHELL_SPACING ** 3 / area * 1e3  # [mm] per shell point: excess volume / area
    weigh = bulge_weight(name)
    if weigh is not None:
        w = w * weigh(S)
    tree = cKDTree(sample_surface(tris, 0.5e-3, rng))
    schedule = SCHEDULE
    best = None
    for _ in range(N_RESTARTS):
        init, lab = kmeans2(P, k, minit="++", seed=rng, iter=30)
        C0, R0 = balls_for_assignment(P, lab, k)
        C, R = smooth_fit(P * 1e3, S * 1e3, w, C0 * 1e3, R0 * 1e3, schedule)
        C, R = cover(P, C * 1e-3, R * 1e-3)
        C, R = refine(P, C, R)
        mx, mean = excess_stats(C, R, solids, 2e-3, exact=False, tree=tree, weigh=weigh)
        score = mean + 0.25 * mx
        if best is None or score < best[0]:
            best = (score, C, R)
    return round_spheres(best[1], best[2], np.concatenate([tris.reshape(-1, 3), sample_surface_grid(tris, COVER_SPACING)]))


# ---------------------------------------------------------------------------------
# URDF
# ---------------------------------------------------------------------------------
def xyz_text(v) -> str:
    return " ".join(fmt(x) for x in v)


def urdf_text(spheres: dict[str, tuple[np.ndarray, np.ndarray]]) -> str:
    out = [
        '<?xml version="1.0"?>',
        "<!-- Franka Emika Panda (arm + Franka Hand) for tandem.",
        "     GENERATED by python_ref/make_panda_urdf.py - do not edit by hand; see README.md.",
        "     Kinematics: Franka's published Craig DH table + datasheet limits, in franka_description",
        "     frame conventions.  Collision: spheres enclosing the example-robot-data collision meshes. -->",
        '<robot name="panda">',
    ]

    def link(name):
        if name not in INERTIA and name not in spheres:  # massless frame (flange, TCP)
            out.append(f'  <link name="{name}"/>')
            return
        out.append(f'  <link name="{name}">')
        if name in INERTIA:
            m, com, (ixx, ixy, ixz, iyy, iyz, izz) = INERTIA[name]
            out.extend([
                "    <inertial>",
                f'      <origin xyz="{xyz_text(com)}" rpy="0 0 0"/>',
                f'      <mass value="{fmt(m)}"/>',
                f'      <inertia ixx="{fmt(ixx)}" ixy="{fmt(ixy)}" ixz="{fmt(ixz)}" '
                f'iyy="{fmt(iyy)}" iyz="{fmt(iyz)}" izz="{fmt(izz)}"/>',
                "    </inertial>",
            ])
        for group in (g for g in spheres if group_link(g) == name):
            for i, (c, r) in enumerate(zip(*spheres[group])):
                out.extend([
                    f'    <collision name="{group}_s{i}">' if group == name else f'    <collision name="{group}">',
                    f'      <origin xyz="{" ".join(fmt_round(x) for x in c)}" rpy="0 0 0"/>',
                    f'      <geometry><sphere radius="{fmt_round(r)}"/></geometry>',
                    "    </collision>",
                ])
        out.append("  </link>")

    def joint(name, jtype, parent, child, xyz, rpy, axis=None, limit=None, mimic=None):
        out.append(f'  <joint name="{name}" type="{jtype}">')
        out.append(f'    <parent link="{parent}"/>')
        out.append(f'    <child link="{child}"/>')
        out.append(f'    <origin xyz="{xyz_text(xyz)}" rpy="{xyz_text(rpy)}"/>')
        if axis is not None:
            out.append(f'    <axis xyz="{xyz_text(axis)}"/>')
        if limit is not None:
            lo, hi, vel, eff = limit
            out.append(f'    <limit lower="{fmt(lo)}" upper="{fmt(hi)}" velocity="{fmt(vel)}" effort="{fmt(eff)}"/>')
        if mimic is not None:
            out.append(f'    <mimic joint="{mimic}" multiplier="1" offset="0"/>')
        out.append("  </joint>")

    link("panda_link0")
    for i, (jname, a, d, alpha) in enumerate(DH, start=1):
        xyz, rpy = dh_origin(a, d, alpha)
        if jname == "panda_joint8":  # flange: fixed
            joint(jname, "fixed", f"panda_link{i - 1}", f"panda_link{i}", xyz, rpy)
        else:
            joint(jname, "revolute", f"panda_link{i - 1}", f"panda_link{i}", xyz, rpy,
                  axis=(0, 0, 1), limit=ARM_LIMITS[jname])
        link(f"panda_link{i}")
    joint("panda_hand_joint", "fixed", "panda_link8", "panda_hand", (0, 0, 0), (0, 0, HAND_YAW))
    link("panda_hand")
    out.append("  <!-- gripper frame: Franka Hand TCP, centre between the fingertips -->")
    joint("panda_hand_tcp_joint", "fixed", "panda_hand", "panda_hand_tcp", (0, 0, TCP_Z), (0, 0, 0))
    link("panda_hand_tcp")
    joint("panda_finger_joint1", "prismatic", "panda_hand", "panda_leftfinger", (0, 0, FINGER_Z), (0, 0, 0),
          axis=(0, 1, 0), limit=FINGER_LIMIT)
    link("panda_leftfinger")
    joint("panda_finger_joint2", "prismatic", "panda_hand", "panda_rightfinger", (0, 0, FINGER_Z), (0, 0, 0),
          axis=(0, -1, 0), limit=FINGER_LIMIT, mimic="panda_finger_joint1")
    link("panda_rightfinger")
    out.append("</robot>")
    return "\n".join(out) + "\n"


# ---------------------------------------------------------------------------------
# Verification
# ---------------------------------------------------------------------------------
def se3_errors(M1, M2):
    return float(np.abs(M1.rotation - M2.rotation).max()), float(np.abs(M1.translation - M2.translation).max())


def check_kinematics(urdf: Path) -> dict:
    import pinocchio as pin

    res = {}
    for mimic in (False, True):
        ours = pin.buildModelFromUrdf(str(urdf), mimic=mimic)
        erd = pin.buildModelFromUrdf(str(ERD_URDF), mimic=mimic)
        assert ours.nq == erd.nq and ours.nv == erd.nv, (ours.nq, erd.nq)
        d1, d2 = ours.createData(), erd.createData()
        fo = {f.name for f in ours.frames}
        fe = {f.name for f in erd.frames}
        common = sorted(fo & fe)
        only = (sorted(fo - fe), sorted(fe - fo))
        # joint -> q index map (by name)
        qmap = []
        for jid in range(1, ours.njoints):
            name = ours.names[jid]
            if ours.joints[jid].nq == 0:
                continue
            qmap.append((ours.joints[jid].idx_q, erd.joints[erd.getJointId(name)].idx_q, ours.joints[jid].nq))
        rng = np.random.default_rng(1234)
        lo, hi = ours.lowerPositionLimit, ours.upperPositionLimit
        eR = ep = 0.0
        for _ in range(FK_SAMPLES):
            q = lo + (hi - lo) * rng.random(ours.nq)
            qe = np.zeros(erd.nq)
            for io, ie, n in qmap:
                qe[ie:ie + n] = q[io:io + n]
            pin.framesForwardKinematics(ours, d1, q)
            pin.framesForwardKinematics(erd, d2, qe)
            for nm in common:
                r, p = se3_errors(d1.oMf[ours.getFrameId(nm)], d2.oMf[erd.getFrameId(nm)])
                eR, ep = max(eR, r), max(ep, p)
        res[mimic] = dict(nq=ours.nq, frames=len(common), only=only, eR=eR, ep=ep)
    # limits vs erd (no mimic)
    ours = pin.buildModelFromUrdf(str(urdf))
    erd = pin.buildModelFromUrdf(str(ERD_URDF))
    lim = []
    for jid in range(1, ours.njoints):
        name = ours.names[jid]
        io, ie = ours.joints[jid].idx_q, erd.joints[erd.getJointId(name)].idx_q
        iv, ive = ours.joints[jid].idx_v, erd.joints[erd.getJointId(name)].idx_v
        for what, a, b in (("lower", ours.lowerPositionLimit[io], erd.lowerPositionLimit[ie]),
                           ("upper", ours.upperPositionLimit[io], erd.upperPositionLimit[ie]),
                           ("velocity", ours.velocityLimit[iv], erd.velocityLimit[ive]),
                           ("effort", ours.effortLimit[iv], erd.effortLimit[ive])):
            if a != b:
                lim.append(f"{name} {what}: ours {a:g} vs erd {b:g}")
        ie_ = erd.getJointId(name)
        di = np.abs(ours.inertias[jid].toDynamicParameters() - erd.inertias[ie_].toDynamicParameters()).max()
        if di > 1e-12:
            lim.append(f"{name} inertia differs by {di:g}")
    res["limit_diffs"] = lim
    # direct DH product vs Pinocchio panda_link8 and the TCP definition
    d = ours.createData()
    rng = np.random.default_rng(99)
    e_dh = 0.0
    for _ in range(200):
        q = ours.lowerPositionLimit + (ours.upperPositionLimit - ours.lowerPositionLimit) * rng.random(ours.nq)
        pin.framesForwardKinematics(ours, d, q)
        T = np.eye(4)
        for i, (_, a, dd, alpha) in enumerate(DH):
            th = q[ours.joints[ours.getJointId(f"panda_joint{i + 1}")].idx_q] if i < 7 else 0.0
            A = np.eye(4)
            A[:3, :3] = rot_x(alpha) @ rot_z(th)
            A[:3, 3] = rot_x(alpha) @ np.array([a, 0, 0]) + rot_x(alpha) @ rot_z(th) @ np.array([0, 0, dd])
            T = T @ A
        Tt = T.copy()
        Tt[:3, :3] = T[:3, :3] @ rot_z(HAND_YAW)
        Tt[:3, 3] = T[:3, 3] + Tt[:3, :3] @ np.array([0, 0, TCP_Z])
        for nm, X in (("panda_link8", T), ("panda_hand_tcp", Tt)):
            M = d.oMf[ours.getFrameId(nm)]
            e_dh = max(e_dh, np.abs(M.rotation - X[:3, :3]).max(), np.abs(M.translation - X[:3, 3]).max())
    res["dh_err"] = e_dh
    # collision geometry parses as spheres
    geom = pin.buildGeomFromUrdf(ours, str(urdf), pin.GeometryType.COLLISION)
    kinds = {type(g.geometry).__name__ for g in geom.geometryObjects}
    res["geom"] = (geom.ngeoms, kinds)
    return res


def depth_stats(C, R, solids, spacing) -> tuple[float, float]:
    """Distance from the mesh surface to the model surface (how deep inside the sphere union the
    enclosed surface lies), over a `spacing` grid sampling of the mesh surface, measured to a
    `spacing` sampling of the union boundary: (max, mean)."""
    tree = cKDTree(union_boundary_samples(C, R, spacing))
    d = tree.query(sample_surface_grid(np.concatenate(solids), spacing))[0]
    return float(d.max()), float(d.mean())


def check_spheres(spheres, solids, links) -> dict:
    """Per group: coverage of its solids (vertices and a dense sampling inside a sphere).
    Per link (all its groups): excess (model surface -> mesh) and depth (mesh surface -> model
    surface) against the link's full solids, and the grasp-critical bulges."""
    groups, per_link = {}, {}
    for name, (C, R) in spheres.items():
        tris = np.concatenate(solids[name])
        verts = np.unique(tris.reshape(-1, 3), axis=0)
        vgap = (np.linalg.norm(verts[:, None] - C[None], axis=2) - R[None]).min(1).max()
        dense = sample_surface_grid(tris, CHECK_SPACING)
        dgap = max((np.linalg.norm(ch[:, None] - C[None], axis=2) - R[None]).min(1).max()
                   for ch in np.array_split(dense, max(1, len(dense) // 200000)))
        groups[name] = dict(n=len(R), nverts=len(verts), vgap=float(vgap), ndense=len(dense), dgap=float(dgap),
                            rmin=float(R.min()), rmax=float(R.max()))
    for link in links:
        names = [g for g in spheres if group_link(g) == link]
        C = np.concatenate([spheres[g][0] for g in names])
        R = np.concatenate([spheres[g][1] for g in names])
        mx, mean = excess_stats(C, R, links[link], EXCESS_SPACING)
        dmx, dmean = depth_stats(C, R, links[link], DEPTH_SPACING)
        per_link[link] = dict(groups=names, n=len(R), max=mx, mean=mean, depth_max=dmx, depth_mean=dmean,
                              rmin=float(R.min()), rmax=float(R.max()))
        if link == "panda_link0":  # the base sits on its mounting plane z = 0
            per_link[link]["above"] = excess_stats(C, R, links[link], EXCESS_SPACING, above_z=0.0)
    C, R = spheres["panda_hand"]
    outer, pad = spheres["panda_leftfinger"], spheres["panda_leftfinger_pad"]
    critical = dict(
        palm=palm_z(),
        palm_bulge=float((C[:, 2] + R).max() - palm_z()),  # hand model below the palm face
        finger_inner=float(-(outer[0][:, 1] - outer[1]).min()),  # outer finger model past the inner face
        pad_inner=float(-(pad[0][:, 1] - pad[1]).min()),  # pad model past the inner face
    )
    return dict(groups=groups, links=per_link, critical=critical)


def order_spheres(C, R):
    """Sort spheres along the principal axis of their centres (readability only)."""
    if len(C) < 2:
        return C, R
    u = np.linalg.svd(C - C.mean(0))[2][0]
    if u[np.abs(u).argmax()] < 0:
        u = -u
    i = np.argsort((C - C.mean(0)) @ u)
    return C[i], R[i]


def _fit_one(args):
    import time

    name, k, seed = args
    t = time.time()
    res = fit_link(name, group_solids()[name], k, seed)
    print(f"  fitted {name}: {len(res[1])} spheres in {time.time() - t:.0f} s", flush=True)
    return name, res


def main(refit: list[str] | None = None) -> int:
    """Fits every group (or only `refit`, keeping the others' spheres from the current URDF),
    writes the URDF and README, and checks them."""
    from concurrent.futures import ProcessPoolExecutor

    solids = group_solids()
    todo = [n for n in N_SPHERES if n not in MIRRORED and (refit is None or n in refit or MIRRORED.get(n) in refit)]
    jobs = [(name, k, i) for i, (name, k) in enumerate(N_SPHERES.items()) if name in todo]
    jobs.sort(key=lambda j: -len(np.concatenate(solids[j[0]])))
    fitted = read_spheres(OUT_URDF) if refit is not None else {}
    if jobs:
        with ProcessPoolExecutor(max_workers=min(len(jobs), os.cpu_count() or 1)) as ex:
            fitted.update(dict(ex.map(_fit_one, jobs)))
    for name, source in MIRRORED.items():
        if name not in fitted or source in todo:
            fitted[name] = mirrored(*fitted[source])
    spheres = {name: order_spheres(*fitted[name]) for name in N_SPHERES}

    OUT_DIR.mkdir(parents=True, exist_ok=True)
    text = urdf_text(spheres)
    OUT_URDF.write_text(text)
    # re-read the written numbers so the checks see exactly what is in the file
    spheres = read_spheres(OUT_URDF)

    ok = True
    kin = check_kinematics(OUT_URDF)
    for mimic in (False, True):
        r = kin[mimic]
        print(f"FK vs erd (mimic={mimic}, nq={r['nq']}): {FK_SAMPLES} configs x {r['frames']} common frames: "
              f"max|dR| = {r['eR']:.3e}, max|dp| = {r['ep']:.3e} m; frames only in ours/erd: {r['only']}")
        ok &= r["eR"] < FK_TOL and r["ep"] < FK_TOL and not r["only"][0]
    print(f"DH product vs panda_link8 / panda_hand_tcp: max err {kin['dh_err']:.3e}")
    ok &= kin["dh_err"] < FK_TOL
    print("limit/inertia differences vs erd:", kin["limit_diffs"] or "none")
    print(f"collision geometry via pin.buildGeomFromUrdf: {kin['geom'][0]} objects, types {kin['geom'][1]}")
    ok &= kin["geom"][1] == {"Sphere"}

    cov = check_spheres(spheres, solids, link_solids())
    tot = sum(c["n"] for c in cov["groups"].values())
    ok &= kin["geom"][0] == tot
    for name, c in cov["groups"].items():
        print(f"{name:22s} {c['n']:2d} spheres r {c['rmin']*1e3:5.1f}..{c['rmax']*1e3:5.1f} mm | "
              f"vertex gap {c['vgap']*1e3:+.3f} mm ({c['nverts']} verts), dense gap {c['dgap']*1e3:+.3f} mm "
              f"({c['ndense']} pts)")
        ok &= c["vgap"] <= 0 and c["dgap"] <= 0
    for name, c in cov["links"].items():
        print(f"{name:22s} model -> mesh (excess) max {c['max']*1e3:5.1f} mean {c['mean']*1e3:5.1f} mm | "
              f"mesh -> model max {c['depth_max']*1e3:5.1f} mean {c['depth_mean']*1e3:5.1f} mm")
        if "above" in c:
            print(f"{'':22s} (above its mounting plane z >= 0: excess max {c['above'][0]*1e3:.1f} "
                  f"mean {c['above'][1]*1e3:.1f} mm)")
    k = cov["critical"]
    print(f"grasp-critical: hand model {k['palm_bulge']*1e3:.1f} mm below the palm face (z = {k['palm']*1e3:.1f} mm); "
          f"finger outer spheres {k['finger_inner']*1e3:.1f} mm, pads {k['pad_inner']*1e3:.1f} mm past the inner face")
    allmax = max(c["max"] for c in cov["links"].values())
    print(f"total spheres {tot}; excess max {allmax*1e3:.1f} mm")
    OUT_README.write_text(readme_text(kin, cov))
    print("wrote", OUT_URDF.relative_to(REPO), "and", OUT_README.relative_to(REPO))
    print("ALL CHECKS PASSED" if ok else "CHECKS FAILED")
    return 0 if ok else 1


def read_spheres(urdf: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per sphere group (a link's `<link>_s<i>` elements, or the elements named after a pad group)."""
    import xml.etree.ElementTree as ET

    found: dict[str, tuple[list, list]] = {}
    for link in ET.parse(urdf).getroot().iter("link"):
        for col in link.iter("collision"):
            name = col.get("name", "")
            group = link.get("name") if name.startswith(link.get("name") + "_s") else name
            sph = col.find("geometry/sphere")
            cs, rs = found.setdefault(group, ([], []))
            cs.append([float(t) for t in col.find("origin").get("xyz").split()])
            rs.append(float(sph.get("radius")))
    return {g: (np.array(cs), np.array(rs)) for g, (cs, rs) in found.items()}


def readme_text(kin, cov) -> str:
    dh_rows = "\n".join(
        f"  | {n.replace('panda_', '') if n != 'panda_joint8' else 'flange (joint8, fixed)'} | {fmt(a)} | {fmt(d)} | "
        f"{ {0.0: '0', HALF_PI: 'π/2', -HALF_PI: '−π/2'}[al] } |"
        for n, a, d, al in DH
    )
    lim_rows = "\n".join(
        f"  | {n.replace('panda_', '')} | {fmt(lo)} | {fmt(hi)} | {fmt(v)} | {fmt(e)} |" for n, (lo, hi, v, e) in ARM_LIMITS.items()
    )
    links, crit = cov["links"], cov["critical"]
    tot = sum(c["n"] for c in links.values())
    sph_rows = "\n".join(
        f"| {n} | {' + '.join(str(cov['groups'][g]['n']) for g in c['groups'])} | {c['rmin']*1e3:.1f}–{c['rmax']*1e3:.1f} "
        f"| {c['max']*1e3:.1f} | {c['mean']*1e3:.1f} | {c['depth_max']*1e3:.1f} | {c['depth_mean']*1e3:.1f} |"
        for n, c in links.items()
    )
    allmax = max(c["max"] for c in links.values())
    # area-weighted mean is not meaningful across links of very different size: report the plain average
    avgmean = sum(c["mean"] for c in links.values()) / len(links)
    above = links["panda_link0"]["above"]
    fk = kin[False]
    fkm = kin[True]
    diffs = "; ".join(kin["limit_diffs"]) or "none"
    return f"""# Panda — tandem's embedded default robot

`panda.urdf` is the Franka Emika Panda arm with the Franka Hand.  It is **generated** by
[`python_ref/make_panda_urdf.py`](../../../python_ref/make_panda_urdf.py); do not edit it by hand.

## Where the numbers come from

* **Kinematics** — Franka's published Denavit–Hartenberg table (Craig / modified convention,
  `ⁱ⁻¹Tᵢ = RotX(α)·TransX(a)·RotZ(θᵢ)·TransZ(d)`), from Franka's "Robot and interface
  specifications" documentation:

  | joint | a [m] | d [m] | α |
  |---|---|---|---|
{dh_rows}

  Each row becomes a URDF joint origin `xyz = (a, −sin α·d, cos α·d)`, `rpy = (α, 0, 0)` with
  `axis = 0 0 1` (α written as full-precision ±1.5707963267948966).  The flange row is the fixed
  joint `panda_joint8` (`panda_link7` → `panda_link8`).
* **Joint limits** — Franka datasheet:

  | joint | lower [rad] | upper [rad] | velocity [rad/s] | effort [Nm] |
  |---|---|---|---|---|
{lim_rows}

* **Hand** (franka_description conventions) — fixed `panda_hand_joint` from `panda_link8`
  with `rpy = (0, 0, −π/4)`; prismatic `panda_finger_joint1` (→ `panda_leftfinger`, axis +y)
  and `panda_finger_joint2` (→ `panda_rightfinger`, axis −y, `<mimic joint="panda_finger_joint1"/>`),
  both at `z = {fmt(FINGER_Z)}` in `panda_hand`, travel {fmt(FINGER_LIMIT[0])}–{fmt(FINGER_LIMIT[1])} m each,
  {fmt(FINGER_LIMIT[2])} m/s, effort {fmt(FINGER_LIMIT[3])} N.
* **Inertials** — masses / CoMs / inertia tensors copied from the public franka_description
  values (as shipped in example-robot-data's `panda.urdf`).
* **Collision** — spheres only (see below); no meshes are shipped.

## Frames

Link and joint names and all frames are those of franka_description / example-robot-data
(`panda_link0` … `panda_link8`, `panda_hand`, `panda_leftfinger`, `panda_rightfinger`,
`panda_joint1` … `panda_joint8`, `panda_hand_joint`, `panda_finger_joint1/2`):
`panda_link0` is the base (mounting plate, z up); `panda_link{{i}}` rotates about its own z by qᵢ;
`panda_link8` is the flange ({fmt(DH[-1][2])} m along `panda_link7` z); `panda_hand` is the flange
turned −45° about z.

**Gripper frame: `panda_hand_tcp`** (fixed joint `panda_hand_tcp_joint`), `z = {fmt(TCP_Z)}` m from
`panda_hand` with the same orientation: Franka's TCP, the centre between the fingertips; z is the
approach direction, the fingers move along ±y.

Checked by the generator with Pinocchio (`pin.buildModelFromUrdf`) against example-robot-data's
`panda.urdf`, on {FK_SAMPLES} random configurations within the limits (finger joints included):
all {fk['frames']} frames present in both models (every link and joint frame, including
`panda_hand_tcp`) agree to max |ΔR| = {fk['eR']:.1e}, max |Δp| = {fk['ep']:.1e} m (also with
`mimic=True`: {fkm['eR']:.1e} / {fkm['ep']:.1e} m) — the DH-derived origins come out as the same
floating-point numbers as example-robot-data's.  A direct product of the DH matrices reproduces
`panda_link8` and `panda_hand_tcp` to {kin['dh_err']:.1e}.  Differences in limits / inertias vs
example-robot-data: {diffs} (example-robot-data uses 100; 70 N is the Franka Hand's rated continuous grasp force).

## Collision spheres

Each link has several `<collision name="<link>_s<i>">` elements with `<sphere>` geometry
({tot} spheres in total; `panda_link8` and `panda_hand_tcp` have none).  They **enclose** the
example-robot-data collision meshes (`meshes/collision/*.stl`; for the fingers `finger.stl` plus
the four finger collision boxes of example-robot-data's `panda.urdf`, the right finger rotated by
π about z).  The final radii exactly cover a structured surface sampling with
{COVER_SPACING*1e3:g} mm spacing plus a margin of {COVER_MARGIN*1e3:.2f} mm, which bounds the distance
from any surface point to a sample, so the whole mesh surface is enclosed, not just the samples.
The generator checks it independently: every mesh vertex and a {CHECK_SPACING*1e3:g} mm surface
sampling lie inside at least one sphere.  Centres are written with 0.1 mm resolution, radii
rounded up to 0.1 mm.

**Finger pads.** Each finger's spheres come in two groups: the finger's own (`<finger>_s<i>`)
enclose the part of the finger more than {PAD_DEPTH*1e3:g} mm from its inner face (the face towards the
other finger), and the **pad** spheres, every one named `panda_leftfinger_pad` (or
`panda_rightfinger_pad`), enclose the inner {PAD_DEPTH*1e3:g} mm layer: the contact surface.  Problem files
name them in `robot.finger_pads` (see `problems/README.md`): a grasp goal lets only the pads come
close to the grasped object.  The right finger's spheres are the left finger's turned by π about z.

**Where tightness matters for grasping.** The fit weighs excess volume {BULGE_WEIGHT:g}× more below
the palm (hand frame z > {crit['palm']*1e3:.1f} mm, the lowest point of `hand.stl`) and, for the
fingers' own spheres, past the inner face.  Result: the hand's spheres reach
{crit['palm_bulge']*1e3:.1f} mm below the palm face, so the fingers reach
{(TCP_Z - crit['palm'] - crit['palm_bulge'])*1e3:.1f} mm from `panda_hand_tcp` back to the
model's palm ({(TCP_Z - crit['palm'])*1e3:.1f} mm to the mesh's); the fingers' own spheres reach
{crit['finger_inner']*1e3:.1f} mm past the inner face and the pads {crit['pad_inner']*1e3:.1f} mm, of the
10 mm per side that an 8 cm opening leaves around a 6 cm box.

Two measures of the approximation error per link (all its groups), both against the link's full
erd collision geometry:

* *model → mesh* (excess): distance from a point on the boundary of the sphere union to the
  enclosed mesh (0 where inside it), sampled uniformly every {EXCESS_SPACING*1e3:g} mm over the union
  boundary; max is the worst bulge, mean is area-weighted;
* *mesh → model*: distance from a point of the mesh surface to the boundary of the sphere union
  (how deep inside the model the real surface lies), over a {DEPTH_SPACING*1e3:g} mm sampling of the mesh
  surface, measured to a {DEPTH_SPACING*1e3:g} mm sampling of the union boundary (so within about
  {DEPTH_SPACING*1e3:g} mm).

| link | spheres | radii [mm] | model → mesh max [mm] | mean [mm] | mesh → model max [mm] | mean [mm] |
|---|---|---|---|---|---|---|
{sph_rows}

Overall: {tot} spheres, worst excess {allmax*1e3:.1f} mm, mean excess (average over links)
{avgmean*1e3:.1f} mm.  Spheres are poor at flat faces: the large values are bulges over the flat
joint-housing end caps (mostly into the neighbouring link, whose collisions with its parent are
normally not checked) and under the flat bottom of `panda_link0` (below its mounting plane; counting
only the part above z = 0, `panda_link0` has excess max {above[0]*1e3:.1f} mm, mean
{above[1]*1e3:.1f} mm).  The cylindrical parts are covered more tightly.

Fitting (per group): k-means++ initialisation on surface samples, then minimisation of the
(smoothed, weighted) union volume outside the mesh with a coverage penalty, exact re-covering, and a
monotone shrink step (each sphere replaced by the minimum ball of the points it covers); best of
{N_RESTARTS} restarts.  Sphere counts per group are set in `N_SPHERES` in the script.

## Regenerating

```sh
python_ref/.venv/bin/python python_ref/make_panda_urdf.py                   # every group
python_ref/.venv/bin/python python_ref/make_panda_urdf.py --refit panda_hand  # only these, keep the rest
```

(venv with `pin` (Pinocchio) 4.1, numpy, scipy, example-robot-data; about 10 min on 2 cores, the
sphere fitting runs one process per core).  Fixed seeds; rewrites `panda.urdf` and this README and
prints all checks, exiting non-zero if one fails.
"""


def explore(names, ks=range(3, 10)) -> None:
    """`make_panda_urdf.py --explore LINK...`: print excess vs sphere count (to pick N_SPHERES)."""
    solids = group_solids()
    for name in names:
        for k in ks:
            C, R = fit_link(name, solids[name], k)
            mx, mean = excess_stats(C, R, solids[name], 3e-3)
            print(f"{name} k={k}: {len(R)} spheres, excess max {mx*1e3:.1f} mean {mean*1e3:.1f} mm", flush=True)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--explore":
        explore(sys.argv[2:])
        sys.exit(0)
    if len(sys.argv) > 1 and sys.argv[1] == "--refit":
        unknown = [n for n in sys.argv[2:] if n not in N_SPHERES]
        if unknown:
            sys.exit(f"unknown sphere groups {unknown} (have {list(N_SPHERES)})")
        sys.exit(main(sys.argv[2:]))
    sys.exit(main())
