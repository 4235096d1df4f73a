#!/bin/bash
# Session 34, call 3 (nvidia-h200-x2): main 7ba513b, after the failure-path and input fixes
# (StageDecl::needs_before, ABI 8; check_space before each H5MD frame; fresh runs refuse earlier
# checkpoints). The whole CUDA suite on two GPUs; an in-process sweep of hard-disks.yaml over
# both GPUs whose progress lines must be in each run.log; bench-abp at three sizes.
# Calls 4 and 5 ran it again under their own names (s34c4.sh, s34c5.sh).
#   bash bench/experiments/session34/s34c3.sh gpu-carry/BUNDLE.tar.gz [NAME]   carry: the bundle
source tools/gpu/call_lib.sh "${2:-s34c3}" "$1"
suite "$B" 200
step suite 0
if (($(nvidia-smi -L | wc -l) >= 2)); then
  rm -rf /tmp/sw3
  timeout 120 $B/bin/pipeline sweep $B/pipelines/hard-disks.yaml --device cuda --gpus 0,1 --in-process --concurrent 2 \
    --set system.N=16384 --set run.steps=3000 --set step.observe.progress.interval=0 \
    --replicas 4 --out /tmp/sw3 > $O/sweep3.txt 2>&1
  step sweep3 $?
  for d in /tmp/sw3/*/; do [[ -f $d/run.log ]] && cp $d/run.log "$O/sweep3-$(basename $d).log"; done
fi
declare -A D=([main]=$B)
bench_abp main sizes --sizes 1024,16384,1048576
echo done t=$SECONDS >> $I; pack
