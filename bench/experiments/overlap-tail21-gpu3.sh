#!/bin/bash
# tail21, third request (tests only, ~55 s, hard stop 100 s): the bits of 0631497 (the tail's
# check issues its claims' atomics at once, claim_checked) as a plain plugin ("batch" in
# variants3.tar.xz, ABI 5, rpath $ORIGIN/../lib:$ORIGIN/../../lib), from a shadow bundle:
#   bash run3.sh BUNDLE OUT      (OUT/summary3.txt)
# FLIPFLOW_TEST_DEVICE=cuda run-tests test_overlap_correct_cpu_cuda | test_overlap_correct
# test_overlap_correct_walls, two processes side by side. Not needed if the merged suite with
# 0631497 in it runs instead.
set -uo pipefail
SECONDS=0
B=$(cd "${1:?BUNDLE}" && pwd)
OUT=${2:?OUT}
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
W=$(mktemp -d "${TMPDIR:-/tmp}/tail21c.XXXXXX")
trap 'rm -rf "$W"' EXIT
unset FLIPFLOW_PLUGIN_PATH
mkdir -p "$W/v" "$W/sb"
tar xJf "$HERE/variants3.tar.xz" -C "$W/v"
cp -r "$B/bin" "$B/lib" "$B/tests" "$B/plugins" "$B/test-plugins" "$B/pipelines" "$W/sb/"
cp "$W/v/batch/libflipflow_stage_overlap_correct.so" "$W/sb/plugins/"
{ head -n 1 "$B/.flipflow-bundle"; md5sum "$W/sb/plugins/libflipflow_stage_overlap_correct.so" | sed "s|$W/||"; } > "$OUT/summary3.txt"
(cd "$W/sb" && FLIPFLOW_TEST_DEVICE=cuda timeout 95 bin/run-tests test_overlap_correct_cpu_cuda > "$W/t1.txt" 2>&1; echo "exit $? t=$SECONDS" >> "$W/t1.txt") &
(cd "$W/sb" && FLIPFLOW_TEST_DEVICE=cuda timeout 95 bin/run-tests test_overlap_correct test_overlap_correct_walls > "$W/t2.txt" 2>&1; echo "exit $? t=$SECONDS" >> "$W/t2.txt") &
wait
cat "$W/t1.txt" "$W/t2.txt" >> "$OUT/summary3.txt"
