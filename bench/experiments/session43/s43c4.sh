#!/bin/bash
# Session 43, call 4: the one-barrier dense cluster (branch onebar43) lost 8-9 % in call 3. pw =
# its foreign appends a warp's to one block at once; ps = pw's set-up (foreign lists, one more
# cluster barrier) with the two-barrier iterations (dense-setup-only.patch): the set-up's cost
# alone; pn = call 3's. Each block's foreign edges in bench-abp (pt's trace), pw's correction
# tests, then bench-abp main / pn / pw / ps, three interleaved rounds.
#   bash bench/experiments/session43/s43c4.sh gpu-carry/b43a.tar.xz    carry: gpu-carry
# (Its plugin unpacking, rounds and error cases are call_lib.sh's `variant`, `rounds` and
# `errors_test` now, which took over those lines.)
source tools/gpu/call_lib.sh "${2:-s43c4}" "$1"
declare -A D=([main]=$B)
for v in pn pw ps pt; do D[$v]=$(variant $v gpu-carry/$v.tar.xz); done
for n in 2048 4096 8192 16384; do
  timeout 60 ${D[pt]}/bin/pipeline bench ${D[pt]}/pipelines/bench-abp.yaml --device cuda --sizes $n --steps 30 --warmup 5 2>&1 |
    grep dense-trace | awk -v n=$n '{s += $9; if ($9 > m) m = $9; o += $11} END {print "bench n", n, "blocks", $5, "launches x blocks", NR, "mean foreign", s / NR, "max", m, "overflow", o}' >> $O/trace.txt
done
step trace-bench 0
TEST_TIMEOUT=240 correction_tests pw
rounds "main pn pw ps" --sizes 2048,4096,16384 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
