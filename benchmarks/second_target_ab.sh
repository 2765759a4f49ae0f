#!/bin/bash
# A/B of two uros checkouts on a second target of one real workspace (recorded in docs/benchmarks.md).
#
#   bash benchmarks/second_target_ab.sh WORKSPACE TARGET CHECKOUT_A CHECKOUT_B [ROUNDS]
#
# Each run removes TARGET's trees and output with `uros clean`, starts with an empty ccache (a second target's compiles
# all miss) and the workspace's warm generation cache (UROS_GEN_CACHE_DIR, when set), and builds with
# the Python of the checkout's .venv. Rounds go A B B A, so a machine that speeds up or slows down
# during the runs weighs on both. Prints wall seconds, user+system CPU seconds, the library's sha256
# and the number of files in the target's install tree. Compare only figures of one invocation.
set -euo pipefail
ws=$1 target=$2 a=$3 b=$4 rounds=${5:-2}
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
one() { # label checkout
  # uros's own clean: only the target's trees and the output uros wrote, never anything else
  "$2/.venv/bin/python" -m uros_build clean --toolchain "$target" --workspace "$ws" >/dev/null
  rm -rf "$scratch/ccache"
  mkdir "$scratch/ccache"
  local t0 t1
  t0=$(date +%s.%N)
  (cd "$2" && CCACHE_DIR="$scratch/ccache" PYTHONPATH="$2" /usr/bin/time -o "$scratch/time" -f "%U %S" \
    "$2/.venv/bin/python" -m uros_build build --toolchain "$target" --workspace "$ws" >"$scratch/$1.log" 2>&1) ||
    { cp "$scratch/$1.log" "/tmp/uros-ab-$1.log"; echo "$1 failed: /tmp/uros-ab-$1.log"; exit 1; }
  t1=$(date +%s.%N)
  printf '%s wall %.1f cpu %.1f lib %s install files %s\n' "$1" "$(echo "$t1 - $t0" | bc)" \
    "$(awk '{print $1 + $2}' "$scratch/time" | tail -1)" \
    "$(sha256sum "$ws/build/$target/libmicroros.a" | cut -c1-12)" \
    "$(find "$ws/.uros/targets/$target/install" -type f | wc -l)"
}
for _ in $(seq "$rounds"); do one A "$a"; one B "$b"; one B "$b"; one A "$a"; done
