"""The table of benches/peers/compare_komo.sh, from the measured result files.

    python3 komo_table.py OUT_DIR LOAD_BEFORE LOAD_AFTER "PROBLEMS" "HORIZONS" "SOLVERS"

OUT_DIR holds <problem>_T<T>_<solver>.json (each solver's runs, measured by
`komo_seeds --measure`); prints the table and writes OUT_DIR/../komo.json.
"""

import json
import pathlib
import platform
import statistics
import sys

LABEL = {"tandem": "tandem", "rai": "RAI", "rai_gtol": "RAI gtol", "ipopt_near": "IPOPT near",
         "ipopt_all": "IPOPT all"}

LEGEND = """
median ms: median wall time of one solve over all initialisations x repetitions (tandem: as
solve_problem, from a cold start: optimize, validate at 0.002 rad, re-solve with collision rows
between slices if the motion between slices collides; RAI: NLP_Solver.solve() on a freshly built KOMO;
IPOPT: the nlpsol call(s), casadi graph and solver construction excluded; '>' = stopped by the time
limit). cpu ms: the same in process CPU time. opt ms: the optimization alone (tandem: its first solve,
without validation and re-solves; peers: = median ms). ratio: median ms / tandem's median ms;
ratio opt: opt ms / tandem's opt ms. success: converged (tandem: Converged; RAI: feasible; IPOPT:
Solve_Succeeded) AND max eq, max ineq <= 1e-4 by tandem's yardstick AND collision-free between slices
at 0.002 rad AND within the joint limits, per initialisation. conv: the solver's own verdict.
coll-free: validate() collision-free. cost: median over initialisations of tandem's measured cost (sum
of squared scaled accelerations); max eq / max ineq: worst over initialisations, tandem's measure
(ineq includes margin - d for every checked pair: 5e-3 with a 5 mm margin means touching).
RAI: default NLP_Solver options; RAI gtol: stopGTolerance 1e-4. IPOPT near: collision rows only for
pairs within margin + 0.1 m at the start point, solved again with more rows while a left-out pair is
violated; IPOPT all: one row per checked pair and slice (first initialisation(s) only, time limit)."""


def fmt(x, spec):
    return "-" if x is None else format(x, spec)


def worst(runs, key):
    values = [run[key] for run in runs if run.get(key) is not None]
    return max(values) if values else None


def row(p, T, s, x, t, t_opt):
    runs = x["runs"]
    n = len(runs)
    timeout = any(run.get("status") == "process_timeout" for run in runs)
    opt = x.get("median_solve_ms", x["median_ms"])
    x["ratio"] = x["median_ms"] / t
    x["ratio_opt"] = opt / t_opt
    costs = [run["cost"] for run in runs if run.get("cost") is not None]
    more = ">" if timeout else ""
    return (f"{p if s == 'tandem' else '':<21} {T if s == 'tandem' else '':>3} {LABEL[s]:<10} "
            f"{more + format(x['median_ms'], '.2f'):>10} {fmt(x.get('median_cpu_ms'), '.2f'):>9} "
            f"{more + format(opt, '.2f'):>9} {more + format(x['ratio'], '.1f'):>7} "
            f"{more + format(x['ratio_opt'], '.1f'):>9} "
            f"{x.get('successes', 0):>3}/{n:<3} {sum(bool(run['converged']) for run in runs):>3}/{n:<1} "
            f"{sum(bool(run.get('collision_free')) for run in runs):>5}/{n:<3} "
            f"{fmt(statistics.median(costs) if costs else None, '.4g'):>8} "
            f"{fmt(worst(runs, 'eq'), '.1e'):>8} {fmt(worst(runs, 'ineq'), '.1e'):>8}")


def notes(r):
    out = []
    pairs = r.get("rai", {}).get("pairs", {})
    if pairs.get("only_tandem"):
        out.append(f"RAI does not check {sum(pairs['only_tandem'].values())} of tandem's {pairs['tandem']} pairs "
                   f"({', '.join(pairs['only_tandem'])}); tandem's yardstick does")
    for s in ("ipopt_near", "ipopt_all"):
        x = r.get(s)
        if not x:
            continue
        if "timeout_s" in x:
            out.append(f"{LABEL[s]}: stopped after {x['timeout_s']:.0f} s (IPOPT's own limit is checked between "
                       f"iterations only)")
            continue
        runs = x["runs"]
        rounds = [run.get("rounds", 1) for run in runs]
        out.append(f"{LABEL[s]}: {x['variables']} variables, collision rows "
                   f"{statistics.median(run['collision_rows'] for run in runs):.0f} of {x['collision_rows_all']}, "
                   f"rounds {min(rounds)}-{max(rounds)}, iterations "
                   f"{statistics.median(run['iterations'] for run in runs):.0f}, statuses "
                   f"{sorted({run['status'] for run in runs})}, solver build {x['build_s']:.1f} s (not timed)")
    for s in ("rai", "rai_gtol"):
        if s in r:
            runs = r[s]["runs"]
            out.append(f"{LABEL[s]}: evaluations {statistics.median(run['evaluations'] for run in runs):.0f}, "
                       f"min distance {min(run['min_distance'] for run in runs) * 1e3:.2f} mm")
    t = r["tandem"]["runs"]
    out.append(f"tandem: re-solves with rows between slices {sum(run['resolves'] > 0 for run in t)}/{len(t)}, "
               f"outer {statistics.median(run['outer_iterations'] for run in t):.0f}, "
               f"inner steps {statistics.median(run['inner_steps'] for run in t):.0f}, "
               f"evaluations {statistics.median(run['evaluations'] for run in t):.0f}, "
               f"min distance {min(run['min_distance'] for run in t) * 1e3:.2f} mm")
    return out


def main():
    out = pathlib.Path(sys.argv[1])
    load_before, load_after = sys.argv[2], sys.argv[3]
    problems, horizons, solvers = sys.argv[4].split(), [int(t) for t in sys.argv[5].split()], sys.argv[6].split()
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name")),
               platform.processor())
    print(f"CPU: {cpu}; load average before {load_before}, after {load_after}")
    head = (f"{'problem':<21} {'T':>3} {'solver':<10} {'median ms':>10} {'cpu ms':>9} {'opt ms':>9} {'ratio':>7} "
            f"{'ratio opt':>9} {'success':>7} {'conv':>5} {'coll-free':>9} {'cost':>8} {'max eq':>8} {'max ineq':>8}")
    print(head)
    print("-" * len(head))
    results = {}
    for p in problems:
        for T in horizons:
            r = {s: json.loads((out / f"{p}_T{T}_{s}.json").read_text()) for s in solvers}
            results[f"{p}_T{T}"] = r
            t, t_opt = r["tandem"]["median_ms"], r["tandem"]["median_solve_ms"]
            for s in solvers:
                print(row(p, T, s, r[s], t, t_opt))
    print(LEGEND)
    for key, r in results.items():
        print(f"\n{key}:\n  " + "\n  ".join(notes(r)))
    summary = {k: {s: {kk: vv for kk, vv in x.items() if kk != "runs"}
                   | {"runs": [{kk: vv for kk, vv in run.items() if kk != "trajectory"} for run in x["runs"]]}
                   for s, x in r.items()} for k, r in results.items()}
    (out.parent / "komo.json").write_text(json.dumps(
        {"cpu": cpu, "load_before": load_before, "load_after": load_after, "results": summary}, indent=1))
    print(f"\nwritten: {out.parent / 'komo.json'}")


if __name__ == "__main__":
    main()
