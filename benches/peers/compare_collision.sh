#!/usr/bin/env bash
# Side-by-side collision speed: tandem (criterion, benches/collision.rs) and
# coal through Pinocchio's C++ (benches/peers/coal_collision.cpp) on the same
# geometry — the Panda's 81 spheres, the table and box of
# problems/panda_grasp_box.toml and 10 seeded random obstacles — the same
# pairs and the same 1000 random configurations, measured in one run, with
# ratios coal / tandem (above 1 means tandem is faster).
#
#   benches/peers/compare_collision.sh
#
# Needs the Python reference environment (scripts/test.sh creates it) for
# coal's and Pinocchio's C++ libraries. Writes target/peers/collision.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
cd "$repo"
mkdir -p target/peers

echo "== tandem (criterion; also writes target/peers/collision_scene.json)" >&2
cargo bench --bench collision -- --noplot --warm-up-time 2 --measurement-time 5 >&2
echo "== coal (Pinocchio C++)" >&2
"$here/run_coal.sh" target/peers/collision_scene.json --seconds 3 > target/peers/coal_collision.json

python3 - "$repo" <<'PY'
import json, sys, pathlib
repo = pathlib.Path(sys.argv[1])
def median(name):
    est = repo / "target/criterion/panda_grasp_box_10" / name / "new/estimates.json"
    return json.loads(est.read_text())["median"]["point_estimate"]
coal = json.loads((repo / "target/peers/coal_collision.json").read_text())
res = coal["results_ns"]
rows = [
    ("collision_free", "collision_check", "boolean check, early exit (computeCollisions, stop at first)"),
    ("distance_all_pairs", "distance_all_pairs", "signed distance of every pair (computeDistances)"),
    ("min_distance", "distance_all_pairs", "closest pair (tandem: branch and bound; coal: computeDistances)"),
]
print(f"{coal['pairs']} pairs, {coal['configurations']} configurations, {coal['collision_fraction']:.1%} in collision (coal)")
print(f"{'query':<66} {'tandem ns':>10} {'coal ns':>10} {'coal/tandem':>12}")
out = []
for ours, theirs, label in rows:
    t, c = median(ours), res[theirs]["median"]
    print(f"{label:<66} {t:>10.0f} {c:>10.0f} {c / t:>12.1f}")
    out.append({"query": ours, "tandem_ns": t, "coal_ns": c, "ratio_coal_over_tandem": c / t})
(repo / "target/peers/collision.json").write_text(json.dumps({"rows": out, "coal": coal}, indent=1))
PY
