#!/bin/bash
# Session 21, call 3 (2 H200s): main 656d022 (slab.h in the ghost kernels: never on 2 GPUs) — the
# 2-GPU decomposition bit tests, then weak scaling of decomp-lj and decomp-hard-spheres (ghost
# margin 0.3 sigma, new in session 20 and never timed on GPUs) on 1 and 2 GPUs.
set -u
SECONDS=0
export NCCL_NVLS_ENABLE=0 NCCL_DEBUG=WARN
tar -xzf gpu-carry/bundle-s21.tar.gz
B=$PWD/bundle; O=/tmp/c3; rm -rf $O; mkdir -p $O
[[ -f /usr/lib/x86_64-linux-gnu/libnccl.so.2 ]] && export FLIPFLOW_NCCL_LIBRARY=/usr/lib/x86_64-linux-gnu/libnccl.so.2
I=$O/info.txt
{ nvidia-smi -L; echo "nccl=${FLIPFLOW_NCCL_LIBRARY:-loader}"; head -1 $B/.flipflow-bundle; } > $I
pack() { (cd /tmp && tar -czf $OUT/c3.tgz.part c3 && mv $OUT/c3.tgz.part $OUT/c3.tgz); }
step() { echo "$1 rc=$2 t=$SECONDS" >> $I; pack; }
(cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 150 bin/run-tests test_decomposition test_team > $O/tests-a.txt 2>&1; echo "rc=$?" >> $O/tests-a.txt) &
(cd $B && FLIPFLOW_TEST_DEVICE=cuda CATCH_ARGS="~[long]" timeout 150 bin/run-tests test_decomposition_delaunay > $O/tests-b.txt 2>&1; echo "rc=$?" >> $O/tests-b.txt) &
wait
{ echo "tests: $(cat $O/tests-*.txt | grep -c "^PASS") PASS, $(cat $O/tests-*.txt | grep -c "^FAIL") FAIL"; grep -h "^FAIL" $O/tests-*.txt; } >> $I
step tests 0
for y in decomp-lj decomp-hard-spheres; do
  for g in 1 2; do
    timeout 60 $B/bin/pipeline bench $B/tests/data/$y.yaml --gpus $g --sizes $((1048576 * g)) --steps 100 --warmup 20 > $O/bench-$y-$g.txt 2>&1
    step $y-$g $?
  done
done
echo done t=$SECONDS >> $I; pack
