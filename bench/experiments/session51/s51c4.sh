#!/bin/bash
# Session 51, call 4: branch regs51 (main + the dense kernels' launch pair count in 32 bits and
# the broken counts read from shared memory where decided: what late51 changed beside its late
# iterations, +1 % at 4 096 and 16 384 in call 1) against main's overlap_correct plugin (main51,
# in regs51's bundle). The correction's six CUDA test executables on regs51 (with the new ABP
# cases at 600 and 1 000 particles), its error cases, graph capture, rollback and sweep tests;
# bench-abp five interleaved rounds at 256 / 1 024 / 2 048 / 4 096 / 8 192 / 16 384.
#   bash bench/experiments/session51/s51c4.sh gpu-carry/bR51.tar.xz
#   carry: gpu-carry/bR51.tar.xz, gpu-carry/vmain51.tar.xz
source tools/gpu/call_lib.sh s51c4 "$1"
declare -A D=([regs]=$B)
D[main]=$(variant main gpu-carry/vmain51.tar.xz)
correction_tests regs
errors_test regs
TEST_TIMEOUT=150 variant_tests regs test_graph_capture test_rollback test_sweep
ROUNDS=5 rounds "main regs" --sizes 256,1024,2048,4096,8192,16384 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
