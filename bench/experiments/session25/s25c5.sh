#!/bin/bash
# Session 25, call 5 (one H200, bundle b25b of main a91f7c6: kClusterMaxN 8192 and Lawson's
# tail_args): the whole CUDA suite in six groups at once (the slow executables first, one to a
# group), test_out_of_memory alone after them; then g512 (the grid kernel in blocks of 512, one
# an SM, tiles of >= 512: half the blocks at each grid barrier) against main's plugin, bench-abp
# 200 steps after 20, interleaved, three rounds (2^20 one round each).
#   carry: gpu-carry/b25b.tar.gz gpu-carry/v25g.tgz
source tools/gpu/call_lib.sh c5 "$1"
slow="test_hard_sphere_eos test_decomposition_delaunay test_checkpoint test_overlap_correct_cpu_cuda test_rollback_stress test_tran_aggregation"
rest=$(cd $B/bin && ls test_* | grep -v '^test_out_of_memory$' | grep -v -x -F "$(echo $slow | tr ' ' '\n')")
all=$(echo $slow $rest | tr ' ' '\n' | awk 'NF {print NR % 6, $0}')
for g in 0 1 2 3 4 5; do
  TEST_TIMEOUT=280 tests $B $O/tests-$g.txt $(echo "$all" | awk -v g=$g '$1 == g {print $2}') &
done
wait
TEST_TIMEOUT=40 tests $B $O/tests-oom.txt test_out_of_memory
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; cat $O/tests-*.txt | grep "^FAIL"; grep -h "^rc=" $O/tests-*.txt; } >> $I
step suite 0
tar -xzf gpu-carry/v25g.tgz -C gpu-carry
declare -A D=([main]=$B [g512]=$(shadow g512 gpu-carry/v25g512))
TEST_TIMEOUT=120 tests ${D[g512]} $O/tests-g512.txt test_overlap_correct_cpu_cuda test_overlap_correct; step tests-g512 0
b() { local v=$1 tag=$2; shift 2
  timeout 90 ${D[$v]}/bin/pipeline bench ${D[$v]}/pipelines/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in main g512 g512 main main g512; do b $v small --sizes 16384,32768,65536,262144 --steps 200 --warmup 20; done
for v in main g512; do b $v big --sizes 1048576 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
