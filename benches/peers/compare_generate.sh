#!/usr/bin/env bash
# Bulk trajectory generation side by side: `tandem generate` (release, 1
# thread) and RAI (PyPI `robotic`: IK by KOMO, RRT_PathFinder, then KOMO;
# benches/peers/rai_generate.py, single-threaded) on the same N samples of
# problems/panda_grasp_family.toml (run seed S, horizon T = 50), one after the
# other in one run. Prints samples/s, accepted/s, acceptance, median
# per-sample time and the ratios tandem / RAI.
#
#   benches/peers/compare_generate.sh [--count N] [--seed S] [--tight] [--tandem-goals] [--table]
#
#   --count N        samples 0 … N−1 (default 100)
#   --seed S         run seed (default 0)
#   --tight          also run RAI's KOMO with stopTolerance 1e-4 (default options miss eq ≤ 1e-4)
#   --tandem-goals   also run RAI from tandem's IK goal configurations instead of its own IK
#   --table          only print the table of the last run's result files
#
# Same on both sides: the sampled problems (examples/family_export.rs writes
# what `ProblemFamily::sample(S, id)` gives tandem: start, box pose, random
# obstacles), the Panda's 61 collision spheres and the obstacles, the
# objectives, slices, horizon and duration, and the acceptance yardstick:
# every final trajectory of both sides is judged by the same tandem code
# (family_export --measure / --dataset): eq and ineq ≤ 1e-4
# (TrajectoryProblem::measure), collision-free between slices at 2 mrad and
# within limits (TrajectoryOptimizer::validate), q_T within 1 mm / 10 mrad of
# the grasp (tandem generate's goal check), plus the solver's own
# convergence (tandem: converged; RAI: feasible). Acceptance at 1e-3 is
# printed too.
# Differences (see rai_generate.py): RAI does not check the grasp target box
# against the arm (it cannot allow only the gripper's contact with it;
# tandem's yardstick still checks it); RAI's RRT aims at one IK goal, tandem's
# at up to 4 and shortcuts its path; RAI's collision term is its summed
# accumulatedCollisions with the margin built into the shapes; tandem
# re-solves when its result collides between slices, RAI does not; RAI's
# time excludes Python's start, the JSON loading and the family sampling
# (tandem's includes its sampling and writing Parquet).
# Timed: tandem — `tandem generate`'s own rate (samples / wall time of the
# run, family loading included), median of its per-sample times
# (_timings/*.csv), and the process's CPU time; RAI — the sum of its
# per-sample times (scene, goal, RRT, KOMO) plus the one-off robot build,
# median per-sample time, and the same in process CPU time. samples/CPU-s
# discounts the other load of a shared machine.
#
# Needs the peers' venv (benches/peers/setup_peers.sh). Writes
# target/peers/generate/ (samples/, tandem_dataset/, *.json) and
# target/peers/generate_peers.json.
# Env:
#   PEERS_VENV=path   the peers' venv (default: benches/peers/.venv)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
venv="${PEERS_VENV:-$here/.venv}"
die() { echo "${0##*/}: error: $*" >&2; exit 1; }

count=100 seed=0 tight=0 tandem_goals=0 table=0 horizon=50
family="problems/panda_grasp_family.toml"
while (( $# )); do
  case "$1" in
    --count) count="${2:?--count needs a value}"; shift 2 ;;
    --seed) seed="${2:?--seed needs a value}"; shift 2 ;;
    --tight) tight=1; shift ;;
    --tandem-goals) tandem_goals=1; shift ;;
    --table) table=1; shift ;;
    *) die "unknown argument $1 (see the usage at the top of $0)" ;;
  esac
done
[[ "$count" =~ ^[1-9][0-9]*$ ]] || die "--count must be a positive integer, got $count"
[[ "$seed" =~ ^[0-9]+$ ]] || die "--seed must be a non-negative integer, got $seed"
out="$repo/target/peers/generate"
if (( table )); then
  [[ -f "$out/load" ]] || die "no earlier run in $out"
  IFS='|' read -r load_before load_after <"$out/load"
  exec python3 "$here/generate_table.py" "$out" "$load_before" "$load_after"
fi
[[ -x "$venv/bin/python" ]] || die "no peers venv at $venv: run benches/peers/setup_peers.sh first"
# (from /tmp: importing robotic writes z.log.global into the working directory)
(cd /tmp && "$venv/bin/python" -c 'import robotic') >/dev/null 2>&1 \
  || die "robotic (RAI) missing from $venv or not importable: run benches/peers/setup_peers.sh (needs liblapack3)"

cd "$repo"
echo "== building tandem and examples/family_export.rs (release)" >&2
cargo build --release --bin tandem --example family_export >&2 || die "cargo build --release failed"
tandem="$repo/target/release/tandem"
export_bin="$repo/target/release/examples/family_export"
[[ -x "$tandem" && -x "$export_bin" ]] || die "release binaries missing after the build"

rm -rf "$out"
mkdir -p "$out"
echo "== exporting samples 0..$count of $family (seed $seed, T = $horizon)" >&2
"$export_bin" "$family" --count "$count" --seed "$seed" -T "$horizon" --out "$out/samples"

load_before="$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo '?')"
began=$SECONDS
echo "== tandem generate: $count samples, 1 thread" >&2
# bash's `time` adds the process's CPU time (user, system) to the summary.
TIMEFORMAT='cpu: %U user %S system'
{ time "$tandem" generate --family "$family" --count "$count" --seed "$seed" -T "$horizon" --threads 1 --quiet \
  --out "$out/tandem_dataset" >"$out/tandem_summary.txt"; } 2>>"$out/tandem_summary.txt" \
  || die "tandem generate failed: $(cat "$out/tandem_summary.txt")"
cat "$out/tandem_summary.txt" >&2
"$export_bin" "$family" --count "$count" --seed "$seed" -T "$horizon" --dataset "$out/tandem_dataset" \
  >"$out/tandem_measured.json"

rai() {  # rai LABEL ARGS...: one RAI run, then tandem's verdict on it
  local label="$1"; shift
  echo "== RAI ($label): $count samples, 1 thread" >&2
  (cd "$here" && OMP_NUM_THREADS=1 "$venv/bin/python" rai_generate.py "$out/samples" --count "$count" "$@") \
    >"$out/rai_$label.raw.json" || die "rai_generate.py ($label) failed"
  "$export_bin" "$family" --count "$count" --seed "$seed" -T "$horizon" --measure "$out/rai_$label.raw.json" \
    >"$out/rai_$label.json"
}
rai default
if (( tight )); then rai tight --komo-option stopTolerance=1e-4; fi
if (( tandem_goals )); then rai tandem_goals --goals tandem; fi
load_after="$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo '?')"
echo "$load_before|$load_after" >"$out/load"
echo "== done in $(( SECONDS - began )) s" >&2

python3 "$here/generate_table.py" "$out" "$load_before" "$load_after"
