#!/usr/bin/env bash
# Side-by-side kinematics speed: tandem (criterion, benches/kinematics.rs) and
# Pinocchio's C++ (benches/peers/pinocchio_kinematics.cpp) on the same Panda
# URDF (7 active joints, fingers fixed), measured in one run, with ratios
# tandem / Pinocchio (below 1.0 means tandem is faster).
#
#   benches/peers/compare_kinematics.sh [URDF] [FRAME]
#
# Defaults: problems/robots/panda/panda.urdf, panda_hand. Needs the Python
# reference environment (scripts/test.sh creates it) for Pinocchio's C++ libraries.
# Writes target/peers/kinematics.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
urdf="${1:-$repo/problems/robots/panda/panda.urdf}"
frame="${2:-panda_hand}"
cd "$repo"
mkdir -p target/peers

echo "== tandem (criterion)" >&2
cargo bench --bench kinematics -- --noplot --warm-up-time 2 --measurement-time 5 >&2
echo "== Pinocchio C++" >&2
"$here/run_pinocchio.sh" "$urdf" "$frame" --samples 100 > target/peers/pinocchio_kinematics.json

python3 - "$repo" <<'PY'
import json, sys, pathlib
repo = pathlib.Path(sys.argv[1])
def median(name):
    est = repo / "target/criterion/panda" / name / "new/estimates.json"
    return json.loads(est.read_text())["median"]["point_estimate"]
pin = json.loads((repo / "target/peers/pinocchio_kinematics.json").read_text())["results_ns"]
pairs = [
    ("fk_joints", "fk_joints", "forward kinematics (joint/body placements)"),
    ("fk_all_frames", "fk_all_frames", "FK + all frame placements (framesForwardKinematics)"),
    ("fk_frame_jacobian", "frame_jacobian_with_fk", "FK + frame pose + 6x7 Jacobian (computeFrameJacobian)"),
]
rows = []
print(f"{'operation':<55} {'tandem ns':>10} {'pinocchio ns':>13} {'ratio':>7}")
for ours, theirs, label in pairs:
    t, p = median(ours), pin[theirs]["median"]
    rows.append({"operation": ours, "tandem_ns": t, "pinocchio_op": theirs, "pinocchio_ns": p, "ratio": t / p})
    print(f"{label:<55} {t:>10.1f} {p:>13.1f} {t / p:>7.2f}")
(repo / "target/peers/kinematics.json").write_text(json.dumps(rows, indent=1))
PY
