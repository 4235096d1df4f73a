#!/bin/bash
# Session 26, call 4 (one H200, bundle b26a of 72dbe32, overlap_correct as shadow plugins; the
# other plugins are HEAD's): HOOMD-blue built meanwhile (nice, 16 cores);
#   1. the whole CUDA suite with loc (a cluster's tail keeps its claims, marks and list, in block
#      0's shared memory) in six groups, test_out_of_memory alone after them;
#   2. loc against main b8bc5b0's plugin, bench-abp 200 steps after 20 at 2^10..2^13, 3 rounds;
#   3. issue 20's HOOMD-blue row in one lease: HOOMD's ABP + WCA at 2e-3, flipflow's bench-abp
#      (main) at 2^14 and 2^20;
#   4. Carter side by side with main.
#   carry: gpu-carry/b26a.tar.gz gpu-carry/v26main.tgz gpu-carry/v26loc.tgz gpu-carry/hoomd-kit.tgz
#          gpu-carry/peers-bundle.tar.gz
source tools/gpu/call_lib.sh c4 "$1"
tar -xzf gpu-carry/hoomd-kit.tgz
(OUT=$O HOOMD_JOBS=16 nice -n 19 bash hoomd-kit/build.sh 420 > $O/hoomd-build.txt 2>&1; echo "build rc=$? t=$SECONDS" >> $O/hoomd-build.txt) &
build=$!
for v in v26main v26loc; do tar -xzf gpu-carry/$v.tgz -C gpu-carry; done
declare -A D=([main]=$(shadow main gpu-carry/v26main) [loc]=$(shadow loc gpu-carry/v26loc))
L=${D[loc]}
slow="test_hard_sphere_eos test_decomposition_delaunay test_checkpoint test_overlap_correct_cpu_cuda test_rollback_stress test_tran_aggregation"
rest=$(cd $L/bin && ls test_* | grep -v '^test_out_of_memory$' | grep -v -x -F "$(echo $slow | tr ' ' '\n')")
all=$(echo $slow $rest | tr ' ' '\n' | awk 'NF {print NR % 6, $0}')
pids=()
for g in 0 1 2 3 4 5; do
  TEST_TIMEOUT=300 tests $L $O/tests-$g.txt $(echo "$all" | awk -v g=$g '$1 == g {print $2}') &
  pids+=($!)
done
wait "${pids[@]}"
TEST_TIMEOUT=40 tests $L $O/tests-oom.txt test_out_of_memory
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; cat $O/tests-*.txt | grep "^FAIL"; grep -h "^rc=" $O/tests-*.txt | tr '\n' ' '; echo; } >> $I
step suite 0
wait $build; step hoomd-build 0
b() { local v=$1 tag=$2; shift 2
  timeout 90 ${D[$v]}/bin/pipeline bench ${D[$v]}/pipelines/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter|rror" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in main loc loc main main loc; do b $v small --sizes 1024,4096,8192 --steps 200 --warmup 20; done
((SECONDS < 500)) && { OUT=$O timeout $((540 - SECONDS)) bash hoomd-kit/run.sh --sizes 16384 1048576 --dts 2e-3 --max-seconds 8 > $O/hoomd-run.txt 2>&1; step hoomd $?; }
((SECONDS < 540)) && b main hoomd-row --sizes 16384,1048576 --steps 200 --warmup 20
mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
((SECONDS < 530)) && { timeout $((585 - SECONDS)) bash bench/carter_side_by_side.sh ${D[main]} /tmp/pb/bundle $O/carter small > $O/carter-run.txt 2>&1; step carter $?; }
echo done t=$SECONDS >> $I; pack
