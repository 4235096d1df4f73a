#!/bin/bash
# ABP φ = 0.4 (pipelines/abp-carter-phi0.4.yaml), 5 000 steps (t = 50), seeds 42..49, 2 threads:
# aae16dd's overlap_correct plugin (old) against main's (new); MSD at t = 25 and 50 and the correction's
# iterations a step, interleaved.
cd /tmp/cpuab
for s in 42 43 44 45 46 47 48 49; do
  for v in old new; do
    rm -rf runs/$v-$s
    ./$v/bin/pipeline run ./$v/pipelines/abp-carter-phi0.4.yaml --device cpu --threads 2 --set run.steps=5000 \
      --set run.seed=$s --out runs/$v-$s --force > runs-$v-$s.log 2>&1
    /usr/bin/python3 -c "
import h5py,sys
f=h5py.File('runs/$v-$s/abp-carter-phi0.4.h5','r')
m=f['/observables/observe.msd/msd/value'][:]; st=f['/observables/observe.msd/msd/step'][:]
print('$v seed $s:', ' '.join('t=%g MSD %.4f' % (st[i]*0.01, m[i]) for i in range(len(st)) if st[i] in (2500, 5000)))
"
  done
done
