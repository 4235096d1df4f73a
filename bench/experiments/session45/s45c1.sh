#!/bin/bash
# Session 45, call 1: the whole CUDA suite and issue 20's rows on main 9db0cd0 (session 44's last
# code: reach44 and rows44 merged; session 44 ran the suite only on 3cd3b0e and the correction's
# thirteen test executables on the rows44 plugin), as session 44's call 8: HOOMD-blue built on the
# host's cores while the whole CUDA suite runs; HOOMD-blue's ABP + WCA row, flipflow's at 2^10,
# 2^14 and 2^20 right after, 2^20 after 3 000 steps, Carter side by side and the sweep row.
#   bash bench/experiments/session45/s45c1.sh gpu-carry/b45m.tar.xz   carry: gpu-carry (the bundle,
#   hoomd-kit.tgz = ../shared/peers-gpu/hoomd as hoomd-kit/, peers-bundle.tar.gz = ../shared/peers-gpu/bundle)
source tools/gpu/call_lib.sh "${2:-s45c1}" "$1"
declare -A D=([main]=$B)
issue20_rows 1024,16384,1048576
echo done t=$SECONDS >> $I; pack
