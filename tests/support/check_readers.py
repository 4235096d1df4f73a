#!/usr/bin/python3
"""Checks for tests/test_readers.cpp: open flipflow's files with the readers users have
(MDAnalysis, gsd) and compare what they read with the H5MD file's own numbers (h5py).

  check_readers.py mdanalysis MD.h5 NATIVE.h5   # observe.h5md layout: mdanalysis vs layout: h5md
  check_readers.py refused NATIVE.h5            # MDAnalysis refuses the plain layout of a 2-D run
  check_readers.py gsd OUT.gsd SOURCE.h5        # tools/convert's output vs its source
  check_readers.py same A.h5 B.h5               # every /particles and /observables dataset equal
  check_readers.py plain NATIVE.h5              # the default layout, as before the option

Prints one "ok ..." line per check; exits 1 with the first difference.
"""
import sys
import warnings

warnings.filterwarnings("ignore")
import h5py
import numpy as np


def fail(msg):
    print("FAILED: " + msg)
    sys.exit(1)


def native(path):
    f = h5py.File(path, "r")
    p = f["particles/all"]
    dim = int(p["box"].attrs["dimension"])
    return f, p, dim, np.asarray(p["box/edges"][:], dtype=np.float64)


def check_mdanalysis(md_path, native_path):
    from MDAnalysis.coordinates.H5MD import H5MDReader

    f, p, dim, L = native(native_path)
    pos = p["position/value"][:]
    steps = p["position/step"][:]
    times = p["position/time"][:]
    r = H5MDReader(md_path, convert_units=False)
    if r.n_frames != pos.shape[0] or r.n_atoms != pos.shape[1]:
        fail(f"MDAnalysis reads {r.n_frames} frames of {r.n_atoms} atoms, the file has {pos.shape[:2]}")
    Lz = L[2] if dim == 3 else 1.0
    for k, ts in enumerate(r):
        want = pos[k].astype(np.float32)  # MDAnalysis keeps float32 coordinates
        if not np.array_equal(ts.positions[:, :dim], want):
            fail(f"frame {k}: positions differ, max |d| = {np.abs(ts.positions[:, :dim] - want).max()}")
        if dim == 2 and np.any(ts.positions[:, 2] != 0):
            fail(f"frame {k}: z is not 0 in a 2-D run")
        box = np.array([L[0], L[1], Lz, 90, 90, 90], dtype=np.float32)
        if ts.dimensions is None or not np.allclose(ts.dimensions, box, rtol=1e-6, atol=0):
            fail(f"frame {k}: box {ts.dimensions}, expected {box}")
        if ts.data["step"] != steps[k] or ts.time != times[k]:
            fail(f"frame {k}: step/time {ts.data['step']}/{ts.time}, expected {steps[k]}/{times[k]}")
        # Observables line up with the frames: row k of every one is frame k (dt at each frame).
        dt_rows = f["observables/dt/step"][:]
        at = np.nonzero(dt_rows == steps[k])[0]
        if len(at) != 1 or ts.data["dt"] != f["observables/dt/value"][at[0]]:
            fail(f"frame {k}: dt {ts.data['dt']} is not the file's dt at step {steps[k]}")
    print(f"ok mdanalysis: {r.n_frames} frames, {r.n_atoms} atoms, {dim}D, box {L[0]:.6g} x {L[1]:.6g} x {Lz:.6g}")


def check_refused(native_path):
    from MDAnalysis.coordinates.H5MD import H5MDReader

    try:
        H5MDReader(native_path, convert_units=False)
    except ValueError as e:
        if "3-dimensional" not in str(e):
            fail(f"MDAnalysis refused the plain 2-D layout for another reason: {e}")
        print(f"ok refused: MDAnalysis says '{e}' for the plain 2-D layout")
        return
    fail("MDAnalysis opened the plain 2-D layout: the `layout: mdanalysis` option may be unneeded now")


def expected_diameters(f, p):
    """Each particle's diameter: /particles/all/diameter, else sigma * types[k].diameter of the
    pipeline the run ran (its --set overrides applied), else None."""
    if "diameter" in p:
        return p["diameter/value"][-1]
    where = next((w for w in ("parameters/effective_pipeline", "parameters/pipeline") if w in f), None)
    if where is None:
        return None
    try:
        import yaml
    except ImportError:
        return None
    system = yaml.safe_load(f[where][()].decode())["system"]
    types = system.get("types") or [{}]
    per = np.array([float(system.get("sigma", 1.0)) * float(t.get("diameter", 1.0)) for t in types])
    return per[p["species"][:] if len(per) > 1 else np.zeros(p["position/value"].shape[1], dtype=int)]


def check_gsd(gsd_path, h5_path):
    import gsd.hoomd

    f = h5py.File(h5_path, "r")
    p = f["particles/all"]
    dim = int(p["box"].attrs.get("flipflow_dimension", p["box"].attrs["dimension"]))
    edges = p["box/edges"]
    L = np.diag(edges["value"][0])[:dim] if isinstance(edges, h5py.Group) else edges[:][:dim]
    pos = p["position/value"][:][:, :, :dim]
    t = gsd.hoomd.open(gsd_path, "rb")
    if len(t) != pos.shape[0]:
        fail(f"{len(t)} GSD frames, the H5MD file has {pos.shape[0]}")
    for k in range(len(t)):
        s = t[k]
        c = s.configuration
        if int(c.dimensions) != dim or int(c.step) != int(p["position/step"][k]):
            fail(f"frame {k}: dimensions {c.dimensions}, step {c.step}")
        want_box = [L[0], L[1], L[2] if dim == 3 else 0.0, 0, 0, 0]
        if not np.allclose(c.box, want_box, rtol=1e-6, atol=0):
            fail(f"frame {k}: box {c.box}, expected {want_box}")
        got32 = s.particles.position[:, :dim]
        got = got32.astype(np.float64)
        want = pos[k] - L / 2  # GSD boxes are centred on the origin
        # HOOMD's box is half-open, [-L/2, L/2), compared in the file's float32: a coordinate just
        # below L rounds to L/2 there, and convert wraps it to -L/2 with its image one higher.
        half = (L / 2).astype(np.float32)
        if np.any(got32 >= half) or np.any(got32 < -half):
            fail(f"frame {k}: a position lies outside the half-open centred box")
        shift = np.zeros_like(want)
        if "image" in p:
            moved = s.particles.image[:, :dim] - p["image/value"][k][:, :dim]
            if np.any((moved != 0) & (moved != 1)):
                fail(f"frame {k}: images differ by more than the wrap at +L/2")
            shift = moved * L
        if np.abs(got + shift - want).max() > 1e-5 * max(L) or (dim == 2 and np.any(s.particles.position[:, 2] != 0)):
            fail(f"frame {k}: positions differ by {np.abs(got + shift - want).max()}")
        if not np.array_equal(s.particles.typeid, p["species"][:]):
            fail(f"frame {k}: type ids differ")
        want_d = expected_diameters(f, p)
        if want_d is not None and not np.allclose(s.particles.diameter, want_d, rtol=1e-6, atol=0):
            fail(f"frame {k}: diameters {np.unique(s.particles.diameter)}, expected {np.unique(want_d)}")
        direction = next((d for d in ("orientation", "boids.heading") if d in p), None)
        if direction:
            q = s.particles.orientation.astype(np.float64)
            if np.abs(np.linalg.norm(q, axis=1) - 1).max() > 1e-6:
                fail(f"frame {k}: orientations are not unit quaternions")
            # The body axis (1, 0, 0) rotated by q: (w²+x²-y²-z², 2(xy+wz), 2(xz-wy)).
            w, x, y, z = q.T
            axis = np.stack([w * w + x * x - y * y - z * z, 2 * (x * y + w * z), 2 * (x * z - w * y)], axis=1)
            o = p[f"{direction}/value"][k]
            want_axis = (np.stack([np.cos(o), np.sin(o), 0 * o], axis=1) if o.ndim == 1
                         else np.pad(o[:, :3], ((0, 0), (0, 3 - min(3, o.shape[1])))))  # boids: (u_x, u_y)
            if np.abs(axis - want_axis).max() > 1e-5:
                fail(f"frame {k}: the quaternions turn (1,0,0) away from the orientation by {np.abs(axis - want_axis).max()}")
    print(f"ok gsd: {len(t)} frames of {pos.shape[1]} particles, {dim}D, box {list(t[0].configuration.box)}, "
          f"diameters {np.unique(t[0].particles.diameter)}")


def datasets(path):
    f = h5py.File(path, "r")
    out = {}

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and name.split("/")[0] in ("particles", "observables"):
            out[name] = obj[()]

    f.visititems(visit)
    return out


def check_same(a_path, b_path):
    a, b = datasets(a_path), datasets(b_path)
    if set(a) != set(b):
        fail(f"different datasets: {sorted(set(a) ^ set(b))}")
    for name in a:
        if not np.array_equal(a[name], b[name], equal_nan=a[name].dtype.kind == "f"):
            fail(f"{name} differs")
    print(f"ok same: {len(a)} datasets equal")


def check_plain(path):
    f, p, dim, L = native(path)
    if L.shape != (dim,) or p["position/value"].shape[2] != dim or isinstance(p["box/edges"], h5py.Group):
        fail(f"the default layout changed: edges {L.shape}, position {p['position/value'].shape}")
    if "flipflow_dimension" in p["box"].attrs or "flipflow_padded_from" in p["position/value"].attrs:
        fail("the default layout carries the mdanalysis layout's marks")
    print(f"ok plain: {dim}D, box/edges a fixed [{dim}] dataset, position [frames, N, {dim}]")


if __name__ == "__main__":
    what, args = sys.argv[1], sys.argv[2:]
    {"mdanalysis": check_mdanalysis, "refused": check_refused, "gsd": check_gsd, "same": check_same,
     "plain": check_plain}[what](*args)
