#!/bin/bash
# Session 44, call 13 (the session's last device time): variant M (branch rows44, merged into
# main as the session's last code change) in a shadow bundle of main 3cd3b0e's: the CUDA test
# executables beyond the correction's six (call 12) that run overlap_correct on the device
# (rollback, graph capture, sweep, checkpoint, the hard-disk equation of state), in two groups at
# once, and bench-abp at 2^10, 2^14 and 2^20 (200 steps after 20) and at 2^20 after 3 000 steps.
#   bash bench/experiments/session44/s44c13.sh gpu-carry/b44m.tar.xz    carry: gpu-carry (b44m, vM)
source tools/gpu/call_lib.sh s44c13 "$1"
declare -A D=([main]=$B [M]=$(variant M gpu-carry/vM.tar.xz))
TEST_TIMEOUT=90 tests "${D[M]}" "$O/M-tests-a.txt" test_rollback test_rollback_restores test_graph_capture test_hard_disk_eos &
TEST_TIMEOUT=90 tests "${D[M]}" "$O/M-tests-b.txt" test_sweep test_checkpoint test_rollback_stress &
wait
echo "M: $(cat "$O"/M-tests-?.txt | grep -c "^PASS") PASS, $(cat "$O"/M-tests-?.txt | grep -c "^FAIL") FAIL" >> "$I"
step tests 0
bench_abp M rows --sizes 1024,16384,1048576 --steps 200 --warmup 20
bench_abp M late --sizes 1048576 --steps 100 --warmup 3000
echo done t=$SECONDS >> $I; pack
