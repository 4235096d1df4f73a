#!/bin/bash
# Prepared in session 22, not run (no device time left): issue 20's rows not re-measured since
# the correction's read was left past the step, on one H200, from the repository root with
#   carry: gpu-carry/<bundle>.tar.gz, gpu-carry/peers-bundle.tar.gz, gpu-carry/hoomd-kit.tgz
#   bash bench/experiments/session22/next-rows.sh gpu-carry/<bundle>.tar.gz   (~9 min)
# HOOMD-blue builds on the CPU cores while the GPU runs the rest (its build took 341 s in
# session 22's call 1); its bench and flipflow's bench-abp then run one after the other.
source tools/gpu/call_lib.sh rows "$1"
tar -xzf gpu-carry/hoomd-kit.tgz
(OUT=$O bash hoomd-kit/build.sh 450 > $O/hoomd-build.txt 2>&1) &
build=$!
tests $B $O/tests.txt test_tran_aggregation test_cpu_cuda_bits; step tests 0
P=$B/pipelines
mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
PB=$(dirname "$(find /tmp/pb -name run_all.sh | head -1)")
wait $build; step hoomd-build 0
timeout 120 bash bench/carter_side_by_side.sh $B $PB $O/carter small > $O/carter-run.txt 2>&1; step carter $?
timeout 60 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda --sizes 16384,1048576 --steps 200 --warmup 20 > $O/abp.txt 2>&1; step abp $?
OUT=$O timeout 90 bash hoomd-kit/run.sh --sizes 16384 1048576 --dts 2e-3 --max-seconds 8 > $O/hoomd-run.txt 2>&1; step hoomd $?
rm -rf /tmp/sw
timeout 60 $B/bin/pipeline sweep $P/bench-abp.yaml --device cuda --set system.N=16384 --set run.steps=5000 --replicas 64 --out /tmp/sw --concurrent 64 --in-process > $O/sweep.txt 2>&1; step sweep $?
echo done t=$SECONDS >> $I; pack
