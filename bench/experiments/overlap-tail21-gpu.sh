#!/bin/bash
# tail21 (issue 20, the row "bench-abp 2^20, 100 steps after 3000 warm-up steps"): where
# overlap_correct's ~1.09 ms a step goes in the clustered state, and variants of its late iterations.
#   bash run.sh BUNDLE OUT      (about 160 s; every command has a timeout; OUT/tail21.tgz + OUT/summary.txt)
# variants.tar.xz (branch tail21 = main 656d022 + the patches named below; ABI 5; rpath
# $ORIGIN/../lib:$ORIGIN/../../lib, so each loads from a shadow bundle's plugins/ or from a folder
# two below a bundle root):
#   ab     ONE plugin holding 14 variants of the kernel (bench/experiments/overlap-tail21-ab.patch):
#          in the windows of steps FF_TAIL21_WINDOWS (here 20:100 and 3000:3200) every variant runs
#          every step from the same saved positions, in an order rotated step by step; prints
#          each one's ms a step (median, and the median of its step-by-step difference with main),
#          iterations, and whether its positions, image counts and counters equal the step's first
#          run; plus the phase profile of main's kernel (block 0's globaltimer per iteration k:
#          gather, barriers, apply, check; tail or not; candidates, moved). The bench's own numbers
#          in that run are meaningless (14 runs a step in the windows).
#          variants: main (kTailMoved 512, kGroupBelow Threads/2), t128, t2048, t8192 (kTailMoved),
#          g32 (kGroupBelow Threads/8: lane groups only when one pass of 32 does a block's work),
#          g32t2048, sclaim (the tail's claims counted in block 0's shared memory, not a global
#          atomic), shash (the tail's claims in a shared-memory hash set: no global atomics in the
#          tail's check), g32shash, t0 (never the tail), t1024, g64 (kGroupBelow
#          Threads/4), g32sclaim, profile (main + the phase profile).
#   g32    the plain plugin with kGroupBelow = Threads / 8 (one constant changed)
#   shash  the plain plugin with the shared hash set in the tail (bench/experiments/overlap-tail21-shared-set.patch:
#          the clean source a merge would take; the ab plugin's shash is the same logic)
# Order: (1) the CPU == CUDA bit tests of g32 and shash from shadow bundles (4 run-tests
# processes in the background, ~60 s); (2) at 30 s the ab run starts (its first ~20 s are the
# CPU set-up, so its GPU windows come after the tests); (3) bench-abp 2^20 100 steps after 3000
# for main (the bundle's own plugins), g32, shash, then main again while time is left. A bench
# takes ~26 s (set-up ~20 s + 3000 steps; session 20's final call: 26 s), so each has timeout
# min(40, what is left of 175 s) and starts only with at least 28 s left.
set -uo pipefail
SECONDS=0
B=$(cd "${1:?BUNDLE}" && pwd)
OUT=${2:?OUT}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
W=$(mktemp -d "${TMPDIR:-/tmp}/tail21.XXXXXX")
L=$W/logs
mkdir -p "$L" "$W/r/v" "$W/results"
trap 'rm -rf "$W"' EXIT
unset FLIPFLOW_PLUGIN_PATH
I=$L/info.txt
pack() {
  { echo "== info"; cat "$I"; echo "== bench rows"; grep -H -E "^1048576|iterations per|pairs per" "$L"/bench-*.txt 2>/dev/null
    echo "== tests"; grep -h -E "^(PASS|FAIL)|passed,|exit " "$L"/tests-*.txt 2>/dev/null
    echo "== ab"; grep -v -E "^ +[a-z_.]+/|^pipeline " "$L/ab.txt" 2>/dev/null | head -c 20000; } > "$OUT/summary.txt"
  (cd "$W" && tar czf "$OUT/tail21.tgz.part" logs && mv "$OUT/tail21.tgz.part" "$OUT/tail21.tgz")
}
ln -s "$B/lib" "$W/r/lib"
tar xJf "$HERE/variants.tar.xz" -C "$W/r/v"
{
  nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm,temperature.gpu --format=csv,noheader 2>&1
  head -n 1 "$B/.flipflow-bundle"
  md5sum "$B/plugins/libflipflow_stage_overlap_correct.so" "$W"/r/v/*/*.so | sed "s|$W/||"
} > "$I"
shadow() {  # the bundle with the variant's overlap_correct in plugins/
  local d=$W/sb-$1
  mkdir -p "$d"
  cp -r "$B/bin" "$B/lib" "$B/tests" "$B/plugins" "$B/test-plugins" "$B/pipelines" "$d/"
  cp "$W/r/v/$1/libflipflow_stage_overlap_correct.so" "$d/plugins/"
}
for v in g32 shash; do shadow $v; done
echo "shadows t=$SECONDS" >> "$I"
for v in g32 shash; do
  (cd "$W/sb-$v" && FLIPFLOW_TEST_DEVICE=cuda timeout 110 bin/run-tests test_overlap_correct_cpu_cuda \
     > "$L/tests-$v-cpu_cuda.txt" 2>&1; echo "exit $? t=$SECONDS" >> "$L/tests-$v-cpu_cuda.txt") &
  (cd "$W/sb-$v" && FLIPFLOW_TEST_DEVICE=cuda timeout 110 bin/run-tests test_overlap_correct test_overlap_correct_walls \
     > "$L/tests-$v-walls.txt" 2>&1; echo "exit $? t=$SECONDS" >> "$L/tests-$v-walls.txt") &
done
sleep 30
echo "ab start t=$SECONDS" >> "$I"
FLIPFLOW_PLUGIN_PATH=$W/r/v/ab FF_TAIL21_WINDOWS=20:100,3000:3200 timeout 70 "$B/bin/pipeline" bench \
  "$B/pipelines/bench-abp.yaml" --device cuda --sizes 1048576 --steps 100 --warmup 3000 --results "$W/results" \
  > "$L/ab.txt" 2>&1
echo "ab rc=$? t=$SECONDS" >> "$I"
wait
echo "tests done t=$SECONDS" >> "$I"
pack
bench() {  # bench NAME PLUGIN_DIR ('' = the bundle's own)
  local lim=$((175 - SECONDS))
  ((lim > 40)) && lim=40
  if ((lim < 28)); then echo "bench $1 skipped t=$SECONDS" >> "$I"; return; fi
  FLIPFLOW_PLUGIN_PATH=$2 timeout $lim "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda \
    --sizes 1048576 --steps 100 --warmup 3000 --results "$W/results" > "$L/bench-$1.txt" 2>&1
  echo "bench $1 rc=$? t=$SECONDS" >> "$I"
  pack
}
bench main-1 ""
bench g32-1 "$W/r/v/g32"
bench shash-1 "$W/r/v/shash"
bench main-2 ""
echo "done t=$SECONDS" >> "$I"
pack
