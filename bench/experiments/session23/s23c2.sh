#!/bin/bash
# Session 23, call 2 (one H200): issue 20's rows with device decisions, on one machine in one
# lease: HOOMD-blue built on the CPU cores meanwhile; the CUDA tests of the change since call 1;
# bench-abp at 2^20 deciding on the device and on the host (interleaved) and after 3000 steps;
# Carter side by side; the 64-run sweep; then HOOMD's ABP + WCA bench and bench-abp at 2^14, 2^20.
#   carry: gpu-carry/<bundle>.tar.gz gpu-carry/peers-bundle.tar.gz gpu-carry/hoomd-kit.tgz
source tools/gpu/call_lib.sh c2 "$1"
tar -xzf gpu-carry/hoomd-kit.tgz
(OUT=$O bash hoomd-kit/build.sh 420 > $O/hoomd-build.txt 2>&1; echo "build rc=$? t=$SECONDS" >> $O/hoomd-build.txt) &
build=$!
tests $B $O/tests.txt test_cpu_cuda_bits test_delaunay_detect_inversion test_device_decisions test_delaunay_lawson; step tests 0
P=$B/pipelines
b() { local v=$1 tag=$2; shift 2
  FLIPFLOW_DEVICE_DECISIONS=$v timeout 90 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|decided_on_device|overlap_correct/iter" | sed "s/^/dd=$v $tag: /" >> $O/ab.txt; step dd$v-$tag $?; }
for v in 1 0 0 1; do b $v big --sizes 1048576 --steps 200 --warmup 20; done
b 1 late --sizes 1048576 --steps 100 --warmup 3000
mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
timeout 150 bash bench/carter_side_by_side.sh $B /tmp/pb/bundle $O/carter small > $O/carter-run.txt 2>&1; step carter $?
rm -rf /tmp/sw
timeout 60 $B/bin/pipeline sweep $P/bench-abp.yaml --device cuda --set system.N=16384 --set run.steps=5000 --replicas 64 --out /tmp/sw --concurrent 64 --in-process > $O/sweep.txt 2>&1; step sweep $?
wait $build; step hoomd-build 0
((SECONDS < 480)) && { OUT=$O timeout $((570 - SECONDS)) bash hoomd-kit/run.sh --sizes 16384 1048576 --dts 2e-3 --max-seconds 8 > $O/hoomd-run.txt 2>&1; step hoomd $?; }
((SECONDS < 560)) && b 1 hoomd-row --sizes 16384,1048576 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
