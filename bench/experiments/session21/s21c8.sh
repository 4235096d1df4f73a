#!/bin/bash
# Session 21, call 8 (2 H200s), bundle of main 5e1d13f (in-process sweeps on several GPUs): the
# 2-GPU decomposition tests, the sweep spread over two GPUs as processes and as threads (test_sweep),
# and bench-abp 2^14 sweeps in-process on one GPU against two.
set -u
SECONDS=0
export NCCL_NVLS_ENABLE=0 NCCL_DEBUG=WARN
[[ -f /usr/lib/x86_64-linux-gnu/libnccl.so.2 ]] && export FLIPFLOW_NCCL_LIBRARY=/usr/lib/x86_64-linux-gnu/libnccl.so.2
tar -xzf gpu-carry/bundle-s21d.tar.gz
B=$PWD/bundle; O=/tmp/c8; rm -rf $O; mkdir -p $O
I=$O/info.txt
{ nvidia-smi -L; head -1 $B/.flipflow-bundle; nproc; } > $I
pack() { (cd /tmp && tar -czf $OUT/c8.tgz.part c8 && mv $OUT/c8.tgz.part $OUT/c8.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
(cd $B && FLIPFLOW_TEST_DEVICE=cuda timeout 120 bin/test_sweep "sweep: on two or more GPUs*" > $O/test-sweep-gpus.txt 2>&1; echo "rc=$?" >> $O/test-sweep-gpus.txt) &
(cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 120 bin/run-tests test_decomposition test_team > $O/tests-a.txt 2>&1; echo "rc=$?" >> $O/tests-a.txt) &
(cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 120 bin/run-tests test_decomposition_delaunay > $O/tests-b.txt 2>&1; echo "rc=$?" >> $O/tests-b.txt) &
wait
step tests 0
P=$B/pipelines
sw() { local tag=$1 reps=$2; shift 2; rm -rf /tmp/sw; timeout 60 $B/bin/pipeline sweep $P/bench-abp.yaml --device cuda --set system.N=16384 --set run.steps=5000 --replicas $reps --out /tmp/sw "$@" > $O/sweep-$tag.txt 2>&1; step sweep-$tag $?; awk -F, 'NR>1{print $0}' /tmp/sw/index.csv 2>/dev/null | cut -c1-300 | head -4 >> $O/sweep-$tag.txt; }
sw two-inproc-32 64 --concurrent 32 --in-process
sw one-inproc-64 64 --concurrent 64 --in-process --gpus 0
sw two-inproc-64 128 --concurrent 64 --in-process
echo done t=$SECONDS >> $I; pack
