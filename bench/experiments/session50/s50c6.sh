#!/bin/bash
# Session 50, call 6: a small run alone in a dense cluster instead of one block (branch clus50:
# FF_DENSE_ONE_MAX lowers the one block's limit, FF_DENSE_SHIFT forces the cluster's share).
# bench-abp at 1 024: one block (main), 4 blocks of 256, 2 blocks of 512; at 512: one block, 2 of
# 256; five interleaved rounds of 400 steps after 20. The correction's CPU == CUDA test with the
# 1 000-particle cases in a cluster of 4.
#   bash bench/experiments/session50/s50c6.sh gpu-carry/b49f.tar.xz   carry: gpu-carry/b49f.tar.xz, gpu-carry/vclus.tar.xz
source tools/gpu/call_lib.sh s50c6 "$1"
declare -A D=([main]=$B)
D[clus]=$(variant clus gpu-carry/vclus.tar.xz)
(export FF_DENSE_ONE_MAX=512; TEST_TIMEOUT=150 variant_tests clus test_overlap_correct_cpu_cuda test_overlap_correct)
for r in 1 2 3 4 5; do
  bench_abp main r$r --sizes 512,1024 --steps 400 --warmup 20
  FF_DENSE_ONE_MAX=256 bench_abp clus c4x256-r$r --sizes 512,1024 --steps 400 --warmup 20
  FF_DENSE_ONE_MAX=256 FF_DENSE_SHIFT=9 bench_abp clus c2x512-r$r --sizes 1024 --steps 400 --warmup 20
done
echo done t=$SECONDS >> $I; pack
