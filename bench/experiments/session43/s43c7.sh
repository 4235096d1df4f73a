#!/bin/bash
# Session 43, call 7: branch flipstore43 (a flip's two records and two opposite vertices in one
# 16-byte and one 8-byte store on the device; quad()'s records in one load): its delaunay plugin
# (gpu-carry/fs.tar.xz) in a shadow bundle. The Delaunay, bits and rollback CUDA test executables
# (call_lib.sh's `delaunay_tests` now, which took over these lines), then bench-abp main / the
# variant at 2^10, 2^14, 2^16 and 2^20, three interleaved rounds. Call 10 ran it with another variant.
#   bash bench/experiments/session43/s43c7.sh gpu-carry/b43a.tar.xz [gpu-carry/fs.tar.xz [NAME]]    carry: gpu-carry
variant=${2:-gpu-carry/fs.tar.xz}
v=$(basename "$variant" .tar.xz)
# (Its plugin unpacking, rounds and error cases are call_lib.sh's `variant`, `rounds` and
# `errors_test` now, which took over those lines.)
source tools/gpu/call_lib.sh "${3:-s43c7}" "$1"
declare -A D=([main]=$B [$v]=$(variant $v "$variant"))
delaunay_tests $v
rounds "main $v" --sizes 1024,16384,65536,1048576 --steps 200 --warmup 20
echo done t=$SECONDS >> $I; pack
