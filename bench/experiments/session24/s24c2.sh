#!/bin/bash
# Session 24, call 2 (one H200): HOOMD-blue built meanwhile (12 of 16 cores); the CUDA tests of
# overlap_correct with allow_next_kernel at its start (branch corrtrigger, a shadow bundle) and
# bench-abp main vs that variant, interleaved; issue 20's rows with main (b24a): 2^20 after 3000
# steps, Carter side by side; then HOOMD's ABP + WCA and bench-abp at 2^14 and 2^20.
#   carry: gpu-carry/b24a.tar.gz gpu-carry/v24-trig.tgz gpu-carry/peers-bundle.tar.gz gpu-carry/hoomd-kit.tgz
source tools/gpu/call_lib.sh c2 "$1"
tar -xzf gpu-carry/hoomd-kit.tgz
(HOOMD_JOBS=12 OUT=$O bash hoomd-kit/build.sh 420 > $O/hoomd-build.txt 2>&1; echo "build rc=$? t=$SECONDS" >> $O/hoomd-build.txt) &
build=$!
tar -xzf gpu-carry/v24-trig.tgz -C gpu-carry
TRIG=$(shadow trig gpu-carry/trig)
tests $TRIG $O/tests-trig.txt test_overlap_correct test_cpu_cuda_bits test_overlap_correct_cpu_cuda test_device_decisions test_overlap_correct_walls
{ echo "trig tests: $(grep -c "^PASS" $O/tests-trig.txt) PASS, $(grep -c "^FAIL" $O/tests-trig.txt) FAIL"; grep "^FAIL" $O/tests-trig.txt; } >> $I
step tests 0
P=$B/pipelines
b() { local tag=$1 dir=$2; shift 2
  timeout 90 $dir/bin/pipeline bench $P/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter|rror" | sed "s/^/$tag: /" >> $O/ab.txt; step $tag $?; }
for r in main trig trig main main trig; do [[ $r == main ]] && d=$B || d=$TRIG
  b $r $d --sizes 1024,4096,16384,65536 --steps 300 --warmup 20; done
for r in main trig; do [[ $r == main ]] && d=$B || d=$TRIG; b $r-big $d --sizes 1048576 --steps 200 --warmup 20; done
b main-late $B --sizes 1048576 --steps 100 --warmup 3000
mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
timeout 150 bash bench/carter_side_by_side.sh $B /tmp/pb/bundle $O/carter small > $O/carter-run.txt 2>&1; step carter $?
wait $build; step hoomd-build 0
((SECONDS < 480)) && { OUT=$O timeout $((570 - SECONDS)) bash hoomd-kit/run.sh --sizes 16384 1048576 --dts 2e-3 --max-seconds 8 > $O/hoomd-run.txt 2>&1; step hoomd $?; }
((SECONDS < 560)) && b hoomd-row $B --sizes 16384,1048576 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
