#!/usr/bin/env python3
"""Independent reference of the arbiter's metrics on an LQR tracking policy.

Usage:
  arbitration_reference.py < request.json

Request: {"reference": [[q_0], ..., [q_T]], "dt": s, "weights": {"position",
"velocity", "control"}, "step": h, "radius": r, "floor": f,
"cases": [{"q": [..], "velocity": [..]}]}.

For each case, with the gain K of scipy.linalg.solve_discrete_are on the
joint-space double integrator (x = [q, v], x+ = A x + B u, A = [[I, dt I],
[0, I]], B = [[dt²/2 I], [dt I]], Q = diag(position I, velocity I),
R = control I):

* the policy pi(q) = v + (-K e) dt with e = [q - r(s+1), v - v_r(s+1)], r the
  polyline through the waypoints, s the closest point (earliest of ties),
  v_r from backward differences (0 at the first waypoint and at the goal);
* the Hessian metric (the dissertation's eq. 5.5-5.6): f(p) = pi(p).(p - q)
  at q + h e_i and q + h e_i + h e_j, W = -H/2;
* the Fisher metric (Algorithm 3): samples q + r e_i, q - r e_i and r u_k
  for the first n Halton directions, a linear least-squares fit with
  Gaussian weights exp(-|d|^2 / 2r^2), F = -(A + A^T)/2;
* both repaired: eigenvalues floored at f * max, scaled to mean 1.

Writes {"cases": [{"hessian": [[..]], "fisher": [[..]], "hessian_repaired":
[[..]], "fisher_repaired": [[..]], "action": [..]}]}, matrices as rows.
"""
import json
import sys

import numpy as np
import scipy.linalg

PRIMES = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53]


def gain(n, dt, w):
    a = np.block([[np.eye(n), dt * np.eye(n)], [np.zeros((n, n)), np.eye(n)]])
    b = np.vstack([0.5 * dt * dt * np.eye(n), dt * np.eye(n)])
    q = np.diag([w["position"]] * n + [w["velocity"]] * n)
    r = w["control"] * np.eye(n)
    p = scipy.linalg.solve_discrete_are(a, b, q, r)
    return np.linalg.solve(r + b.T @ p @ b, b.T @ p @ a)


class Policy:
    def __init__(self, waypoints, dt, weights):
        self.r = np.array(waypoints, dtype=float)
        self.dt = dt
        self.v = np.zeros_like(self.r)
        self.v[1:] = (self.r[1:] - self.r[:-1]) / dt
        self.k = gain(self.r.shape[1], dt, weights)

    def closest(self, q):
        best_s, best_d = 0.0, np.inf
        for i in range(max(len(self.r) - 1, 1)):
            a, b = self.r[i], self.r[min(i + 1, len(self.r) - 1)]
            ab = b - a
            ab2 = ab @ ab
            t = min(max((q - a) @ ab / ab2, 0.0), 1.0) if ab2 > 0 else 0.0
            d = np.linalg.norm(q - a - t * ab)
            if d < best_d * (1 - 1e-9):
                best_s, best_d = min(i + t, len(self.r) - 1), d
        return best_s

    def interpolate(self, table, s):
        i = min(int(np.floor(s)), len(self.r) - 1)
        if i == len(self.r) - 1:
            return table[i]
        t = s - i
        return table[i] + t * (table[i + 1] - table[i])

    def act(self, q, v):
        last = len(self.r) - 1
        target = min(self.closest(q) + 1.0, last)
        at_goal = target >= last
        vd = np.zeros_like(q) if at_goal else self.interpolate(self.v, target)
        e = np.concatenate([q - self.interpolate(self.r, target), v - vd])
        return v + (-self.k @ e) * self.dt


def hessian_metric(policy, q, v, h):
    n = len(q)
    f = np.zeros(n)
    for i in range(n):
        p = q.copy()
        p[i] += h
        f[i] = h * policy.act(p, v)[i]
    w = np.zeros((n, n))
    for i in range(n):
        for j in range(i, n):
            p = q.copy()
            p[i] += h
            p[j] += h
            a = policy.act(p, v)
            hij = (h * (a[i] + a[j]) - f[i] - f[j]) / (h * h)
            w[i, j] = w[j, i] = -0.5 * hij
    return w


def halton_directions(n, count):
    out = []
    for k in range(count):
        d = []
        for i in range(n):
            base = PRIMES[i % len(PRIMES)] + 2 * (i // len(PRIMES))
            x, scale, m = 0.0, 1.0 / base, k + 1
            while m > 0:
                x += (m % base) * scale
                m //= base
                scale /= base
            d.append(2.0 * x - 1.0)
        d = np.array(d)
        out.append(d / max(np.linalg.norm(d), 1e-12))
    return out


def fisher_metric(policy, q, v, r):
    n = len(q)
    offsets = []
    for i in range(n):
        for sign in (1.0, -1.0):
            d = np.zeros(n)
            d[i] = sign * r
            offsets.append(d)
    offsets += [r * d for d in halton_directions(n, n)]
    xs = [np.zeros(n)] + offsets
    ys = [policy.act(q, v)] + [policy.act(q + d, v) for d in offsets]
    ws = [1.0] + [np.exp(-0.5 * (d @ d) / (r * r)) for d in offsets]
    x = np.array([np.concatenate([[1.0], d]) for d in xs])
    y = np.array(ys)
    sw = np.sqrt(np.array(ws))[:, None]
    coef, *_ = np.linalg.lstsq(x * sw, y * sw, rcond=None)
    a = coef[1:].T  # a[k, j] = d action_k / d q_j
    return -0.5 * (a + a.T)


def repair(m, floor):
    values, vectors = np.linalg.eigh(m)
    top = values.max()
    if not np.isfinite(top) or top <= 0:
        return np.eye(len(m))
    values = np.maximum(values, floor * top)
    values /= values.mean()
    return vectors @ np.diag(values) @ vectors.T


def main():
    request = json.load(sys.stdin)
    policy = Policy(request["reference"], request["dt"], request["weights"])
    out = []
    for case in request["cases"]:
        q = np.array(case["q"], dtype=float)
        v = np.array(case["velocity"], dtype=float)
        hess = hessian_metric(policy, q, v, request["step"])
        fish = fisher_metric(policy, q, v, request["radius"])
        out.append({
            "action": policy.act(q, v).tolist(),
            "hessian": hess.tolist(),
            "fisher": fish.tolist(),
            "hessian_repaired": repair(hess, request["floor"]).tolist(),
            "fisher_repaired": repair(fish, request["floor"]).tolist(),
        })
    json.dump({"cases": out}, sys.stdout)


if __name__ == "__main__":
    main()
