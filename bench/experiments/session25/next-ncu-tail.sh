#!/bin/bash
# Prepared in session 25, not yet run: ncu of overlap_correct's cluster kernel at 2^10 (one launch
# after 120 steps, past the lattice's easy start), with per-instruction stall sampling, to tell
# whether a tail gather's ~6 000 cycles (session 25's phase profile) are memory latency or fp64
# arithmetic: the SASS lines of gather_ids' loads against those of pair_term's square root and
# divisions. A shared-memory tail (branch smallshm, session 14) pays only for the first.
#   bash bench/experiments/session25/next-ncu-tail.sh BUNDLE.tar.gz      carry: the bundle
# (Ran in session 26's call 1; its steps are call_lib.sh's ncu_correction now.)
source tools/gpu/call_lib.sh ncu-tail "$1"
ncu_correction 1024 16384
echo done t=$SECONDS >> $I; pack
