#!/bin/bash
# Session 29, call 6: branch pf29 (the tail's check prefetches a claimed particle's position, degree
# and list into L1 for the next iteration's gather) against main's plugin in bundle b29fin, bench-abp
# at 2^10..2^14, three interleaved rounds; then its six correction test executables.
#   v29pf: branch pf29's plugin (build-var), patchelf --set-rpath '$ORIGIN/../../lib'
#   bash bench/experiments/session29/s29c6.sh gpu-carry/b29fin.tar.gz   carry: b29fin, v29pf
source tools/gpu/call_lib.sh c6 "$1"
tar -xzf gpu-carry/v29pf.tgz -C /tmp
declare -A D=([main]=$B [pf]=$(shadow pf /tmp/v29pf))
for v in main pf pf main main pf; do bench_abp $v ab --sizes 1024,2048,4096,8192,16384 --steps 200 --warmup 20; done
TEST_TIMEOUT=150 correction_tests pf
echo done t=$SECONDS >> $I; pack
