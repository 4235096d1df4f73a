#!/usr/bin/env python3
"""Where two H5MD files differ: for each dataset outside /parameters and /h5md, the shapes, the
first frame (index along the first axis) whose bytes differ, how many frames differ, and the
step of that frame when the dataset has a sibling `step`.  Prints one line per file pair."""
import sys
import h5py
import numpy as np


def datasets(f):
    out = {}
    f.visititems(lambda n, o: out.__setitem__(n, o) if isinstance(o, h5py.Dataset) and
                 not n.startswith(("parameters", "h5md")) else None)
    return out


def main(a, b, tag):
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        da, db = datasets(fa), datasets(fb)
        notes = []
        if set(da) != set(db):
            notes.append(f"names differ: {sorted(set(da) ^ set(db))}")
        for n in sorted(set(da) & set(db)):
            x, y = da[n][()], db[n][()]
            if x.shape != y.shape:
                notes.append(f"{n}: shape {x.shape} vs {y.shape}")
                continue
            if x.ndim == 0:
                if x.tobytes() != y.tobytes():
                    notes.append(f"{n}: {x} vs {y}")
                continue
            xr = x.reshape(x.shape[0], -1).view(np.uint8) if x.size else x
            yr = y.reshape(y.shape[0], -1).view(np.uint8) if y.size else y
            rows = np.nonzero((xr != yr).any(axis=1))[0] if x.size else []
            if len(rows):
                f0 = int(rows[0])
                step = ""
                sib = n.rsplit("/", 1)[0] + "/step"
                if sib in fa and fa[sib].shape and fa[sib].shape[0] > f0:
                    step = f" (step {int(fa[sib][f0])})"
                cols = np.nonzero(x.reshape(x.shape[0], -1)[f0] != y.reshape(y.shape[0], -1)[f0])[0]
                notes.append(f"{n}: {len(rows)} of {x.shape[0]} frames differ, first {f0}{step}, "
                             f"{len(cols)} entries there, first entry {int(cols[0]) if len(cols) else -1}")
        print(f"{tag}: " + ("same" if not notes else "; ".join(notes)))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else sys.argv[2])
