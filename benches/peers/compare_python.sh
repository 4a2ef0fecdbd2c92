#!/usr/bin/env bash
# tandem from Python, side by side:
#   1. per-call cost of FK + frame pose (+ 6x7 Jacobian) from Python, tandem's
#      package against Pinocchio's Python bindings on the same Panda URDF
#      (python_kinematics.py; target: tandem no slower than pin);
#   2. one arbitration tick from Python per mode (python_arbitration.py), to
#      set beside the Rust tick of `cargo bench --bench arbitration`;
#   3. one step of the Gymnasium environments of tandem.gym (python_gym_step.py;
#      target: under 100 µs);
#   4. bulk generation over a local Ray cluster against `tandem generate` with
#      the same CPUs: samples/s, the engine's overhead in %, byte identity
#      (ray_generate.py).
# Release builds of both: `pip install .` (release) into python/.venv, which
# scripts/test.sh creates (it reinstalls its dev build there on its next run).
#
#   benches/peers/compare_python.sh [--count N] [--cpus C] [--no-ray]
#
# Writes target/peers/python_kinematics.json and target/peers/ray_generate.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/../.." && pwd)"
die() { echo "${0##*/}: error: $*" >&2; exit 1; }
count=2000 cpus=2 ray=true
while (( $# )); do
  case "$1" in
    --count) count="${2:?--count needs a value}"; shift 2 ;;
    --cpus) cpus="${2:?--cpus needs a value}"; shift 2 ;;
    --no-ray) ray=false; shift ;;
    *) die "unknown argument $1 (see the usage at the top of $0)" ;;
  esac
done
cd "$repo"
py=python/.venv/bin/python
[[ -x "$py" ]] || die "python/.venv not found: run scripts/test.sh once to create it"
mkdir -p target/peers
echo "== pip install . (release build)" >&2
"$py" -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps . >&2
echo "== FK + Jacobian from Python: tandem vs pin" >&2
"$py" "$here/python_kinematics.py" --json target/peers/python_kinematics.json
echo "== one arbitration tick from Python, every mode" >&2
"$py" "$here/python_arbitration.py" --json target/peers/python_arbitration.json
echo "== one Gymnasium environment step from Python" >&2
"$py" "$here/python_gym_step.py" --json target/peers/python_gym_step.json
if $ray; then
  echo "== bulk generation: Ray vs the CLI ($cpus CPUs)" >&2
  cargo build --release --quiet --bin tandem
  "$py" "$here/ray_generate.py" --tandem target/release/tandem --count "$count" --cpus "$cpus" \
    --json target/peers/ray_generate.json
fi
