#!/bin/bash
# Prepared in session 26 for the next session's first call (not yet run), with a bundle of HEAD:
#   1. the whole CUDA suite (six groups; session 26's call 5 ran seven groups at once and the one
#      with test_checkpoint hit its limit, so nothing runs beside it here);
#   2. the 64-run sweep of bench-abp 2^14 (issue 20's sweep row; its kernels lost barriers in
#      session 26 and it was not re-measured), twice;
#   3. ncu of the correction at 2^10 and 2^14 with L1/L2 hit rates: whether the tail's gathers
#      wait on L2 (bench/experiments/README.md, session 26).
#   bash bench/experiments/session26/next-call1.sh BUNDLE.tar.gz      carry: the bundle
source tools/gpu/call_lib.sh n1 "$1"
suite $B
step suite 0
sw() { rm -rf /tmp/sw; timeout 60 $B/bin/pipeline sweep $B/pipelines/bench-abp.yaml --device cuda --set system.N=16384 \
  --set run.steps=5000 --replicas 64 --out /tmp/sw --concurrent 64 --in-process 2>&1 | tail -2 | sed "s/^/sweep $1: /" >> $O/sweep.txt
  step sweep$1 $?; }
sw 1; sw 2
ncu_correction 1024 16384
echo done t=$SECONDS >> $I; pack
