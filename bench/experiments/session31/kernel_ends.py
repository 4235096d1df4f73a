# Per step of a tools/gpu_trace CSV: each GPU activity's end minus the end of the one before it (its
# share of the step when programmatic launches let kernels start early and overlap), medians.
#   /usr/bin/python3 kernel_ends.py TRACE.csv FIRST_STEP LAST_STEP
import csv,sys,statistics as st
rows=[r for r in csv.DictReader(open(sys.argv[1])) if r['kind'] in('kernel','memcpy','memset')]
rows.sort(key=lambda r:int(r['start_ns']))
# steps: from each 'overdamped' kernel
steps=[];cur=None
for r in rows:
    if 'overdamped' in r['name'] or 'AbpStep' in r['name']:
        cur=[];steps.append(cur)
    if cur is not None: cur.append(r)
steps=steps[int(sys.argv[2]):int(sys.argv[3])]
import collections
d=collections.defaultdict(list)
for i,s in enumerate(steps[:-1]):
    nxt=int(steps[i+1][0]['start_ns'])
    prev_end=int(s[0]['start_ns'])
    for k,r in enumerate(s):
        name=r['name'][:40]
        e=int(r['end_ns'])
        d[(k,name,'start-prev_end')].append((int(r['start_ns'])-prev_end)/1e3)
        d[(k,name,'end-prev_end')].append((e-prev_end)/1e3)
        prev_end=e
    d[(99,'to next step','')].append((nxt-prev_end)/1e3)
    d[(100,'step','')].append((nxt-int(s[0]['start_ns']))/1e3)
for k in sorted(d): print(k, 'median %.1f mean %.1f n=%d'%(st.median(d[k]),st.mean(d[k]),len(d[k])))
