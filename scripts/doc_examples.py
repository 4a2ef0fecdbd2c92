#!/usr/bin/env python3
"""Runs every ```sh block of docs/*.md with bash (-e, pipefail) from the
repository's root, `tandem` being the binary given (its folder first on
PATH), and fails naming the page and line of the first block that fails.

  scripts/doc_examples.py target/release/tandem

The README's ```sh blocks (clone, install, the test command itself, the
page's server) are not run here: tests/docs.rs checks that every tandem
command in them parses, and the commands themselves are the tests'."""

import os
import pathlib
import re
import shutil
import subprocess
import sys
import time

REPO = pathlib.Path(__file__).resolve().parents[1]
BLOCK = re.compile(r"^```sh\n(.*?)^```", re.S | re.M)
DOCS_SCRATCH = "/tmp/tandem-docs"


def main():
    if len(sys.argv) != 2 or not os.access(sys.argv[1], os.X_OK):
        sys.exit("usage: doc_examples.py PATH/TO/tandem")
    binary = pathlib.Path(sys.argv[1]).resolve()
    env = dict(os.environ, PATH=f"{binary.parent}:{os.environ['PATH']}")
    # The pages write under /tmp/tandem-docs; start from nothing, so that
    # what an older tandem left there (a dataset the examples would resume)
    # does not decide the run.
    shutil.rmtree(DOCS_SCRATCH, ignore_errors=True)
    failures, count = [], 0
    for page in sorted((REPO / "docs").glob("*.md")):
        text = page.read_text()
        for m in BLOCK.finditer(text):
            line = text[: m.start()].count("\n") + 2
            count += 1
            start = time.monotonic()
            done = subprocess.run(["bash", "-euo", "pipefail", "-c", m.group(1)], cwd=REPO, env=env,
                                  capture_output=True, text=True)
            where = f"{page.relative_to(REPO)}:{line}"
            if done.returncode != 0:
                failures.append(f"{where}: exit {done.returncode}\n{done.stderr.strip()[-2000:]}")
            print(f"{where}: exit {done.returncode} in {time.monotonic() - start:.1f} s")
    if failures:
        print(f"error: {len(failures)} of {count} shell examples failed:", file=sys.stderr)
        print("\n".join(failures), file=sys.stderr)
        return 1
    print(f"{count} shell examples ran")
    return 0


if __name__ == "__main__":
    sys.exit(main())
