#!/bin/bash
# Session 28, call 4 (the last): bundle b28f of main 5da40b9 (scand27, rows28, tiles of 128):
#   1. HOOMD-blue built beside (nice), the whole CUDA suite on b28f in six groups, and branch
#      it0g28's correction tests (iteration 0 by lane groups in a cluster's blocks of <= 64);
#   2. it0 against main, bench-abp 200 steps after 20 at 2^10..2^16, three interleaved rounds;
#   3. issue 20's rows: bench-abp 2^20 (200 after 20, 100 after 3 000), HOOMD-blue's ABP + WCA at
#      2e-3 and flipflow's bench-abp at 2^14 and 2^20 in the same lease, Carter side by side.
#   bash bench/experiments/session28/s28c4.sh gpu-carry/b28f.tar.gz
#     carry: b28f, v28it0, hoomd-kit.tgz, peers-bundle.tar.gz
source tools/gpu/call_lib.sh c4 "$1"
tar -xzf gpu-carry/hoomd-kit.tgz
(OUT=$O HOOMD_JOBS=16 nice -n 19 bash hoomd-kit/build.sh 420 > $O/hoomd-build.txt 2>&1; echo "build rc=$? t=$SECONDS" >> $O/hoomd-build.txt) &
build=$!
tar -xzf gpu-carry/v28it0.tgz -C /tmp
declare -A D=([main]=$B [it0]=$(shadow it0 /tmp/v28it0))
TEST_TIMEOUT=250 tests ${D[it0]} $O/it0-tests.txt test_overlap_correct_cpu_cuda test_overlap_correct \
  test_overlap_correct_walls test_overlap_correct_determinism test_cpu_cuda_bits test_device_decisions &
it0_tests=$!
suite $B 300
wait $it0_tests
echo "it0: $(grep -c "^PASS" $O/it0-tests.txt) PASS, $(grep -c "^FAIL" $O/it0-tests.txt) FAIL" >> $I
step suite 0
for v in main it0 it0 main main it0; do bench_abp $v small --sizes 1024,2048,4096,16384,65536 --steps 200 --warmup 20; done
wait $build; step hoomd-build 0
for v in main; do bench_abp $v big --sizes 1048576 --steps 200 --warmup 20; done
((SECONDS < 480)) && { OUT=$O timeout $((520 - SECONDS)) bash hoomd-kit/run.sh --sizes 16384 1048576 --dts 2e-3 --max-seconds 8 > $O/hoomd-run.txt 2>&1; step hoomd $?; }
((SECONDS < 510)) && bench_abp main hoomd-row --sizes 16384,1048576 --steps 200 --warmup 20
mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
((SECONDS < 500)) && { timeout $((575 - SECONDS)) bash bench/carter_side_by_side.sh $B /tmp/pb/bundle $O/carter small > $O/carter-run.txt 2>&1; step carter $?; }
((SECONDS < 550)) && BENCH_TIMEOUT=$((590 - SECONDS)) bench_abp main late --sizes 1048576 --steps 100 --warmup 3000
echo done t=$SECONDS >> $I; pack
