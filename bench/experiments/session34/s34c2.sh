#!/bin/bash
# Session 34, call 2 (nvidia-h200-x2): main 4a97563 (RunInfo::messages, ABI 8: every plugin
# rebuilt; test_team and test_sweep mended for two GPUs; the Delaunay team's warning). The whole
# CUDA suite on two GPUs (test_team's and test_sweep's 2-GPU cases run); an in-process sweep over
# both GPUs whose progress lines must be in each run.log; bench-abp at three sizes.
#   bash bench/experiments/session34/s34c2.sh gpu-carry/BUNDLE.tar.gz   carry: the bundle
source tools/gpu/call_lib.sh s34c2 "$1"
suite "$B" 200
step suite 0
if (($(nvidia-smi -L | wc -l) >= 2)); then
  rm -rf /tmp/sw2
  timeout 120 $B/bin/pipeline sweep $B/pipelines/bench-abp.yaml --device cuda --gpus 0,1 --in-process --concurrent 2 \
    --set system.N=65536 --set run.steps=500 --set step.observe.progress.interval=0 --set step.observe.progress.every=100 \
    --replicas 4 --out /tmp/sw2 > $O/sweep2.txt 2>&1
  step sweep2 $?
  for d in /tmp/sw2/*/; do [[ -f $d/run.log ]] && cp $d/run.log "$O/sweep2-$(basename $d).log"; done
fi
declare -A D=([main]=$B)
bench_abp main sizes --sizes 1024,16384,1048576
echo done t=$SECONDS >> $I; pack
