#!/usr/bin/env bash
# Creates the Python environment of the planning and trajectory-optimization
# peers, benches/peers/.venv: RAI (PyPI `robotic`: its RRT_PathFinder and its
# KOMO), OMPL (PyPI `ompl`, RRTConnect), Pinocchio + coal (PyPI `pin`, the OMPL
# peer's collision checker) and casadi (with the IPOPT it ships), pinned.
# Kept apart from python_ref/.venv, which CI installs for the cross-check tests.
#
#   benches/peers/setup_peers.sh
#
# System requirement: RAI's wheel links LAPACK (liblapack.so.3), which a
# slim Debian/Ubuntu lacks:   apt-get install -y liblapack3   (as root).
# Env:
#   PEERS_VENV=path   venv to create or update (default: benches/peers/.venv)
#   PYTHON=python3    interpreter the venv is made from (3.9 ... 3.13)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
venv="${PEERS_VENV:-$here/.venv}"
python="${PYTHON:-python3}"
die() { echo "${0##*/}: error: $*" >&2; exit 1; }

if ! { ldconfig -p 2>/dev/null || /sbin/ldconfig -p 2>/dev/null; } | grep -q 'liblapack\.so\.3'; then
  die "LAPACK (liblapack.so.3) not found: RAI's 'robotic' wheel needs it.
  On Debian/Ubuntu install it with:   apt-get install -y liblapack3   (as root)"
fi
command -v "$python" >/dev/null || die "$python not found (set PYTHON=...)"
[[ -x "$venv/bin/python" ]] || "$python" -m venv "$venv" || die "cannot create the venv $venv"
"$venv/bin/python" -m pip install --quiet robotic==0.4.2 ompl==2.0.1 pin==4.1.0 numpy==2.4.6 \
  casadi==3.8.2 \
  || die "pip install failed"
# (in a scratch folder: importing robotic writes a log file z.log.global there)
(cd "$(mktemp -d)" && "$venv/bin/python" - <<'PY') || die "the peers do not import (see above)"
import robotic, ompl, pinocchio, coal, numpy, casadi
from ompl import base, geometric
import os, sys
from importlib.metadata import version
sys.stderr.write(f"peers ready: robotic {version('robotic')} | ompl {version('ompl')} | "
                 f"pin {version('pin')} | coal {version('coal')} | casadi {version('casadi')}\n")
sys.stderr.flush()
os._exit(0)  # skip the bindings' leak reports at shutdown
PY
echo "venv: $venv" >&2
