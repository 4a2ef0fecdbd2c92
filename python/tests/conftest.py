"""Shared fixtures of tandem's Python tests (run by scripts/test.sh).

Pinocchio and example-robot-data come from python_ref/.venv (the test
environment python/.venv sees its packages); a missing one fails the tests,
it never skips them.
"""

import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PANDA_URDF = REPO / "problems" / "robots" / "panda" / "panda.urdf"
GRASP_FAMILY = REPO / "problems" / "panda_grasp_family.toml"


def erd_share() -> Path:
    """The folder holding example-robot-data's ``robots/``: the wheel
    installs it under ``site-packages/cmeel.prefix/share``, next to
    Pinocchio's Python package."""
    import pinocchio

    prefix = Path(pinocchio.__file__).resolve().parents[4]
    share = prefix / "share"
    if not (share / "example-robot-data" / "robots").is_dir():
        pytest.fail(f"example-robot-data not found under {share}; install python_ref/requirements.txt")
    return share


@pytest.fixture(scope="session")
def erd_panda():
    """(URDF path, package folder) of example-robot-data's Panda."""
    share = erd_share()
    return share / "example-robot-data" / "robots" / "panda_description" / "urdf" / "panda.urdf", share


@pytest.fixture(scope="session")
def tandem_cli() -> Path:
    """The ``tandem`` command-line binary: $TANDEM_BIN (set by
    scripts/test.sh), else target/debug/tandem built by cargo."""
    path = Path(os.environ.get("TANDEM_BIN", REPO / "target" / "debug" / "tandem"))
    if not path.is_file():
        subprocess.run(["cargo", "build", "--quiet", "--bin", "tandem"], cwd=REPO, check=True)
    if not path.is_file():
        pytest.fail(f"no tandem binary at {path}")
    return path
