#!/usr/bin/env bash
# mgpu, last call (~15:05): does branch mgpu pass the decomposed-team and team GPU tests on 2
# GPUs, and its weak scaling.    bash final.sh BUNDLE OUT    (~60-75 s, 2 GPUs)
# final/*.xz: libflipflow.so (0f16631: the branch's head core), the overlap_correct stage .so,
# pipeline, test_decomposition, test_decomposition_delaunay, test_team (15d25da; unchanged
# since), stripped, rpath like the bundle's. A copy of BUNDLE with them swapped in; BUNDLE is
# not touched. If a test fails with 0f16631's core, test_decomposition runs again with
# B/libflipflow.so (7ef5663: the core without 0f16631's snapshot change).
# Stdout: the essentials; OUT/mgpu-final.tgz: every log.
set -uo pipefail
(($# == 2)) || { echo "usage: $0 BUNDLE OUT" >&2; exit 2; }
B=$(cd "$1" && pwd) || exit 2
mkdir -p "$2" && RES=$(cd "$2" && pwd) || exit 2
H=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
SECONDS=0
export NCCL_NVLS_ENABLE=0 NCCL_DEBUG=WARN  # never NVLink multicast
unset FLIPFLOW_PLUGIN_PATH
for d in /usr/local/cuda/lib64 /usr/lib/x86_64-linux-gnu; do
  [[ -z ${FLIPFLOW_NCCL_LIBRARY:-} && -f $d/libnccl.so.2 ]] && export FLIPFLOW_NCCL_LIBRARY=$d/libnccl.so.2
done
T=$(mktemp -d "${TMPDIR:-/tmp}/mgpu.XXXXXX")
OUT=$T/mgpu-final
mkdir -p "$OUT"
finish() {
  echo "===== info"
  cat "$OUT/info.txt"
  for f in "$OUT"/test-*.txt; do
    [[ -f $f ]] || continue
    echo "===== ${f##*/}"
    grep -E "^(All tests passed|test cases:|assertions:)|FAILED|SKIPPED|No test|with expansion|due to unexpected|^  [A-Za-z0-9]" "$f" | head -30
  done
  for f in "$OUT"/lj-*.txt "$OUT"/hs-*.txt; do
    [[ -f $f ]] || continue
    echo "===== ${f##*/}"
    grep -v "^NCCL version" "$f" | head -30
  done
  tar -czf "$RES/mgpu-final.tgz" -C "$T" mgpu-final
  rm -rf "$T"
}
trap finish EXIT
{ nvidia-smi -L; echo "nccl=${FLIPFLOW_NCCL_LIBRARY:-loader}"; } > "$OUT/info.txt" 2>&1
S=$T/bundle
cp -a "$B" "$S"
un() { xz -dc "$H/final/$1.xz" > "$2" && chmod +x "$2"; }
un libflipflow.so "$S/lib/libflipflow.so"
un libflipflow_stage_overlap_correct.so "$S/plugins/libflipflow_stage_overlap_correct.so"
for b in pipeline test_decomposition test_decomposition_delaunay test_team; do un $b "$S/bin/$b"; done
echo "bundle ready t=$SECONDS" >> "$OUT/info.txt"

tst() {  # log limit binary filter
  mkdir -p "$T/scratch-$1"
  (cd "$T/scratch-$1" && FLIPFLOW_TEST_DATA="$S/tests/data" timeout "$2" "$S/bin/$3" -w NoTests "$4") > "$OUT/$1.txt" 2>&1
  local rc=$?
  echo "$1 rc=$rc t=$SECONDS" >> "$OUT/info.txt"
  return $rc
}
# The GPU cases: 2 GPUs through NCCL (the 4-GPU halves skip on 2) and ranks sharing one GPU.
tst test-decomposition 30 test_decomposition '*GPU*'
ok=$?
tst test-decomposition-delaunay 40 test_decomposition_delaunay '*GPU*' || ok=1
tst test-team 30 test_team '*GPU*' || ok=1
if ((ok != 0)); then  # the same test_decomposition with the core before the snapshot change
  xz -dc "$H/B/libflipflow.so.xz" > "$S/lib/libflipflow.so"
  tst test-decomposition-7ef5663 30 test_decomposition '*GPU*'
  un libflipflow.so "$S/lib/libflipflow.so"
fi
# Weak scaling, 2^20 a GPU (main a5fc649: 1 GPU 0.217 ms; 2 GPUs 28.56 ms median, 9.68 steps/s)
if ((SECONDS < 55)); then
  timeout 28 "$S/bin/pipeline" bench "$S/tests/data/decomp-lj.yaml" --gpus 2 --sizes 2097152 --steps 100 \
    --warmup 20 --results "$T/results" > "$OUT/lj-2.txt" 2>&1
  echo "lj-2 rc=$? t=$SECONDS" >> "$OUT/info.txt"
fi
if ((SECONDS < 72)); then
  timeout 12 "$S/bin/pipeline" bench "$S/tests/data/decomp-hard-spheres.yaml" --gpus 2 --sizes 2097152 \
    --steps 30 --warmup 5 --results "$T/results" > "$OUT/hs-2.txt" 2>&1
  echo "hs-2 rc=$? t=$SECONDS" >> "$OUT/info.txt"
fi
echo "done t=$SECONDS" >> "$OUT/info.txt"
