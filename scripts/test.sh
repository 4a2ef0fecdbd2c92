#!/usr/bin/env bash
# Runs every test of tandem, setting up what they need first:
#   1. the Python reference environment python_ref/.venv (Pinocchio, casadi,
#      scipy, example-robot-data, pyarrow from PyPI), rebuilt when
#      python_ref/requirements.txt changes, and the Python package's test
#      environment python/.venv (pytest, ray; python/requirements-test.txt);
#   2. formatting, lint and documentation checks (cargo fmt, cargo clippy
#      -D warnings, cargo doc with rustdoc warnings as errors, of the public
#      and of the private items: broken intra-doc links);
#   3. all Rust tests, including the live cross-checks against python_ref/,
#      and one million random arbitration ticks (tests/arbitration_stress.rs);
#   4. the Python package: `pip install .` (maturin) into python/.venv, then
#      its pytest suite (python/tests: Pinocchio cross-checks, planning,
#      errors, Ray generation equal to the CLI's).
#   5. the teleoperation page of `tandem serve` in headless Chromium
#      (web/tests: Debian's chromium, installed with apt-get when missing;
#      playwright-core and the page's sources from npm, web/package-lock.json),
#      after checking that the committed bundle web/dist/app.js is built
#      from web/src;
#   6. a few seconds of every fuzz target (fuzz/, scripts/fuzz.sh);
#   7. the user pages' examples: examples/arbiter_loop.rs, every ```sh
#      block of docs/ (scripts/doc_examples.py; the Rust and Python blocks
#      ran above as doctests and pytest);
#   8. the reproduction check: the quick versions of the published tables
#      and figures equal to the committed ones, every figure rendered
#      (scripts/reproduce.sh --quick --check; rsvg-convert from Debian's
#      librsvg2-bin, installed when missing).
# The OSQP cross-check backend (feature `osqp`) is built with the cmake of
# python_ref/.venv (PyPI's cmake).
# A missing or broken Python environment is an error, never a skip.
# Everything after the first `cargo test` runs on that one debug build
# (the dependencies at opt-level 2): every cargo command below selects the
# same packages and features, because cargo resolves a dependency's
# features over the packages a command builds, and a different selection
# (`cargo run --example` without --workspace, maturin building python/
# alone) recompiled about 90 crates, about 8 minutes each on two cores.
set -euo pipefail
cd "$(dirname "$0")/.."

# Disk is the scarce resource on CI machines (a run once died of a full
# disk): say what there is, and how long the run has taken so far (to find
# a slow stage), and skip what only helps repeated local builds.
disk() { echo "== disk: $(df -h --output=avail . | tail -1 | tr -d ' ') free ($1), ${SECONDS} s in"; }
disk "start"
if [ -n "${CI:-}" ]; then
  export CARGO_INCREMENTAL=0 PIP_NO_CACHE_DIR=1
fi

venv=python_ref/.venv
stamp="$venv/.requirements.sha256"
want=$(sha256sum python_ref/requirements.txt | cut -d' ' -f1)
if [ ! -x "$venv/bin/python" ] || [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  echo "== setting up the Python reference environment in $venv"
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --disable-pip-version-check -r python_ref/requirements.txt
  echo "$want" > "$stamp"
fi
"$venv/bin/python" -c "import pinocchio, casadi, scipy, numpy, pyarrow, cmake, rosbags, cyclonedds, mujoco, plyfile, pypcd4, octomap, pycpd, small_gicp" \
  || { echo "error: the Python reference environment in $venv is broken; delete it and re-run" >&2; exit 1; }

# The Python package's environment: pytest and ray in python/.venv, which
# sees python_ref/.venv's packages (Pinocchio, scipy, numpy, pyarrow)
# through a .pth file instead of installing them twice.
pyvenv=python/.venv
pystamp="$pyvenv/.requirements.sha256"
pywant=$(cat python/requirements-test.txt "$stamp" | sha256sum | cut -d' ' -f1)
if [ ! -x "$pyvenv/bin/python" ] || [ "$(cat "$pystamp" 2>/dev/null)" != "$pywant" ]; then
  echo "== setting up the Python package's test environment in $pyvenv"
  rm -rf "$pyvenv"
  python3 -m venv "$pyvenv"
  purelib() { "$1/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])'; }
  echo "import site; site.addsitedir('$(purelib "$venv")')" > "$(purelib "$pyvenv")/_tandem_python_ref.pth"
  "$pyvenv/bin/pip" install --quiet --disable-pip-version-check -r python/requirements-test.txt
  echo "$pywant" > "$pystamp"
fi
# Build the bindings for that interpreter, as maturin does (no link to
# libpython): cargo and `pip install .` then share pyo3's build.
export PYO3_PYTHON="$PWD/$pyvenv/bin/python" PYO3_BUILD_EXTENSION_MODULE=1

# MuJoCo for the `mujoco` feature: the libmujoco.so PyPI's wheel ships,
# under the name the linker looks for (mujoco-rs reads the folder from
# MUJOCO_DYNAMIC_LINK_DIR; tandem's build.rs makes it the run path).
mjlib="$PWD/target/mujoco-lib"
mkdir -p "$mjlib"
mjso=$("$venv/bin/python" -c 'import mujoco, pathlib; print(next(pathlib.Path(mujoco.__file__).parent.glob("libmujoco.so.*")))')
ln -sf "$mjso" "$mjlib/libmujoco.so"
ln -sf "$mjso" "$mjlib/$(basename "$mjso")"
export MUJOCO_DYNAMIC_LINK_DIR="$mjlib"

# cmake for the OSQP backend's C sources (CMake 4 needs the policy floor).
export PATH="$PWD/$venv/bin:$PATH" CMAKE_POLICY_VERSION_MINIMUM=3.5

disk "Python environment ready"
echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy"
cargo clippy --workspace --all-targets --features osqp,ros2,mujoco --quiet -- -D warnings
echo "== cargo doc (warnings are errors)"
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --features osqp,ros2,mujoco --quiet
# Again with the private items, whose links the first run does not follow
# (the first catches public pages linking to private items).
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --features osqp,ros2,mujoco --document-private-items --quiet
echo "== cargo test"
cargo test --workspace --all-targets --features osqp,ros2,mujoco --no-run --quiet
disk "tests built"
# The tandem libraries of the test build. A step that adds one compiled
# tandem again with other dependency features (see above): an error, so
# that the ~8 minutes it costs do not come back unnoticed.
tandem_builds() { ls target/debug/deps/libtandem-*.rlib | sort; }
built=$(tandem_builds)
same_build() {
  [ "$(tandem_builds)" = "$built" ] \
    || { echo "error: $1 compiled tandem again with other features than the test build's; select the same packages and features" >&2; exit 1; }
}
cargo test --workspace --all-targets --features osqp,ros2,mujoco --no-fail-fast
cargo test --workspace --doc --features osqp,ros2,mujoco --no-fail-fast
# The stress test again with 1,000,000 ticks (20,000 above), debug
# assertions and overflow checks on: about a minute, where a release
# build of its own took most of a 10-minute stage for the same tallies
# (the release and the debug run count the same statuses).
echo "== arbitration stress test (1,000,000 ticks)"
TANDEM_STRESS_TICKS=1000000 cargo test --quiet --workspace --features osqp,ros2,mujoco --test arbitration_stress -- --nocapture
echo "== examples/arbiter_loop.rs"
cargo build --quiet --workspace --features osqp,ros2,mujoco --example arbiter_loop
same_build "the example's build"
target/debug/examples/arbiter_loop
disk "Rust tests done"

# `pip install .` as a user runs it (maturin from PyPI in an isolated build
# environment), but with the dev profile and the test build's features
# (tandem's osqp and ros2 too): it reuses the test build above (only pyo3,
# numpy and the bindings compile) instead of a release build.
echo "== pip install . (the Python package)"
MATURIN_PEP517_ARGS="--profile dev --features mujoco,tandem/osqp,tandem/ros2" "$pyvenv/bin/pip" install --quiet \
  --disable-pip-version-check --force-reinstall --no-deps .
same_build "pip install ."
echo "== pytest python/tests"
TANDEM_BIN="$PWD/target/debug/tandem" "$pyvenv/bin/python" -m pytest -q -p no:cacheprovider python/tests

# The browser page: Chromium from Debian (CI machines start without it),
# the page's npm packages, the bundle check, then the end-to-end tests
# against the tandem binary the Rust tests built.
echo "== teleoperation page in headless Chromium (web/tests)"
apt() { if [ "$(id -u)" -eq 0 ]; then DEBIAN_FRONTEND=noninteractive apt-get "$@"; else sudo DEBIAN_FRONTEND=noninteractive apt-get "$@"; fi; }
# A Debian package, installed when its program is missing.
need() {
  local program=$1 package=$2
  command -v "$program" > /dev/null && return
  echo "   installing Debian's $package"
  apt install -y -q "$package" > /dev/null \
    || { apt update -q > /dev/null && apt install -y -q "$package" > /dev/null; } \
    || { echo "error: could not install $package (apt-get); the tests need $program" >&2; exit 1; }
}
need chromium chromium
(cd web && npm ci --no-audit --no-fund --loglevel=error)
(cd web && node build.mjs node_modules/.app-check.js)
cmp -s web/dist/app.js web/node_modules/.app-check.js \
  || { echo "error: web/dist/app.js is not built from web/src: run 'npm run build' in web/ and commit it" >&2; exit 1; }
(cd web && node tests/teleop.test.mjs --bin ../target/debug/tandem --python "../$venv/bin/python")
disk "browser tests done"

# Every fuzz target for a few seconds (a fresh build of fuzz/ is part of
# the cost; scripts/fuzz.sh TARGET SECONDS fuzzes for real).
echo "== fuzz smoke: every target for ${FUZZ_SMOKE_SECONDS:=3} s"
FUZZ_PROFILE=smoke FUZZ_JOBS=2 scripts/fuzz.sh all "$FUZZ_SMOKE_SECONDS"
disk "fuzz smoke done"

# The test build's binary (with MuJoCo, for the physics run) runs the user
# pages' shell examples and the quick reproduction: the published results
# are the same bytes from a debug and a release build (no fast-math; the
# SIMD kernels are chosen by the CPU, not the profile).
echo "== the shell examples of docs/"
"$venv/bin/python" scripts/doc_examples.py target/debug/tandem
echo "== reproduction check (scripts/reproduce.sh --quick --check)"
need rsvg-convert librsvg2-bin
scripts/reproduce.sh --quick --check --bin target/debug/tandem
disk "end"
