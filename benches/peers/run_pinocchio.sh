#!/usr/bin/env bash
# Build and run the Pinocchio C++ kinematics peer benchmark against the Pinocchio that
# ships in the python_ref venv (pip `pin`, cmeel wheels).
#
#   benches/peers/run_pinocchio.sh [URDF] [FRAME] [--samples N] [--configs N] [--seed S]
#
# Prints one JSON object on stdout (build chatter goes to stderr).
# Env:
#   VENV=path             venv to use (default: <repo>/python_ref/.venv)
#   PIN_HEADER_ONLY=1     compile Pinocchio's algorithms into the benchmark binary instead of
#                         calling the explicit instantiations in libpinocchio_default.so
#   PIN_PEER_NO_INSTALL=1 do not pip-install missing header-only build deps, just fail
#   PIN_PEER_REBUILD=1    force recompilation
#
# Deliberately NO -march=native: see pin_env.sh (generic x86-64 wheel libraries, Eigen ABI).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
venv="${VENV:-$repo/python_ref/.venv}"
src="$here/pinocchio_kinematics.cpp"
build="$here/build"

# die/note, venv + cmeel prefix discovery, header-only deps, incs/defs/libdirs, pin_build.
source "$here/pin_env.sh"

suffix=""
if [[ "${PIN_HEADER_ONLY:-0}" == 1 ]]; then
  suffix="_header_only"
else
  defs+=(-DPINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION)
fi

defs+=(-DPIN_PEER_DEFAULT_URDF="\"$default_urdf\"")

# buildModel lives in libpinocchio_parsers (which pulls urdfdom/boost/coal via its own
# DT_NEEDED + $ORIGIN runpath); the algorithm instantiations in libpinocchio_default.
libs=(-lpinocchio_parsers -lpinocchio_default -lboost_serialization -lboost_filesystem)

mkdir -p "$build"
exe="$build/pinocchio_kinematics$suffix"
cmd=("${CXX:-g++}" -O3 -DNDEBUG -std=c++17 -march=x86-64 -mtune=generic
     "${defs[@]}" "${incs[@]}" "$src" -o "$exe" "${libdirs[@]}" "${libs[@]}")
pin_build "$exe" "$build/.cmd$suffix" "$src" "${cmd[@]}"

exec "$exe" "$@"
