#!/bin/bash
# Session 21, call 1 (one H200): CUDA tests of main 656d022 (3cd1c5d's slab.h in the ghost
# kernels never ran on a GPU), bench-abp small and large, CUPTI timelines at 2^10 and 2^14.
set -u
SECONDS=0
export NCCL_NVLS_ENABLE=0
tar -xzf gpu-carry/bundle-s21.tar.gz
B=$PWD/bundle; O=/tmp/c1; rm -rf $O; mkdir -p $O
I=$O/info.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv > $I; head -1 $B/.flipflow-bundle >> $I
pack() { (cd /tmp && tar -czf $OUT/c1.tgz.part c1 && mv $OUT/c1.tgz.part $OUT/c1.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
L=("test_decomposition" "test_decomposition_delaunay test_team" "test_overlap_correct_cpu_cuda" "test_overlap_correct test_overlap_correct_walls test_overlap_correct_verlet test_neighbors_verlet")
for k in 0 1 2 3; do
  (cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 170 bin/run-tests ${L[$k]} > $O/tests-$k.txt 2>&1; echo "rc=$? t=$SECONDS" >> $O/tests-$k.txt) &
done
wait
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; grep -h "^FAIL" $O/tests-*.txt; } >> $I
step tests 0
P=$B/pipelines
run() { local tag=$1 lim=$2; shift 2; timeout $lim $B/bin/pipeline bench "$@" --device cuda > $O/$tag.txt 2>&1; step $tag $?; }
run abp 60 $P/bench-abp.yaml --sizes 1024,4096,16384,65536,1048576 --steps 200 --warmup 20
for n in 1024 16384; do
  CUDA_INJECTION64_PATH=$B/lib/libflipflow_gpu_trace.so FLIPFLOW_GPU_TRACE=$O/trace-$n.csv timeout 40 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda --sizes $n --steps 30 --warmup 20 > $O/trace-$n.txt 2>&1
  step trace-$n $?
done
echo done t=$SECONDS >> $I; pack
