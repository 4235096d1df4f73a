#!/bin/bash
# For the next session (not run): CudaExec's element loops strided over at most 8 blocks an SM
# (next-strided-element-loops.patch, core/backend/cuda/loop.cuh). Lawson's gated grid round at 2^20
# (a8e477e) launches its kernels over the candidate list's capacity (~197 000) and four times it,
# one thread an element, where ~18 000 are used: three waves of early-exiting blocks a kernel. The
# patch changes every plugin's element loops, so the variant is every plugin built with it:
#   git apply bench/experiments/session32/next-strided-element-loops.patch
#   cmake --build build-var -j8; mkdir /tmp/v33s; cp build-var/plugins/*.so /tmp/v33s/
#   for f in /tmp/v33s/*.so; do patchelf --set-rpath '$ORIGIN/../../lib' $f; done
#   tar -czf gpu-carry/v33s.tgz -C /tmp v33s; git checkout -- core
#   bash bench/experiments/session32/next-call2.sh gpu-carry/BUNDLE.tar.gz   carry: the bundle, v33s
source tools/gpu/call_lib.sh n2 "$1"
tar -xzf gpu-carry/v33s.tgz -C /tmp
declare -A D=([main]=$B [s]=$(shadow s /tmp/v33s))
TEST_TIMEOUT=240 correction_tests s
for r in 1 2 3; do
  for v in main s; do bench_abp $v r$r --sizes 1024,16384,65536,262144 --steps 200 --warmup 20; done
done
for v in main s main s; do bench_abp $v m20 --sizes 1048576 --steps 200 --warmup 20; done
echo done t=$SECONDS >> $I; pack
