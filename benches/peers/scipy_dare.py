#!/usr/bin/env python3
"""Times scipy.linalg.solve_discrete_are (+ the gain K) on tandem's DARE bench cases.

Usage:
  scipy_dare.py [CASES_JSON]

CASES_JSON (default target/peers/dare_cases.json, written by
`cargo bench -p tandem-solvers --bench dare`) holds {"cases": [{"name", "a",
"b", "q", "r"}]}, matrices as lists of rows. For each case the timed call is
P = solve_discrete_are(A, B, Q, R) followed by K = (R + BᵀPB)⁻¹BᵀPA, i.e. the
same output as tandem's solve. Each sample averages `number` calls (chosen so
a sample takes about 20 ms); the median and minimum over the samples are
reported, in µs per call, as one JSON object on stdout.

BLAS runs single-threaded (OPENBLAS_NUM_THREADS=1 etc. are set before numpy
loads), like tandem's solver: at these sizes extra threads only add
synchronisation, and on a loaded machine they oversubscribe the cores.
"""
import json
import os
import pathlib
import statistics
import sys
import timeit

for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

import numpy as np  # noqa: E402  (after the thread settings)
import scipy  # noqa: E402
import scipy.linalg  # noqa: E402

SAMPLES = 31
SAMPLE_SECONDS = 0.02


def solve(a, b, q, r):
    p = scipy.linalg.solve_discrete_are(a, b, q, r)
    k = np.linalg.solve(r + b.T @ p @ b, b.T @ p @ a)
    return p, k


def time_case(case):
    a, b, q, r = (np.array(case[key], dtype=float) for key in ("a", "b", "q", "r"))
    timer = timeit.Timer(lambda: solve(a, b, q, r))
    number, _ = timer.autorange()
    number = max(1, int(number * SAMPLE_SECONDS / 0.2))  # autorange targets 0.2 s
    samples = [t / number * 1e6 for t in timer.repeat(repeat=SAMPLES, number=number)]
    return {"median": statistics.median(samples), "min": min(samples), "samples": SAMPLES, "number": number}


def main():
    path = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "target/peers/dare_cases.json")
    if not path.is_file():
        raise SystemExit(f"scipy_dare: {path} not found; run `cargo bench -p tandem-solvers --bench dare` first")
    cases = json.loads(path.read_text())["cases"]
    results = {case["name"]: time_case(case) for case in cases}
    json.dump({"scipy_version": scipy.__version__, "numpy_version": np.__version__, "results_us": results},
              sys.stdout, indent=1)


if __name__ == "__main__":
    main()
