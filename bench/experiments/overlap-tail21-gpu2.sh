#!/bin/bash
# tail21, second request (short: ~105 s, hard stop 125 s): the committed change of branch tail21
# (5c48a6e: kGroupBelow Threads/8 and the tail's claims counted in shared memory; "new" in
# variants2.tar.xz, ABI 5, rpath $ORIGIN/../lib:$ORIGIN/../../lib) as a plain plugin:
#   bash run2.sh BUNDLE OUT      (OUT/summary2.txt, OUT/tail21-2.tgz)
# (1) its CPU == CUDA bit tests from a shadow bundle (two run-tests processes, ~50 s):
#     test_overlap_correct_cpu_cuda; test_overlap_correct test_overlap_correct_walls;
# (2) then bench-abp 2^20, 100 steps after 3000, main (the bundle's plugins) and new, one each
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
    grep -h -E "^(PASS|FAIL)|passed,|exit " "$L"/tests-*.txt 2>/dev/null; } > "$OUT/summary2.txt"
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
wait
echo "tests done t=$SECONDS" >> "$I"
pack
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
