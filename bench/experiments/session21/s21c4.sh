#!/bin/bash
# Session 21, call 4 (2 H200s), bundle of main 2ea0410: a sweep spread over two GPUs (the new
# test_sweep case, and 64 runs of bench-abp 2^14 on one GPU against two GPUs).
set -u
SECONDS=0
tar -xzf gpu-carry/bundle-s21b.tar.gz
B=$PWD/bundle; O=/tmp/c4; rm -rf $O; mkdir -p $O
I=$O/info.txt
{ nvidia-smi -L; head -1 $B/.flipflow-bundle; nproc; } > $I
pack() { (cd /tmp && tar -czf $OUT/c4.tgz.part c4 && mv $OUT/c4.tgz.part $OUT/c4.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
(cd $B && FLIPFLOW_TEST_DEVICE=cuda timeout 150 bin/test_sweep "sweep: on two or more GPUs*" > $O/test-sweep-gpus.txt 2>&1; echo "rc=$?" >> $O/test-sweep-gpus.txt)
step test 0
P=$B/pipelines
sw() { local tag=$1; shift; rm -rf /tmp/sw; timeout 75 $B/bin/pipeline sweep $P/bench-abp.yaml --device cuda --set system.N=16384 --set run.steps=5000 --replicas 64 --out /tmp/sw "$@" > $O/sweep-$tag.txt 2>&1; step sweep-$tag $?; cut -d, -f1-20 /tmp/sw/index.csv 2>/dev/null | awk -F, 'NR>1{print $0}' | head -3 >> $O/sweep-$tag.txt; }
sw one-inproc --concurrent 64 --in-process
sw two-procs --concurrent 32
sw one-procs --concurrent 48 --gpus 0
echo done t=$SECONDS >> $I; pack
