#!/usr/bin/env bash
# Regenerates every published table and figure from the current binary.
#
#   scripts/reproduce.sh [--quick] [--check] [--bin PATH] [--only NAMES]
#
# Full (default): the dissertation's sizes. Each experiment's outputs go to
# docs/results/NAME/ (table.txt: what the command printed; its JSON; its
# figures); the published figures are copied to docs/figures/ and the
# tables in docs/experiments.md between `<!-- reproduce: NAME -->` and
# `<!-- /reproduce -->` are replaced by table.txt. The binary must be built
# with `--features mujoco` (reach-grasp-physics; MUJOCO_DYNAMIC_LINK_DIR as
# scripts/test.sh sets it). Sizes and times on a 2-core machine (release
# build): demo, figures, planar, reach-grasp and traded together take about
# 5 minutes, reach-grasp-physics about 9; learned trains four DDPG actors
# (about an hour); policy follows the shipped policy
# (policies/panda_grasp_family.safetensors; its provenance beside it says
# how it was trained) on 1000 tasks, alone and under shared control, in
# under a minute; policy-centred the same with sum-of-squares centred on
# the robot's action (--sos-center 0.5).
#
# --quick: small seeded versions of the same runs (seconds) into
# docs/results/quick/NAME/.
#
# --check (with --quick): runs the quick versions into a temporary
# directory and fails unless
#   1. their data equals the committed docs/results/quick/ (JSON and CSV,
#      timing fields dropped, numbers equal to 1e-9 relative), for the
#      runs that do not train a candle network (see below);
#   2. every figure renders (rsvg-convert) and renders to the same pixels
#      as its committed quick counterpart (compared after rendering, not
#      as SVG bytes);
#   3. docs/figures/*.svg are the files docs/results/ holds and every
#      reproduce block in docs/experiments.md is its table.txt.
# The runs that train a candle network (learned, traded's network
# predictor) and policy are rendered and checked for shape only: candle's
# matrix kernels, and the policy network's own (AVX-512, AVX2 or
# portable), choose their SIMD path by the CPU at run time, so their
# numbers are the same on one machine and not across machines (and traded
# charges the planning time it measures).
#
# Exit status: 0 reproduced (or check passed), 1 a run or a check failed,
# 2 usage error.
set -euo pipefail
cd "$(dirname "$0")/.."

quick=0 check=0 bin="" only=""
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    --check) check=1 ;;
    --bin) bin="${2:?--bin needs a path}"; shift ;;
    --only) only="${2:?--only needs a comma-separated list}"; shift ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) echo "error: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done
if [ "$check" = 1 ] && [ "$quick" = 0 ]; then
  echo "error: --check compares quick runs; use it with --quick" >&2; exit 2
fi
all="demo figures planar reach-grasp reach-grasp-physics traded learned policy policy-centred"
names=${only//,/ }
names=${names:-$all}
for n in $names; do
  case " $all " in *" $n "*) ;; *) echo "error: --only: unknown run '$n' (one of: $all)" >&2; exit 2 ;; esac
done

if [ -z "$bin" ]; then
  export MUJOCO_DYNAMIC_LINK_DIR=${MUJOCO_DYNAMIC_LINK_DIR:-$PWD/target/mujoco-lib}
  [ -e "$MUJOCO_DYNAMIC_LINK_DIR/libmujoco.so" ] || {
    echo "error: no libmujoco.so in MUJOCO_DYNAMIC_LINK_DIR ($MUJOCO_DYNAMIC_LINK_DIR): run scripts/test.sh once (it links PyPI mujoco 3.17's library there), or point the variable at that library's folder" >&2
    exit 1
  }
  echo "== cargo build --release --features mujoco --bin tandem"
  cargo build --release --quiet --features mujoco --bin tandem
  bin=target/release/tandem
fi
[ -x "$bin" ] || { echo "error: --bin: '$bin' is not an executable" >&2; exit 2; }
bin=$(realpath "$bin")
command -v rsvg-convert > /dev/null \
  || { echo "error: rsvg-convert is needed to render the figures (Debian: apt-get install librsvg2-bin)" >&2; exit 1; }

if [ "$check" = 1 ]; then
  root=$(mktemp -d "${TMPDIR:-/tmp}/tandem-reproduce.XXXXXX")
  trap 'rm -rf "$root"' EXIT
elif [ "$quick" = 1 ]; then
  root=docs/results/quick
else
  root=docs/results
fi

# One run: its directory emptied, the command's standard output in table.txt.
# Commands run from the repository's root and write into $out (the run's
# directory, set by the loop below).
run() {
  local name=$1; shift
  local dir=$out
  rm -rf "$dir"; mkdir -p "$dir"
  echo "== $name: $*"
  local start=$SECONDS
  "$@" > "$dir/table.txt" || { echo "error: '$name' failed ($*)" >&2; exit 1; }
  echo "   $((SECONDS - start)) s"
}

# The figures of the single-problem commands, one of each kind.
gallery() {
  local status=0
  "$bin" arbitrate builtin:panda_grasp_box --mode sos --plot "$out/arbitrate.svg" --field "$out/metric_field.svg" || status=$?
  "$bin" plan builtin:panda_reach_obstacle --svg "$out/plan.svg" || status=$?
  "$bin" solve builtin:panda_reach_obstacle --out "$out/solve" || status=$?
  "$bin" policy --time-varying --plot "$out/policy.svg" || status=$?
  # One 1 kHz episode's accelerations and jerks against the Panda's limits,
  # with the motion limits and without them (the commands before they existed).
  "$bin" arbitrate builtin:panda_grasp_box --mode sos --rate 1000 --motion-plot "$out/motion_limits.svg" || status=$?
  "$bin" arbitrate builtin:panda_grasp_box --mode sos --rate 1000 --no-motion-limits \
    --motion-plot "$out/motion_limits_off.svg" || status=$?
  return $status
}

for name in $names; do
  out="$root/$name"
  if [ "$quick" = 1 ]; then
    case $name in
      demo) run demo "$bin" demo --out "$out" ;;
      figures) run figures gallery ;;
      planar) run planar "$bin" experiment planar --tasks 8 --out "$out" ;;
      reach-grasp) run reach-grasp "$bin" experiment reach-grasp --tasks 4 --out "$out" ;;
      reach-grasp-physics) run reach-grasp-physics "$bin" experiment reach-grasp --physics mujoco --tasks 1 --out "$out" ;;
      traded) run traded "$bin" experiment traded --episodes 2 --training 5 --out "$out" ;;
      learned) run learned "$bin" experiment learned --episodes 2 --train-episodes 3 --train-seeds 1 --out "$out" ;;
      policy) run policy "$bin" experiment policy --tasks 10 --arbitration-tasks 1 --out "$out" ;;
      policy-centred) run policy-centred "$bin" experiment policy --tasks 10 --arbitration-tasks 10 --sos-center 0.5 --out "$out" ;;
    esac
  else
    case $name in
      demo) run demo "$bin" demo --out "$out" ;;
      figures) run figures gallery ;;
      planar) run planar "$bin" experiment planar --out "$out" ;;
      reach-grasp) run reach-grasp "$bin" experiment reach-grasp --out "$out" ;;
      reach-grasp-physics) run reach-grasp-physics "$bin" experiment reach-grasp --physics mujoco --out "$out" ;;
      traded) run traded "$bin" experiment traded --out "$out" ;;
      learned) run learned "$bin" experiment learned --out "$out" ;;
      policy) run policy "$bin" experiment policy --tasks 1000 --arbitration-tasks 1000 --out "$out" ;;
      policy-centred) run policy-centred "$bin" experiment policy --tasks 1000 --arbitration-tasks 1000 --sos-center 0.5 --out "$out" ;;
    esac
  fi
  # Episode recordings, generated datasets and trained weights are data for
  # analysis, not published results.
  find "$root/$name" \( -name episodes -o -name '*.safetensors' -o -name '*.parquet' \) -prune -exec rm -rf {} +
  rm -rf "$root/$name/data"
done

python=python3
[ -x python_ref/.venv/bin/python ] && python=python_ref/.venv/bin/python
if [ "$check" = 1 ]; then
  "$python" scripts/reproduce_check.py --new "$root" --committed docs/results/quick --published docs
  exit
fi
if [ "$quick" = 0 ]; then
  "$python" scripts/reproduce_check.py --publish docs
fi
echo "== done: $root"
