"""Every ```python block of the README and docs/ runs, so that the examples
users copy cannot go stale. Each block runs in a fresh namespace from a
temporary working directory (files it writes land there), with the
repository's relative paths (problems/…) reachable through a symlink."""

import os
import re
import shutil
from pathlib import Path

import pytest

from conftest import REPO

DOCS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def blocks():
    for doc in DOCS:
        text = doc.read_text()
        for m in BLOCK.finditer(text):
            line = text[: m.start()].count("\n") + 2
            yield pytest.param(doc, line, m.group(1), id=f"{doc.relative_to(REPO)}:{line}")


@pytest.fixture(scope="module", autouse=True)
def fresh_docs_scratch():
    """The pages write under /tmp/tandem-docs: start from nothing, so that
    what an older tandem left there (a dataset the examples would resume)
    does not decide the run."""
    shutil.rmtree("/tmp/tandem-docs", ignore_errors=True)


def test_the_docs_have_python_examples():
    assert sum(1 for _ in blocks()) >= 5


@pytest.mark.parametrize(("doc", "line", "code"), list(blocks()))
def test_python_block_runs(doc, line, code, tmp_path, monkeypatch):
    (tmp_path / "problems").symlink_to(REPO / "problems")
    (tmp_path / "examples").symlink_to(REPO / "examples")
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__docs__"}
    exec(compile(code, f"{doc}:{line}", "exec"), namespace)
