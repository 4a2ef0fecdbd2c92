#!/usr/bin/env bash
# Build and run the Pinocchio + coal C++ collision peer benchmark against the Pinocchio and
# coal that ship in the python_ref venv (pip `pin`, cmeel wheels).
#
#   benches/peers/run_coal.sh REQUEST.json [--seconds S]
#
# REQUEST.json is a "collision scene exchange" request, the same one
# python_ref/coal_reference.py reads (its "output" and "timing" keys are ignored here).
# The C++ side has no JSON library, so the venv's python first converts it to the line-based
# text format documented in coal_collision.cpp. Prints one JSON object on stdout (build
# chatter goes to stderr).
# Env:
#   VENV=path             venv to use (default: <repo>/python_ref/.venv)
#   PIN_PEER_NO_INSTALL=1 do not pip-install missing header-only build deps, just fail
#   PIN_PEER_REBUILD=1    force recompilation
#
# Deliberately NO -march=native: see pin_env.sh (generic x86-64 wheel libraries, Eigen ABI).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
venv="${VENV:-$repo/python_ref/.venv}"
src="$here/coal_collision.cpp"
build="$here/build"

# die/note, venv + cmeel prefix discovery, header-only deps, incs/defs/libdirs, pin_build.
source "$here/pin_env.sh"

(( $# >= 1 )) && [[ -f "$1" ]] || die "usage: run_coal.sh REQUEST.json [--seconds S]"
request="$1"
shift

[[ -f "$prefix/lib/libcoal.so" && -f "$prefix/lib/libpinocchio_collision.so" && -f "$prefix/include/coal/config.hh" ]] \
  || die "coal / pinocchio_collision not found under $prefix (the 'pin' wheel ships them)"

# Compile definitions of CMake's pinocchio::pinocchio_{default,collision} and coal::coal
# targets: the collision-enabled GeometryData/GeometryObject layout must match the libraries.
defs+=(
  -DPINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION -DPINOCCHIO_WITH_COLLISION -DPINOCCHIO_WITH_HPP_FCL
  -DCOAL_BACKWARD_COMPATIBILITY_WITH_HPP_FCL -DCOAL_HAS_OCTOMAP -DCOAL_HAVE_OCTOMAP
  -DOCTOMAP_MAJOR_VERSION=1 -DOCTOMAP_MINOR_VERSION=10 -DOCTOMAP_PATCH_VERSION=0
)
# buildModel/buildGeom in libpinocchio_parsers, algorithm instantiations in
# libpinocchio_default, the collision ones in libpinocchio_collision, narrow phase in libcoal.
libs=(-lpinocchio_parsers -lpinocchio_collision -lpinocchio_default -lcoal
      -lboost_serialization -lboost_filesystem)

mkdir -p "$build"
exe="$build/coal_collision"
# -Wno-deprecated-declarations: coal 3 headers warn about their own deprecated members.
cmd=("${CXX:-g++}" -O3 -DNDEBUG -std=c++17 -march=x86-64 -mtune=generic -Wno-deprecated-declarations
     "${defs[@]}" "${incs[@]}" "$src" -o "$exe" "${libdirs[@]}" "${libs[@]}")
pin_build "$exe" "$build/.cmd_coal" "$src" "${cmd[@]}"

# JSON request -> scene text (format in coal_collision.cpp). repr() round-trips f64 exactly.
scene="$(mktemp "${TMPDIR:-/tmp}/coal_scene.XXXXXX")"
trap 'rm -f "$scene"' EXIT
"$venv/bin/python" - "$request" "$scene" <<'EOF' || die "cannot convert $request"
import json, sys

req = json.load(open(sys.argv[1]))
lines = ["tandem-coal-scene 1", req["urdf"]]

def strings(items):
    for s in items:
        if "\n" in s:
            raise SystemExit(f"newline in {s!r}")
    lines.append(str(len(items)))
    lines.extend(items)

strings(list(req.get("package_dirs", [])))
strings(list(req["joints"]))
held = req.get("held", {})
lines.append(str(len(held)))
for name, value in held.items():
    lines += [name, repr(float(value))]
strings([f"{e['link']}_{e['index']}" for e in req["robot_elements"]])
obstacles = req.get("obstacles", [])
lines.append(str(len(obstacles)))
for o in obstacles:
    shape = o["shape"]
    if shape == "box":
        abc = o["half_extents"]
    elif shape == "sphere":
        abc = [o["radius"], 0, 0]
    elif shape in ("cylinder", "capsule"):
        abc = [o["radius"], o["length"], 0]
    else:
        raise SystemExit(f"unknown obstacle shape {shape!r}")
    rot = o.get("rotation", [[1, 0, 0], [0, 1, 0], [0, 0, 1]])
    nums = list(abc) + list(o.get("translation", [0, 0, 0])) + [x for row in rot for x in row]
    lines.append(" ".join([shape] + [repr(float(x)) for x in nums]))
lines.append(str(len(req["pairs"])))
lines += [f"{int(a)} {int(b)}" for a, b in req["pairs"]]
configs = req["configurations"]
lines.append(f"{len(configs)} {len(req['joints'])}")
lines += [" ".join(repr(float(x)) for x in q) for q in configs]
open(sys.argv[2], "w").write("\n".join(lines) + "\n")
EOF

"$exe" "$scene" "$@"
