#!/bin/bash
# Session 17, lead: does splitting a 64-run sweep over processes (each its own CUDA context, under
# MPS) beat one process of 64 threads (3.97e8 particle-steps/s, host-bound in the driver)?
#   bash bench/experiments/sweep-processes-mps.sh BUNDLE OUT   (~2.5 min on an H200; not yet run)
set -u
B=$1; O=$2; W=$(mktemp -d /tmp/mps.XXXX); R=$O/mps.txt
P=$B/pipelines/bench-abp.yaml; ST=${STEPS:-10000}; N=${N:-16384}
log() { echo "$*" | tee -a $R; }
agg() { # groups, runs per group, wall seconds
  python3 -c "import sys; g,r,w=map(float,sys.argv[1:]); print('%.3e particle-steps/s over the wall (%d runs, %.1f s)'%(g*r*$N*$ST/w, g*r, w))" "$@" 2>/dev/null || echo "g=$1 r=$2 wall=$3"; }
log "mps.sh $(date -u +%FT%TZ) $(nvidia-smi -L | head -1) cores $(nproc) steps $ST"
# (c) reference: one process, 64 threads
t0=$(date +%s.%N)
timeout 100 $B/bin/pipeline sweep $P --device ${DEVICE:-cuda} --set system.N=$N --set run.steps=$ST --replicas 64 --concurrent 64 --in-process --out $W/ip64 > $W/ip64.log 2>&1; rc=$?
t1=$(date +%s.%N); log "in-process 64: rc=$rc $(agg 1 64 $(python3 -c "print($t1 - $t0)"))"; grep "runs done" $W/ip64.log | tee -a $R
# (b) processes under MPS (the sweep starts its own daemon), 48 at once (the client cap), one wave
t0=$(date +%s.%N)
timeout 100 $B/bin/pipeline sweep $P --device ${DEVICE:-cuda} --set system.N=$N --set run.steps=$ST --replicas 48 --concurrent 48 --mps on --out $W/p48 > $W/p48.log 2>&1; rc=$?
t1=$(date +%s.%N); log "processes 48 (MPS): rc=$rc $(agg 1 48 $(python3 -c "print($t1 - $t0)"))"; grep "runs done" $W/p48.log | tee -a $R
# (a) hybrid: G in-process sweeps of 64/G runs each, side by side, under one MPS daemon of ours
export CUDA_MPS_PIPE_DIRECTORY=$W/mps-pipe CUDA_MPS_LOG_DIRECTORY=$W/mps-log
mkdir -p $CUDA_MPS_PIPE_DIRECTORY $CUDA_MPS_LOG_DIRECTORY
nvidia-cuda-mps-control -d && log "MPS daemon started"
for G in 4 8; do
  r=$((64 / G)); t0=$(date +%s.%N)
  for g in $(seq 1 $G); do
    timeout 100 $B/bin/pipeline sweep $P --device ${DEVICE:-cuda} --set system.N=$N --set run.steps=$ST --replicas $r --concurrent $r --in-process --out $W/h$G-$g > $W/h$G-$g.log 2>&1 &
  done
  wait; t1=$(date +%s.%N)
  log "hybrid $G processes x $r threads (MPS): $(agg $G $r $(python3 -c "print($t1 - $t0)"))"
  for g in $(seq 1 $G); do grep "runs done" $W/h$G-$g.log; done | tee -a $R
done
echo quit | nvidia-cuda-mps-control; log "MPS daemon stopped"
cp $W/*.log $O/ 2>/dev/null; rm -rf $W
