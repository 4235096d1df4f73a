#!/bin/bash
# Session 26, call 1 (one H200, bundle b26a of main 72dbe32, whose last CUDA change is 95e2846):
# the whole CUDA suite in six groups at once (as s25c5.sh), test_out_of_memory alone after them;
# then branch fused25's plugin (session 25's next-fused-check.sh: its overlap tests, and bench-abp
# 200 steps after 20 interleaved with main at 2^10..2^16, three rounds); then session 25's
# next-ncu-tail.sh (ncu stall sampling of the correction at 2^10 and 2^14).
#   carry: gpu-carry/b26a.tar.gz gpu-carry/v26fused.tgz
source tools/gpu/call_lib.sh c1 "$1"
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
tar -xzf gpu-carry/v26fused.tgz -C gpu-carry
declare -A D=([main]=$B [fused]=$(shadow fused gpu-carry/v26fused))
TEST_TIMEOUT=200 tests ${D[fused]} $O/tests-fused.txt test_overlap_correct_cpu_cuda test_overlap_correct \
  test_overlap_correct_walls test_overlap_correct_determinism test_cpu_cuda_bits test_device_decisions
step tests-fused 0
b() { local v=$1 tag=$2; shift 2
  timeout 90 ${D[$v]}/bin/pipeline bench ${D[$v]}/pipelines/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter" | sed "s/^/$v $tag: /" >> $O/ab.txt; step $v-$tag $?; }
for v in main fused fused main main fused; do b $v small --sizes 1024,4096,8192,16384,65536 --steps 200 --warmup 20; done
NCU=$(command -v ncu || ls /usr/local/cuda*/bin/ncu /opt/nvidia/nsight-compute/*/ncu 2>/dev/null | head -n 1)
echo "ncu: ${NCU:-none}" >> $I
for n in 1024 16384; do
  timeout 120 "$NCU" --target-processes all --clock-control none -k regex:correct_kernel \
    --launch-skip 120 --launch-count 1 \
    --section LaunchStats --section Occupancy --section SchedulerStats --section WarpStateStats \
    --section InstructionStats --section SpeedOfLight --section SourceCounters \
    -f -o "$O/oc-$n" "$B/bin/pipeline" bench "$B/pipelines/bench-abp.yaml" --device cuda --sizes $n \
    --steps 1 --warmup 125 > "$O/ncu-run-$n.txt" 2>&1
  step ncu-$n $?
  [[ -f $O/oc-$n.ncu-rep ]] || continue
  "$NCU" -i "$O/oc-$n.ncu-rep" --page details > "$O/ncu-details-$n.txt" 2>&1
  "$NCU" -i "$O/oc-$n.ncu-rep" --page source --csv --print-source sass 2>&1 | xz > "$O/ncu-sass-$n.csv.xz"
  rm -f "$O/oc-$n.ncu-rep"; step ncu-export-$n 0
done
echo done t=$SECONDS >> $I; pack
