#!/bin/bash
# (Kept for the record: variants.tar.xz held the plugins of branch maint20 at 83673aa (v1) and v1 +
# the v2 patches of this folder.)
# maint20 (issue 20: delaunay.detect_inversion, delaunay.lawson, abp.integrate at 2^20), call 1.
#   bash run1.sh BUNDLE OUT        (<= ~175 s; every step has its own timeout; writes OUT/run1.txt)
# Unpacks variants.tar.xz (next to this script) into BUNDLE/m20/:
#   v1/  libflipflow_stage_delaunay.so + libflipflow_plugin_abp.so of branch maint20 (all changes,
#        bit-neutral: vector loads of quads and points, position_prev written by detect's marking
#        loop, detect's counters published by its last block (the loop strides with one grid of
#        resident blocks), Lawson's tail counting in shared memory, abp's Gaussian pairs drawn
#        before truncation, u01 and quadrant_sincos without int->double conversions);
#   v2/  v1 + MarkInversions at 8 blocks/SM (32 registers, 36 B spills) + abp.integrate at 6 blocks/SM (40
#        registers, 52 B of spills) + Lawson's grid round without the fill between apply and mark
#        (apply's element 0 clears the marked count; decide keeps it for apply);
#   (rpath $ORIGIN/../../lib; FLIPFLOW_PLUGIN_PATH puts them before BUNDLE/plugins).
# 1. bits with v1 (and v2), the tests in parallel (~15-20 s);
# 2. bench-abp 2^14 and 2^20 (100 steps after 20), main / v1 / v2 interleaved, two rounds while
#    the time lasts (main and v1 first in each round).
set -uo pipefail
SECONDS=0
B=$(cd "${1:?BUNDLE}" && pwd)
OUT=${2:?OUT}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
V=$B/m20
mkdir -p "$V"
tar xJf "$HERE/variants.tar.xz" -C "$V" 2>/dev/null ||
  python3 -c "import tarfile, sys; tarfile.open(sys.argv[1]).extractall(sys.argv[2])" "$HERE/variants.tar.xz" "$V"
export FLIPFLOW_TEST_DATA=$B/tests/data
R=$OUT/run1.txt
bench() {  # bench NAME(main|v1|v2) TIMEOUT
  local name=$1
  if [[ $name == main ]]; then unset FLIPFLOW_PLUGIN_PATH; else export FLIPFLOW_PLUGIN_PATH=$V/$name; fi
  echo "== bench-abp $name (from ${SECONDS} s)"
  timeout "$2" "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda --sizes 16384,1048576 --steps 100 \
    --warmup 20 --results "$OUT/results-$name" 2>&1 | grep -E "^[0-9]|lawson_candidates per|lawson_flips per|lawson_rounds per|iterations per|pairs per|rror" | head -16
  unset FLIPFLOW_PLUGIN_PATH
}
{
  nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv,noheader
  cat "$B/.flipflow-bundle" 2>/dev/null | head -3
  for v in v1 v2; do
    FLIPFLOW_PLUGIN_PATH=$V/$v "$B/bin/pipeline" stages > "$OUT/stages-$v.txt" 2>&1 || { echo "$v does not load:"; tail -3 "$OUT/stages-$v.txt"; }
  done
  # 1. the tests (CPU == CUDA), each in its own folder, in the background
  mkdir -p "$OUT/tests"
  (
    for t in test_cpu_cuda_bits test_delaunay_lawson test_delaunay_detect_inversion test_delaunay_flip test_abp_integrate \
             test_boids_delaunay test_rollback_restores; do
      mkdir -p "$OUT/tests/v1-$t"
      (cd "$OUT/tests/v1-$t" && FLIPFLOW_PLUGIN_PATH=$V/v1 FLIPFLOW_TEST_DEVICE=cuda timeout 45 "$B/bin/$t" "~[long]" \
        > log.txt 2>&1; echo "rc=$?" >> log.txt) &
    done
    for t in test_cpu_cuda_bits test_abp_integrate test_delaunay_detect_inversion test_delaunay_lawson; do
      mkdir -p "$OUT/tests/v2-$t"
      (cd "$OUT/tests/v2-$t" && FLIPFLOW_PLUGIN_PATH=$V/v2 FLIPFLOW_TEST_DEVICE=cuda timeout 45 "$B/bin/$t" "~[long]" \
        > log.txt 2>&1; echo "rc=$?" >> log.txt) &
    done
    wait
  ) &
  tests=$!
  wait $tests
  echo "== tests (done at ${SECONDS} s)"
  for d in "$OUT"/tests/*; do
    echo "$(basename "$d"): $(grep -E "All tests passed|test cases? failed|assertions.*failed" "$d/log.txt" | tail -1) $(tail -1 "$d/log.txt")"
    grep -B2 -A12 "FAILED" "$d/log.txt" | head -30
  done
  # 2. interleaved rounds (a bench of both sizes is ~25-30 s, mostly the 2^20 set-up); stop
  #    starting benches once one more could end past ~175 s
  for round in 1 2; do
    for v in main v1 v2; do
      ((SECONDS + 30 < 175)) || break 2
      bench $v 40
    done
  done
  echo "total: ${SECONDS} s"
} 2>&1 | tee "$R"
