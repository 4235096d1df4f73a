#!/bin/bash
# Session 44, call 11: abp plugin variant L (branch lanes44: the overdamped integrators' device loop
# with two threads a particle, each drawing every other Gaussian pair, exchanged by shuffles; at
# every N here) against main 3cd3b0e's bundle: the integrators' and bits CUDA test executables,
# then bench-abp at 2^10, 2^14, 2^16 and 2^20, five interleaved rounds.
#   bash bench/experiments/session44/s44c11.sh gpu-carry/b44m.tar.xz    carry: gpu-carry (b44m, vL)
source tools/gpu/call_lib.sh s44c11 "$1"
declare -A D=([main]=$B [L]=$(variant L gpu-carry/vL.tar.xz))
TEST_TIMEOUT=200 tests "${D[L]}" "$O/L-tests.txt" test_abp_integrate test_abp_non_finite test_rng test_cpu_cuda_bits \
  test_rollback test_overdamped_integrate
echo "L: $(grep -c "^PASS" "$O/L-tests.txt") PASS, $(grep -c "^FAIL" "$O/L-tests.txt") FAIL" >> "$I"
step tests 0
ROUNDS=5 rounds "main L" --sizes 1024,16384,65536,1048576 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
