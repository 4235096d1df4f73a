#!/bin/bash
# Session 30, call 14: dtail30 with the owners' shared memory reached through cluster.map_shared_rank
# (v30dtg, shadowed into b30h's bundle): its correction test executables, then bench-abp 200 steps
# after 20 at 2^10 - 2^13 against main (713c209's plugin), two interleaved rounds.
#   bash bench/experiments/session30/s30c14.sh gpu-carry/b30h.tar.gz    carry: the bundle, v30m2/v30dtg.tgz
source tools/gpu/call_lib.sh c14 "$1"
for v in v30m2 v30dtg; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([dtg]=$(shadow dtg /tmp/v30dtg) [main]=$(shadow main /tmp/v30m2))
TEST_TIMEOUT=200 correction_tests dtg
for r in 1 2; do
  for v in main dtg; do bench_abp $v small --sizes 1024,2048,4096,8192 --steps 200 --warmup 20; done
done
echo done t=$SECONDS >> $I; pack
