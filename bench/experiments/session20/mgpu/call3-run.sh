#!/usr/bin/env bash
# mgpu (branch mgpu): decomposed teams on 2 GPUs.   bash run.sh BUNDLE OUT   (< 3 min, 2 GPUs)
# Makes copies of BUNDLE with files of this folder swapped in (xz; stripped; rpath like the
# bundle's; nothing in BUNDLE changes). Built from branch mgpu:
#   bin/test_decomposition, bin/test_decomposition_delaunay, bin/pipeline, plugins/
#   libflipflow_stage_overlap_correct.so: d01b117;  A/libflipflow.so: 0992694 (device-side
#   refresh, host migration);  B/libflipflow.so: 7ef5663 (A + migration on the device, no upload
#   after a host refresh).
# Variants: old = BUNDLE + the new test binaries (the one-GPU test against main's code: its hard
# spheres must FAIL); stage = old + the stage's fix; A, B = all of it with core A or B.
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
OUT=$T/mgpu-logs  # every log; at the end: the essentials to stdout, all of it as RES/mgpu.tgz
mkdir -p "$OUT"
finish() {
  echo "===== info"
  cat "$OUT/info.txt"
  for f in "$OUT"/test-*.txt; do
    [[ -f $f ]] || continue
    echo "===== ${f##*/}"
    grep -E "^(All tests passed|test cases:|assertions:)|FAILED|SKIPPED|No test|with expansion|due to unexpected|^  [A-Za-z0-9]" "$f" | head -40
  done
  for f in "$OUT"/lj-*.txt "$OUT"/hs-*.txt "$OUT"/abp-*.txt; do
    [[ -f $f ]] || continue
    echo "===== ${f##*/}"
    grep -v "^NCCL version" "$f" | head -30
  done
  tar -czf "$RES/mgpu.tgz" -C "$T" mgpu-logs
  rm -rf "$T"
}
trap finish EXIT
{ nvidia-smi -L; echo "nccl=${FLIPFLOW_NCCL_LIBRARY:-loader}"; } > "$OUT/info.txt" 2>&1
un() { xz -dc "$H/$1.xz" > "$2" && chmod +x "$2"; }
for v in old stage A B; do
  cp -a "$B" "$T/$v"
  un bin/test_decomposition "$T/$v/bin/test_decomposition"
  un bin/test_decomposition_delaunay "$T/$v/bin/test_decomposition_delaunay"
done
for v in stage A B; do un plugins/libflipflow_stage_overlap_correct.so "$T/$v/plugins/libflipflow_stage_overlap_correct.so"; done
for v in A B; do
  un $v/libflipflow.so "$T/$v/lib/libflipflow.so"
  un bin/pipeline "$T/$v/bin/pipeline"
done
echo "shadows ready t=$SECONDS" >> "$OUT/info.txt"

v_one='decomposition: 2 and 3 ranks on one GPU*'
v_two='decomposition: 2 and 4 GPUs give one GPU*'
d_one='decomposed Delaunay: 2 ranks on one GPU*'
d_two='decomposed Delaunay: 2 and 4 GPUs give one GPU*'
left() { ((SECONDS <= 172 - $1)) || { echo "$2 skipped (time) t=$SECONDS" >> "$OUT/info.txt"; return 1; }; }
tst() {  # variant log limit binary test-names...
  local v=$1 log=$2 lim=$3 bin=$4
  shift 4
  left "$lim" "$log" || return 1
  mkdir -p "$T/scratch-$log"
  (cd "$T/scratch-$log" && FLIPFLOW_TEST_DATA="$T/$v/tests/data" timeout "$lim" "$T/$v/bin/$bin" -w NoTests "$@") \
    > "$OUT/$log.txt" 2>&1
  local rc=$?
  echo "$log rc=$rc t=$SECONDS" >> "$OUT/info.txt"
  return $rc
}
bench() {  # variant log limit args...
  local v=$1 log=$2 lim=$3
  shift 3
  left "$lim" "$log" || return 1
  timeout "$lim" "$T/$v/bin/pipeline" bench "$@" --results "$T/results" > "$OUT/$log.txt" 2>&1
  local rc=$?
  echo "$log rc=$rc t=$SECONDS" >> "$OUT/info.txt"
  return $rc
}
lj=tests/data/decomp-lj.yaml
hs=tests/data/decomp-hard-spheres.yaml
ok=1
tst B test-B-verlet 40 test_decomposition "$v_one,$v_two" || ok=0
tst B test-B-delaunay 45 test_decomposition_delaunay "$d_one,$d_two" || ok=0
# issue 21's weak scaling, 2^20 a GPU (main a5fc649: 1 GPU 0.217 ms; 2 GPUs 28.56 ms median, 9.68 steps/s)
bench B lj-2-B 35 "$T/B/$lj" --gpus 2 --sizes 2097152 --steps 100 --warmup 20 || ok=0
tst old test-old 25 test_decomposition "$v_one"
if ((ok == 0)); then  # B failed somewhere: the same with core A (host migration)
  tst A test-A-verlet 40 test_decomposition "$v_one,$v_two"
  bench A lj-2-A 35 "$T/A/$lj" --gpus 2 --sizes 2097152 --steps 50 --warmup 10
  tst A test-A-delaunay 45 test_decomposition_delaunay "$d_one,$d_two"
fi
bench B hs-2-B 30 "$T/B/$hs" --gpus 2 --sizes 2097152 --steps 50 --warmup 10
bench B lj-1-B 15 "$T/B/$lj" --sizes 1048576 --steps 100 --warmup 20
tst stage test-stage 20 test_decomposition "$v_one"
bench B abp-2-B 20 "$T/B/pipelines/bench-abp.yaml" --gpus 2 --sizes 2097152 --steps 10 --warmup 2
echo "done t=$SECONDS" >> "$OUT/info.txt"
