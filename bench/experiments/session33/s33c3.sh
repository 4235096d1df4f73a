#!/bin/bash
# Session 33, call 3: issue 20's rows on main 4f73933 (419e796: Lawson's grid round first above
# half a pass). HOOMD-blue is built on the host's cores while the whole CUDA suite runs (its
# limits raised for the shared CPU); then HOOMD-blue's ABP + WCA row, flipflow's at 2^14 and 2^20
# right after, 2^20 after 3 000 steps, Carter side by side and the sweep row.
#   bash bench/experiments/session33/s33c3.sh gpu-carry/b33b.tar.gz [NAME]
#   carry: b33b, hoomd-kit.tgz, peers-bundle.tar.gz
# (The rows' steps are call_lib.sh's `issue20_rows` now, which took over these lines.)
source tools/gpu/call_lib.sh "${2:-c3}" "$1"
declare -A D=([main]=$B)
issue20_rows 16384,1048576
echo done t=$SECONDS >> $I; pack
