#!/bin/bash
# Session 43, call 3: branch onebar43 (the dense cluster with one cluster barrier an iteration:
# foreign edges, moves into a second buffer committed after the verdict; the two-barrier form when
# a block's foreign edges overflow). pt = its plugin with FF_DENSE_FOREIGN_TRACE (each block's
# foreign edges and overflow printed at a step's first launch): bench-abp and the correction's
# CPU == CUDA test, to see which form runs where; pn = the plugin itself: the correction's CUDA
# tests and error cases, then bench-abp against main's bundle, three interleaved rounds.
#   bash bench/experiments/session43/s43c3.sh gpu-carry/b43a.tar.xz    carry: gpu-carry
# (Its plugin unpacking, rounds and error cases are call_lib.sh's `variant`, `rounds` and
# `errors_test` now, which took over those lines.)
source tools/gpu/call_lib.sh "${2:-s43c3}" "$1"
declare -A D=([main]=$B [pn]=$(variant pn gpu-carry/pn.tar.xz) [pt]=$(variant pt gpu-carry/pt.tar.xz))
for n in 2048 4096 8192 12288 16384; do
  timeout 60 ${D[pt]}/bin/pipeline bench ${D[pt]}/pipelines/bench-abp.yaml --device cuda --sizes $n --steps 30 --warmup 5 2>&1 |
    grep dense-trace | awk -v n=$n '{f[$8]++; if ($8 > m) m = $8; o += $10} END {print "bench n", n, "lines", NR, "max foreign", m, "overflow lines", o}' >> $O/trace.txt
done
step trace-bench 0
(cd ${D[pt]} && FLIPFLOW_TEST_DEVICE=cuda timeout 200 bin/test_overlap_correct_cpu_cuda > $O/pt-cpu-cuda.txt 2>&1; echo rc=$? >> $O/pt-cpu-cuda.txt)
grep dense-trace $O/pt-cpu-cuda.txt | awk '{k = $3 " " $10; c[k]++; if ($8 > m[$3]) m[$3] = $8} END {for (x in c) print "test n overflow", x, "lines", c[x], "max foreign", m[substr(x, 1, index(x, " ") - 1)]}' | sort -n -k4 >> $O/trace.txt
grep -v dense-trace $O/pt-cpu-cuda.txt | tail -5 >> $O/trace.txt
xz -f $O/pt-cpu-cuda.txt
step trace-test 0
TEST_TIMEOUT=240 correction_tests pn
errors_test pn
rounds "main pn" --sizes 1024,2048,4096,8192,16384 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
