#!/bin/bash
# Session 44, call 4: two overlap_correct plugin variants on top of E (branch reach44: the dense
# kernel's reach tests without branches, a warp's listing with one atomic add, a cluster testing
# only the rounds its share fills), against E and main b15981f's bundle:
#   F (branch reachF44): a cluster's reach tests read every position through distributed shared
#     memory, without a branch on the owner
#   G (branch reachG44): the listing stores each listed edge's ends and offset, so the pushes do not
#     read the positions again
# The correction's CUDA tests and error cases on F and G, then bench-abp at 256 to 16 384, five
# interleaved rounds.
#   bash bench/experiments/session44/s44c4.sh gpu-carry/b44.tar.xz    carry: gpu-carry (b44, vE, vF, vG)
source tools/gpu/call_lib.sh s44c4 "$1"
declare -A D=([main]=$B [E]=$(variant E gpu-carry/vE.tar.xz) [F]=$(variant F gpu-carry/vF.tar.xz) [G]=$(variant G gpu-carry/vG.tar.xz))
correction_tests F G
for v in F G; do errors_test $v; mv "$O/errors.txt" "$O/errors-$v.txt"; done
ROUNDS=5 rounds "main E F G" --sizes 512,1024,2048,4096,16384 --steps 400 --warmup 20
echo done t=$SECONDS >> $I; pack
