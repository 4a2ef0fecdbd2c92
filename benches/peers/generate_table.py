"""The table of benches/peers/compare_generate.sh: tandem generate vs RAI.

    python3 generate_table.py OUT_DIR LOAD_BEFORE LOAD_AFTER

Reads OUT_DIR/tandem_summary.txt (tandem generate's summary: its rate),
OUT_DIR/tandem_dataset/_timings/*.csv (its per-sample times),
OUT_DIR/tandem_measured.json (its rows judged by family_export --dataset)
and OUT_DIR/rai_LABEL.json (RAI's samples judged by family_export
--measure). A sample is accepted when the solver converged (tandem: accepted
by generate; RAI: feasible) and tandem's verdict holds: eq, ineq ≤ the
tolerance (1e-4, and 1e-3 as a second column), collision-free between
slices, within limits, goal reached. Prints the table and writes
OUT_DIR/../generate_peers.json. Standard library only.
"""

import csv
import glob
import json
import os
import re
import sys

from planning_common import median

TOLERANCES = (1e-4, 1e-3)


def accepted(s, converged, tol):
    return (converged and "eq" in s and s["eq"] <= tol and s["ineq"] <= tol and s["collision_free"]
            and s["within_limits"] and s["goal_reached"])


def failure(s, converged, tol):
    """Why a sample is not accepted at `tol`."""
    if "eq" not in s:
        return s.get("reason") or s.get("status") or "no_trajectory"
    for ok, reason in ((converged, s.get("status", "not_converged")), (s["collision_free"], "in_collision"),
                       (s["within_limits"], "outside_limits"), (s["goal_reached"], "goal_missed")):
        if not ok:
            return reason
    return f"eq_or_ineq_above_{tol:g}"


def judge(side, samples, converged):
    """Acceptance counts and failure reasons at each tolerance."""
    side["accepted"], side["failures"] = {}, {}
    for tol in TOLERANCES:
        key = f"{tol:g}"
        side["accepted"][key] = sum(1 for s in samples if accepted(s, converged(s), tol))
        reasons = {}
        for s in samples:
            if not accepted(s, converged(s), tol):
                r = failure(s, converged(s), tol)
                reasons[r] = reasons.get(r, 0) + 1
        side["failures"][key] = reasons


def tandem_side(out):
    text = open(os.path.join(out, "tandem_summary.txt")).read()
    m = re.search(r"(\d+) samples in ([\d.]+) s, ([\d.]+) samples/s", text)
    if not m:
        raise SystemExit(f"no rate in {out}/tandem_summary.txt:\n{text}")
    cpu = re.search(r"cpu: ([\d.]+) user ([\d.]+) system", text)
    rows = []
    for f in sorted(glob.glob(os.path.join(out, "tandem_dataset", "_timings", "*.csv"))):
        with open(f) as fh:
            rows.extend(csv.DictReader(fh))
    measured = json.load(open(os.path.join(out, "tandem_measured.json")))
    side = {
        "name": "tandem generate",
        "samples": int(m.group(1)),
        # The printed rate comes from the exact elapsed time (the seconds are rounded).
        "seconds": int(m.group(1)) / float(m.group(3)),
        "cpu_seconds": float(cpu.group(1)) + float(cpu.group(2)) if cpu else None,
        "own_accepted": sum(1 for s in measured["samples"] if s.get("accepted")),
        "median_ms": median([float(r["total_ms"]) for r in rows]),
        "slowest": max(((float(r["total_ms"]), int(r["id"]), r["outcome"]) for r in rows), default=None),
        "sum_ms": sum(float(r["total_ms"]) for r in rows),
        "phases_ms": {"plan (RRT-Connect + shortcut)": median([float(r["plan_ms"]) for r in rows]),
                      "rest (sampling, models, IK, optimize, validate)":
                          median([float(r["optimize_ms"]) for r in rows])},
    }
    judge(side, measured["samples"], lambda s: bool(s.get("accepted")))
    return side


def rai_side(path):
    d = json.load(open(path))
    samples = d["samples"]
    totals = [s["times_ms"]["total"] for s in samples]
    label = os.path.basename(path)[len("rai_"):-len(".json")]
    side = {
        "name": f"RAI ({label})",
        "goals": d["goals"],
        "komo_options": d.get("komo_options"),
        "samples": len(samples),
        "seconds": (sum(totals) + d.get("setup_ms", 0.0)) / 1e3,
        "setup_ms": d.get("setup_ms"),
        "cpu_seconds": (sum(s["cpu_ms"] for s in samples) + d.get("setup_cpu_ms", 0.0)) / 1e3,
        "own_accepted": sum(1 for s in samples if s["converged"]),
        "median_ms": median(totals),
        "slowest": max(((s["times_ms"]["total"], s["id"], s["status"]) for s in samples), default=None),
        "sum_ms": sum(totals),
        "median_cpu_ms": median([s["cpu_ms"] for s in samples]),
        "phases_ms": {k: median([s["times_ms"].get(k, 0.0) for s in samples]) for k in ("scene", "goal", "rrt", "komo")},
        "rrt_solved": sum(1 for s in samples if s.get("rrt_solved")),
        "robotic_version": d.get("robotic_version"),
        "pairs_sample0": d.get("pairs_sample0"),
    }
    judge(side, samples, lambda s: bool(s["converged"]))
    return side


def rates(side):
    side["samples_per_s"] = side["samples"] / side["seconds"]
    side["samples_per_cpu_s"] = side["samples"] / side["cpu_seconds"] if side["cpu_seconds"] else None
    side["accepted_per_s"] = {k: n / side["seconds"] for k, n in side["accepted"].items()}
    side["acceptance"] = {k: n / side["samples"] for k, n in side["accepted"].items()}


def ratio(a, b):
    return a / b if b else None


def fmt_ratio(r):
    return f"{r:.1f}x" if r is not None else "n/a (RAI: 0)"


def main():
    out, load_before, load_after = sys.argv[1:4]
    tandem = tandem_side(out)
    peers = [rai_side(p) for p in sorted(glob.glob(os.path.join(out, "rai_*.json"))) if not p.endswith(".raw.json")]
    if not peers:
        raise SystemExit(f"no RAI result in {out}")
    for side in [tandem] + peers:
        rates(side)
    t1, t2 = (f"{t:g}" for t in TOLERANCES)
    print(f"\nBulk generation: {tandem['samples']} samples of the family, T = 50, single-threaded "
          f"(load average {load_before} before, {load_after} after)")
    head = (f"{'generator':<22} {'samples/s':>9} {'accepted/s':>11} {'acceptance':>11} {'acc/s @' + t2:>11} "
            f"{'acc. @' + t2:>10} {'median ms':>10} {'samples/CPU-s':>14}")
    print(head)
    print(f"{'':<22} {'':>9} {'(eq<=' + t1 + ')':>11} {'(eq<=' + t1 + ')':>11}")
    for s in [tandem] + peers:
        print(f"{s['name']:<22} {s['samples_per_s']:>9.2f} {s['accepted_per_s'][t1]:>11.2f} "
              f"{100 * s['acceptance'][t1]:>10.1f}% {s['accepted_per_s'][t2]:>11.2f} "
              f"{100 * s['acceptance'][t2]:>9.1f}% {s['median_ms']:>10.1f} {s['samples_per_cpu_s'] or float('nan'):>14.2f}")
    print()
    for p in peers:
        p["ratios"] = {
            "samples_per_s": ratio(tandem["samples_per_s"], p["samples_per_s"]),
            "accepted_per_s": {k: ratio(tandem["accepted_per_s"][k], p["accepted_per_s"][k]) for k in (t1, t2)},
            "median_time": ratio(p["median_ms"], tandem["median_ms"]),
            "samples_per_cpu_s": ratio(tandem["samples_per_cpu_s"], p["samples_per_cpu_s"]),
        }
        r = p["ratios"]
        print(f"tandem / {p['name']}: samples/s {fmt_ratio(r['samples_per_s'])}, accepted/s "
              f"{fmt_ratio(r['accepted_per_s'][t1])} (@{t1}), {fmt_ratio(r['accepted_per_s'][t2])} (@{t2}); "
              f"median per-sample time RAI/tandem {fmt_ratio(r['median_time'])}; "
              f"samples/CPU-s {fmt_ratio(r['samples_per_cpu_s'])}")
    print(f"\nnot accepted (@{t1} | @{t2}):")
    print(f"  tandem: generate accepted {tandem['own_accepted']}; {tandem['failures'][t1]} | {tandem['failures'][t2]}")
    for p in peers:
        print(f"  {p['name']}: RAI feasible {p['own_accepted']}, RRT solved {p['rrt_solved']}; "
              f"{p['failures'][t1]} | {p['failures'][t2]}")
    print("median phase times (ms):")
    print(f"  tandem: {json.dumps({k: round(v, 1) for k, v in tandem['phases_ms'].items()})}")
    for p in peers:
        print(f"  {p['name']}: {json.dumps({k: round(v, 1) for k, v in p['phases_ms'].items()})}"
              f"; one-off robot build {p['setup_ms']:.0f} ms")
    print("slowest sample (share of the summed sample times):")
    for side in [tandem] + peers:
        ms, i, outcome = side["slowest"]
        print(f"  {side['name']}: id {i}, {ms:.0f} ms ({outcome}), {100 * ms / side['sum_ms']:.0f} %")
    result = {"load_before": load_before, "load_after": load_after, "tolerances": [t1, t2],
              "tandem": tandem, "peers": peers}
    path = os.path.join(os.path.dirname(os.path.abspath(out)), "generate_peers.json")
    with open(path, "w") as f:
        json.dump(result, f, indent=1)
    print(f"\nwritten: {path}")


if __name__ == "__main__":
    main()
