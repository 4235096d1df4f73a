#!/bin/bash
# Session 20, final call (one H200): the GPU suite of main 2e93842 (mgpu merged, the sweep's
# 8-block cluster), then issue 20's rows and the sweep A/B (old = a5fc649's overlap_correct).
set -u
SECONDS=0
export NCCL_NVLS_ENABLE=0
tar -xzf gpu-carry/bundle-s20f.tar.gz
B=$PWD/bundle; O=/tmp/f; rm -rf $O; mkdir -p $O/suite $B/old/plugins
cp gpu-carry/final20/old/*.so $B/old/plugins/
I=$O/info.txt
nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv > $I; head -1 $B/.flipflow-bundle >> $I
pack() { (cd /tmp && tar -czf $OUT/f.tgz.part f && mv $OUT/f.tgz.part $OUT/f.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
first="test_overlap_correct_cpu_cuda test_overlap_correct test_overlap_correct_walls test_decomposition test_decomposition_delaunay test_team test_rollback test_boids_delaunay test_delaunay_flip test_neighbors_delaunay test_cpu_cuda_bits test_sweep"
rest=$(cd $B/bin && ls test_* | grep -v -x -F "$(echo $first | tr ' ' '\n')")
i=0; declare -a L=("" "" "" "" "" "")
for t in $first $rest; do [[ -x $B/bin/$t ]] || continue; L[$((i % 6))]+=" $t"; i=$((i+1)); done
for k in 0 1 2 3 4 5; do
  (cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 200 bin/run-tests ${L[$k]} > $O/suite/tests-$k.txt 2>&1; echo "rc=$? t=$SECONDS" >> $O/suite/tests-$k.txt) &
done
wait
{ echo "suite: $(cat $O/suite/*.txt | grep -c "^PASS") PASS, $(cat $O/suite/*.txt | grep -c "^FAIL") FAIL"; grep -h "^FAIL" $O/suite/*.txt; } >> $I
step suite 0
P=$B/pipelines
sweep() { rm -rf /tmp/sw; FLIPFLOW_PLUGIN_PATH=$2 timeout 40 $B/bin/pipeline sweep $P/bench-abp.yaml --device cuda --set system.N=16384 --set run.steps=5000 --replicas 64 --concurrent 64 --in-process --out /tmp/sw 2>&1 | tail -1 | sed "s/^/$1: /" >> $O/sweep.txt; step sweep-$1 $?; }
sweep new-1 ""; sweep old-1 $B/old/plugins; sweep new-2 ""; sweep old-2 $B/old/plugins
run() { local tag=$1 lim=$2; shift 2; timeout $lim $B/bin/pipeline bench "$@" --device cuda > $O/$tag.txt 2>&1; step $tag $?; }
run abp 60 $P/bench-abp.yaml --sizes 1024,16384,1048576 --steps 200 --warmup 20
((SECONDS < 420)) && run abp3000 50 $P/bench-abp.yaml --sizes 1048576 --steps 100 --warmup 3000
((SECONDS < 470)) && run phoretic-c2 35 $P/phoretic-c2-short.yaml --sizes 1048576 --steps 50 --warmup 20
((SECONDS < 480)) && { rm -rf /tmp/sw; timeout 30 $B/bin/pipeline sweep $P/bench-abp.yaml --device cuda --set system.N=16384 --set run.steps=5000 --replicas 64 --concurrent 64 --in-process --out /tmp/sw 2>&1 | tail -1 | sed "s/^/new-3: /" >> $O/sweep.txt; step sweep-new-3 $?; }
echo done t=$SECONDS >> $I; pack
