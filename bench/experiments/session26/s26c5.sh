#!/bin/bash
# Session 26, call 5 (one H200, bundle b26a of 72dbe32 with overlap_correct as shadow plugins; the
# other plugins are HEAD's):
#   1. the whole CUDA suite with HEAD e78df67's overlap_correct (fused25 and the tail's two
#      barriers) in six groups, t256's correction tests as a seventh, test_out_of_memory after;
#   2. t256 (the tail from an iteration that moved <= 256 particles instead of 512, cluster and
#      grid) against HEAD, bench-abp 200 steps after 20 at 2^10..2^16 (three rounds), 2^20 (one).
#   carry: gpu-carry/b26a.tar.gz gpu-carry/v26head.tgz gpu-carry/v26t256.tgz
source tools/gpu/call_lib.sh c5 "$1"
for v in v26head v26t256; do tar -xzf gpu-carry/$v.tgz -C gpu-carry; done
declare -A D=([head]=$(shadow head gpu-carry/v26head) [t256]=$(shadow t256 gpu-carry/v26t256))
H=${D[head]}
slow="test_hard_sphere_eos test_decomposition_delaunay test_checkpoint test_overlap_correct_cpu_cuda test_rollback_stress test_tran_aggregation"
rest=$(cd $H/bin && ls test_* | grep -v '^test_out_of_memory$' | grep -v -x -F "$(echo $slow | tr ' ' '\n')")
all=$(echo $slow $rest | tr ' ' '\n' | awk 'NF {print NR % 6, $0}')
pids=()
for g in 0 1 2 3 4 5; do
  TEST_TIMEOUT=280 tests $H $O/tests-$g.txt $(echo "$all" | awk -v g=$g '$1 == g {print $2}') &
  pids+=($!)
done
TEST_TIMEOUT=200 tests ${D[t256]} $O/t256-tests.txt test_overlap_correct_cpu_cuda test_overlap_correct \
  test_overlap_correct_walls test_overlap_correct_determinism test_cpu_cuda_bits &
pids+=($!)
wait "${pids[@]}"
TEST_TIMEOUT=40 tests $H $O/tests-oom.txt test_out_of_memory
{ echo "suite: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; cat $O/tests-*.txt | grep "^FAIL"; grep -h "^rc=" $O/tests-*.txt | tr '\n' ' '; echo;
  echo "t256: $(grep -c "^PASS" $O/t256-tests.txt) PASS, $(grep -c "^FAIL" $O/t256-tests.txt) FAIL"; } >> $I
step suite 0
b() { local v=$1 tag=$2; shift 2
  timeout 90 ${D[$v]}/bin/pipeline bench ${D[$v]}/pipelines/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter|rror" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in head t256 t256 head head t256; do b $v small --sizes 1024,4096,8192,16384,65536 --steps 200 --warmup 20; done
for v in t256 head; do b $v big --sizes 1048576 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
