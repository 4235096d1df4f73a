#!/bin/bash
# Session 21, final call (one H200): the GPU suite of main 23db6ab (tail21 merged; six streams,
# [long] left to the CPU suite); overlap_correct before tail21 ("pre", 5e1d13f's plugin) against
# the merged one at small N and after 3000 steps, interleaved; issue 20's rows (bench-abp 2^10 ..
# 2^20, phoretic-c2-short); helper tail21's second request (short form); Carter's program side by
# side if time is left.
set -u
SECONDS=0
export NCCL_NVLS_ENABLE=0
tar -xzf gpu-carry/bundle-final21.tar.gz
B=$PWD/bundle; O=/tmp/f; rm -rf $O; mkdir -p $O/suite
I=$O/info.txt
{ nvidia-smi --query-gpu=name,clocks.sm,clocks.max.sm --format=csv; head -1 $B/.flipflow-bundle; nproc; } > $I
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
mkdir -p $B/pre/plugins && cp gpu-carry/lead/pre/plugins/*.so $B/pre/plugins/
P=$B/pipelines
for r in 1 2; do for v in pre merged; do
  pp=""; [[ $v == pre ]] && pp=$B/pre/plugins
  FLIPFLOW_PLUGIN_PATH=$pp timeout 30 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda --sizes 1024,4096,16384 --steps 300 --warmup 20 2>&1 | grep -E "^[0-9]|iterations per" | sed "s/^/$v r$r: /" >> $O/ab-small.txt
  step ab-small-$v-$r $?
done; done
run() { local tag=$1 lim=$2; shift 2; timeout $lim $B/bin/pipeline bench "$@" --device cuda > $O/$tag.txt 2>&1; step $tag $?; }
run abp 70 $P/bench-abp.yaml --sizes 1024,4096,16384,1048576 --steps 200 --warmup 20
((SECONDS < 330)) && run abp3000 45 $P/bench-abp.yaml --sizes 1048576 --steps 100 --warmup 3000
((SECONDS < 370)) && { FLIPFLOW_PLUGIN_PATH=$B/pre/plugins timeout 45 $B/bin/pipeline bench $P/bench-abp.yaml --device cuda --sizes 1048576 --steps 100 --warmup 3000 > $O/abp3000-pre.txt 2>&1; step abp3000-pre $?; }
((SECONDS < 400)) && run phoretic-c2 40 $P/phoretic-c2-short.yaml --sizes 1048576 --steps 50 --warmup 20
((SECONDS < 430)) && { TAIL21_SHORT=1 timeout 75 bash gpu-carry/tail21/run2.sh $B $O/tail21 > $O/tail21-run2.txt 2>&1; step tail21 $?; }
if ((SECONDS < 420)) && [[ -f gpu-carry/peers-bundle.tar.gz ]]; then
  mkdir -p /tmp/pb && tar -xzf gpu-carry/peers-bundle.tar.gz -C /tmp/pb
  PB=$(dirname $(find /tmp/pb -name run_all.sh | head -1))
  timeout 120 bash bench/carter_side_by_side.sh $B $PB $O/carter small > $O/carter-run.txt 2>&1
  step carter $?
fi
echo done t=$SECONDS >> $I; pack
