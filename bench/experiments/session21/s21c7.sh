#!/bin/bash
# Session 21, call 7 (2 H200s), bundle of main 01b7afc: the 2-GPU decomposition tests after the
# ghost copies' refactor, the sweep spread over two GPUs (new test_sweep case), and 64 runs of
# bench-abp 2^14 on one GPU (in one process) against two GPUs (processes under MPS).
set -u
SECONDS=0
export NCCL_NVLS_ENABLE=0 NCCL_DEBUG=WARN
[[ -f /usr/lib/x86_64-linux-gnu/libnccl.so.2 ]] && export FLIPFLOW_NCCL_LIBRARY=/usr/lib/x86_64-linux-gnu/libnccl.so.2
tar -xzf gpu-carry/bundle-s21c.tar.gz
B=$PWD/bundle; O=/tmp/c7; rm -rf $O; mkdir -p $O
I=$O/info.txt
{ nvidia-smi -L; head -1 $B/.flipflow-bundle; nproc; } > $I
pack() { (cd /tmp && tar -czf $OUT/c7.tgz.part c7 && mv $OUT/c7.tgz.part $OUT/c7.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
(cd $B && FLIPFLOW_TEST_DEVICE=cuda timeout 120 bin/test_sweep "sweep: on two or more GPUs*" > $O/test-sweep-gpus.txt 2>&1; echo "rc=$?" >> $O/test-sweep-gpus.txt) &
(cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 120 bin/run-tests test_decomposition test_team > $O/tests-a.txt 2>&1; echo "rc=$?" >> $O/tests-a.txt) &
(cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 120 bin/run-tests test_decomposition_delaunay > $O/tests-b.txt 2>&1; echo "rc=$?" >> $O/tests-b.txt) &
wait
step tests 0
P=$B/pipelines
sw() { local tag=$1; shift; rm -rf /tmp/sw; timeout 60 $B/bin/pipeline sweep $P/bench-abp.yaml --device cuda --set system.N=16384 --set run.steps=5000 --replicas 64 --out /tmp/sw "$@" > $O/sweep-$tag.txt 2>&1; step sweep-$tag $?; awk -F, 'NR>1{print $0}' /tmp/sw/index.csv 2>/dev/null | cut -c1-300 | head -4 >> $O/sweep-$tag.txt; }
sw one-inproc --concurrent 64 --in-process
sw two-procs --concurrent 32
echo done t=$SECONDS >> $I; pack
