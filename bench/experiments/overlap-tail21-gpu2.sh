#!/bin/bash
# tail21, second request (short: ~115 s, hard stop 125 s; TAIL21_SHORT=1: ~60 s, no benches):
# variants2.tar.xz (ABI 5, rpath $ORIGIN/../lib:$ORIGIN/../../lib):
#   new  the committed change of branch tail21 as a plain plugin (5c48a6e: kGroupBelow Threads/8
#        and the tail's claims counted in shared memory)
#   ab2  the A/B plugin again (bench/experiments/overlap-tail21-ab2.patch): main, g32sclaim (= new),
#        g32batch (new + the tail's checks issue their claims' atomics all at once instead of one
#        neighbour after the other), g32shash, t128g32sclaim, t128g32batch, and the phase profile of
#        g32sclaim; windows 20:60 and 3000:3200 of one bench process
#   bash run2.sh BUNDLE OUT      (OUT/summary2.txt, OUT/tail21-2.tgz)
# (1) new's CPU == CUDA bit tests from a shadow bundle (two run-tests processes, ~50 s):
#     test_overlap_correct_cpu_cuda; test_overlap_correct test_overlap_correct_walls;
# (2) at 30 s the ab2 run (its first ~20 s are the CPU set-up; ~28 s in all, timeout 60);
# (3) then bench-abp 2^20, 100 steps after 3000, main (the bundle's plugins) and new, one each
#     (~27 s each; each starts only with 28 s left of 125 s).
set -uo pipefail
SECONDS=0
B=$(cd "${1:?BUNDLE}" && pwd)
OUT=${2:?OUT}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
W=$(mktemp -d "${TMPDIR:-/tmp}/tail21b.XXXXXX")
L=$W/logs2
mkdir -p "$L" "$W/r/v" "$W/results"
trap 'rm -rf "$W"' EXIT
unset FLIPFLOW_PLUGIN_PATH
I=$L/info.txt
pack() {
  { cat "$I"; grep -H -E "^1048576|iterations per" "$L"/bench-*.txt 2>/dev/null
    grep -h -E "^(PASS|FAIL)|passed,|exit " "$L"/tests-*.txt 2>/dev/null
    grep -v -E "^ +[a-z_.]+/|^pipeline " "$L/ab2.txt" 2>/dev/null | head -c 16000; } > "$OUT/summary2.txt"
  (cd "$W" && tar czf "$OUT/tail21-2.tgz.part" logs2 && mv "$OUT/tail21-2.tgz.part" "$OUT/tail21-2.tgz")
}
ln -s "$B/lib" "$W/r/lib"
tar xJf "$HERE/variants2.tar.xz" -C "$W/r/v"
{ nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv,noheader 2>&1; head -n 1 "$B/.flipflow-bundle"
  md5sum "$B/plugins/libflipflow_stage_overlap_correct.so" "$W"/r/v/*/*.so | sed "s|$W/||"; } > "$I"
d=$W/sb-new
mkdir -p "$d"
cp -r "$B/bin" "$B/lib" "$B/tests" "$B/plugins" "$B/test-plugins" "$B/pipelines" "$d/"
cp "$W/r/v/new/libflipflow_stage_overlap_correct.so" "$d/plugins/"
(cd "$d" && FLIPFLOW_TEST_DEVICE=cuda timeout 100 bin/run-tests test_overlap_correct_cpu_cuda > "$L/tests-cpu_cuda.txt" 2>&1
 echo "exit $? t=$SECONDS" >> "$L/tests-cpu_cuda.txt") &
(cd "$d" && FLIPFLOW_TEST_DEVICE=cuda timeout 100 bin/run-tests test_overlap_correct test_overlap_correct_walls \
   > "$L/tests-walls.txt" 2>&1; echo "exit $? t=$SECONDS" >> "$L/tests-walls.txt") &
sleep 30
echo "ab2 start t=$SECONDS" >> "$I"
FLIPFLOW_PLUGIN_PATH=$W/r/v/ab2 FF_TAIL21_WINDOWS=20:60,3000:3200 timeout 60 "$B/bin/pipeline" bench \
  "$B/pipelines/bench-abp.yaml" --device cuda --sizes 1048576 --steps 100 --warmup 3000 --results "$W/results" \
  > "$L/ab2.txt" 2>&1
echo "ab2 rc=$? t=$SECONDS" >> "$I"
wait
echo "tests done t=$SECONDS" >> "$I"
pack
[[ ${TAIL21_SHORT:-0} == 1 ]] && { echo "short: no benches" >> "$I"; pack; exit 0; }
bench() {  # bench NAME PLUGIN_DIR ('' = the bundle's own)
  local lim=$((125 - SECONDS))
  ((lim > 40)) && lim=40
  if ((lim < 28)); then echo "bench $1 skipped t=$SECONDS" >> "$I"; return; fi
  FLIPFLOW_PLUGIN_PATH=$2 timeout $lim "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda \
    --sizes 1048576 --steps 100 --warmup 3000 --results "$W/results" > "$L/bench-$1.txt" 2>&1
  echo "bench $1 rc=$? t=$SECONDS" >> "$I"
  pack
}
bench main ""
bench new "$W/r/v/new"
echo "done t=$SECONDS" >> "$I"
pack
