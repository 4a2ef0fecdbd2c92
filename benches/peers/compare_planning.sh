#!/usr/bin/env bash
# Side-by-side RRT-Connect planning: tandem (examples/plan_seeds.rs), RAI's
# RRT_PathFinder (benches/peers/rai_plan.py) and OMPL's RRTConnect
# (benches/peers/ompl_plan.py) on problems/panda_reach_obstacle.toml and
# problems/panda_grasp_box.toml, each for the same number of seeds, one after
# the other in one run, with the same geometry: the Panda's 61 collision
# spheres from its URDF, padded by the planner clearance as in tandem's
# search, the same obstacles, the same checked pairs, start and joint goals
# (IK solutions for the grasp goal, from tandem), and the same edge-validation
# resolution where the peer allows it. Prints a table with the ratios
# peer median / tandem median (above 1 means tandem is faster).
#
#   benches/peers/compare_planning.sh [--seeds N]     (default 50)
#
# Needs the peers' venv (benches/peers/setup_peers.sh creates it; RAI needs
# Debian's liblapack3). Writes target/peers/plan_<problem>.json (the scene
# the peers read), target/peers/plan_<problem>_{tandem,rai,ompl}.json and
# target/peers/planning.json (all results).
# Env:
#   PEERS_VENV=path   the peers' venv (default: benches/peers/.venv)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
venv="${PEERS_VENV:-$here/.venv}"
die() { echo "${0##*/}: error: $*" >&2; exit 1; }

seeds=50
while (( $# )); do
  case "$1" in
    --seeds) seeds="${2:?--seeds needs a value}"; shift 2 ;;
    *) die "unknown argument $1 (usage: compare_planning.sh [--seeds N])" ;;
  esac
done
[[ "$seeds" =~ ^[1-9][0-9]*$ ]] || die "--seeds must be a positive integer, got $seeds"
[[ -x "$venv/bin/python" ]] || die "no peers venv at $venv: run benches/peers/setup_peers.sh first"

cd "$repo"
out="$repo/target/peers"
mkdir -p "$out"
echo "== building examples/plan_seeds.rs (release)" >&2
cargo build --release --example plan_seeds >&2
tandem="$repo/target/release/examples/plan_seeds"

problems=(panda_reach_obstacle panda_grasp_box)
load_before="$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo '?')"
for p in "${problems[@]}"; do
  scene="$out/plan_$p.json"
  echo "== $p: tandem ($seeds seeds)" >&2
  "$tandem" "problems/$p.toml" --seeds "$seeds" --scene "$scene" >"$out/plan_${p}_tandem.json"
  echo "== $p: RAI RRT_PathFinder ($seeds seeds)" >&2
  (cd "$here" && "$venv/bin/python" rai_plan.py "$scene" --seeds "$seeds") >"$out/plan_${p}_rai.json"
  echo "== $p: OMPL RRTConnect ($seeds seeds)" >&2
  (cd "$here" && "$venv/bin/python" ompl_plan.py "$scene" --seeds "$seeds" --also-max) >"$out/plan_${p}_ompl.json"
done
load_after="$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo '?')"

python3 - "$out" "$load_before" "$load_after" "${problems[@]}" <<'PY'
import json, pathlib, platform, sys

out = pathlib.Path(sys.argv[1])
load_before, load_after, problems = sys.argv[2], sys.argv[3], sys.argv[4:]
cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), platform.processor())

def f(x, digits=1):
    return "-" if x is None else f"{x:.{digits}f}"

rows, results = [], {}
print(f"CPU: {cpu}; load average before {load_before}, after {load_after}")
head = (f"{'problem':<21} {'planner':<7} {'solved':>7} {'plan ms':>8} {'simpl ms':>9} {'total ms':>9} "
        f"{'p95 ms':>8} {'cpu ms':>8} {'plan ratio':>10} {'total ratio':>11} {'cpu ratio':>9} {'check us':>9}")
print(head)
print("-" * len(head))
for p in problems:
    scene = json.loads((out / f"plan_{p}.json").read_text())
    r = {k: json.loads((out / f"plan_{p}_{k}.json").read_text()) for k in ("tandem", "rai", "ompl")}
    r["tandem"]["check_us"] = scene["tandem_check_ns"] / 1e3
    results[p] = r
    t = r["tandem"]
    for key, label in (("tandem", "tandem"), ("rai", "RAI"), ("ompl", "OMPL")):
        x = r[key]
        total = x["median_ms"]
        plan = x["median_planning_ms"]
        x["ratio_planning"] = plan / t["median_planning_ms"]
        x["ratio_total"] = total / t["median_ms"]
        x["ratio_cpu"] = x["median_cpu_ms"] / t["median_cpu_ms"]
        print(f"{p if key == 'tandem' else '':<21} {label:<7} {x['solved']:>3}/{x['seeds']:<3} {f(plan, 2):>8} "
              f"{f(x['median_simplify_ms'], 2):>9} {f(total, 2):>9} {f(x['p95_ms'], 2):>8} "
              f"{f(x['median_cpu_ms'], 2):>8} {f(x['ratio_planning']):>10} {f(x['ratio_total']):>11} "
              f"{f(x['ratio_cpu']):>9} {f(x['check_us'], 2):>9}")
print("""
plan ms: median search time (tandem: RRT-Connect incl. reruns after a failed certification; RAI: solve();
OMPL: RRTConnect.solve()). simpl ms: median simplification (tandem: greedy + 100 random shortcuts +
certified clearance check of every edge; RAI: none, its RRT returns the raw tree path; OMPL:
PathSimplifier.reduceVertices until no progress). total ms: median of search + simplification, per run
(wall clock); cpu ms: the same runs in process CPU time, which a busy machine inflates less.
Ratios: peer median / tandem median (plan: search only; total and cpu: with simplification, RAI has none).
check us: one collision check of one configuration, median over the scene's random configurations
(tandem: CollisionModel::collision_free; RAI: setJointState + coll_totalViolation through Python;
OMPL: Pinocchio computeCollisions over coal's broad phase through Python).""")
for p in problems:
    r = results[p]
    rai, ompl = r["rai"], r["ompl"]
    print(f"\n{p}:")
    print(f"  tandem: step {r['tandem']['step']} rad, resolution {r['tandem']['resolution']} rad (max norm), "
          f"clearance {r['tandem']['clearance']} m; median {r['tandem']['median_iterations']:.0f} iterations, "
          f"{r['tandem']['certified']}/{r['tandem']['seeds']} certified, {r['tandem']['runs']} searches")
    print(f"  RAI: stepsize {rai['stepsize']} rad, {rai['subsamples']} checks per step "
          f"(resolution {rai['resolution']:.4f} rad, Euclidean), goal {rai['goal']} of {rai['goals_available']}, "
          f"median {f(rai['median_queries'], 0)} queries = {f(rai['check_us_in_planner'])} us per query in the planner; "
          f"validity agrees with tandem on {rai['agreement'][0]}/{rai['agreement'][1]} configurations; "
          f"pairs {rai['pairs']['rai']} vs tandem {rai['pairs']['tandem']}"
          + (f", not checked by RAI: {rai['pairs']['only_tandem']}" if rai['pairs']['only_tandem'] else "")
          + (f", extra in RAI: {rai['pairs']['only_rai']}" if rai['pairs']['only_rai'] else ""))
    print(f"  OMPL: range {ompl['range']} rad, resolution {ompl['resolution']} rad ({ompl['resolution_norm']} norm), "
          f"{ompl['goals']} goal state(s), median {f(ompl['median_checks'], 0)} checks = "
          f"{f(ompl['check_us_in_planner'])} us per check in the planner; simplifyMax instead of reduceVertices: "
          f"median {f(ompl['median_simplify_max_ms'])} ms; validity agrees with tandem on "
          f"{ompl['agreement'][0]}/{ompl['agreement'][1]} configurations, the same {ompl['pairs']} pairs")
(out / "planning.json").write_text(json.dumps(
    {"cpu": cpu, "load_before": load_before, "load_after": load_after, "results": results}, indent=1))
print(f"\nwritten: {out / 'planning.json'}")
PY
