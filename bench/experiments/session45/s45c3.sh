#!/bin/bash
# Session 45, call 3: is the host a ceiling for the small rows? Call 2's CUPTI timeline at 2^10
# had the GPU idle 7.3 us a step, waiting for launches (under CUPTI a launch call takes ~6 us).
# host_waits.c (LD_PRELOAD) times every launch and every wait of `pipeline bench`; host_waits.py
# prints the host's own time a step (the period minus its waits) over the back-to-back pass, at
# 256, 1 024 and 16 384 particles; then bench-abp without the shim at 64-1 024 particles.
#   bash bench/experiments/session45/s45c3.sh gpu-carry/b45n.tar.xz    carry: gpu-carry (b45n)
source tools/gpu/call_lib.sh s45c3 "$1"
declare -A D=([main]=$B)
E=tools/gpu  # (host_waits.c and .py were in bench/experiments/session45 when this call ran)
gcc -O2 -shared -fPIC $E/host_waits.c -o /tmp/hw.so -ldl > $O/hw-build.txt 2>&1
step hw-build $?
for n in 256 1024 16384; do
  LD_PRELOAD=/tmp/hw.so HOST_WAITS_OUT=/tmp/hw-$n.txt timeout 60 "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" \
    --device cuda --sizes $n --steps 400 --warmup 20 > $O/hw-run-$n.txt 2>&1
  python3 $E/host_waits.py /tmp/hw-$n.txt 20 400 >> $O/host-waits.txt 2>&1
  xz -c /tmp/hw-$n.txt > $O/hw-$n.txt.xz
  step hw-$n 0
done
ROUNDS=2 rounds main --sizes 64,128,256,512,1024 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
