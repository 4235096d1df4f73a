#!/bin/bash
# Session 25, call 2 (one H200, bundle b25a of main with tail_args): Lawson's tail_args on CUDA
# (the tests of its two callers), the correction's phase profile at 2^10 / 2^12 / 2^14
# (overlap-tail-profile.patch as a shadow plugin), issue 20's small rows with its protocol
# (200 steps after 20), and bench-abp at Δt 0.02 beside 0.01 (the HOOMD row's Δt question).
#   carry: gpu-carry/b25a.tar.gz gpu-carry/v25-prof.tgz
source tools/gpu/call_lib.sh c2 "$1"
tests $B $O/tests.txt test_delaunay_lawson test_device_decisions test_cpu_cuda_bits test_delaunay_detect_inversion
step tests 0
tar -xzf gpu-carry/v25-prof.tgz -C gpu-carry
V=$(shadow prof gpu-carry/v25prof)
for n in 1024 4096 16384; do
  timeout 60 $V/bin/pipeline bench $V/pipelines/bench-abp.yaml --device cuda --sizes $n --steps 300 --warmup 20 > $O/prof-$n.txt 2>&1
  step prof-$n $?
done
b() { local tag=$1; shift
  timeout 120 $B/bin/pipeline bench $B/pipelines/bench-abp.yaml --device cuda "$@" 2>&1 |
    grep -E "^[0-9]|overlap_correct/iter|rollback" | sed "s/^/$tag: /" >> $O/ab.txt; step $tag $?; }
b rows-a --sizes 1024,16384 --steps 200 --warmup 20
for dt in 0.01 0.02 0.01 0.02; do b dt$dt --sizes 16384,1048576 --steps 200 --warmup 20 --set run.dt=$dt; done
b rows-b --sizes 1024,16384 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
