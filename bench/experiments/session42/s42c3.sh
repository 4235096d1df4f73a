#!/bin/bash
# Session 42, call 3: the dense cluster with its share as a template constant (dense_kernel<R,
# Shift>), one block up to 1 024 particles (3 edges a thread). E = the bundle (clusters of 512 a
# block up to 8 192 particles, of 1 024 above), F = clusters of 256 a block up to 4 096, then as E;
# main = main 24aca08's plugin. Interleaved, then the correction's tests on E and F.
#   bash bench/experiments/session42/s42c3.sh gpu-carry/b42c.tar.gz gpu-carry/varF.tar.xz gpu-carry/main.tar.xz   carry: gpu-carry
# (Its plugin unpacking, rounds and error cases are call_lib.sh's `variant`, `rounds` and
# `errors_test` now, which took over those lines.)
source tools/gpu/call_lib.sh "${4:-s42c3}" "$1"
declare -A D=([E]=$B [F]=$(variant F "$2") [main]=$(variant main "$3"))
rounds "E F main" --sizes 1024,1280,1536,2048,3072,4096,8192,12288,16384 --steps 200 --warmup 20
TEST_TIMEOUT=240 correction_tests E F
echo done t=$SECONDS >> $I; pack
