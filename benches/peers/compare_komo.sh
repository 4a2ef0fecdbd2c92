#!/usr/bin/env bash
# Side-by-side trajectory optimization: tandem (examples/komo_seeds.rs), RAI's
# KOMO (benches/peers/rai_komo.py) and casadi + IPOPT (benches/peers/casadi_komo.py)
# on problems/panda_reach.toml, panda_reach_obstacle.toml and panda_grasp_box.toml
# at T = 20 and T = 50, one after the other in one run, on the same problem:
# the Panda's 61 collision spheres from its URDF, the same obstacles and checked
# pairs, the same objectives (feature, slices, kind, scale, target, order), the
# same start, horizon and duration, and the same initialisations (K RRT-Connect
# paths from tandem, resampled to T). Every solver's final trajectory is measured
# by tandem's yardstick (TrajectoryProblem::measure: cost, max equality and
# inequality violation; TrajectoryOptimizer::validate: collisions between slices
# at 0.002 rad, joint limits). Prints a table with the ratios
# peer median time / tandem median time (above 1 means tandem is faster).
#
#   benches/peers/compare_komo.sh [--inits K] [--reps R] [--ipopt-reps R] [--ipopt-all-inits N] [--quick]
#
#   --inits K            RRT-Connect initialisations per problem and T (default 5)
#   --reps R             timed solves per initialisation for tandem and RAI (default 10)
#   --ipopt-reps R       timed solves per initialisation for IPOPT (default 1)
#   --ipopt-all-inits N  initialisations for IPOPT with every pair (the slow one; default 1)
#   --quick              skip IPOPT with every pair
#   --table              only print the table of the last run's result files
#
# Needs the peers' venv (benches/peers/setup_peers.sh; RAI needs Debian's
# liblapack3). Writes target/peers/komo/<problem>_T<T>.json (the problem the
# peers read), target/peers/komo/<problem>_T<T>_<solver>.json (each solver's
# runs, measured) and target/peers/komo.json (all results).
# Env:
#   PEERS_VENV=path      the peers' venv (default: benches/peers/.venv)
#   IPOPT_ALL_LIMIT=600  seconds allowed to IPOPT with every pair per problem and T (then: timeout)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
venv="${PEERS_VENV:-$here/.venv}"
die() { echo "${0##*/}: error: $*" >&2; exit 1; }

inits=5 reps=10 ipopt_reps=1 ipopt_all_inits=1 quick=0 table=0 limit="${IPOPT_ALL_LIMIT:-600}"
while (( $# )); do
  case "$1" in
    --inits) inits="${2:?--inits needs a value}"; shift 2 ;;
    --reps) reps="${2:?--reps needs a value}"; shift 2 ;;
    --ipopt-reps) ipopt_reps="${2:?--ipopt-reps needs a value}"; shift 2 ;;
    --ipopt-all-inits) ipopt_all_inits="${2:?--ipopt-all-inits needs a value}"; shift 2 ;;
    --quick) quick=1; shift ;;
    --table) table=1; shift ;;
    *) die "unknown argument $1 (see the usage at the top of $0)" ;;
  esac
done
for v in "$inits" "$reps" "$ipopt_reps" "$ipopt_all_inits"; do
  [[ "$v" =~ ^[1-9][0-9]*$ ]] || die "counts must be positive integers, got $v"
done
problems=(panda_reach panda_reach_obstacle panda_grasp_box)
horizons=(20 50)
solvers=(tandem rai rai_gtol ipopt_near)
(( quick )) || solvers+=(ipopt_all)
out="$repo/target/peers/komo"
if (( table )); then
  [[ -f "$out/panda_reach_T20_ipopt_all.json" ]] || solvers=(tandem rai rai_gtol ipopt_near)
  load_before='?' load_after='?'
  [[ -f "$out/load" ]] && IFS='|' read -r load_before load_after <"$out/load"
  exec python3 "$here/komo_table.py" "$out" "$load_before" "$load_after" "${problems[*]}" "${horizons[*]}" \
    "${solvers[*]}"
fi
[[ -x "$venv/bin/python" ]] || die "no peers venv at $venv: run benches/peers/setup_peers.sh first"
"$venv/bin/python" -c 'import casadi' 2>/dev/null || die "casadi missing from $venv: run benches/peers/setup_peers.sh"

cd "$repo"
mkdir -p "$out"
echo "== building examples/komo_seeds.rs (release)" >&2
cargo build --release --example komo_seeds >&2
tandem="$repo/target/release/examples/komo_seeds"

load_before="$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo '?')"
began=$SECONDS
for p in "${problems[@]}"; do
  for T in "${horizons[@]}"; do
    base="$out/${p}_T$T"
    echo "== $p, T = $T: tandem ($inits initialisations x $reps)" >&2
    "$tandem" "problems/$p.toml" --horizon "$T" --inits "$inits" --reps "$reps" --export "$base.json" \
      >"${base}_tandem.json"
    measure() {  # measure SOLVER: tandem's yardstick on the peer's raw result
      "$tandem" "problems/$p.toml" --horizon "$T" --measure "${base}_$1.raw.json" >"${base}_$1.json"
    }
    echo "== $p, T = $T: RAI KOMO, default options" >&2
    (cd "$here" && "$venv/bin/python" rai_komo.py "$base.json" --reps "$reps") >"${base}_rai.raw.json"
    measure rai
    echo "== $p, T = $T: RAI KOMO, stopGTolerance 1e-4" >&2
    (cd "$here" && "$venv/bin/python" rai_komo.py "$base.json" --reps "$reps" --stop-g-tolerance 1e-4 \
      --label "RAI KOMO (stopGTolerance 1e-4)") >"${base}_rai_gtol.raw.json"
    measure rai_gtol
    echo "== $p, T = $T: casadi + IPOPT, pairs within margin + 0.1 m, re-solved when needed" >&2
    (cd "$here" && "$venv/bin/python" casadi_komo.py "$base.json" --reps "$ipopt_reps" --cutoff 0.1) \
      >"${base}_ipopt_near.raw.json"
    measure ipopt_near
    if (( ! quick )); then
      echo "== $p, T = $T: casadi + IPOPT, every pair ($ipopt_all_inits initialisation(s), ${limit} s limit)" >&2
      # IPOPT checks its own time limit between iterations only, and one
      # iteration can take many minutes here: a hard limit on the process.
      if ! (cd "$here" && timeout "$limit" "$venv/bin/python" casadi_komo.py "$base.json" --reps "$ipopt_reps" \
        --max-inits "$ipopt_all_inits" --max-wall-time "$limit") >"${base}_ipopt_all.raw.json"; then
        echo "   (stopped after $limit s)" >&2
        python3 -c 'import json, sys; print(json.dumps({"solver": "casadi + IPOPT", "timeout_s": float(sys.argv[1]),
          "median_ms": 1e3 * float(sys.argv[1]), "runs": [{"init": 0, "times_ms": [1e3 * float(sys.argv[1])],
          "converged": False, "status": "process_timeout", "iterations": None, "collision_rows": None}]}))' \
          "$limit" >"${base}_ipopt_all.raw.json"
      fi
      measure ipopt_all
    fi
  done
done
load_after="$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo '?')"
echo "$load_before|$load_after" >"$out/load"
echo "== done in $(( SECONDS - began )) s" >&2

python3 "$here/komo_table.py" "$out" "$load_before" "$load_after" "${problems[*]}" "${horizons[*]}" "${solvers[*]}"
