#!/usr/bin/env bash
# tandem against VAMP (KavrakiLab's vector-accelerated planner) on
# MotionBenchMaker's 700 Panda problems (or the UR5 or Baxter sets VAMP
# ships, with its sphere URDFs), on this machine: RRT-Connect plus
# simplification, 3 runs per problem, each planner pinned to the same core,
# in alternating rounds (VAMP, tandem, VAMP, ...) so that both see the same
# machine. VAMP is built from its source release on PyPI (vamp-planner 0.6.4)
# with its own compiler and flags (GCC, -O3 -march=native and the fast-math
# subset its CMake sets) and timed by benches/peers/vamp_mbm.py, which makes
# the calls and reads the clocks of VAMP's own scripts/evaluate_mbm.py.
# tandem is timed by `cargo bench --bench motionbenchmaker -- --seeds 3`.
# Prints per round and the median over rounds: planning and planning +
# simplification, median and mean (ms), and the ratios tandem / VAMP (below
# 1 means tandem is faster).
#
#   benches/peers/compare_vamp.sh [--rounds N] [--core K] [--robot R] [--per-family N]
#
# Defaults: 5 rounds, core 1, the Panda, every problem. --robot ur5 or
# baxter plans VAMP's set for that robot on both sides (tandem through
# `motionbenchmaker -- --set`); --per-family N takes the first N problems of
# each family on both sides (the Baxter's 1,800 take minutes per round).
# VAMP's Fetch set is left out: its start states set the wheel joints,
# which VAMP's Fetch URDF does not have, and tandem (like MoveIt) refuses
# a state naming joints the robot lacks.
#
# VAMP's build fetches its C++ dependencies (CPM.cmake, nigh, pdqsort,
# SIMDxorshift) from GitHub. Without network access to GitHub, set
# VAMP_DEPS to a folder holding their sources as CPM.cmake/, nigh/,
# pdqsort/ and SIMDxorshift/ (VAMP 0.6.4 pins nigh 9713099, pdqsort b1ef26a,
# SIMDxorshift 857c1a0): the build then takes them, and nanobind from PyPI,
# instead (only where they come from changes, not the flags). Needs
# Eigen 3.4 (Debian: libeigen3-dev) and a C++17 compiler.
# Writes target/peers/vamp/ (the venv, VAMP's source and problem sets) and
# target/peers/vamp_vs_tandem_<robot>.json (every round).
#
# --pointcloud: both planners on point clouds, VAMP with its own pipeline
# (that of its scripts/evaluate_mbm.py --pointcloud), on the same points.
#
#   benches/peers/compare_vamp.sh --pointcloud [--rounds N] [--core K] [--per-family N]
#       [--filter SPACING] [--no-margin]
#
# benches/peers/vamp_pointcloud.py first samples every valid Panda problem
# as evaluate_mbm.py does (10,000 points on every box and cylinder, seeded)
# into one binary PLY per problem, target/peers/vamp/clouds/<family>/NNNN.ply
# (kept between runs); both sides then read those files (reading is not
# timed) and run, per run, filter, build, planning and simplification:
# - VAMP (vamp_pointcloud.py): vamp.filter_pointcloud (its Morton-order
#   minimum-distance filter) at 2 cm with its cull at the Panda's 1.19 m
#   reach, the CAPT (Environment.add_pointcloud) of 2.5 mm points, then
#   RRT-Connect and simplify with the settings vamp_mbm.py uses; VAMP's C++
#   clocks.
# - tandem (`motionbenchmaker -- --clouds DIR --seeds 3`, the bench binary
#   run directly, so that no rebuild lands inside a round): the same cull,
#   its minimum-distance filter at SPACING (default 0.0025 m), the point
#   tree and collision model over the kept points as balls of 2.5 mm plus
#   the filter's margin (= SPACING: the kept points then stand for every
#   point of the file, so each certified edge is certified against the
#   whole cloud), RRT-Connect, shortcutting and certification.
#   --no-margin: balls of 2.5 mm at the kept points, as VAMP treats its
#   filtered cloud (edges then certified against the kept points only;
#   written to ..._pointcloud_no_margin.json instead).
# Prints a table of filter, build, planning, planning + simplification and
# filter + build + planning + simplification, median and mean (ms), the
# median over rounds and the ratios tandem / VAMP, and writes
# target/peers/vamp_vs_tandem_panda_pointcloud.json (every round).
# Env:
#   VAMP_VENV=path   the venv VAMP is installed in (default target/peers/vamp/venv)
#   VAMP_DEPS=path   local sources of VAMP's C++ dependencies (see above)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
die() { echo "${0##*/}: error: $*" >&2; exit 1; }

rounds=5
core=1
robot=panda
per_family=""
pointcloud=""
tandem_filter=0.0025
no_margin=""
while (( $# )); do
  case "$1" in
    --pointcloud) pointcloud=1; shift ;;
    --filter) tandem_filter="${2:?--filter needs a value}"; shift 2 ;;
    --no-margin) no_margin=1; shift ;;
    --rounds) rounds="${2:?--rounds needs a value}"; shift 2 ;;
    --core) core="${2:?--core needs a value}"; shift 2 ;;
    --robot) robot="${2:?--robot needs a value}"; shift 2 ;;
    --per-family) per_family="${2:?--per-family needs a value}"; shift 2 ;;
    *) die "unknown argument $1 (usage: compare_vamp.sh [--pointcloud [--filter SPACING] [--no-margin]] [--rounds N] [--core K] [--robot R] [--per-family N])" ;;
  esac
done
[[ "$rounds" =~ ^[1-9][0-9]*$ ]] || die "--rounds must be a positive integer, got $rounds"
[[ "$core" =~ ^[0-9]+$ ]] || die "--core must be a CPU number, got $core"
[[ "$robot" != fetch ]] || die "VAMP's Fetch set names wheel joints its Fetch URDF lacks, and tandem refuses such states"
[[ "$robot" =~ ^(panda|ur5|baxter)$ ]] || die "--robot must be panda, ur5 or baxter, got $robot"
[[ -z "$per_family" || "$per_family" =~ ^[1-9][0-9]*$ ]] || die "--per-family must be a positive integer"
[[ -z "$pointcloud" || "$robot" == panda ]] || die "--pointcloud plans the Panda set only"
[[ "$tandem_filter" =~ ^[0-9]*\.?[0-9]+$ ]] || die "--filter must be a spacing in m, got $tandem_filter"
command -v taskset >/dev/null || die "taskset not found (util-linux)"

out="$repo/target/peers/vamp"
venv="${VAMP_VENV:-$out/venv}"
src="$out/vamp_planner-0.6.4"
mkdir -p "$out"
if ! "$venv/bin/python" -c "import vamp; vamp.$robot" 2>/dev/null; then
  [[ -x "$venv/bin/python" ]] || python3 -m venv "$venv" || die "cannot create the venv $venv"
  "$venv/bin/pip" install --quiet scikit-build-core nanobind cmake ninja numpy typing_extensions pyyaml \
    xmltodict tqdm fire || die "pip install of VAMP's build tools failed"
  "$venv/bin/pip" download --quiet --no-deps --no-build-isolation --no-binary vamp-planner vamp-planner==0.6.4 -d "$out" \
    || die "cannot download vamp-planner 0.6.4 from PyPI"
  rm -rf "$src" && tar xzf "$out/vamp_planner-0.6.4.tar.gz" -C "$out"
  defines=()
  if [[ -n "${VAMP_DEPS:-}" ]]; then
    for d in CPM.cmake nigh pdqsort SIMDxorshift; do
      [[ -d "$VAMP_DEPS/$d" ]] || die "VAMP_DEPS=$VAMP_DEPS has no $d/"
    done
    printf 'set(CPM_USE_LOCAL_PACKAGES ON)\ninclude(%s/CPM.cmake/cmake/CPM.cmake)\n' "$VAMP_DEPS" \
      >"$src/cmake/FetchInitCPM.cmake"
    sed -i 's|CPMAddPackage("gh:wjakob/nanobind#[0-9a-f]*")|find_package(nanobind CONFIG REQUIRED)|' \
      "$src/cmake/Python.cmake"
    defines=(-Ccmake.define.CPM_nigh_SOURCE="$VAMP_DEPS/nigh" -Ccmake.define.CPM_pdqsort_SOURCE="$VAMP_DEPS/pdqsort"
      -Ccmake.define.CPM_SIMDxorshift_SOURCE="$VAMP_DEPS/SIMDxorshift"
      -Ccmake.define.nanobind_DIR="$("$venv/bin/python" -m nanobind --cmake_dir)")
  fi
  echo "== building VAMP 0.6.4 (its flags; a few minutes)" >&2
  (cd "$src" && PATH="$venv/bin:$PATH" "$venv/bin/pip" install --quiet --no-build-isolation . "${defines[@]}" \
    "-Ccmake.define.VAMP_ROBOT_MODULES=panda;ur5;baxter;fetch" \
    "-Ccmake.define.VAMP_ROBOT_STRUCTS=Panda;UR5;Baxter;Fetch") || die "VAMP's build failed"
fi
resources="$src/resources/$robot"
problems="$resources/problems.pkl"
if [[ ! -f "$problems" ]]; then
  (cd "$src/resources" && "$venv/bin/python" problem_tar_to_pkl_json.py --robot "$robot" >/dev/null 2>&1) \
    || die "VAMP's problem_tar_to_pkl_json.py failed"
fi
if [[ -n "$pointcloud" ]]; then
  clouds="$out/clouds"
  pc_args=()
  [[ -z "$per_family" ]] || pc_args+=(--per-family "$per_family")
  echo "== writing the clouds (VAMP's sampling) to $clouds" >&2
  "$venv/bin/python" "$here/vamp_pointcloud.py" "$problems" "$clouds" --write-only "${pc_args[@]}" \
    || die "vamp_pointcloud.py could not write the clouds"
  cd "$repo"
  echo "== building tandem's bench" >&2
  bench="$(cargo bench --bench motionbenchmaker --no-run --message-format=json \
    | python3 -c 'import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("executable") and m["target"]["name"] == "motionbenchmaker":
        print(m["executable"])')"
  [[ -x "$bench" ]] || die "cannot find the motionbenchmaker bench binary"
  tandem_args=(--bench --clouds "$clouds" --seeds 3 --point-radius 0.0025 --filter "$tandem_filter"
    --out "$out/tandem_panda_pointcloud.json" "${pc_args[@]}")
  [[ -z "$no_margin" ]] || tandem_args+=(--no-margin)
  rows="$out/rounds_pointcloud.jsonl"
  : >"$rows"
  for r in $(seq "$rounds"); do
    echo "== round $r of $rounds: VAMP, then tandem (core $core)" >&2
    vamp="$(taskset -c "$core" "$venv/bin/python" "$here/vamp_pointcloud.py" "$problems" "$clouds" --trials 3 \
      "${pc_args[@]}")"
    taskset -c "$core" "$bench" "${tandem_args[@]}" >/dev/null
    echo "{\"vamp\": $vamp, \"tandem\": $(cat "$out/tandem_panda_pointcloud.json")}" >>"$rows"
  done
  python3 - "$rows" "$repo/target/peers/vamp_vs_tandem_panda_pointcloud${no_margin:+_no_margin}.json" "$core" <<'PY'
import json, platform, statistics, sys

rounds = [json.loads(line) for line in open(sys.argv[1])]
names = [("filter", "filter"), ("build", "build"), ("planning", "planning"),
         ("total", "planning + simplification"), ("filter_build_plan_simplify", "filter + build + planning + simplification")]
last = rounds[-1]
v, t = last["vamp"], last["tandem"]
print(f"MotionBenchMaker, Panda, point clouds: VAMP 0.6.4 against tandem, the same PLY files, 3 runs per problem, "
      f"core {sys.argv[3]}, {len(rounds)} alternating rounds ({platform.processor() or platform.machine()})")
print(f"VAMP: filter at {v['settings']['filter_radius_m']} m, points of {v['settings']['point_radius_m']} m; "
      f"tandem: filter at {t['settings']['filter_spacing_m']} m, balls of {t['settings']['ball_radius_m']:.4f} m "
      + ("(point radius + the filter's margin: certified against every point of the file)" if t["settings"]["margin"]
         else "(no margin: certified against the kept points only)"))
print("| figure | VAMP (ms) | tandem (ms) | tandem / VAMP, median of rounds | per round |")
print("| --- | --- | --- | --- | --- |")
for key, name in names:
    for stat in ("median_ms", "mean_ms"):
        a = [r["vamp"][key][stat] for r in rounds]
        b = [r["tandem"][key][stat] for r in rounds]
        ratios = [y / x for x, y in zip(a, b)]
        each = ", ".join(f"{x:.2f}" for x in ratios)
        print(f"| {name}, {stat[:-3]} | {statistics.median(a):.3f} | {statistics.median(b):.3f} | "
              f"{statistics.median(ratios):.2f} | {each} |")
for side, r in (("VAMP", v), ("tandem", t)):
    p = r["points"]
    print(f"{side}: solved {r['solved']} of {r['runs']} runs; points per cloud {p['original_median']:.0f} median, "
          f"{p['filtered_median']:.0f} after the filter (median; mean {p['filtered_mean']:.0f}); "
          f"mean path length after simplification {r['mean_path_length_rad']:.4f} rad")
reasons = {}
for u in t["unsolved"]:
    reason = u.split(": ", 1)[1].split(":")[0]
    reasons[reason] = reasons.get(reason, 0) + 1
if reasons:
    print("tandem's unsolved runs: " + ", ".join(f"{n} {r}" for r, n in sorted(reasons.items())))
if v["unsolved"]:
    print(f"VAMP's unsolved runs: {len(v['unsolved'])} ({', '.join(v['unsolved'][:10])}{', ...' if len(v['unsolved']) > 10 else ''})")
json.dump(rounds, open(sys.argv[2], "w"))
PY
  exit 0
fi
# tandem plans the vendored Panda set (the same 700 problems), or VAMP's set.
tandem_args=(--seeds 3 --out "$out/tandem_$robot.json")
vamp_args=(--robot "$robot" --trials 3)
if [[ -n "$per_family" ]]; then
  tandem_args+=(--per-family "$per_family")
  vamp_args+=(--per-family "$per_family")
fi
if [[ "$robot" != panda ]]; then
  mkdir -p "$out/$robot" && tar xjf "$resources/problems.tar.bz2" -C "$out/$robot"
  tandem_args+=(--set "$out/$robot/problems" --urdf "$resources/${robot}_spherized.urdf"
    --srdf "$resources/$robot.srdf" --robot "$robot")
fi

cd "$repo"
echo "== building tandem's bench" >&2
cargo bench --bench motionbenchmaker --no-run >&2
rows="$out/rounds.jsonl"
: >"$rows"
for r in $(seq "$rounds"); do
  echo "== round $r of $rounds: VAMP, then tandem (core $core)" >&2
  vamp="$(taskset -c "$core" "$venv/bin/python" "$here/vamp_mbm.py" "$problems" "${vamp_args[@]}")"
  taskset -c "$core" cargo bench --bench motionbenchmaker -- "${tandem_args[@]}" >/dev/null
  echo "{\"vamp\": $vamp, \"tandem\": $(cat "$out/tandem_$robot.json")}" >>"$rows"
done

python3 - "$rows" "$repo/target/peers/vamp_vs_tandem_$robot.json" "$core" "$robot" <<'PY'
import json, platform, statistics, sys

rounds = [json.loads(line) for line in open(sys.argv[1])]
figures = [("planning", "median_ms"), ("planning", "mean_ms"), ("total", "median_ms"), ("total", "mean_ms")]
names = {"planning": "planning", "total": "planning + simplification"}
print(f"MotionBenchMaker, {sys.argv[4]}: VAMP 0.6.4 against tandem, 3 runs per problem, core {sys.argv[3]}, "
      f"{len(rounds)} alternating rounds ({platform.processor() or platform.machine()})")
print("| figure | VAMP (ms) | tandem (ms) | tandem / VAMP, median of rounds | per round |")
print("| --- | --- | --- | --- | --- |")
for figure, stat in figures:
    v = [r["vamp"][figure][stat] for r in rounds]
    t = [r["tandem"][figure][stat] for r in rounds]
    ratios = [b / a for a, b in zip(v, t)]
    each = ", ".join(f"{x:.2f}" for x in ratios)
    print(f"| {names[figure]}, {stat[:-3]} | {statistics.median(v):.3f} | {statistics.median(t):.3f} | "
          f"{statistics.median(ratios):.2f} | {each} |")
last = rounds[-1]
unsolved = last["tandem"]["unsolved"]
print(f"solved: VAMP {last['vamp']['solved']} of the {last['vamp']['runs']} runs of problems it finds valid, "
      f"tandem {last['tandem']['solved']} of {last['tandem']['solved'] + len(unsolved)} runs")
reasons = {}
for u in unsolved:
    reason = u.split(": ", 1)[1].split(":")[0]
    reasons[reason] = reasons.get(reason, 0) + 1
if reasons:
    print("tandem's unsolved runs: " + ", ".join(f"{n} {r}" for r, n in sorted(reasons.items())))
print(f"mean path length after simplification: VAMP {last['vamp']['mean_path_length_rad']:.4f} rad, "
      f"tandem {last['tandem']['mean_path_length_rad']:.4f} rad (tandem's edges certified)")
json.dump(rounds, open(sys.argv[2], "w"))
PY
