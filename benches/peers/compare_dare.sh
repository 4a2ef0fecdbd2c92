#!/usr/bin/env bash
# Side-by-side DARE speed: tandem (criterion, solvers/benches/dare.rs) and
# scipy.linalg.solve_discrete_are (benches/peers/scipy_dare.py) on the same
# matrices, measured in one run, with ratios scipy / tandem (how many times
# faster tandem is).
#
#   benches/peers/compare_dare.sh
#
# Cases: dare/n4_m2 and dare/n30_m10 (seeded random stabilisable systems),
# dare/n14_m7 (the Panda's per-joint double integrator, solved as seven
# decoupled joints), dare/n14_m7_dense (the same as one 14-state system) and
# their warm starts from a nearby P (dare/n14_m7_warm, dare/n14_m7_dense_warm;
# scipy has no warm start, so its time is a cold solve of the same matrices). The criterion bench
# writes the matrices to target/peers/dare_cases.json; the peer reads them.
# Needs the Python reference environment (scripts/test.sh creates it), or
# TANDEM_PYTHON pointing to a Python with numpy and scipy.
# Writes target/peers/dare.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
python="${TANDEM_PYTHON:-$repo/python_ref/.venv/bin/python}"
[ -x "$python" ] || { echo "error: $python not found; run scripts/test.sh (or set TANDEM_PYTHON)" >&2; exit 1; }
cd "$repo"
mkdir -p target/peers

echo "== tandem (criterion)" >&2
cargo bench -p tandem-solvers --bench dare -- --noplot >&2
echo "== scipy" >&2
"$python" "$here/scipy_dare.py" target/peers/dare_cases.json > target/peers/scipy_dare.json

"$python" - "$repo" <<'PY'
import json, sys, pathlib
repo = pathlib.Path(sys.argv[1])
peer = json.loads((repo / "target/peers/scipy_dare.json").read_text())
labels = {
    "n4_m2": "random stabilisable, n = 4, m = 2",
    "n14_m7": "Panda double integrator, n = 14, m = 7",
    "n14_m7_dense": "  the same, dense (no decoupling)",
    "n14_m7_warm": "  the same, warm start",
    "n14_m7_dense_warm": "  the same, dense, warm start",
    "n30_m10": "random stabilisable, n = 30, m = 10",
}
rows = []
print(f"{'case':<42} {'tandem µs':>10} {'scipy µs':>10} {'scipy/tandem':>13}")
for name, label in labels.items():
    est = repo / "target/criterion/dare" / name / "new/estimates.json"
    t = json.loads(est.read_text())["median"]["point_estimate"] / 1000.0
    s = peer["results_us"][name]["median"]
    rows.append({"case": name, "tandem_us": t, "scipy_us": s, "speedup": s / t})
    print(f"{label:<42} {t:>10.1f} {s:>10.1f} {s / t:>13.1f}")
print(f"(scipy {peer['scipy_version']}, single-threaded BLAS; medians)")
out = {"scipy_version": peer["scipy_version"], "results": rows}
(repo / "target/peers/dare.json").write_text(json.dumps(out, indent=1))
PY
