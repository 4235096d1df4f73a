#!/bin/bash
# Session 26, call 4 (one H200, bundle b26a of 72dbe32, overlap_correct as shadow plugins; the
# other plugins are HEAD's): HOOMD-blue built meanwhile (nice, 16 cores);
#   1. the whole CUDA suite with loc (a cluster's tail keeps its claims, marks and list, in block
#      0's shared memory) in six groups, test_out_of_memory alone after them;
#   2. loc against main b8bc5b0's plugin, bench-abp 200 steps after 20 at 2^10..2^13, 3 rounds;
#   3. issue 20's HOOMD-blue row in one lease: HOOMD's ABP + WCA at 2e-3, flipflow's bench-abp
#      (main) at 2^14 and 2^20;
#   4. Carter side by side with main.
# (It ran with its steps written out; they are call_lib.sh's suite and bench_abp now.)
#   carry: gpu-carry/b26a.tar.gz gpu-carry/v26main.tgz gpu-carry/v26loc.tgz gpu-carry/hoomd-kit.tgz
#          gpu-carry/peers-bundle.tar.gz
source tools/gpu/call_lib.sh c4 "$1"
tar -xzf gpu-carry/hoomd-kit.tgz
(OUT=$O HOOMD_JOBS=16 nice -n 19 bash hoomd-kit/build.sh 420 > $O/hoomd-build.txt 2>&1; echo "build rc=$? t=$SECONDS" >> $O/hoomd-build.txt) &
build=$!
for v in v26main v26loc; do tar -xzf gpu-carry/$v.tgz -C gpu-carry; done
declare -A D=([main]=$(shadow main gpu-carry/v26main) [loc]=$(shadow loc gpu-carry/v26loc))
suite ${D[loc]} 300
step suite 0
wait $build; step hoomd-build 0
for v in main loc loc main main loc; do bench_abp $v small --sizes 1024,4096,8192 --steps 200 --warmup 20; done
((SECONDS < 500)) && { OUT=$O timeout $((540 - SECONDS)) bash hoomd-kit/run.sh --sizes 16384 1048576 --dts 2e-3 --max-seconds 8 > $O/hoomd-run.txt 2>&1; step hoomd $?; }
((SECONDS < 540)) && bench_abp main hoomd-row --sizes 16384,1048576 --steps 200 --warmup 20
mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
((SECONDS < 530)) && { timeout $((585 - SECONDS)) bash bench/carter_side_by_side.sh ${D[main]} /tmp/pb/bundle $O/carter small > $O/carter-run.txt 2>&1; step carter $?; }
echo done t=$SECONDS >> $I; pack
