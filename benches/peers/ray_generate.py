"""Throughput of bulk generation over Ray against the command line with the
same cores: ``tandem generate --threads C`` and ``tandem.distributed.generate``
on a local Ray cluster of C CPUs (one part per task, one thread each), the
same family, count, seed and horizon. Run by compare_python.sh (release
builds of both).

    python ray_generate.py --tandem target/release/tandem [--count N] [--cpus C] [-T T] [--chunk-size K] [--json out.json]

Reports samples/s of each and the engine's overhead in %: Ray's wall time
over the CLI's, minus 1, with and without starting the cluster, and the same
for CPU time (user + system, of the CLI process, and of the driver and every
process it started — GCS, raylet, workers — during the run; Linux /proc), the
fairer figure on a shared machine, where Ray's processes (a session of their
own) and the CLI get different shares of the cores. Checks that the two
datasets are byte-identical (timings excepted).
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import ray
import tandem.distributed

REPO = Path(__file__).resolve().parents[2]
FAMILY = REPO / "problems" / "panda_grasp_family.toml"


def descendants_cpu_s(root=None):
    """CPU seconds (user + system) of this process and every live descendant."""
    tick = os.sysconf("SC_CLK_TCK")
    stats = {}
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        stats[int(pid)] = (int(fields[1]), (int(fields[11]) + int(fields[12])) / tick)  # ppid, utime + stime
    root = root or os.getpid()
    total, todo = 0.0, [root]
    while todo:
        pid = todo.pop()
        total += stats.get(pid, (0, 0.0))[1]
        todo.extend(child for child, (ppid, _) in stats.items() if ppid == pid)
    return total


def files(folder):
    return {p.name: p.read_bytes() for p in sorted(Path(folder).iterdir()) if p.is_file()}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tandem", type=Path, required=True, help="the tandem binary (release)")
    parser.add_argument("--count", type=int, default=2000)
    parser.add_argument("--cpus", type=int, default=2)
    parser.add_argument("-T", "--horizon", type=int, default=50)
    parser.add_argument("--chunk-size", type=int, default=100, help="ids per part (one Ray task each)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    run = dict(count=args.count, seed=args.seed, horizon=args.horizon, chunk_size=args.chunk_size)

    with tempfile.TemporaryDirectory() as tmp:
        cli_out, ray_out = Path(tmp) / "cli", Path(tmp) / "ray"
        began, cpu_began = time.monotonic(), resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run(
            [args.tandem, "generate", "--family", FAMILY, "--out", cli_out, "--count", str(args.count),
             "--seed", str(args.seed), "-T", str(args.horizon), "--chunk-size", str(args.chunk_size),
             "--threads", str(args.cpus), "--quiet"],
            check=True,
            stdout=subprocess.DEVNULL,
        )
        cli_s = time.monotonic() - began
        cpu_end = resource.getrusage(resource.RUSAGE_CHILDREN)
        cli_cpu = (cpu_end.ru_utime - cpu_began.ru_utime) + (cpu_end.ru_stime - cpu_began.ru_stime)

        began = time.monotonic()
        ray.init(address="local", num_cpus=args.cpus, include_dashboard=False, log_to_driver=False)
        init_s = time.monotonic() - began
        began, cpu_began = time.monotonic(), descendants_cpu_s()
        summary = tandem.distributed.generate(FAMILY, out=ray_out, progress=False, **run)
        ray_s = time.monotonic() - began
        ray_cpu = descendants_cpu_s() - cpu_began
        ray.shutdown()
        identical = files(cli_out) == files(ray_out)

    result = {
        "count": args.count, "cpus": args.cpus, "horizon": args.horizon, "chunk_size": args.chunk_size,
        "accepted": summary["manifest"]["accepted"], "cli_s": cli_s, "ray_s": ray_s, "ray_init_s": init_s,
        "cli_samples_per_s": args.count / cli_s, "ray_samples_per_s": args.count / ray_s,
        "overhead_percent": 100 * (ray_s / cli_s - 1), "overhead_with_init_percent": 100 * ((ray_s + init_s) / cli_s - 1),
        "cli_cpu_s": cli_cpu, "ray_cpu_s": ray_cpu, "cpu_overhead_percent": 100 * (ray_cpu / cli_cpu - 1),
        "identical": identical,
    }
    print(f"{args.count} samples, T = {args.horizon}, {args.cpus} CPUs, parts of {args.chunk_size}:")
    print(f"  tandem generate --threads {args.cpus}: {cli_s:6.1f} s  {result['cli_samples_per_s']:6.1f} samples/s")
    print(f"  tandem.distributed (Ray):      {ray_s:6.1f} s  {result['ray_samples_per_s']:6.1f} samples/s"
          f"  (+ {init_s:.1f} s ray.init)")
    print(f"  CPU time: CLI {cli_cpu:.1f} s, Ray {ray_cpu:.1f} s (driver, GCS, raylet, workers)")
    print(f"  overhead: wall {result['overhead_percent']:+.1f} % ({result['overhead_with_init_percent']:+.1f} % with ray.init),"
          f" CPU {result['cpu_overhead_percent']:+.1f} %; datasets byte-identical: {identical}")
    if args.json:
        args.json.write_text(json.dumps(result, indent=1))
    if not identical:
        sys.exit("the Ray dataset differs from the CLI's")


if __name__ == "__main__":
    main()
