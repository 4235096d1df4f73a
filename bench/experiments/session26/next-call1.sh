#!/bin/bash
# Prepared in session 26 for the next session's first call (not yet run), with a bundle of HEAD:
#   1. the whole CUDA suite (six groups; session 26's call 5 ran seven groups at once and the one
#      with test_checkpoint hit its limit, so nothing runs beside it here);
#   2. the 64-run sweep of bench-abp 2^14 (issue 20's sweep row; its kernels lost barriers in
#      session 26 and it was not re-measured), twice;
#   3. ncu of the correction at 2^10 and 2^14 with L1/L2 hit rates: whether the tail's gathers
#      wait on L2 (bench/experiments/README.md, session 26).
# (Run in session 27 as s27c1.sh, with its sweep written out; that is call_lib.sh's sweep_abp now.)
#   bash bench/experiments/session26/next-call1.sh BUNDLE.tar.gz      carry: the bundle
source tools/gpu/call_lib.sh n1 "$1"
suite $B
step suite 0
sweep_abp 1; sweep_abp 2
ncu_correction 1024 16384
echo done t=$SECONDS >> $I; pack
