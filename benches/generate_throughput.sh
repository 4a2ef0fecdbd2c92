#!/usr/bin/env bash
# Throughput and memory of bulk generation, in one run: `tandem generate` on
# problems/panda_grasp_family.toml at T = 50 with 1 and with 2 threads (same
# seed and ids), then a larger run for peak memory. Prints samples/s,
# accepted/s, the 1 → 2 thread speed-up, peak resident memory, and checks
# that the 1- and 2-thread datasets are byte-identical.
#
#   benches/generate_throughput.sh [--count N] [--memory-count M] [--seed S]
#
#   --count N         samples per throughput run (default 1000)
#   --memory-count M  samples of the memory run with all threads (default 10000; 0 skips it)
#
# Writes target/peers/generate.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/.." && pwd)"
die() { echo "${0##*/}: error: $*" >&2; exit 1; }
count=1000 memory_count=10000 seed=1
while (( $# )); do
  case "$1" in
    --count) count="${2:?--count needs a value}"; shift 2 ;;
    --memory-count) memory_count="${2:?--memory-count needs a value}"; shift 2 ;;
    --seed) seed="${2:?--seed needs a value}"; shift 2 ;;
    *) die "unknown argument $1 (see the usage at the top of $0)" ;;
  esac
done
[[ -x /usr/bin/time ]] || die "/usr/bin/time is needed for peak memory (Debian: apt install time)"
cd "$repo"
cargo build --release --quiet
tandem="$repo/target/release/tandem"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

run() {  # run LABEL COUNT THREADS: one generate run, summary as JSON on stdout
  local label=$1 n=$2 threads=$3 out="$work/$1"
  /usr/bin/time -f '%M %e' -o "$work/$label.time" "$tandem" generate --family problems/panda_grasp_family.toml \
    --count "$n" -T 50 --seed "$seed" --threads "$threads" --out "$out" --quiet --json >"$work/$label.json"
  read -r rss_kib wall <"$work/$label.time"
  python3 - "$work/$label.json" "$label" "$n" "$threads" "$rss_kib" "$wall" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
label, n, threads, rss, wall = sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5]), float(sys.argv[6])
print(json.dumps({"label": label, "count": n, "threads": threads, "wall_s": wall,
                  "samples_per_s": n / wall, "accepted_per_s": m["accepted"] / wall,
                  "accepted": m["accepted"], "rejected_by_reason": m["rejected_by_reason"],
                  "peak_rss_mib": rss / 1024}))
PY
}

load_before="$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo '?')"
echo "== $count samples, 1 thread" >&2
one="$(run one "$count" 1)"
echo "== $count samples, 2 threads" >&2
two="$(run two "$count" 2)"
cmp -s <(cd "$work/one" && cat part-*.parquet _manifest.json) <(cd "$work/two" && cat part-*.parquet _manifest.json) \
  && identical=true || identical=false
memory='null'
if (( memory_count > 0 )); then
  echo "== $memory_count samples, all threads (peak memory)" >&2
  memory="$(run memory "$memory_count" "$(nproc)")"
fi
load_after="$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo '?')"
mkdir -p target/peers
python3 - "$one" "$two" "$memory" "$identical" "$load_before" "$load_after" <<'PY'
import json, sys
one, two, memory = json.loads(sys.argv[1]), json.loads(sys.argv[2]), json.loads(sys.argv[3])
identical, before, after = sys.argv[4] == "true", sys.argv[5], sys.argv[6]
print(f"load average before {before}, after {after}")
print("| run | samples | threads | wall s | samples/s | accepted/s | accepted | peak memory |")
print("| --- | --- | --- | --- | --- | --- | --- | --- |")
for r in [one, two] + ([memory] if memory else []):
    print(f"| {r['label']} | {r['count']} | {r['threads']} | {r['wall_s']:.1f} | {r['samples_per_s']:.1f} | "
          f"{r['accepted_per_s']:.1f} | {r['accepted']} | {r['peak_rss_mib']:.1f} MiB |")
print(f"speed-up 1 → 2 threads: {two['samples_per_s'] / one['samples_per_s']:.2f}x; "
      f"1- and 2-thread datasets byte-identical: {identical}")
json.dump({"one_thread": one, "two_threads": two, "memory": memory, "identical": identical,
           "load_before": before, "load_after": after}, open("target/peers/generate.json", "w"), indent=1)
if not identical:
    sys.exit("the 1- and 2-thread datasets differ")
PY
