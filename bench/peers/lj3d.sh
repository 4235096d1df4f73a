#!/bin/bash
# flipflow vs LAMMPS, 3D LJ 36-18 Brownian dynamics (Tran; pipelines/lj-aggregation.yaml), side by side.
# Usage (from anywhere): bench/peers/lj3d.sh [ROUNDS=2]
# Env: LMP (default /tmp/lmpsrc/build_deb/lmp_bd, built by ../shared/peers/build_lammps_bd.sh),
#      FF (default build/bin/pipeline), N (65536), PHI (0.15), NWARM (100), NRUN (1000), DT (5e-6),
#      RNG (gaussian | uniform: LAMMPS fix brownian noise), FF_RESULTS (where `pipeline bench` writes
#      its JSON line; default a temp folder, so bench/results is left alone), RESULTS (summary lines
#      are appended there too when set), WAIT_LOAD (e.g. 1.5: before each round, wait until the
#      1-minute load average is below it, at most WAIT_MAX seconds, default 900; the machine is
#      shared, and LAMMPS' MPI ranks lose most under another load).
# Each round: LAMMPS 2 MPI ranks, LAMMPS 1 rank + 2 OpenMP threads (-sf omp), flipflow 2 threads.
# Both start from a random-sequential-addition start (r >= sigma) and time the same step window
# (steps NWARM .. NWARM+NRUN after the start): LAMMPS' second `run`, flipflow bench's throughput pass.
set -e
ROUNDS=${1:-2}
REPO=$(cd "$(dirname "$0")/../.." && pwd)
P=$REPO/bench/peers
LMP=${LMP:-/tmp/lmpsrc/build_deb/lmp_bd}
FF=${FF:-$REPO/build/bin/pipeline}
N=${N:-65536}; PHI=${PHI:-0.15}; NWARM=${NWARM:-100}; NRUN=${NRUN:-1000}; DT=${DT:-5e-6}; RNG=${RNG:-gaussian}
W=${W:-/tmp/lj3d-bench}; mkdir -p $W
FF_RESULTS=${FF_RESULTS:-$W/ff-results}
DATA=$W/rsa$N.data
[ -f $DATA ] || python3 $P/rsa3d.py $N $PHI 1 $DATA
say() { echo "$*"; [ -z "$RESULTS" ] || echo "$*" >> "$RESULTS"; }
lmp_run() {  # tag, prefix, extra args, seed
  local log=$W/log.$1.$4
  (cd $W && OMP_NUM_THREADS=${OMP:-1} $2 $LMP -in $P/in.lj3d-bd -var data $DATA -var dt $DT -var nwarm $NWARM \
      -var nrun $NRUN -var seed $4 -var rng $RNG $3 -log $log -screen none)
  local lt=$(grep "^Loop time" $log | tail -1)
  local t=$(echo "$lt" | awk '{print $4}') steps=$(echo "$lt" | awk '{print $9}')
  local nb=$(grep "^Neighbor list builds" $log | tail -1 | awk '{print $5}')
  local db=$(grep "^Dangerous builds" $log | tail -1 | awk '{print $4}')
  local nn=$(grep "^Total # of neighbors" $log | tail -1 | awk '{print $6}')
  local pe=$(awk '/^ *Step/{getline; getline; print $2}' $log | tail -1)
  local pairpct=$(grep "^Pair " $log | tail -1 | awk -F'|' '{gsub(/ /,"",$6);print $6}')
  local neighpct=$(grep "^Neigh " $log | tail -1 | awk -F'|' '{gsub(/ /,"",$6);print $6}')
  LSPS=$(python3 -c "print(f'{$steps/$t:.2f}')")
  say "  LAMMPS $1: $LSPS steps/s ($steps steps in $t s; neighbour builds $nb, dangerous $db; half-list pairs within r_c+skin $nn; pair ${pairpct}%, neigh ${neighpct}%)"
}
say "== flipflow vs LAMMPS, 3D LJ 36-18 BD, $(date -u +%FT%TZ) on $(hostname): $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
say "   flipflow $(git -C $REPO rev-parse --short HEAD)$(git -C $REPO diff --quiet HEAD -- . ':!bench' || echo '+local changes') ($FF); LAMMPS $LMP ($(strings $LMP 2>/dev/null | grep -m1 -o '[0-9]\{1,2\} [A-Z][a-z][a-z] 20[0-9][0-9]' || echo '?'))"
say "   N = $N, phi = $PHI, eps = 14, n = 18, r_cut = 1.5, skin 0.3, D = mu = kT = 1, dt = $DT, rng $RNG; warm-up $NWARM steps, $NRUN timed"
for r in $(seq 1 $ROUNDS); do
  if [ -n "$WAIT_LOAD" ]; then
    waited=0
    while awk -v m=$WAIT_LOAD '{exit !($1 >= m)}' /proc/loadavg && [ $waited -lt ${WAIT_MAX:-900} ]; do
      sleep 10; waited=$((waited + 10))
    done
    say "   round $r: waited ${waited} s for a 1-minute load average below $WAIT_LOAD"
  fi
  say "   round $r: load average $(cut -d' ' -f1-3 /proc/loadavg)"
  OMP=1 lmp_run mpi2 "mpirun -np 2 --allow-run-as-root --oversubscribe" "" $((12345 + r)); L1=$LSPS
  OMP=2 lmp_run omp2 "" "-sf omp -pk omp 2" $((12345 + r)); L2=$LSPS
  out=$($FF bench $REPO/pipelines/lj-aggregation.yaml --sizes $N --steps $NRUN --warmup $NWARM --device cpu \
        --threads 2 --results $FF_RESULTS --set run.seed=$r --set run.dt=$DT 2>&1)
  echo "$out" > $W/ff.$r.txt
  F=$(echo "$out" | awk -v n=$N '$1==n{print $3}')
  say "  flipflow: $F steps/s (throughput pass; median step $(echo "$out" | awk -v n=$N '$1==n{print $2}') ms; per stage ms:$(echo "$out" | awk -v n=$N '$1==n{for(i=5;i<=NF;i++) printf " %s", $i}'); $(echo "$out" | grep 'per step' | sed 's/^ *//' | paste -sd';' | sed 's/;/; /g'))"
  say "  ratio flipflow / best LAMMPS = $(python3 -c "print(f'{$F/max($L1,$L2):.2f}')")  (target >= 2)"
done
