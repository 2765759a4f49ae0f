#!/bin/bash
# Where a second target's CPU goes (recorded in docs/benchmarks.md).
#
#   bash benchmarks/second_target_perf.sh WORKSPACE TARGET OUTDIR
#
# Builds TARGET in WORKSPACE as a new target (its .uros/targets/TARGET and build/TARGET folders are
# removed first; ccache gets an empty folder of its own, so every compile misses, as on a new
# target), with `uros` from PATH, under system-wide `perf record` (97 Hz, every core), and prints
# the samples per program (`perf report --sort comm -n`; one sample is ~10 ms of one core's time).
# The generation cache stays as it is: run it once before to measure a second target with it warm.
set -euo pipefail
ws=${1:?WORKSPACE}; target=${2:?TARGET}; out=${3:?OUTDIR}
command -v perf >/dev/null || { echo "perf not found: apt-get install linux-perf" >&2; exit 2; }
mkdir -p "$out"
rm -rf "$ws/.uros/targets/$target" "$ws/build/$target"
CCACHE_DIR=$(mktemp -d)
export CCACHE_DIR
trap 'rm -rf "$CCACHE_DIR"' EXIT
perf record -F 97 -a -g -o "$out/perf.data" -- \
  /usr/bin/time -f "total wall %e cpu %U+%S" uros build --toolchain "$target" --workspace "$ws" \
  > "$out/build.out" 2>&1
grep -E 'colcon built|interface code|configure:|ccache:|total wall' "$out/build.out" || true
LC_ALL=C perf report -i "$out/perf.data" --sort comm --stdio --no-children -g none -n 2>/dev/null \
  | grep -v '^#' | grep -v '^$' | head -20
