#!/bin/bash
# Session 28, call 2: two overlap_correct variants against main's (64707fc: scand27 merged; its
# plugin is v28scand, built from branch scand27, the same source):
#   rows: branch rows28 (77e9aa4): block 0 holds the iterations' sums in shared memory and stores
#         them to pinned result in runs of 32 and at the launch's end (no store over the bus
#         before a team barrier's fence);
#   t128: main with team_shape.cuh's kMinTile 128 (at 2^14 128 blocks on 128 SMs instead of 64).
# Their correction tests on CUDA, then bench-abp 200 steps after 20 at 2^10..2^16, three
# interleaved rounds; 2^20 200 after 20 and 100 after 3 000, scand against rows.
#   bash bench/experiments/session28/s28c2.sh gpu-carry/b28.tar.gz   carry: b28, v28scand, v28rows, v28t128
source tools/gpu/call_lib.sh c2 "$1"
for v in v28scand v28rows v28t128; do tar -xzf gpu-carry/$v.tgz -C /tmp; done
declare -A D=([scand]=$(shadow scand /tmp/v28scand) [rows]=$(shadow rows /tmp/v28rows) [t128]=$(shadow t128 /tmp/v28t128))
correction_tests rows t128
for v in scand rows t128 t128 rows scand scand t128 rows; do
  bench_abp $v small --sizes 1024,4096,8192,16384,65536 --steps 200 --warmup 20
done
for v in scand rows rows scand; do bench_abp $v big --sizes 1048576 --steps 200 --warmup 20; done
for v in scand rows; do bench_abp $v late --sizes 1048576 --steps 100 --warmup 3000; done
echo done t=$SECONDS >> $I; pack
