#!/usr/bin/env bash
# Side-by-side safety filter: tandem's full arbitration tick (criterion,
# benches/arbitration.rs) against the Python Clarabel and OSQP solving the
# same QPs tandem built (every joint-limit, velocity-limit and distance row
# of each tick of a recorded Panda grasp episode; benches/peers/qp_peer.py).
# The peers only solve; tandem's tick also validates, estimates intent,
# queries the policy, computes distances, solves and certifies the step.
#
#   benches/peers/compare_arbitration.sh
#
# (cbfpy, the JAX CBF-QP filter, needs its barriers as JAX functions of the
# state; tandem's distances come from its collision model, so the peer here
# is the solver the filter reduces to, on identical data.)
# Creates benches/peers/.venv-qp (clarabel, osqp, numpy, scipy from PyPI).
# Writes target/peers/arbitration.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
venv="$here/.venv-qp"
cd "$repo"
mkdir -p target/peers
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet clarabel==0.11.1 osqp==1.1.3 numpy==2.4.6 scipy==1.17.1
fi
features=""
command -v cmake >/dev/null && features="--features osqp" && export CMAKE_POLICY_VERSION_MINIMUM=3.5
echo "== tandem: exporting the episode's QPs" >&2
TANDEM_EXPORT_QP="$repo/target/peers/arbitration_qps.json" cargo bench --bench arbitration $features >&2
echo "== tandem (criterion)" >&2
cargo bench --bench arbitration $features -- --noplot 2>&1 | tee target/peers/arbitration_tandem.txt >&2
echo "== Python Clarabel and OSQP" >&2
"$venv/bin/python" "$here/qp_peer.py" target/peers/arbitration_qps.json > target/peers/arbitration_peer.json

"$venv/bin/python" - "$repo" <<'PY'
import json, sys, pathlib
repo = pathlib.Path(sys.argv[1])
peer = json.loads((repo / "target/peers/arbitration_peer.json").read_text())
def median(group):
    est = repo / "target/criterion" / group / "new/estimates.json"
    return json.loads(est.read_text())["median"]["point_estimate"] / 1000.0
rows = []
print(f"{'tandem':<44} {'µs':>8}   peer (Python, solve only)          µs    peer/tandem")
for name, group in [("full tick, direct (closed form first)", "arbitration_tick/direct"),
                    ("full tick, direct, active set forced", "arbitration_solver/direct_active-set"),
                    ("full tick, direct, Clarabel forced", "arbitration_solver/direct_clarabel")]:
    t = median(group)
    for peer_name in ("clarabel", "osqp"):
        p = peer[peer_name]["median_us"]
        rows.append({"tandem": name, "tandem_us": t, "peer": peer_name, "peer_us": p, "ratio": p / t})
        print(f"{name:<44} {t:>8.1f}   {peer_name:<30} {p:>8.1f} {p / t:>10.1f}x")
print(f"({peer['problems']} QPs; largest difference from tandem's command: "
      f"Clarabel {peer['clarabel']['max_difference']:.1e}, OSQP {peer['osqp']['max_difference']:.1e} rad/s; "
      f"clarabel {peer['versions']['clarabel']}, osqp {peer['versions']['osqp']})")
(repo / "target/peers/arbitration.json").write_text(json.dumps({"rows": rows, "peer": peer}, indent=1))
PY
