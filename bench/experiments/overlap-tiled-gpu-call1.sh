#!/bin/bash
# octile3 (issue 20 item 3): overlap_correct `scheme: tiled` on CUDA, GPU request 1.
#
#   bash gpu-carry/octile3/run.sh BUNDLE OUT      (BUNDLE: the lead's bundle of main, ABI 5)
#
# A shadow bundle: the branch's plugin variants (gzipped here, rpath $ORIGIN/../../lib) and its
# test_overlap_correct_cpu_cuda go to BUNDLE/octile3/{<variant>,bin}; FLIPFLOW_PLUGIN_PATH puts a
# variant's plugin before the bundle's. Variants (libflipflow_stage_overlap_correct.so each):
#   head:   branch octile3 cfea0b0 (skip + the cells in three grid barriers a step instead of six)
#   skip:   3aa615b (shared + quiet tiles not run again)
#   shared: 0587f96 (tiles of <= 1536 members run their inner iterations in shared memory)
#   prof:   head + globaltimer stamps of block 0 per phase, printed at exit ("tiled profile")
# Questions:
#   1. bits: do the CUDA loops of scheme: tiled give the CPU's bits? test_overlap_correct_cpu_cuda
#      "[tiled]" (3000-150000 particles, tiles 128-4096, inner 1-8, walls x/y, mark, float,
#      max_iterations 1-3, 150 ABP steps, corrupt meshes) with head and skip; shared if both fail;
#   2. speed: bench-abp at 2^14 and 2^20, jacobi vs tiled (tile 1024, inner 4) shared / skip / head,
#      interleaved, 2 rounds (overlap_correct ms a step; global iterations a step);
#   3. where a tiled step's time goes (prof): 1024x4 and 256x4;
#   4. the jacobi cases of the same binary with head (time permitting).
# Logs in OUT: bits-*.txt, bench.txt. Under 3 minutes (each part has a timeout; later parts check SECONDS).
set -uo pipefail
SECONDS=0
C=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
B=$(cd "$1" && pwd)
OUT=$2
mkdir -p "$OUT"
S=$B/octile3
mkdir -p "$S/bin"
for v in head skip shared prof; do
  mkdir -p "$S/$v"
  gzip -dc "$C/$v.so.gz" > "$S/$v/libflipflow_stage_overlap_correct.so"
done
gzip -dc "$C/test_overlap_correct_cpu_cuda.gz" > "$S/bin/test_overlap_correct_cpu_cuda"
chmod +x "$S/bin/test_overlap_correct_cpu_cuda"
export FLIPFLOW_TEST_DATA=$B/tests/data  # repo_file: $B/pipelines/abp.yaml
T=$S/bin/test_overlap_correct_cpu_cuda
RES=$(mktemp -d)
nvidia-smi -L | tee "$OUT/bench.txt"

bits() {  # variant, seconds, test filter
  local v=$1 secs=$2 filter=$3
  echo "== bits: $v \"$filter\" (at ${SECONDS} s)"
  FLIPFLOW_PLUGIN_PATH=$S/$v:$B/plugins timeout "$secs" "$T" "$filter" > "$OUT/bits-$v.txt" 2>&1
  local rc=$?
  echo "exit $rc after ${SECONDS} s" >> "$OUT/bits-$v.txt"
  grep -E "FAILED|^  [A-Za-z0-9(].*$|passed|failed|^exit" "$OUT/bits-$v.txt" | grep -v "^  SKIPPED" | head -60
  return $rc
}
echo "== 1. bits: scheme tiled, CPU == CUDA"
bits head 60 "[tiled]"
rc_head=$?
rc_skip=0
((SECONDS < 50)) && { bits skip 45 "[tiled]"; rc_skip=$?; }
((rc_head != 0 && rc_skip != 0 && SECONDS < 90)) && bits shared 40 "[tiled]"

bench() {  # variant, name, then --set arguments
  local v=$1 name=$2
  shift 2
  echo "-- $name ($v)" | tee -a "$OUT/bench.txt"
  FLIPFLOW_PLUGIN_PATH=$S/$v:$B/plugins timeout 30 "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda \
    --sizes 16384,1048576 --steps 200 --warmup 20 --results "$RES" "$@" > "$RES/out.txt" 2>&1
  local rc=$?
  grep -E "^[0-9]|overlap_correct/(iterations|pairs) per|tiled profile" "$RES/out.txt" | tee -a "$OUT/bench.txt"
  ((rc == 0)) || { echo "bench $name: exit $rc" | tee -a "$OUT/bench.txt"; tail -5 "$RES/out.txt" | tee -a "$OUT/bench.txt"; }
}
tiled=(--set step.overlap_correct.scheme=tiled)
echo "== 2. speed: bench-abp, jacobi vs tiled, interleaved (at ${SECONDS} s)"
bench head "round 1 jacobi" --set step.overlap_correct.scheme=jacobi
bench head "round 1 tiled 1024x4" "${tiled[@]}"
bench skip "round 1 tiled 1024x4" "${tiled[@]}"
bench shared "round 1 tiled 1024x4" "${tiled[@]}"
((SECONDS < 130)) && bench prof "tiled 1024x4" "${tiled[@]}"
((SECONDS < 140)) && bench head "round 2 jacobi" --set step.overlap_correct.scheme=jacobi
((SECONDS < 145)) && bench head "round 2 tiled 1024x4" "${tiled[@]}"
((SECONDS < 150)) && bench skip "round 2 tiled 1024x4" "${tiled[@]}"
((SECONDS < 155)) && bench prof "tiled 256x4" "${tiled[@]}" --set step.overlap_correct.tile=256
echo "after ${SECONDS} s" | tee -a "$OUT/bench.txt"

if ((SECONDS < 150)); then
  echo "== 4. bits: the plugin's jacobi path (the binary's other cases, head)"
  FLIPFLOW_PLUGIN_PATH=$S/head:$B/plugins timeout $((172 - SECONDS)) "$T" "~[tiled]" > "$OUT/bits-jacobi.txt" 2>&1
  echo "exit $? after ${SECONDS} s" >> "$OUT/bits-jacobi.txt"
  tail -4 "$OUT/bits-jacobi.txt"
fi
rm -rf "$RES"
echo "total: ${SECONDS} s"
