#!/bin/bash
# Session 50, call 1: branch gather50's overlap_correct plugin (the one-block run, n ≤ 1 024, by
# particles: gather_block.cuh, one block barrier an iteration, positions by parity, only the
# particles around the last moves gather) against main's (b49f = cfb6dc7, main's code).
# The correction's six CUDA test executables, its error cases and the graph-capture, rollback
# and sweep tests on the variant; bench-abp at 256 / 512 / 1 024 (and 4 096, a cluster: the same
# code in both) five interleaved rounds of 400 steps after 20, then 200 steps after 300.
#   bash bench/experiments/session50/s50c1.sh gpu-carry/b49f.tar.xz   carry: gpu-carry/b49f.tar.xz, gpu-carry/vgather.tar.xz
source tools/gpu/call_lib.sh s50c1 "$1"
declare -A D=([main]=$B)
D[gather]=$(variant gather gpu-carry/vgather.tar.xz)
correction_tests gather
errors_test gather
TEST_TIMEOUT=150 variant_tests gather test_graph_capture test_rollback test_sweep
ROUNDS=5 rounds "main gather" --sizes 256,512,1024,4096 --steps 400 --warmup 20
ROUNDS=2 rounds "main gather" --sizes 1024 --steps 200 --warmup 300
echo done t=$SECONDS >> $I; pack
