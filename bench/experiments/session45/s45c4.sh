#!/bin/bash
# Session 45, call 4: call 3 again (its shim recorded nothing: every process now says how many
# records it has, and one without leaves the file alone), with the shim's bindings logged.
#   bash bench/experiments/session45/s45c4.sh gpu-carry/b45n.tar.xz    carry: gpu-carry (b45n)
source tools/gpu/call_lib.sh s45c4 "$1"
# (these calls ran the same lines written out, from bench/experiments/session45; call_lib.sh's
# host_waits came after them)
host_waits 256 1024 16384
LD_DEBUG=bindings LD_PRELOAD=/tmp/host_waits.so "$B/bin/pipeline" --help 2>&1 | grep -E "cudaEventSynchronize|cudaLaunchKernelExC" > $O/bindings.txt
echo done t=$SECONDS >> $I; pack
