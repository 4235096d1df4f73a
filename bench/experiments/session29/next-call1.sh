#!/bin/bash
# Prepared in session 29 for the next session's first call (not yet run): the whole CUDA suite on
# HEAD (6065ec1's code passed 69/69; after it only docs and test_overlap_correct's new case, a
# host-side check of pair_push at contact up to rounding), then bench-abp's rows, three rounds, and
# the 64-run sweep twice, so the next change has a baseline from its own lease.
#   rm -rf bundle && tools/bundle build bundle && tar -cf - bundle | gzip -5 > gpu-carry/b30.tar.gz
#   bash bench/experiments/session29/next-call1.sh gpu-carry/b30.tar.gz      carry: the bundle
source tools/gpu/call_lib.sh n1 "$1"
declare -A D=([head]=$B)
suite $B
step suite 0
for r in 1 2 3; do bench_abp head small --sizes 1024,2048,4096,8192,16384,65536 --steps 200 --warmup 20; done
bench_abp head big --sizes 1048576 --steps 200 --warmup 20
bench_abp head late --sizes 1048576 --steps 100 --warmup 3000
sweep_abp 1
sweep_abp 2
echo done t=$SECONDS >> $I; pack
