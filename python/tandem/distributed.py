"""Bulk generation over a Ray cluster, byte-identical to ``tandem generate``.

>>> import tandem.distributed
>>> summary = tandem.distributed.generate(
...     "problems/panda_grasp_family.toml", count=100_000, seed=7, out="dataset")
>>> summary["manifest"]["accepted"]

Every part file still missing from ``out`` (``chunk_size`` ids each) is one
Ray task. A task generates its part with the same Rust code as the command
line — as shard ``k`` of ``K`` (``K`` parts), in a temporary folder on the
node that runs it — and returns the file's bytes; the driver writes them
into ``out`` (atomically: a part exists whole or not at all) and, once every
part is there, writes ``_manifest.json`` with the Rust generator itself. A
dataset depends on (family, count, seed, horizon, chunk size, attempts,
budget) only, not on where or in which order parts were made, so the result
is the dataset ``tandem generate`` writes, byte for byte (``_timings/``, the
wall-clock times, excepted). An interrupted run resumes: call it again with
the same arguments and only the missing parts are computed.

Cluster: by default a local Ray cluster on this machine's cores (or the one
``ray.init`` already started in this process); ``address="ray://host:10001"``
or ``"auto"`` joins an existing one. Every node needs the ``tandem`` package
and the family file (and the problem and robot files it names) at the same
path as the driver — a shared or identical checkout. Each node's
``_dataset.json`` is compared with the driver's, so a node holding another
version of the family is refused rather than mixed in.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from typing import Any, Callable, Optional, Union

from . import _native
from ._native import DatasetError

ProgressCallback = Callable[[dict], None]


def _generate_part(family: str, settings: dict, part: int, parts: int, threads: int) -> dict:
    """Ray task: part ``part`` of ``parts`` generated in a temporary folder;
    returns its files' bytes and counts."""
    with tempfile.TemporaryDirectory(prefix="tandem-part-") as tmp:
        summary = _native.generate(family, tmp, threads=threads, shard=(part, parts), **settings)
        names = [n for n in os.listdir(tmp) if n.startswith("part-") and n.endswith(".parquet")]
        if len(names) != 1:
            raise DatasetError(f"part {part}: expected one part file in {tmp}, found {sorted(names)}")
        timings = os.listdir(os.path.join(tmp, "_timings"))

        def read(*path: str) -> bytes:
            with open(os.path.join(tmp, *path), "rb") as f:
                return f.read()

        manifest = summary["manifest"]
        return {
            "file": names[0],
            "part": read(names[0]),
            "timings": [(name, read("_timings", name)) for name in timings],
            "dataset": read("_dataset.json"),
            "samples": manifest["samples"],
            "accepted": manifest["accepted"],
            "node": os.uname().nodename,
        }


def _write_atomically(path: str, data: bytes) -> None:
    """Writes ``data`` to a hidden temporary name, flushes it to disk, then
    renames it into place (the Rust generator's convention)."""
    folder, name = os.path.split(path)
    temporary = os.path.join(folder, f".{name}.tmp")
    with open(temporary, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(temporary, path)


def _print_progress(p: dict) -> None:
    rate = p["samples_done"] / max(p["elapsed_s"], 1e-9)
    eta = (p["samples_total"] - p["samples_done"]) / max(rate, 1e-9)
    sys.stderr.write(
        f"tandem.distributed: {p['parts_done']}/{p['parts_total']} parts, "
        f"{p['samples_done']}/{p['samples_total']} samples ({p['accepted']} accepted) "
        f"in {p['elapsed_s']:.0f} s · {rate:.1f} samples/s · ETA {eta:.0f} s\n"
    )
    sys.stderr.flush()


def generate(
    family_path: Union[str, os.PathLike],
    *,
    count: int,
    out: Union[str, os.PathLike],
    seed: int = 0,
    horizon: Optional[int] = None,
    chunk_size: int = 100,
    attempts: int = 3,
    max_evaluations: int = 200,
    initial_guess: str = "planned",
    cpus_per_task: int = 1,
    address: Optional[str] = None,
    init_kwargs: Optional[dict] = None,
    max_in_flight: Optional[int] = None,
    progress: Union[bool, ProgressCallback] = True,
) -> dict:
    """Generates (or completes) the dataset of samples ``0 … count − 1`` of
    a problem family in ``out`` over Ray; the same files and bytes as
    ``tandem generate --family F --count N --seed S --out DIR`` with the
    same ``horizon`` (``-T``), ``chunk_size``, ``attempts``,
    ``max_evaluations`` and ``initial_guess`` (``--initial-guess``).

    ``cpus_per_task``: CPUs each part claims from Ray, and the threads it
    runs on. ``address``: a Ray cluster to join (default: the one already
    initialised in this process, else a new local one); ``init_kwargs``:
    more arguments of ``ray.init`` (e.g. ``num_cpus``). ``max_in_flight``:
    parts submitted at once (default: twice the cluster's task slots).
    ``progress``: a line on stderr per finished part (True), nothing
    (False), or a callable receiving ``{"parts_done", "parts_total",
    "samples_done", "samples_total", "accepted", "elapsed_s"}``.

    Returns the summary of the final manifest pass (as
    :func:`tandem.generate`: ``{"manifest": {...}, ...}``) with this run's
    ``"distributed"`` figures: parts and samples computed, wall-clock
    seconds, and the parts each node made. Raises :class:`tandem.DatasetError`
    (or :class:`tandem.ProblemError` for a bad family) before any work for
    bad settings or a folder holding another dataset.
    """
    began = time.monotonic()
    family = os.path.abspath(os.fspath(family_path))
    folder = os.path.abspath(os.fspath(out))
    settings: dict[str, Any] = dict(
        count=count,
        seed=seed,
        horizon=horizon,
        chunk_size=chunk_size,
        attempts=attempts,
        max_evaluations=max_evaluations,
        initial_guess=initial_guess,
    )
    if cpus_per_task < 1:
        raise DatasetError(f"cpus_per_task must be at least 1, got {cpus_per_task}")
    missing = _native.missing_parts(family, folder, **settings)
    report = _print_progress if progress is True else (progress or None)
    nodes: dict[str, int] = {}
    samples_done = 0
    if missing:
        samples_done = _run_parts(
            family, folder, settings, missing, cpus_per_task, address, init_kwargs, max_in_flight, report, nodes, began
        )
    summary = _native.generate(family, folder, threads=1, **settings)
    summary["distributed"] = {
        "parts_computed": len(missing),
        "samples_computed": samples_done,
        "elapsed_s": time.monotonic() - began,
        "parts_by_node": nodes,
    }
    return summary


def _run_parts(
    family: str,
    folder: str,
    settings: dict,
    missing: list,
    cpus_per_task: int,
    address: Optional[str],
    init_kwargs: Optional[dict],
    max_in_flight: Optional[int],
    report: Optional[ProgressCallback],
    nodes: dict,
    began: float,
) -> int:
    """Runs the missing parts as Ray tasks, writing each into ``folder`` as
    it arrives; returns the number of samples computed."""
    import ray

    started = False
    if not ray.is_initialized():
        ray.init(address=address, **(init_kwargs or {}))
        started = True
    try:
        with open(os.path.join(folder, "_dataset.json"), "rb") as f:
            expected = f.read()
        count, chunk_size = settings["count"], settings["chunk_size"]
        parts = _native.part_count(count=count, chunk_size=chunk_size)
        samples = 0
        for k in missing:
            first, end = _native.part_ids(k, count=count, chunk_size=chunk_size)
            samples += end - first
        slots = max(1, int(ray.cluster_resources().get("CPU", 1)) // cpus_per_task)
        window = max_in_flight or 2 * slots
        task = ray.remote(num_cpus=cpus_per_task)(_generate_part)
        queue = list(missing)
        running: dict[Any, int] = {}
        progress: dict[str, Any] = {
            "parts_done": 0,
            "parts_total": len(missing),
            "samples_done": 0,
            "samples_total": samples,
            "accepted": 0,
            "elapsed_s": 0.0,
        }
        try:
            while queue or running:
                while queue and len(running) < window:
                    k = queue.pop(0)
                    running[task.remote(family, settings, k, parts, cpus_per_task)] = k
                [ready], _ = ray.wait(list(running), num_returns=1)
                k = running.pop(ready)
                result = ray.get(ready)
                if result["dataset"] != expected:
                    raise DatasetError(
                        f"node {result['node']} generated part {k} with other run parameters "
                        f"(its _dataset.json differs from {folder}/_dataset.json: another version of "
                        f"the family or of tandem?)"
                    )
                for name, data in result["timings"]:
                    _write_atomically(os.path.join(folder, "_timings", name), data)
                _write_atomically(os.path.join(folder, result["file"]), result["part"])
                nodes[result["node"]] = nodes.get(result["node"], 0) + 1
                progress["parts_done"] += 1
                progress["samples_done"] += result["samples"]
                progress["accepted"] += result["accepted"]
                progress["elapsed_s"] = time.monotonic() - began
                if report:
                    report(dict(progress))
        finally:
            for ref in running:
                ray.cancel(ref)
        return int(progress["samples_done"])
    finally:
        if started:
            ray.shutdown()
