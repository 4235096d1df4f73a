#!/bin/bash
# Prepared in session 28 for the next session's first call (not yet run): the whole CUDA suite on
# HEAD (65b7671's lane groups up to 128 particles a block ran only the correction's six test
# executables on a GPU, and the suite last ran on 5da40b9), the 64-run sweep row (its clusters of
# 8 take the same lane-group threshold), bench-abp's rows, three rounds, and where a tail gather's
# ~3 750 cycles go (overlap-tail-gather-clocks.patch: the candidate's load, v's own loads, the
# neighbour's position, the pair math, the group's sums, take; block 0's thread 0, launches
# 150-155) at 2^10 and 2^14, to decide on a tail with its state in shared memory
# (bench/experiments/README.md, "The tail's independent groups"), and branch smtail28 (a team's
# tail up to 2 048 particles reads positions from a shared-memory copy): its correction tests,
# then bench-abp against HEAD at 2^10..2^13, three rounds.
#   rm -rf bundle && tools/bundle build bundle && tar -cf - bundle | gzip -5 > gpu-carry/b29.tar.gz
#   tclk: git apply bench/experiments/session28/overlap-tail-gather-clocks.patch; cmake --build
#         build-var --target flipflow_stage_overlap_correct; copy its plugin to /tmp/v29tclk/,
#         patchelf --set-rpath '$ORIGIN/../../lib', tar -czf gpu-carry/v29tclk.tgz -C /tmp v29tclk;
#         git checkout -- stages/
#   smt:  the same from branch smtail28 (738576c; rebased on HEAD if main moved), into v29smt
#   bash bench/experiments/session28/next-call1.sh gpu-carry/b29.tar.gz      carry: the bundle, v29tclk, v29smt
source tools/gpu/call_lib.sh n1 "$1"
for v in v29tclk v29smt; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([head]=$B [tclk]=$(shadow tclk /tmp/v29tclk) [smt]=$(shadow smt /tmp/v29smt))
suite $B
step suite 0
correction_tests smt
for v in head smt smt head head smt; do bench_abp $v ab --sizes 1024,2048,4096,8192 --steps 200 --warmup 20; done
sweep_abp 1
sweep_abp 2
for r in 1 2 3; do bench_abp head small --sizes 1024,2048,4096,8192,16384,65536 --steps 200 --warmup 20; done
bench_abp head big --sizes 1048576 --steps 200 --warmup 20
bench_abp head late --sizes 1048576 --steps 100 --warmup 3000
for n in 1024 16384; do
  timeout 120 ${D[tclk]}/bin/pipeline bench ${D[tclk]}/pipelines/bench-abp.yaml --device cuda --sizes $n --steps 200 \
    --warmup 20 2>&1 | grep TCLK > $O/tclk-$n.txt
  step tclk-$n 0
done
echo done t=$SECONDS >> $I; pack
