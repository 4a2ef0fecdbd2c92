#!/usr/bin/env bash
# Runs every test of tandem, setting up what they need first:
#   1. the Python reference environment python_ref/.venv (Pinocchio, casadi,
#      scipy, example-robot-data, pyarrow from PyPI), rebuilt when
#      python_ref/requirements.txt changes;
#   2. formatting and lint checks (cargo fmt, cargo clippy -D warnings);
#   3. all Rust tests, including the live cross-checks against python_ref/;
#   4. a few seconds of every fuzz target (fuzz/, scripts/fuzz.sh).
# A missing or broken Python environment is an error, never a skip.
set -euo pipefail
cd "$(dirname "$0")/.."

# Disk is the scarce resource on CI machines (a run once died of a full
# disk): say what there is, and skip what only helps repeated local builds.
disk() { echo "== disk: $(df -h --output=avail . | tail -1 | tr -d ' ') free ($1)"; }
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
"$venv/bin/python" -c "import pinocchio, casadi, scipy, numpy, pyarrow" \
  || { echo "error: the Python reference environment in $venv is broken; delete it and re-run" >&2; exit 1; }

disk "Python environment ready"
echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy"
cargo clippy --workspace --all-targets --quiet -- -D warnings
echo "== cargo test"
cargo test --workspace --all-targets --no-run --quiet
disk "tests built"
cargo test --workspace --all-targets --no-fail-fast
cargo test --workspace --doc --no-fail-fast
# Every fuzz target for a few seconds (a fresh build of fuzz/ is part of
# the cost; scripts/fuzz.sh TARGET SECONDS fuzzes for real).
echo "== fuzz smoke: every target for ${FUZZ_SMOKE_SECONDS:=3} s"
FUZZ_PROFILE=smoke scripts/fuzz.sh all "$FUZZ_SMOKE_SECONDS"
disk "end"
