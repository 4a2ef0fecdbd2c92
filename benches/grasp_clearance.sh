#!/usr/bin/env bash
# Generated grasps checked with real meshes: `tandem generate` on
# problems/panda_grasp_family.toml (T = 50), then python_ref/grasp_mesh_check.py
# on the final slice of every accepted trajectory — example-robot-data's Panda
# collision meshes placed by Pinocchio, measured against the box with coal.
# Prints the worst clearances of the hand, the fingers' outer parts, the arm
# and the pads at the final slice and over every slice of the motion, the
# largest tilt and the failures (box not between the pads, fingertip centre
# outside the footprint, a clearance below the margin at any slice; the pads
# may come close during the motion); exits 1 when a grasp fails.
#
#   benches/grasp_clearance.sh [--count N] [--seed S] [--threads K] [--margin M]
#
#   --count N    family samples (default 1200, for at least 1000 accepted grasps)
#   --margin M   clearance the hand and fingers must keep (m, default 0.005)
#
# Writes target/peers/grasp_clearance.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/.." && pwd)"
die() { echo "${0##*/}: error: $*" >&2; exit 1; }
count=1200 seed=0 threads="$(nproc)" margin=0.005
while (( $# )); do
  case "$1" in
    --count) count="${2:?--count needs a value}"; shift 2 ;;
    --seed) seed="${2:?--seed needs a value}"; shift 2 ;;
    --threads) threads="${2:?--threads needs a value}"; shift 2 ;;
    --margin) margin="${2:?--margin needs a value}"; shift 2 ;;
    *) die "unknown argument $1 (see the usage at the top of $0)" ;;
  esac
done
python="${TANDEM_PYTHON:-$repo/python_ref/.venv/bin/python}"
[[ -x "$python" ]] || die "no reference Python at $python (scripts/test.sh creates python_ref/.venv)"
cd "$repo"
cargo build --release --quiet
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
echo "== tandem generate: $count samples, seed $seed, $threads threads" >&2
target/release/tandem generate --family problems/panda_grasp_family.toml --count "$count" -T 50 \
  --seed "$seed" --threads "$threads" --out "$work/data" --quiet --json >"$work/generate.json"
echo "== mesh check of every accepted grasp" >&2
status=0
"$python" python_ref/grasp_mesh_check.py --dataset "$work/data" --object box --margin "$margin" --slices all \
  >"$work/check.json" || status=$?
mkdir -p target/peers
python3 - "$work/generate.json" "$work/check.json" "$margin" <<'PY'
import json, sys
gen, check, margin = json.load(open(sys.argv[1])), json.load(open(sys.argv[2])), float(sys.argv[3])
w = check["worst"]
print(f"{gen['accepted']} accepted of {gen['accepted'] + sum(gen['rejected_by_reason'].values())} samples; "
      f"rejected by reason: {gen['rejected_by_reason']}")
print(f"mesh check (coal {check['coal_version']}) of {check['count']} grasps, margin {margin * 1e3:g} mm:")
print(f"  worst clearance to the box: hand {w['hand'] * 1e3:.2f} mm, fingers' outer parts "
      f"{w['finger_outer'] * 1e3:.2f} mm, arm {w['arm'] * 1e3:.2f} mm, pads {w['pad'] * 1e3:.2f} mm; "
      f"largest tilt {w['tilt'] * 1e3:.3f} mrad")
m = check["worst_motion"]
print(f"  over all {check['configurations']} slices of the motions: hand {m['hand'] * 1e3:.2f} mm, fingers' outer "
      f"parts {m['finger_outer'] * 1e3:.2f} mm, arm {m['arm'] * 1e3:.2f} mm, pads {m['pad'] * 1e3:.2f} mm; "
      f"failed {w['failed']}")
for g in check.get("failed_grasps", [])[:20]:
    print("  FAILED", g)
json.dump({"generate": gen, "check": check, "margin": margin},
          open("target/peers/grasp_clearance.json", "w"), indent=1)
PY
exit "$status"
