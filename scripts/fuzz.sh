#!/usr/bin/env bash
# Fuzzes one of tandem's parsers (or all of them) with libFuzzer:
#
#   scripts/fuzz.sh TARGET SECONDS [libFuzzer options...]
#   scripts/fuzz.sh all SECONDS          # every target, SECONDS each
#   scripts/fuzz.sh list                 # the targets
#
# Targets are the [[bin]]s of fuzz/Cargo.toml (sources in
# fuzz/fuzz_targets/). Builds with the stable toolchain: the same
# SanitizerCoverage instrumentation cargo-fuzz passes, without a
# sanitizer runtime (tandem has no unsafe code a sanitizer would watch
# beyond its SIMD kernels), with debug assertions and overflow checks.
# Each run starts from the seeds in fuzz/corpus/TARGET (committed) plus
# what earlier runs found in fuzz/corpus-found/TARGET (not committed);
# a crash, panic, timeout (> 10 s) or out-of-memory (> 2 GB) input is
# written to fuzz/artifacts/TARGET/ and the script exits non-zero.
# Prints the executions done per target. FUZZ_JOBS=N runs N targets of
# `all` at once; FUZZ_PROFILE=smoke builds at opt-level 1 (quicker to
# build, slower to run: for the few seconds of scripts/test.sh).
set -euo pipefail
cd "$(dirname "$0")/.."

targets() { sed -n 's/^name = "\(.*\)"$/\1/p' fuzz/Cargo.toml | grep -v '^tandem-fuzz$'; }

if [ "${1:-}" = "list" ]; then targets; exit 0; fi
if [ $# -lt 2 ]; then
  echo "usage: scripts/fuzz.sh TARGET|all SECONDS [libFuzzer options...]  (targets: $(targets | tr '\n' ' '))" >&2
  exit 2
fi
target=$1 seconds=$2
shift 2

host=$(rustc -vV | sed -n 's/^host: //p')
# What `cargo fuzz build --sanitizer none` passes (coverage-guided, with
# comparison tracing), plus debug assertions and overflow checks.
export RUSTFLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing -Cdebug-assertions -Coverflow-checks"
# --target keeps the flags off build scripts and proc macros.
profile=${FUZZ_PROFILE:-release}
cargo build --quiet --manifest-path fuzz/Cargo.toml --profile "$profile" --bins --target "$host" --target-dir fuzz/target
bin=fuzz/target/$host/$profile

run_one() {
  local t=$1
  shift
  [ -x "$bin/$t" ] || { echo "fuzz.sh: no target '$t' (have: $(targets | tr '\n' ' '))" >&2; return 2; }
  mkdir -p "fuzz/corpus-found/$t" "fuzz/artifacts/$t"
  local log
  log=$(mktemp)
  # Run from the repository root: relative paths in inputs resolve there.
  local status=0
  "$bin/$t" "fuzz/corpus-found/$t" "fuzz/corpus/$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -max_len=32768 -print_final_stats=1 -artifact_prefix="fuzz/artifacts/$t/" "$@" >"$log" 2>&1 || status=$?
  local runs took
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  took=$(sed -n 's/^Done [0-9]* runs in \([0-9]*\) second.*/\1/p' "$log" | tail -1)
  if [ $status -ne 0 ]; then
    grep -E "ERROR|panicked|Test unit written|SUMMARY" "$log" | head -20 >&2 || true
    echo "fuzz $t: FAILED after ${runs:-?} executions (log: $log)" >&2
    return 1
  fi
  echo "fuzz $t: ${runs:-?} executions in ${took:-$seconds} s, no crash, no hang"
  rm -f "$log"
}

if [ "$target" = "all" ]; then
  jobs=${FUZZ_JOBS:-1}
  failed=0
  if [ "$jobs" -le 1 ]; then
    for t in $(targets); do run_one "$t" "$@" || failed=1; done
  else
    pids=()
    for t in $(targets); do
      run_one "$t" "$@" & pids+=($!)
      while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do sleep 0.2; done
    done
    for p in "${pids[@]}"; do wait "$p" || failed=1; done
  fi
  exit $failed
fi
run_one "$target" "$@"
