"""`tandem ros2` through DDS on loopback: command in -> command out latency,
CPU per tick, late ticks and memory, at 100 Hz and 1 kHz.

Run with the reference environment's Python after a release build:
    cargo build --release --features ros2
    python_ref/.venv/bin/python benches/ros2_node.py [--seconds 20]

A Cyclone DDS process (python_ref/ros2_robot.py, scenario "latency") plays
the robot (/joint_states at 250 Hz) and the operator (TwistStamped at
50 Hz, each with a unique stamp). The latency of a command is the time from
its write until the diagnostics of the first tick that used it (published
right after that tick's command) arrive back in the operator's process:
command in, waiting for the next tick, the tick, command out, and DDS both
ways. CPU is the node's user + system time over the run divided by its
ticks; memory is its peak resident set (VmHWM).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
BIN = REPO / "target/release/tandem"


def cpu_seconds(pid):
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def peak_rss_mb(pid):
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def percentile(values, p):
    s = sorted(values)
    return s[min(len(s) - 1, int(round(p / 100 * (len(s) - 1))))]


def measure(rate, seconds, domain):
    with tempfile.TemporaryDirectory() as tmp:
        config = Path(tmp) / "node.yaml"
        config.write_text(f"domain_id: {domain}\nrate_hz: {rate}\nmode: sos\n")
        node = subprocess.Popen([BIN, "ros2", "--json", "--config", config], stdout=subprocess.PIPE, text=True)
        try:
            ready = json.loads(node.stdout.readline())
            cpu0 = cpu_seconds(node.pid)
            request = {
                "domain": domain, "ready": ready, "urdf": str(REPO / "problems/robots/panda/panda.urdf"),
                "command_out": "trajectory", "out_topic": "/joint_trajectory_controller/joint_trajectory",
                "node": "/tandem", "scenario": "latency", "seconds": seconds, "command_hz": 50,
            }
            robot = subprocess.run([sys.executable, REPO / "python_ref/ros2_robot.py"], input=json.dumps(request),
                                   capture_output=True, text=True, check=True)
            cpu1 = cpu_seconds(node.pid)
            rss = peak_rss_mb(node.pid)
        finally:
            node.terminate()
        report = json.loads(node.stdout.readline())
        node.wait()
    seen = json.loads(robot.stdout)
    latency_ms = [1e3 * x for x in seen["latency_s"]]
    return {
        "rate_hz": rate,
        "commands": len(latency_ms),
        "unanswered": seen["unanswered"],
        "latency_median_ms": statistics.median(latency_ms),
        "latency_p99_ms": percentile(latency_ms, 99),
        "tick_median_us": report["tick_us"]["median"],
        "tick_p99_us": report["tick_us"]["p99"],
        "cpu_per_tick_us": 1e6 * (cpu1 - cpu0) / max(1, report["ticks"]),
        "ticks": report["ticks"],
        "late_ticks": report["late_ticks"],
        "peak_rss_mb": rss,
    }


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=20.0)
    args = parser.parse_args()
    if not BIN.is_file():
        sys.exit(f"{BIN} is missing: cargo build --release --features ros2")
    rows = [measure(rate, args.seconds, 60 + k) for k, rate in enumerate((100, 1000))]
    print("| loop | commands | latency median | latency p99 | tick median | tick p99 | CPU per tick | late ticks | peak RSS |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['rate_hz']} Hz | {r['commands']} | {r['latency_median_ms']:.2f} ms | {r['latency_p99_ms']:.2f} ms | "
              f"{r['tick_median_us']:.1f} µs | {r['tick_p99_us']:.1f} µs | {r['cpu_per_tick_us']:.0f} µs | "
              f"{r['late_ticks']} of {r['ticks']} | {r['peak_rss_mb']:.1f} MB |")
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
