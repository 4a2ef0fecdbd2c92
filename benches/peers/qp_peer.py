#!/usr/bin/env python3
"""Times the Python Clarabel and OSQP on tandem's safety-filter QPs.

Usage:
  qp_peer.py PROBLEMS_JSON

PROBLEMS_JSON (written by `TANDEM_EXPORT_QP=FILE cargo bench --bench
arbitration`) holds {"n": 7, "problems": [{"p", "q", "g", "h", "u"}]}: the
DirectControl safety filter of each tick of a recorded Panda grasp episode,
min ½uᵀPu + qᵀu s.t. Gu ≤ h (P column-major n × n; G row-major m × n, every
joint-limit, velocity-limit and distance row tandem built that tick), and
tandem's executed command u.

Each peer is given the same data as tandem's own solver and the same
advantage: one solver object per row count, set up before timing, only its
data updated per tick (Clarabel: update P/q/A/b with presolve off; OSQP:
update, warm-started). Reported: median and p99 µs per solve over 20 passes,
and the largest difference between the peer's u and tandem's (rad/s). One
JSON object on stdout.
"""
import json
import os
import statistics
import sys
import time

import clarabel
import numpy as np
import osqp
import scipy.sparse as sp


def dense_csc(m, upper=False):
    rows, cols = m.shape
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    keep = (r <= c) if upper else np.ones_like(r, dtype=bool)
    return sp.csc_matrix((m[keep] + 0.0, (r[keep], c[keep])), shape=m.shape)


def values(mat_csc_pattern, m):
    # Values of dense m in the column-major order of a dense CSC pattern.
    out = []
    for j in range(mat_csc_pattern.shape[1]):
        rows = mat_csc_pattern.indices[mat_csc_pattern.indptr[j]:mat_csc_pattern.indptr[j + 1]]
        out.extend(m[rows, j])
    return np.array(out)


def problems(path):
    data = json.load(open(path))
    n = data["n"]
    for p in data["problems"]:
        m = len(p["h"])
        yield (np.array(p["p"]).reshape(n, n, order="F"), np.array(p["q"]), np.array(p["g"]).reshape(m, n),
               np.array(p["h"]), np.array(p["u"]))


class ClarabelPeer:
    def __init__(self):
        self.solvers = {}

    def solve(self, P, q, G, h):
        m = len(h)
        if m not in self.solvers:
            settings = clarabel.DefaultSettings()
            settings.verbose = False
            settings.presolve_enable = False
            settings.equilibrate_enable = False
            settings.input_sparse_dropzeros = False
            settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = 1e-8
            Pc, Ac = dense_csc(np.ones_like(P), upper=True), dense_csc(np.ones_like(G))
            solver = clarabel.DefaultSolver(Pc, q, Ac, h, [clarabel.NonnegativeConeT(m)], settings)
            self.solvers[m] = (solver, Pc, Ac)
        solver, Pc, Ac = self.solvers[m]
        solver.update(P=values(Pc, np.triu(P)), q=q, A=values(Ac, G), b=h)
        return np.array(solver.solve().x)


class OsqpPeer:
    def __init__(self):
        self.solvers = {}

    def solve(self, P, q, G, h):
        m = len(h)
        lower = np.full(m, -np.inf)
        if m not in self.solvers:
            Pc, Ac = dense_csc(np.ones_like(P), upper=True), dense_csc(np.ones_like(G))
            solver = osqp.OSQP()
            solver.setup(Pc, q, Ac, lower, h, verbose=False, eps_abs=1e-8, eps_rel=1e-8, polishing=True,
                         warm_starting=True, max_iter=4000)
            self.solvers[m] = (solver, Pc, Ac)
        solver, Pc, Ac = self.solvers[m]
        solver.update(Px=values(Pc, np.triu(P)), q=q, Ax=values(Ac, G), l=lower, u=h)
        return np.array(solver.solve().x)


def run(peer, items):
    times, worst = [], 0.0
    for _ in range(20):
        for P, q, G, h, u in items:
            began = time.perf_counter()
            x = peer.solve(P, q, G, h)
            times.append((time.perf_counter() - began) * 1e6)
            worst = max(worst, float(np.max(np.abs(x - u))))
    times.sort()
    return {"median_us": statistics.median(times), "p99_us": times[int(0.99 * (len(times) - 1))],
            "max_difference": worst}


def main():
    # OSQP's C code prints ("Polishing not needed ...") to stdout whatever
    # `verbose` says: keep file descriptor 1 for the JSON result only.
    result = os.fdopen(os.dup(1), "w")
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
    items = list(problems(sys.argv[1]))
    out = {"problems": len(items), "rows": [len(i[3]) for i in items][:1],
           "clarabel": run(ClarabelPeer(), items), "osqp": run(OsqpPeer(), items),
           "versions": {"clarabel": clarabel.__version__, "osqp": osqp.__version__}}
    json.dump(out, result)
    result.close()


if __name__ == "__main__":
    main()
