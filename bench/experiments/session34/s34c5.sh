#!/bin/bash
# Session 34, call 5 (nvidia-h200-x2): main 3e1fb4d, the session's last code (after call 4: the review's
# fixes: observe.h5md's stage state, a continuation's folder check; host code only). The
# whole CUDA suite on two GPUs; an in-process sweep of hard-disks.yaml over
# both GPUs whose progress lines must be in each run.log; bench-abp at three sizes.
#   bash bench/experiments/session34/s34c5.sh gpu-carry/BUNDLE.tar.gz   carry: the bundle
source tools/gpu/call_lib.sh s34c5 "$1"
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
