#!/bin/bash
# Session 34, call 1 (nvidia-h200-x2): session 33's next-call1.sh on main 6025b46, which adds
# detect_inversion's occupancy asked once per device (per_device.cuh). The whole CUDA suite on
# GPU 0; then on both GPUs a decomposed team of bench-abp at 2^18 (Lawson's tail on the cluster
# of 16 on both GPUs) and an in-process sweep over GPUs 0 and 1 (runs on the second GPU ask
# detect's occupancy and Lawson's cluster there); then the sweep row and bench-abp at three sizes.
#   bash bench/experiments/session34/s34c1.sh gpu-carry/BUNDLE.tar.gz   carry: the bundle
source tools/gpu/call_lib.sh s34c1 "$1"
suite "$B" 200
step suite 0
if (($(nvidia-smi -L | wc -l) >= 2)); then
  timeout 120 $B/bin/pipeline run $B/pipelines/bench-abp.yaml --device cuda --gpus 2 --set system.N=262144 \
    --set run.steps=200 --out /tmp/team2 > $O/team2.txt 2>&1
  step team2 $?
  timeout 120 $B/bin/pipeline sweep $B/pipelines/bench-abp.yaml --device cuda --gpus 0,1 --in-process --concurrent 2 \
    --set system.N=65536 --set run.steps=500 --replicas 4 --out /tmp/sw2 > $O/sweep2.txt 2>&1
  step sweep2 $?
  cp /tmp/sw2/*.csv $O/ 2>/dev/null
  for d in /tmp/sw2/*/; do [[ -f $d/run.log ]] && cp $d/run.log "$O/sweep2-$(basename $d).log"; done
fi
sweep_abp main
declare -A D=([main]=$B)
bench_abp main sizes --sizes 1024,16384,1048576
echo done t=$SECONDS >> $I; pack
