#!/bin/bash
# Hard disks at 2^16 on the 2-core CPU (the CPU row's run: Δt 1e-3, two threads), interleaved between
# builds of different commits, each run bracketed by a cache line's round trip between CPUs 0 and 1
# (tools/bench/core_to_core.cpp: ~55 ns on one L3, ~320 ns across two). Each build runs its own
# tree's pipelines/hard-disks.yaml.
#   bench/experiments/session49/cpu_ab.sh ROUNDS TREE[:BUILD] ...   (BUILD default TREE/build)
# Prints per run: round, tree, probe before, steps/s, median ms, probe after, stage ms.
set -u
rounds=$1; shift
c2c=/tmp/c2c
[ -x $c2c ] || g++ -O2 -pthread "$(dirname "$0")/../../../tools/bench/core_to_core.cpp" -o $c2c
for r in $(seq 1 "$rounds"); do
  for spec in "$@"; do
    tree=${spec%%:*}; build=$tree/build; [[ $spec == *:* ]] && build=${spec#*:}
    a=$($c2c); res=$(mktemp -d)
    "$build/bin/pipeline" bench "$tree/pipelines/hard-disks.yaml" --device cpu --threads ${THREADS:-2} --sizes 65536 \
      --steps ${STEPS:-300} --warmup 200 --set run.dt=1e-3 --results "$res" 2>&1 | grep -E "^65536" | head -1 > "$res/row"
    b=$($c2c)
    printf "%s %s %s %s %s\n" "$r" "$(basename $tree)" "$a" "$b" "$(cat $res/row)"
    rm -rf "$res"
  done
done
