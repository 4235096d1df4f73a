#!/bin/bash
# For the next session (not run): the host-only changes after session 33's call 6 on the GPU.
# 68ad089 (Lawson's cluster check once per device, overlap_correct's shared-tail limit that only
# grows), 443b2a2 / a673946 (in-process sweeps: HDF5 check, one setup lock, gmtime_r,
# getpwuid_r, the device description of the calling thread's GPU): the whole CUDA suite on one
# GPU; then, on a machine of two GPUs (kind nvidia-h200-x2), a decomposed team of bench-abp at
# 2^18 (131 072 particles a rank: Lawson's tail on the cluster of 16 on both GPUs, which before
# 68ad089 allowed the cluster size on the first GPU only) and an in-process sweep over both GPUs.
#   bash bench/experiments/session33/next-call1.sh gpu-carry/BUNDLE.tar.gz   carry: the bundle
source tools/gpu/call_lib.sh n1 "$1"
suite "$B" 200
step suite 0
if (($(nvidia-smi -L | wc -l) >= 2)); then
  timeout 120 $B/bin/pipeline run $B/pipelines/bench-abp.yaml --device cuda --gpus 2 --set system.N=262144 \
    --set run.steps=200 --out /tmp/team2 > $O/team2.txt 2>&1
  step team2 $?
  timeout 120 $B/bin/pipeline sweep $B/pipelines/bench-abp.yaml --device cuda --gpus 0,1 --in-process --concurrent 2 \
    --set system.N=65536 --set run.steps=500 --replicas 4 --out /tmp/sw2 > $O/sweep2.txt 2>&1
  step sweep2 $?
fi
echo done t=$SECONDS >> $I; pack
