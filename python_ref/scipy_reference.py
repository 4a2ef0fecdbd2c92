#!/usr/bin/env python3
"""scipy reference DARE solutions for tandem's cross-check tests.

Usage:
  scipy_reference.py < request.json

Request: {"problems": [{"a": [[..]], "b": [[..]], "q": [[..]], "r": [[..]],
"n": [[..]] (optional cross term)}]}, matrices as lists of rows.
Writes one JSON object on stdout: {"solutions": [{"p": [[..]], "k": [[..]]}],
"scipy_version": str}, where P = scipy.linalg.solve_discrete_are(A, B, Q, R,
s=N) and K = (R + BᵀPB)⁻¹(BᵀPA + Nᵀ), the gain of u = −Kx for the cost
xᵀQx + uᵀRu + 2xᵀNu. Values are written with repr precision (round-trip).
"""
import json
import sys

import numpy as np
import scipy
import scipy.linalg


def matrix(rows, name):
    m = np.array(rows, dtype=float)
    if m.ndim != 2:
        raise SystemExit(f"scipy_reference: {name} must be a list of rows, got shape {m.shape}")
    return m


def solve(problem):
    a, b, q, r = (matrix(problem[k], k) for k in ("a", "b", "q", "r"))
    n = matrix(problem["n"], "n") if problem.get("n") is not None else None
    p = scipy.linalg.solve_discrete_are(a, b, q, r, s=n)
    rhs = b.T @ p @ a + (n.T if n is not None else 0.0)
    k = np.linalg.solve(r + b.T @ p @ b, rhs)
    return {"p": p.tolist(), "k": k.tolist()}


def main():
    request = json.load(sys.stdin)
    solutions = [solve(p) for p in request["problems"]]
    json.dump({"solutions": solutions, "scipy_version": scipy.__version__}, sys.stdout)


if __name__ == "__main__":
    main()
