#!/usr/bin/env bash
# Side-by-side registration speed on the same points: tandem's rigid CPD
# and point-to-plane ICP (benches/perception.rs, release) against pycpd and
# small_gicp (benches/peers/registration_peers.py), one problem per Table
# 7.1 object on the grasp table, with ratios peer / tandem (how many times
# faster tandem is). CPD: 40 EM steps, 300 × 200 points, scale estimated
# (pycpd always estimates it). ICP: the segment onto 8,000 model samples,
# at most 50 iterations, both stopping at a step under 1e-8 (rad and m).
#
#   benches/peers/compare_registration.sh [--quick]
#
# Needs the Python reference environment (scripts/test.sh creates it), or
# TANDEM_PYTHON pointing to a Python with pycpd and small_gicp; MuJoCo's
# library as scripts/test.sh prepares it (MUJOCO_DYNAMIC_LINK_DIR).
# Writes target/peers/perception.json and target/peers/registration.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
python="${TANDEM_PYTHON:-$repo/python_ref/.venv/bin/python}"
[ -x "$python" ] || { echo "error: $python not found; run scripts/test.sh (or set TANDEM_PYTHON)" >&2; exit 1; }
export MUJOCO_DYNAMIC_LINK_DIR="${MUJOCO_DYNAMIC_LINK_DIR:-$repo/target/mujoco-lib}"
quick=()
runs=10
if [ "${1:-}" = "--quick" ]; then quick=(--quick); runs=2; fi
cd "$repo"
mkdir -p target/peers
echo "== tandem (benches/perception.rs)" >&2
cargo bench --features mujoco --bench perception -- "${quick[@]}" --json target/peers/perception.json \
  --cases target/peers/registration_cases.json >&2
echo "== pycpd, small_gicp" >&2
"$python" "$here/registration_peers.py" target/peers/registration_cases.json "$runs" > target/peers/registration.json
"$python" - "$repo" <<'PY'
import json, sys, pathlib
repo = pathlib.Path(sys.argv[1])
r = json.loads((repo / "target/peers/registration.json").read_text())
print(f"pycpd {r['pycpd_version']}, small_gicp {r['small_gicp_version']}; median ms")
print(f"{'object':<10} {'CPD tandem':>11} {'pycpd':>9} {'ratio':>7} {'ICP tandem':>11} {'small_gicp':>11} {'ratio':>7}")
for c in r["cases"]:
    print(f"{c['object']:<10} {c['tandem_cpd_ms']:>11.2f} {c['cpd_ms']:>9.2f} {c['cpd_ms'] / c['tandem_cpd_ms']:>7.1f} "
          f"{c['tandem_icp_ms']:>11.2f} {c['icp_ms']:>11.2f} {c['icp_ms'] / c['tandem_icp_ms']:>7.2f}")
PY
