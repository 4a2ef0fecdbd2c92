#!/usr/bin/env python3
"""Checks and publishes the outputs of scripts/reproduce.sh (see there).

  reproduce_check.py --new DIR --committed docs/results/quick --published docs
      compare a fresh quick run with the committed one, render every
      figure, and check the published figures and tables; exit 1 on any
      difference, naming the file and the first differing field.
  reproduce_check.py --publish docs
      copy the published figures from docs/results/ to docs/figures/ and
      write every table.txt into its block of docs/experiments.md.
"""

import argparse
import csv
import json
import math
import pathlib
import re
import subprocess
import sys
import tempfile

# Runs whose numbers depend on candle's CPU kernels or the policy network's
# (chosen by the CPU at run time), and traded's on the planning time it
# measures and charges: rendered and checked for their files, not their
# numbers.
CANDLE_RUNS = {"learned", "traded", "policy", "policy-centred"}

# Published figure (docs/figures/NAME) <- its source under docs/results/.
PUBLISHED_FIGURES = {
    "shared_control.svg": "demo/shared_control.svg",
    "planar.svg": "planar/planar.svg",
    "reach_grasp.svg": "reach-grasp/reach_grasp.svg",
    "reach_grasp_success.svg": "reach-grasp/reach_grasp_success.svg",
    "traded_accuracy.svg": "traded/traded_accuracy.svg",
    "learned_training.svg": "learned/training_curves.svg",
    "learned_authority.svg": "learned/authority.svg",
    "metric_field.svg": "figures/metric_field.svg",
    "policy.svg": "figures/policy.svg",
    "motion_limits.svg": "figures/motion_limits.svg",
    "motion_limits_off.svg": "figures/motion_limits_off.svg",
}

BLOCK = re.compile(r"<!-- reproduce: ([a-z-]+) -->\n```text\n(.*?)```\n<!-- /reproduce -->", re.S)

# Fields that are measurements of time, not results.
TIMING_KEYS = {"seconds", "elapsed", "cpu_seconds", "wall_seconds"}


def is_timing(key):
    return key in TIMING_KEYS or key.endswith(("_us", "_ms", "_seconds", "_per_second"))


class Mismatch(Exception):
    pass


def same_number(a, b):
    if isinstance(a, bool) or isinstance(b, bool):
        return a == b
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return a == b or abs(a - b) <= 1e-9 * max(abs(a), abs(b)) + 1e-12


def compare(a, b, where):
    if isinstance(a, dict) and isinstance(b, dict):
        keys = {k for k in a.keys() | b.keys() if not is_timing(k)}
        for k in sorted(keys):
            if k not in a or k not in b:
                raise Mismatch(f"{where}.{k}: present in only one of the runs")
            compare(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            raise Mismatch(f"{where}: {len(a)} entries, committed {len(b)}")
        for i, (x, y) in enumerate(zip(a, b)):
            compare(x, y, f"{where}[{i}]")
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)):
        if not same_number(a, b):
            raise Mismatch(f"{where}: {a!r}, committed {b!r}")
    elif a != b:
        raise Mismatch(f"{where}: {a!r}, committed {b!r}")


def cell(text):
    try:
        return float(text)
    except ValueError:
        return text


def load(path):
    if path.suffix == ".json":
        return json.loads(path.read_text())
    with path.open(newline="") as f:
        return [[cell(c) for c in row] for row in csv.reader(f)]


def render(svg, png):
    done = subprocess.run(["rsvg-convert", "-b", "white", str(svg), "-o", str(png)], capture_output=True, text=True)
    if done.returncode != 0 or not png.exists() or png.stat().st_size < 1000:
        raise Mismatch(f"{svg}: does not render ({done.stderr.strip() or 'empty image'})")
    return png.read_bytes()


def check(new, committed, published):
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        runs = sorted(p.name for p in committed.iterdir() if p.is_dir())
        if sorted(p.name for p in new.iterdir() if p.is_dir()) != runs:
            failures.append(f"runs differ: {sorted(p.name for p in new.iterdir())} against committed {runs}")
        figures = 0
        for run in runs:
            ours, theirs = new / run, committed / run
            names = sorted(str(p.relative_to(theirs)) for p in theirs.rglob("*") if p.is_file())
            fresh = sorted(str(p.relative_to(ours)) for p in ours.rglob("*") if p.is_file()) if ours.is_dir() else []
            if fresh != names:
                failures.append(f"{run}: files {fresh}, committed {names}")
                continue
            for name in names:
                a, b = ours / name, theirs / name
                try:
                    if a.suffix in (".json", ".csv") and run not in CANDLE_RUNS:
                        compare(load(a), load(b), f"{run}/{name}")
                    elif a.suffix == ".svg":
                        figures += 1
                        png_new = render(a, tmp / f"{run}-{a.stem}-new.png")
                        png_old = render(b, tmp / f"{run}-{a.stem}-committed.png")
                        if run not in CANDLE_RUNS and png_new != png_old:
                            raise Mismatch(f"{run}/{name}: renders differently from the committed figure")
                except Mismatch as e:
                    failures.append(str(e))
        print(f"quick runs: {len(runs)} compared, {figures} figures rendered")
    failures += check_published(published)
    if failures:
        print("error: the committed results are not what this binary writes:", file=sys.stderr)
        for f in failures:
            print(f"  {f}", file=sys.stderr)
        print("re-run scripts/reproduce.sh (and --quick) and commit docs/results and docs/figures", file=sys.stderr)
        return 1
    print("reproduction check passed")
    return 0


def check_published(docs):
    failures = []
    results = docs / "results"
    for figure, source in PUBLISHED_FIGURES.items():
        src, dst = results / source, docs / "figures" / figure
        if not src.exists():
            failures.append(f"{src}: missing (the source of docs/figures/{figure})")
        elif not dst.exists() or dst.read_bytes() != src.read_bytes():
            failures.append(f"docs/figures/{figure} is not {src}")
    text = (docs / "experiments.md").read_text()
    blocks = BLOCK.findall(text)
    if not blocks:
        failures.append("docs/experiments.md has no reproduce blocks")
    for run, table in blocks:
        source = results / run / "table.txt"
        if not source.exists() or source.read_text() != table:
            failures.append(f"docs/experiments.md: the '{run}' table is not {source}")
    return failures


def publish(docs):
    results = docs / "results"
    for figure, source in PUBLISHED_FIGURES.items():
        src = results / source
        if src.exists():
            (docs / "figures" / figure).write_bytes(src.read_bytes())
    path = docs / "experiments.md"

    def table(m):
        source = results / m.group(1) / "table.txt"
        body = source.read_text() if source.exists() else m.group(2)
        return f"<!-- reproduce: {m.group(1)} -->\n```text\n{body}```\n<!-- /reproduce -->"

    path.write_text(BLOCK.sub(table, path.read_text()))
    failures = check_published(docs)
    for f in failures:
        print(f"warning: {f}", file=sys.stderr)
    return 0


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--new", type=pathlib.Path)
    parser.add_argument("--committed", type=pathlib.Path)
    parser.add_argument("--published", type=pathlib.Path)
    parser.add_argument("--publish", type=pathlib.Path)
    args = parser.parse_args()
    if args.publish:
        return publish(args.publish)
    if not (args.new and args.committed and args.published):
        parser.error("--new, --committed and --published go together")
    return check(args.new, args.committed, args.published)


if __name__ == "__main__":
    sys.exit(main())
