#!/bin/bash
# Session 51, call 1: branch late51's overlap_correct (the one block's late iterations by
# particles: once an iteration moved at most kLateMoved particles, groups of 8 lanes gather the
# particles around the last moves, one block barrier an iteration) against main's code (b49f =
# cfb6dc7, as main51: main's overlap_correct plugin in late51's bundle, the other plugins' code
# being the same). The bundle is late51's whole (its test executables have the new CPU == CUDA cases:
# ABP steps at 600 and 1 000 particles, the correction counter compared); late16 / late64 are
# its plugin with kLateMoved 16 / 64.
# The correction's six CUDA test executables on late51 and main51 (the control for the new cases),
# its error cases and the graph-capture, rollback
# and sweep tests on late51; bench-abp five interleaved rounds at 256 / 512 / 1 024 (400 steps
# after 20), 1 024 after 300 steps, and 4 096 / 16 384 (clusters: counters' registers only).
#   bash bench/experiments/session51/s51c1.sh gpu-carry/bL51.tar.xz
#   carry: gpu-carry/bL51.tar.xz, gpu-carry/vmain51.tar.xz, gpu-carry/vlate16.tar.xz, gpu-carry/vlate64.tar.xz
source tools/gpu/call_lib.sh s51c1 "$1"
declare -A D=([late]=$B)
D[main]=$(variant main gpu-carry/vmain51.tar.xz)
D[late16]=$(variant late16 gpu-carry/vlate16.tar.xz)
D[late64]=$(variant late64 gpu-carry/vlate64.tar.xz)
correction_tests late main
errors_test late
TEST_TIMEOUT=150 variant_tests late test_graph_capture test_rollback test_sweep
ROUNDS=5 rounds "main late late16 late64" --sizes 256,512,1024 --steps 400 --warmup 20
ROUNDS=2 rounds "main late late64" --sizes 1024 --steps 200 --warmup 300
ROUNDS=3 rounds "main late" --sizes 4096,16384 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
