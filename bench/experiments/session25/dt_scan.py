#!/usr/bin/python3
"""Session 25: does bench-abp's physics hold at a larger step? ABP (v0 = 1, Dr = 0.05, D = 0.01,
bench-abp.yaml's) at packing fraction PHI, N particles, to simulated time T, for several Δt and
seeds on the CPU: the MSD at a few times (observe.msd through observe.h5md's observables), the
correction's iterations, rollbacks. Usage: dt_scan.py N PHI T DT,DT,... SEEDS OUTDIR"""
import subprocess, sys, os, h5py, numpy as np

n, phi, T = int(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
dts = [float(x) for x in sys.argv[4].split(',')]
seeds, out = int(sys.argv[5]), sys.argv[6]
pipeline = os.path.join(os.path.dirname(__file__), '../../../build/bin/pipeline')
os.makedirs(out, exist_ok=True)
every_t = T / 10  # MSD every tenth of the run
res = {}
for dt in dts:
    steps = int(round(T / dt))
    every = max(1, int(round(every_t / dt)))
    for s in range(1, seeds + 1):
        tag = f'n{n}-phi{phi}-dt{dt}-s{s}'
        y = f"""system: {{dimensions: 2, N: {n}, packing_fraction: {phi}, sigma: 1.0, init: triangular_lattice_sample}}
run: {{steps: {steps}, dt: {dt}, seed: {s}, precision: double}}
plugins: [abp]
step:
  - {{stage: delaunay.sort}}
  - {{stage: abp.integrate, v0: 1.0, Dr: 0.05, D: 0.01}}
  - {{stage: delaunay.detect_inversion}}
  - {{stage: delaunay.flip}}
  - {{stage: delaunay.lawson}}
  - {{stage: overlap_correct}}
  - {{stage: observe.msd, every: {every}}}
  - {{stage: observe.h5md, every: {every}, file: m.h5, fields: []}}
"""
        yp = os.path.join(out, tag + '.yaml')
        open(yp, 'w').write(y)
        r = subprocess.run([pipeline, 'run', yp, '--device', 'cpu', '--threads', '2', '--out', os.path.join(out, tag),
                            '--force'], capture_output=True, text=True)
        if r.returncode:
            print(tag, 'FAILED', r.stderr[-500:]); continue
        with h5py.File(os.path.join(out, tag, 'm.h5')) as f:
            o = f['observables']
            msd = o['observe.msd/msd/value'][:] if 'observe.msd/msd' in o else o['msd/value'][:]
            it = o['overlap_correct/iterations/value'][:]
            rb = o['rollbacks/value'][-1] if 'rollbacks' in o else -1
        done = [l for l in r.stdout.splitlines() + r.stderr.splitlines() if l.startswith('done')]
        res.setdefault(dt, []).append((msd, it.mean(), rb, done[0] if done else ''))
print(f'N={n} phi={phi} T={T}: MSD at t = T/10 .. T (mean ± SE over seeds); iterations a step; rollbacks')
for dt, rows in res.items():
    m = np.array([r[0] for r in rows])
    mean, se = m.mean(0), m.std(0, ddof=1) / np.sqrt(len(rows)) if len(rows) > 1 else 0 * m.mean(0)
    pts = ' '.join(f'{a:.3g}±{b:.2g}' for a, b in zip(mean[1::2], se[1::2]))
    print(f'dt={dt}: {pts} | it {np.mean([r[1] for r in rows]):.2f} | rb {sum(r[2] for r in rows)} | {rows[0][3]}')
