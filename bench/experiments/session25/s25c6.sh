#!/bin/bash
# Session 25, call 6 (one H200, bundle b25c of main with the grid in blocks of 512): the
# correction's CUDA tests on that commit; issue 20's rows with it against a91f7c6's plugin (blocks
# of 256; a shadow bundle): bench-abp 2^20 100 steps after 3000, phoretic c2 short at 2^20; then
# Carter side by side and phoretic c0, c1, c3, c4 with it alone.
#   carry: gpu-carry/b25c.tar.gz gpu-carry/v25head.tgz gpu-carry/peers-bundle.tar.gz
source tools/gpu/call_lib.sh c6 "$1"
TEST_TIMEOUT=200 tests $B $O/tests-a.txt test_overlap_correct_cpu_cuda test_cpu_cuda_bits &
TEST_TIMEOUT=200 tests $B $O/tests-b.txt test_overlap_correct test_overlap_correct_walls test_overlap_correct_determinism test_device_decisions test_hard_disk_eos &
wait
{ echo "tests: $(cat $O/tests-[ab].txt | grep -c "^PASS") PASS, $(cat $O/tests-[ab].txt | grep -c "^FAIL") FAIL"; cat $O/tests-[ab].txt | grep "^FAIL"; } >> $I
step tests 0
tar -xzf gpu-carry/v25head.tgz -C gpu-carry
declare -A D=([new]=$B [old]=$(shadow old gpu-carry/v25head))
b() { local v=$1 tag=$2 file=$3; shift 3
  timeout 120 ${D[$v]}/bin/pipeline bench ${D[$v]}/pipelines/$file.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter|rror" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in new old; do b $v late bench-abp --sizes 1048576 --steps 100 --warmup 3000; done
for v in new old; do b $v c2 phoretic-c2-short --sizes 1048576 --steps 50 --warmup 20; done
mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
timeout 150 bash bench/carter_side_by_side.sh $B /tmp/pb/bundle $O/carter small > $O/carter-run.txt 2>&1; step carter $?
for c in 0 1 3 4; do b new c$c phoretic-c$c-short --sizes 1048576 --steps 50 --warmup 20; done
echo done t=$SECONDS >> $I; pack
