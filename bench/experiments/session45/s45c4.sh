#!/bin/bash
# Session 45, call 4: call 3 again (its shim recorded nothing: every process now says how many
# records it has, and one without leaves the file alone), with the shim's bindings logged.
#   bash bench/experiments/session45/s45c4.sh gpu-carry/b45n.tar.xz    carry: gpu-carry (b45n)
source tools/gpu/call_lib.sh s45c4 "$1"
E=tools/gpu  # (host_waits.c and .py were in bench/experiments/session45 when this call ran)
gcc -O2 -shared -fPIC $E/host_waits.c -o /tmp/hw.so -ldl > $O/hw-build.txt 2>&1
step hw-build $?
LD_DEBUG=bindings LD_PRELOAD=/tmp/hw.so "$B/bin/pipeline" --help 2>&1 | grep -E "cudaEventSynchronize|cudaLaunchKernelExC" > $O/bindings.txt
for n in 256 1024 16384; do
  LD_PRELOAD=/tmp/hw.so HOST_WAITS_OUT=/tmp/hw-$n.txt timeout 60 "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" \
    --device cuda --sizes $n --steps 400 --warmup 20 > $O/hw-run-$n.txt 2>&1
  python3 $E/host_waits.py /tmp/hw-$n.txt 20 400 >> $O/host-waits.txt 2>&1
  xz -c /tmp/hw-$n.txt > $O/hw-$n.txt.xz
  step hw-$n 0
done
echo done t=$SECONDS >> $I; pack
