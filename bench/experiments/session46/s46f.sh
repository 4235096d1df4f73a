#!/bin/bash
# Session 46, call 6: where the host's own time goes in bench-abp's step at 2^10 and 2^14
# (tools/gpu/host_profile.c: call stacks sampled on the CPU-time clock, 100 000 steps of
# `pipeline run`), on main 4f74f74's bundle. Symbolise here: host_profile.py hp-N.txt --root bundle
#   bash bench/experiments/session46/s46f.sh gpu-carry/b46a.tar.xz    carry: gpu-carry (b46a)
source tools/gpu/call_lib.sh s46f "$1"
host_profile 1024 16384
echo done t=$SECONDS >> $I; pack
