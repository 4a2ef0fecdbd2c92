# Shared build environment for the C++ peer benchmarks compiled against the Pinocchio
# (and coal) that ship in the python_ref venv (pip `pin`, cmeel wheels).
# Sourced (not run) by run_pinocchio.sh and run_coal.sh, which set `venv` first.
#
# Defines: die, note, pin_build; prefix (the cmeel prefix), incs, defs (compile
# definitions of CMake's pinocchio::pinocchio_{headers,parsers} targets), libdirs,
# default_urdf (example-robot-data's panda.urdf).
#
# Deliberately NO -march=native for anything built with this: the wheel's libraries are
# built for generic x86-64, and Eigen's alignment/ABI (EIGEN_MAX_ALIGN_BYTES) changes with
# AVX, which makes objects shared with the .so (Model/Data built by the URDF parser) crash.
# Callers pin -march=x86-64.

# Messages carry the calling script's name.
die() { echo "${0##*/}: error: $*" >&2; exit 1; }
note() { echo "${0##*/}: $*" >&2; }

[[ "$(uname -m)" == "x86_64" ]] || die "only x86_64 is supported (generic x86-64 flags), got $(uname -m)"
command -v "${CXX:-g++}" >/dev/null || die "${CXX:-g++} not found"

if [[ ! -x "$venv/bin/python" ]]; then
  die "Python venv not found at $venv.
  The Pinocchio peer benchmark uses the C++ headers and libraries shipped in the
  python_ref venv (pip package 'pin'). Run the test setup first (create
  python_ref/.venv and 'pip install pin example-robot-data'), or set VENV=/path/to/venv."
fi

# Locate the cmeel prefix (site-packages/cmeel.prefix) via the venv's own python, falling back
# to a glob in case python cannot start.
prefix="$("$venv/bin/python" - 2>/dev/null <<'EOF' || true
import sysconfig, os
p = os.path.join(sysconfig.get_paths()["purelib"], "cmeel.prefix")
print(p if os.path.isdir(p) else "")
EOF
)"
if [[ -z "$prefix" ]]; then
  for p in "$venv"/lib/python3*/site-packages/cmeel.prefix; do
    [[ -d "$p" ]] && prefix="$p" && break
  done
fi
[[ -n "$prefix" && -d "$prefix" ]] || die "no cmeel.prefix in $venv (is the 'pin' package installed? run the test setup)"
[[ -f "$prefix/include/pinocchio/config.hpp" && -f "$prefix/lib/libpinocchio_default.so" && -f "$prefix/lib/libpinocchio_parsers.so" ]] \
  || die "Pinocchio C++ headers/libraries not found under $prefix (pip 'pin' >= 3 / 'libpinocchio' needed)"

# The wheels do not ship Eigen or urdfdom_headers (build-time-only deps of the wheel), but
# Pinocchio's public headers need them. They are header-only cmeel packages on PyPI; the
# versions match what pin 4.1 was built against (Eigen 3.4.x; urdfdom_headers 3.0.0, see
# PINOCCHIO_URDFDOM_HEADERS_*_VERSION in lib/cmake/pinocchio/pinocchioTargets.cmake).
need=()
[[ -f "$prefix/include/eigen3/Eigen/Core" ]] || need+=("cmeel-eigen>=3.4.1,<3.5")
[[ -f "$prefix/include/urdfdom_headers/urdf_model/model.h" || -f "$prefix/include/urdf_model/model.h" ]] \
  || need+=("cmeel-urdfdom-headers==3.0.0")
if (( ${#need[@]} )); then
  if [[ "${PIN_PEER_NO_INSTALL:-0}" == 1 ]]; then
    die "missing header-only build deps in $prefix: ${need[*]} (pip install them into $venv)"
  fi
  note "installing header-only build deps into $venv: ${need[*]}"
  "$venv/bin/python" -m pip install --quiet "${need[@]}" >&2 || die "pip install ${need[*]} failed"
fi

incs=(-I"$prefix/include" -I"$prefix/include/eigen3")
[[ -d "$prefix/include/urdfdom_headers" ]] && incs+=(-I"$prefix/include/urdfdom_headers")

# urdfdom_headers version, from the installed header package (falls back to 3.0.0).
uh_ver="$(sed -n 's/^Version: *//p' "$prefix/lib/pkgconfig/urdfdom_headers.pc" 2>/dev/null | head -n1 || true)"
[[ -n "$uh_ver" ]] || uh_ver="3.0.0"
IFS=. read -r uh_major uh_minor uh_patch <<<"$uh_ver"

# Same compile definitions CMake's pinocchio::pinocchio_{headers,default,parsers} targets add.
defs=(
  -DBOOST_MPL_LIMIT_LIST_SIZE=30 -DBOOST_MPL_LIMIT_VECTOR_SIZE=30
  -DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS -DBOOST_FUSION_INVOKE_MAX_ARITY=12
  -DPINOCCHIO_WITH_URDFDOM
  -DPINOCCHIO_URDFDOM_HEADERS_MAJOR_VERSION="${uh_major:-3}"
  -DPINOCCHIO_URDFDOM_HEADERS_MINOR_VERSION="${uh_minor:-0}"
  -DPINOCCHIO_URDFDOM_HEADERS_PATCH_VERSION="${uh_patch:-0}"
)

default_urdf="$prefix/share/example-robot-data/robots/panda_description/urdf/panda.urdf"

libdirs=()
for d in "$prefix/lib" "$prefix/lib64"; do
  [[ -d "$d" ]] && libdirs+=(-L"$d" -Wl,-rpath,"$d" -Wl,-rpath-link,"$d")
done

# pin_build EXE STAMP SRC COMPILER ARGS...: run the compile command unless EXE is newer than
# SRC, the calling script and this file, and was built by exactly the same command (STAMP).
pin_build() {
  local exe="$1" stamp="$2" src="$3"
  shift 3
  if [[ "${PIN_PEER_REBUILD:-0}" == 1 || ! -x "$exe" || "$src" -nt "$exe" || "$0" -nt "$exe" \
        || "$(dirname "$src")/peer_util.hpp" -nt "$exe" \
        || "${BASH_SOURCE[0]}" -nt "$exe" || "$(cat "$stamp" 2>/dev/null || true)" != "$*" ]]; then
    note "compiling: $(printf '%q ' "$@")"
    "$@" >&2 || die "compilation failed"
    printf '%s' "$*" >"$stamp"
  fi
}
