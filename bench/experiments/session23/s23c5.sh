#!/bin/bash
# Session 23, call 5 (one H200): test_cpu_cuda_bits' closed-gate case (new since call 4) on the
# bundle of main; then branch gated2048's delaunay plugin (a gated launch takes up to 2 048 Lawson
# candidates, two passes of the tail kernel's block, against 1 024) in a shadow bundle: its CUDA
# tests, and bench-abp at 2^14, 2^15, 2^16 against main's, interleaved.
#   carry: gpu-carry/<bundle>.tar.gz gpu-carry/var2048/libflipflow_stage_delaunay.so
source tools/gpu/call_lib.sh c5 "$1"
tests $B $O/tests-main.txt test_cpu_cuda_bits; step tests-main 0
V=$(shadow v2048 gpu-carry/var2048)
tests $V $O/tests-v2048.txt test_cpu_cuda_bits test_delaunay_lawson test_delaunay_detect_inversion test_device_decisions; step tests-v2048 0
b() { local tag=$1 dir=$2
  timeout 60 $dir/bin/pipeline bench $dir/pipelines/bench-abp.yaml --device cuda --sizes 16384,32768,65536 --steps 300 --warmup 20 2>&1 |
    grep -E "^[0-9]|decided_on_device|lawson_candidates|overlap_correct/iter" | sed "s/^/$tag: /" >> $O/ab.txt; step $tag $?; }
for r in main v2048 v2048 main main v2048; do if [[ $r == main ]]; then b main $B; else b v2048 $V; fi; done
echo done t=$SECONDS >> $I; pack
