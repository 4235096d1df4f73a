#!/bin/bash
# Prepared in session 27 for the next session's first call (not yet run):
#   1. the whole CUDA suite on HEAD (redux27 merged: its correction tests passed in session 27's
#      call 8, the suite only on the commit before it);
#   2. branches held27's and scand27's correction tests on CUDA (held27: the thread that gathered a
#      particle applies and checks it; scand27: a team block's candidates through shared memory;
#      bench/experiments/README.md, "Where a correction iteration's time goes");
#   3. bench-abp 200 steps after 20 at 2^10..2^16, three interleaved rounds, HEAD against held27,
#      scand27 and c16 (overlap-cluster-16384.patch: the cluster of 16 up to 16 384 particles,
#      where the grid's barrier is ~8 k cycles an iteration); 2^20 one round each (HEAD, held27,
#      scand27).
# Making the carried files (build-var: a second build tree of this checkout, CMAKE_BUILD_TYPE=Release):
#   bundle:  rm -rf bundle && tools/bundle build bundle && tar -cf - bundle | gzip -5 > gpu-carry/b28.tar.gz
#   held:    git checkout held27 (rebased on HEAD if main moved); cmake --build build-var --target
#            flipflow_stage_overlap_correct; copy build-var/plugins/libflipflow_stage_overlap_correct.so
#            to /tmp/v28held/, patchelf --set-rpath '$ORIGIN/../../lib', tar -czf gpu-carry/v28held.tgz -C /tmp v28held
#   scand:   the same from branch scand27, into v28scand
#   c16:     git apply bench/experiments/session27/overlap-cluster-16384.patch on main, the same
#            steps into v28c16, then git checkout -- stages/
#   bash bench/experiments/session27/next-call1.sh BUNDLE.tar.gz      carry: the bundle, v28held, v28scand, v28c16
source tools/gpu/call_lib.sh n1 "$1"
for v in v28held v28scand v28c16; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([head]=$B [held]=$(shadow held /tmp/v28held) [scand]=$(shadow scand /tmp/v28scand) [c16]=$(shadow c16 /tmp/v28c16))
suite $B
step suite 0
for v in held scand; do
  TEST_TIMEOUT=200 tests ${D[$v]} $O/$v-tests.txt test_overlap_correct_cpu_cuda test_overlap_correct \
    test_overlap_correct_walls test_overlap_correct_determinism test_cpu_cuda_bits test_device_decisions &
done
wait
for v in held scand; do echo "$v: $(grep -c "^PASS" $O/$v-tests.txt) PASS, $(grep -c "^FAIL" $O/$v-tests.txt) FAIL" >> $I; done
step variant-tests 0
for v in head held scand c16 c16 scand held head head c16 held scand; do
  bench_abp $v small --sizes 1024,4096,8192,16384,65536 --steps 200 --warmup 20
done
for v in held scand head; do bench_abp $v big --sizes 1048576 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
