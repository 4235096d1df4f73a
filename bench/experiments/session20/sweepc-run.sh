#!/bin/bash
# Sweep row (issue 20): 64 runs of bench-abp 2^14 sharing one GPU; overlap_correct's cluster when
# runs share: main 16 x 512 (16 SMs) vs 16 x 256 (8 SMs, 2 blocks an SM) vs 8 x 512 (8 SMs),
# interleaved, 2 rounds; then the winner's bits (test_overlap_correct_cpu_cuda in a shadow bundle).
#   bash run.sh BUNDLE OUT
set -u
SECONDS=0
find "$(dirname "${BASH_SOURCE[0]}")" -name "*.so.gz" -exec gunzip -kf {} \;
C=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd); B=$(cd "$1" && pwd); O=$2; mkdir -p $O
for r in 1 2; do
  for v in main c16x256 c8x512; do
    ((SECONDS > 110)) && break 2
    pp=; [[ $v != main ]] && pp=$C/$v
    rm -rf /tmp/swc
    s=$(FLIPFLOW_PLUGIN_PATH=$pp CUDA_VISIBLE_DEVICES=0 timeout 40 $B/bin/pipeline sweep $B/pipelines/bench-abp.yaml --device cuda \
      --set system.N=16384 --set run.steps=5000 --replicas 64 --concurrent 64 --in-process --out /tmp/swc 2>&1 | tail -1)
    echo "round $r $v: $s t=$SECONDS" | tee -a $O/sweep.txt
  done
done
for v in c16x256 c8x512; do
  ((SECONDS > 150)) && break
  S=/tmp/shadow-$v; rm -rf $S; mkdir -p $S; cp -r $B/bin $B/lib $B/tests $B/plugins $B/test-plugins $S/ 2>/dev/null
  cp $B/.flipflow-bundle $S/ 2>/dev/null
  cp $C/$v/b/libflipflow_stage_overlap_correct.so $S/plugins/
  (cd $S && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 60 bin/run-tests test_overlap_correct_cpu_cuda 2>&1 | tail -3) | sed "s/^/$v bits: /" | tee -a $O/sweep.txt
done
