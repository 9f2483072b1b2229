#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Servo-step benchmark: callgrind instruction count, then host timing and the budget table.
# usage: bench.sh BENCH_BIN STEPS CG_STEPS OUT_DIR
set -eu
bin=$1 steps=$2 cg_steps=$3 out=$4
command -v valgrind >/dev/null || { echo "bench: valgrind not found" >&2; exit 1; }
t0=$(date +%s.%N)
valgrind --tool=callgrind --toggle-collect=hg_servo_step \
    --callgrind-out-file="$out/callgrind.out" "$bin" "$cg_steps" 2>"$out/callgrind.log"
t1=$(date +%s.%N)
ir=$(awk '/^(summary|totals):/ { print $2; exit }' "$out/callgrind.out")
[ -n "$ir" ] || { echo "bench: no instruction count in $out/callgrind.out" >&2; exit 1; }
"$bin" "$steps" "$ir" "$cg_steps" "$(awk "BEGIN { print $t1 - $t0 }")"
