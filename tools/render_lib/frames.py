"""tools/render's frames: one frame of an H5MD file drawn as disks (2D), or as the projection or a
slice of spheres (3D), coloured by orientation, species, a per-particle field or cluster labels,
with periodic images, walls and Voronoi cells (tools/render --help)."""
import math
import os
import sys

from render_lib.common import (
    PROG, in_sigma_units, LEGEND_BESIDE, quantity_label, InputProblem, fail, did_you_mean, need,
    pipeline_walls, species_diameters, pipeline_sigma, fit_title, save, default_out)


# Per-particle fields whose angle colours the disks, the first the file has: ABP's orientation,
# the boids' heading (plugins/boids).
ANGLE_FIELDS = ("orientation", "boids.heading")


# --color-by values that are not the name of a per-particle element of the file.
COLOR_MODES = ("orientation", "species", "touched", "depth", "none")


def frame_index(n_frames, frame, path):
    if n_frames == 0:
        raise InputProblem(f"{path}: /particles/all/position/value has no frames")
    k = frame if frame >= 0 else n_frames + frame
    if not 0 <= k < n_frames:
        raise InputProblem(f"{path}: --frame {frame} is out of range; the file has {n_frames} frames "
                           f"(0..{n_frames - 1}, or -1 for the last)")
    return k


def orientation_angles(np, value, k, n):
    """θ per particle from an orientation frame: [N], [N,1] (angle), [N,2] or [N,3] (unit vector; 3D: the azimuth)."""
    o = np.asarray(value[k], dtype=float)
    if o.ndim == 1 and o.shape[0] == n:
        return o
    if o.ndim == 2 and o.shape == (n, 1):
        return o[:, 0]
    if o.ndim == 2 and o.shape == (n, 2):
        return np.arctan2(o[:, 1], o[:, 0])
    if o.ndim == 2 and o.shape == (n, 3):
        return np.arctan2(o[:, 1], o[:, 0])  # 3D: the azimuth
    raise InputProblem(f"orientation frame has shape {o.shape}; expected ({n},), ({n}, 1), ({n}, 2) or ({n}, 3)")


def particle_values(np, f, name, k, n_frames, frame, n):
    """One frame of the per-particle element /particles/all/NAME (e.g. voronoi.area), as [N]."""
    where = f"/particles/all/{name}/value"
    if where not in f:
        have = sorted(e for e in f["particles/all"].keys() if e not in ("box", "species")) if "particles/all" in f else []
        raise InputProblem(f"{f.filename}: --color-by {name}: no {where}; {did_you_mean(name, COLOR_MODES + tuple(have))}"
                           f"colour by orientation, species, touched, depth, "
                           f"none or a per-particle element of the file ({', '.join(have) or 'none'}); write it "
                           f"with observe.h5md `fields: [..., {name}]`")
    v = f[where]
    kv = k if v.shape[0] == n_frames else v.shape[0] - 1 if frame == -1 else k
    if kv >= v.shape[0]:
        raise InputProblem(f"{f.filename}: {where} has {v.shape[0]} frames, fewer than the positions ({n_frames})")
    a = np.asarray(v[kv])
    if a.ndim == 2 and a.shape[1] == 1:
        a = a[:, 0]
    if a.shape != (n,):
        raise InputProblem(f"{f.filename}: {where} has frames of shape {a.shape}; colouring needs one number per "
                           f"particle ({n},)")
    return a


def value_scale(np, plt, v, cmap):
    """(colour map, norm) for per-particle values: one colour per integer for integer values
    (voronoi.sides), else a continuous map over the central 99 % of the values."""
    import matplotlib.colors as mcolors
    if np.issubdtype(v.dtype, np.integer):
        lo, hi = int(v.min()), int(v.max())
        cm = plt.get_cmap(cmap or "coolwarm", hi - lo + 1)
        return cm, mcolors.BoundaryNorm(np.arange(lo - 0.5, hi + 1.5), cm.N)
    lo, hi = np.percentile(v, [0.5, 99.5]) if v.size else (0.0, 1.0)
    return plt.get_cmap(cmap or "viridis"), mcolors.Normalize(lo, hi if hi > lo else lo + 1)


def is_label_field(np, name, v):
    """Whether an integer field names clusters or other groups rather than measuring something:
    its name says label (cluster.label), or it has too many values for a colour bar of one colour
    per value. Such values are coloured categorically (label_colors)."""
    if not np.issubdtype(v.dtype, np.integer) or not v.size:
        return False
    return "label" in name.split(".")[-1] or int(v.max()) - int(v.min()) + 1 > 32


def label_colors(np, plt, v, cmap):
    """(RGBA per particle, legend entries [(colour, text)], summary) of an integer label field:
    a qualitative palette cycled over the groups of two or more particles, in the order of their
    labels (observe.clusters' labels are smallest indices, and delaunay.sort numbers the particles
    along a Hilbert curve, so clusters next to each other get different colours); grey for the
    monomers (a label only one particle has) and light grey for -1 (cluster.label's particles that
    take no part)."""
    labels, inverse, counts = np.unique(v, return_inverse=True, return_counts=True)
    palette = plt.get_cmap(cmap or "tab20")
    n_pal = palette.N if palette.N <= 32 else 12
    colours = [palette(i / (n_pal - 1) if palette.N > 32 else i) for i in range(n_pal)]
    # tab20's two greys would read as monomers.
    colours = [c for c in colours if max(c[:3]) - min(c[:3]) > 0.05] or colours
    grouped = (counts >= 2) & (labels >= 0)
    rank = np.cumsum(grouped) - 1
    monomer, no_part = (0.62, 0.62, 0.62, 1.0), (0.88, 0.88, 0.88, 1.0)
    per_label = np.asarray([colours[rank[j] % len(colours)] if grouped[j] else no_part if labels[j] < 0
                            else monomer for j in range(labels.size)], dtype=float).reshape(-1, 4)
    n_groups = int(grouped.sum())
    n_mono = int(((counts == 1) & (labels >= 0)).sum())
    n_none = int(counts[labels < 0].sum())
    legend = [(colours[0], f"{n_groups} clusters of ≥ 2 ({len(colours)} colours, cycled)"),
              (monomer, f"{n_mono} monomers")]
    if n_none:
        legend.append((no_part, f"{n_none} taking no part (-1)"))
    summary = f"{n_groups} clusters of ≥ 2 coloured, {n_mono} monomers grey" + (
        f", {n_none} taking no part light grey" if n_none else "")
    return per_label[inverse.reshape(-1)], legend, summary


def periodic_voronoi(np, x, L, wall_axis=None):
    """Voronoi cells of the points x [N, 2] in the periodic box L, as polygons covering the box:
    (list of [k, 2] vertex arrays, owner index per polygon). The cells of the points and of
    their periodic images near the box (scipy.spatial.Voronoi of the points and their images in
    a band around the box), to be clipped to the box when drawn. With hard walls at 0 and L
    along wall_axis (0 or 1) the images across them are mirror images instead, which cut each
    cell exactly at the wall (the bisector of a point and its mirror image is the wall)."""
    try:
        from scipy.spatial import Voronoi
    except ImportError:
        fail(f"--voronoi needs scipy ({sys.executable} lacks it; Debian: apt-get install python3-scipy)", 3)
    n = x.shape[0]
    spacing = math.sqrt(L[0] * L[1] / max(n, 1))
    band = min(0.5 * min(L), 12 * spacing)  # images this far out complete every cell near the box
    pts, owner = [x], [np.arange(n)]
    for sx in (-1, 0, 1):
        for sy in (-1, 0, 1):
            if sx == 0 and sy == 0:
                continue
            y = x + np.array([sx * L[0], sy * L[1]])
            if wall_axis is not None and (sx, sy)[wall_axis]:
                side = (sx, sy)[wall_axis]  # -1: mirrored about 0, +1: about L
                y[:, wall_axis] = (0.0 if side < 0 else 2 * L[wall_axis]) - x[:, wall_axis]
            keep = (y[:, 0] > -band) & (y[:, 0] < L[0] + band) & (y[:, 1] > -band) & (y[:, 1] < L[1] + band)
            pts.append(y[keep])
            owner.append(np.nonzero(keep)[0])
    pts, owner = np.concatenate(pts), np.concatenate(owner)
    vor = Voronoi(pts)
    # Draw the cells of the points within a few spacings of the box: they cover it, and their
    # regions are complete (the band's images surround them).
    near = ((pts[:, 0] > -3 * spacing) & (pts[:, 0] < L[0] + 3 * spacing) &
            (pts[:, 1] > -3 * spacing) & (pts[:, 1] < L[1] + 3 * spacing))
    polys, who = [], []
    for p in np.nonzero(near)[0]:
        region = vor.regions[vor.point_region[p]]
        if not region or -1 in region:
            continue
        polys.append(vor.vertices[region])
        who.append(owner[p])
    return polys, np.asarray(who, dtype=int)


def render_frame(np, h5py, args):
    import matplotlib.pyplot as plt
    from matplotlib.collections import EllipseCollection
    from matplotlib.patches import Rectangle

    with h5py.File(args.file, "r") as f:
        pos_ds = need(f, "/particles/all/position/value", "particle positions, [frames, N, dim]")
        if pos_ds.ndim != 3:
            raise InputProblem(f"{args.file}: /particles/all/position/value has shape {pos_ds.shape}; "
                               f"expected [frames, N, dim]")
        k = frame_index(pos_ds.shape[0], args.frame, args.file)
        x = np.asarray(pos_ds[k], dtype=float)
        n, dim = x.shape
        if dim not in (2, 3):
            raise InputProblem(f"{args.file}: positions have {dim} components; expected 2 or 3")
        edges = np.asarray(need(f, "/particles/all/box/edges", "the periodic box")[()], dtype=float).reshape(-1)
        if edges.size < 2:
            raise InputProblem(f"{args.file}: /particles/all/box/edges has {edges.size} values; expected {dim}")
        L = edges[:2]
        step = time = None
        if "particles/all/position/step" in f:
            step = int(f["particles/all/position/step"][k])
        if "particles/all/position/time" in f:
            time = float(f["particles/all/position/time"][k])

        species = np.zeros(n, dtype=int)
        names = []
        if "particles/all/species" in f:
            sp = f["particles/all/species"]
            species = np.asarray(sp[()] if sp.ndim == 1 else sp[-1], dtype=int).reshape(-1)
            if species.size != n:
                raise InputProblem(f"{args.file}: /particles/all/species has {species.size} entries, "
                                   f"positions have {n} particles")
            if "names" in sp.attrs:
                names = [s.decode() if isinstance(s, bytes) else str(s) for s in sp.attrs["names"]]
        n_species = int(species.max()) + 1 if n else 1

        theta = None
        angle_field = next((a for a in ANGLE_FIELDS if f"particles/all/{a}/value" in f), None)
        if angle_field is not None:
            where = f"/particles/all/{angle_field}/value"
            ov = f[where]
            ko = k if ov.shape[0] == pos_ds.shape[0] else ov.shape[0] - 1 if args.frame == -1 else k
            if ko >= ov.shape[0]:
                raise InputProblem(f"{args.file}: {where} has {ov.shape[0]} frames, "
                                   f"fewer than the positions ({pos_ds.shape[0]})")
            try:
                theta = orientation_angles(np, ov, ko, n)
            except InputProblem as e:
                raise InputProblem(f"{args.file}: {where}: {e}")

        touched = None
        if args.color_by == "touched":
            tv = need(f, "/particles/all/overlap_correct.touched/value",
                      "the particles an overlap correction touched (overlap_correct `mark: true`, observe.h5md "
                      "`fields: [..., overlap_correct.touched]`)")
            kt = k if tv.shape[0] == pos_ds.shape[0] else tv.shape[0] - 1 if args.frame == -1 else k
            if kt >= tv.shape[0]:
                raise InputProblem(f"{args.file}: /particles/all/overlap_correct.touched/value has {tv.shape[0]} "
                                   f"frames, fewer than the positions ({pos_ds.shape[0]})")
            touched = np.asarray(tv[kt]).reshape(-1) != 0
            if touched.size != n:
                raise InputProblem(f"{args.file}: /particles/all/overlap_correct.touched/value has {touched.size} "
                                   f"entries a frame, positions have {n} particles")

        # The axis of the hard walls (drawn on every frame of a run with walls; with --voronoi the
        # axis whose images are mirror images).
        wall_axis = pipeline_walls(f) if args.walls == "auto" else None if args.walls == "none" else "xy".index(args.walls)
        field_values = None  # --color-by a per-particle element (voronoi.area, voronoi.sides, ...)
        categories = None  # (RGBA per particle, legend, summary) of an integer label field (cluster.label)
        if args.color_by not in COLOR_MODES:
            field_values = particle_values(np, f, args.color_by, k, pos_ds.shape[0], args.frame, n)
            field_values = in_sigma_units(args.color_by, field_values, pipeline_sigma(f))
            if np.issubdtype(field_values.dtype, np.floating) and np.isnan(field_values).all():
                # observe.h5md writes NaN where nothing had computed the field yet: the initial frame
                # of a field the steps compute (a force, voronoi.area, trap.energy).
                raise InputProblem(f"{args.file}: {args.color_by} has no values at frame {k}: it is NaN, not computed yet "
                                   "(the stage that writes it runs in the steps, after the initial frame); "
                                   "draw a later frame (--frame 1, or the last by default)")
            if is_label_field(np, args.color_by, field_values):
                # Before a 3D view picks its spheres: a monomer is one in the whole frame.
                categories = label_colors(np, plt, field_values, args.cmap)

        if args.diameter is not None:
            diam = np.full(n, args.diameter)
            diam_source = "--diameter"
        elif "particles/all/diameter/value" in f:
            dv = f["particles/all/diameter/value"]
            diam = np.asarray(dv[min(k, dv.shape[0] - 1)], dtype=float).reshape(-1)
            diam_source = "/particles/all/diameter"
        else:
            per = species_diameters(f, n_species)
            if per is not None and len(per) >= n_species:
                diam = np.asarray(per, dtype=float)[species]
                diam_source = ("/parameters/effective_pipeline" if "parameters/effective_pipeline" in f
                               else "/parameters/pipeline") + ": " + ", ".join(
                                   f"{d:g}" for d in sorted(set(per[:n_species])))
            else:
                diam = np.ones(n)
                diam_source = "default 1"
        sigma = pipeline_sigma(f)

    color_by = args.color_by
    if color_by == "orientation" and theta is None:
        if args.color_by_given:
            raise InputProblem(f"{args.file}: --color-by orientation, but there is no "
                               f"/particles/all/orientation/value nor /particles/all/boids.heading/value (write "
                               f"one with observe.h5md `fields: [position, orientation]`)")
        color_by = "species"
    if color_by == "depth" and not (dim == 3 and args.slice is None):
        raise InputProblem(f"{args.file}: --color-by depth is for the projection of a 3D frame (without --slice)")
    if dim == 3 and args.slice is None and not args.color_by_given:
        # A projection of every sphere coloured by anything else is one solid colour where the
        # spheres cover the box (all of it from a few layers on): the depth of the nearest is
        # what the picture can show.
        color_by = "depth"

    # 3D: the projection along z of every sphere, the nearest (largest z) drawn last, or the
    # cross-sections with the mid-plane z = L_z/2 of the spheres whose centres lie in the slab
    # |z − L_z/2| < W/2 (--slice W). Each sphere at its full diameter would make spheres at
    # different heights look as if they overlapped; the cross-sections of spheres that do not
    # overlap never do.
    view = ""
    depth = None  # z / σ of the drawn spheres (--color-by depth)
    if dim == 3:
        Lz = edges[2] if edges.size > 2 else L[1]
        z = np.mod(x[:, 2], Lz)
        if args.slice is not None:
            lo, hi = 0.5 * (Lz - args.slice), 0.5 * (Lz + args.slice)
            dz = z - 0.5 * Lz
            pick = np.nonzero((z >= lo) & (z < hi) & (np.abs(dz) < 0.5 * diam))[0]
            view = f"slice z ∈ [{lo:g}, {hi:g}), cross-sections with z = {0.5 * Lz:g}"
        else:
            pick = np.argsort(z, kind="stable")
            view = "projection along z"
        x, diam, species = x[pick], diam[pick], species[pick]
        depth = z[pick] / sigma
        if args.slice is not None:
            diam = 2 * np.sqrt(np.maximum(0.25 * diam ** 2 - dz[pick] ** 2, 0.0))
        if theta is not None:
            theta = theta[pick]
        if touched is not None:
            touched = touched[pick]
        if field_values is not None:
            field_values = field_values[pick]
        if categories is not None:
            categories = (categories[0][pick],) + categories[1:]
    elif args.slice is not None:
        raise InputProblem(f"{args.file}: --slice is for 3D frames; this one is {dim}D")
    if args.voronoi and dim != 2:
        raise InputProblem(f"{args.file}: --voronoi draws 2D Voronoi cells; this frame is {dim}D")
    n_drawn = x.shape[0]

    # Periodic images of the disks that cross an edge, so the box looks like the simulation; none
    # across hard walls (no disk interacts through them).
    x2 = np.mod(x[:, :2], L)
    r = 0.5 * diam
    ox, od, oi = [x2], [diam], [np.arange(n_drawn)]
    for sx in (-1, 0, 1):
        for sy in (-1, 0, 1):
            if (sx == 0 and sy == 0) or (wall_axis is not None and (sx, sy)[wall_axis]):
                continue
            shifted = x2 + np.array([sx * L[0], sy * L[1]])
            near = ((shifted[:, 0] + r > 0) & (shifted[:, 0] - r < L[0]) &
                    (shifted[:, 1] + r > 0) & (shifted[:, 1] - r < L[1]))
            if near.any():
                ox.append(shifted[near]); od.append(diam[near]); oi.append(np.nonzero(near)[0])
    xy = np.concatenate(ox); dd = np.concatenate(od); idx = np.concatenate(oi)
    # The images were appended after every disk; in the order of their disks instead, so that a
    # 3D projection's far spheres (drawn first) lie under the near ones at the edges too.
    order = np.argsort(idx, kind="stable")
    xy, dd, idx = xy[order], dd[order], idx[order]

    # Margins around the box: 1 % of it, and along the wall axis of a run with walls room for the
    # walls (hatched bands) drawn there.
    pad = [0.01 * max(L)] * 2
    if wall_axis is not None:
        pad[wall_axis] = 0.025 * max(L)
    aspect = (L[1] + 2 * pad[1]) / (L[0] + 2 * pad[0])
    w_in = args.size
    # A colour bar or a legend goes beside the box, never over the particles: the figure widens for it.
    legend_beside = categories is not None or (color_by == "species" and n_species > 1) or color_by == "touched"
    fig_w = w_in * (1.25 if color_by in ("orientation", "depth") or (field_values is not None and categories is None)
                    else 1.35 if legend_beside else 1.0)
    fig, ax = plt.subplots(figsize=(fig_w, w_in * aspect + 0.4))
    coll = EllipseCollection(dd, dd, np.zeros_like(dd), units="xy", offsets=xy,
                             offset_transform=ax.transData, linewidths=0)
    clip = Rectangle((0, 0), L[0], L[1], transform=ax.transData)
    scale = None  # (colour map, norm) of --color-by FIELD
    area_check = []  # |drawn cell area − voronoi.area| per particle (--voronoi --color-by voronoi.area)
    if field_values is not None and categories is None:
        scale = value_scale(np, plt, field_values, args.cmap)

    def paint_by_field(c, pick):
        # c's colours from --color-by FIELD for the particles `pick` (its values on the scale, or
        # its categories); False when no field colours the frame.
        if scale is not None:
            c.set_array(field_values[pick])
            c.set_cmap(scale[0])
            c.set_norm(scale[1])
        elif categories is not None:
            c.set_facecolor(categories[0][pick])
        else:
            return False
        return True
    if args.voronoi:
        # The cells of the frame's positions (scipy), filled with the field's colour when
        # colouring by one (the disks then drawn as outlines), their edges drawn.
        from matplotlib.collections import PolyCollection
        polys, who = periodic_voronoi(np, x2, L, wall_axis)
        cells = PolyCollection(polys, closed=True, edgecolors="0.15", linewidths=0.4, zorder=0.5)
        if not paint_by_field(cells, who):
            cells.set_facecolor("none")
        ax.add_collection(cells)
        cells.set_clip_path(clip)
        if field_values is not None and color_by == "voronoi.area":
            # The drawn cells against the file's areas: the cell of each particle itself (not of an
            # image) by the shoelace formula; they agree when the file's cells are the drawn
            # ones (voronoi.mirror with walls, voronoi.geometry without).
            own = [(p, w) for p, w in zip(polys, who)]
            seen = np.zeros(n_drawn, dtype=bool)
            for p, w in own:
                c = p.mean(axis=0)
                if seen[w] or not (0 <= c[0] < L[0] and 0 <= c[1] < L[1]):
                    continue
                seen[w] = True
                a = 0.5 * abs(np.dot(p[:, 0], np.roll(p[:, 1], -1)) - np.dot(p[:, 1], np.roll(p[:, 0], -1)))
                area_check.append(abs(a - field_values[w]))
    if color_by == "orientation":
        # [-π, π), the range abp.integrate writes θ in (README, "What the values are")
        coll.set_array(np.mod(theta[idx] + math.pi, 2 * math.pi) - math.pi)
        coll.set_cmap(args.cmap or "hsv")
        coll.set_clim(-math.pi, math.pi)
    elif color_by == "depth":
        coll.set_array(depth[idx])
        coll.set_cmap(args.cmap or "viridis")
        coll.set_clim(0, Lz / sigma)
    elif color_by == "species":
        import matplotlib.colors as mcolors
        palette = plt.get_cmap(args.cmap or "tab10")
        colors = [palette(s % palette.N) for s in range(n_species)]
        coll.set_facecolor([colors[s] for s in species[idx]])
    elif color_by == "touched":
        coll.set_facecolor(np.where(touched[idx][:, None], [[0.85, 0.1, 0.1, 1.0]], [[0.75, 0.75, 0.75, 1.0]]))
    elif (scale is not None or categories is not None) and args.voronoi:
        coll.set_facecolor("none")
        coll.set_edgecolor("0.15")
        coll.set_linewidth(0.4)
    elif not paint_by_field(coll, idx):
        coll.set_facecolor("0.35")
    if dim == 3:
        # Thin dark outlines: the spheres of a projection or a slice that touch or lie over each
        # other are told apart (filled alone, touching disks of one colour merge into blobs).
        # About 4 % of a disk's width on screen, so they stay thin for small spheres.
        d_pt = float(np.median(diam)) / (L[0] + 2 * pad[0]) * w_in * 72 if n_drawn else 0.0
        coll.set_edgecolor((0.1, 0.1, 0.1, 0.7))
        coll.set_linewidth(min(0.6, max(0.1, 0.04 * d_pt)))
    ax.add_collection(coll)
    coll.set_clip_path(clip)
    ax.add_patch(Rectangle((0, 0), L[0], L[1], fill=False, edgecolor="black", linewidth=0.8))
    if wall_axis is not None:
        # The hard walls: hatched bands beyond 0 and L along the wall axis, their faces drawn bold
        # (the periodic edges stay thin).
        band = pad[wall_axis]
        for lo in (-band, L[wall_axis]):
            xy0 = (lo, -pad[1]) if wall_axis == 0 else (-pad[0], lo)
            size = (band, L[1] + 2 * pad[1]) if wall_axis == 0 else (L[0] + 2 * pad[0], band)
            ax.add_patch(Rectangle(xy0, *size, facecolor="0.85", edgecolor="0.3", hatch="////", linewidth=0))
        for at in (0.0, L[wall_axis]):
            if wall_axis == 0:
                ax.plot([at, at], [-pad[1], L[1] + pad[1]], color="black", linewidth=2.2, solid_capstyle="butt")
            else:
                ax.plot([-pad[0], L[0] + pad[0]], [at, at], color="black", linewidth=2.2, solid_capstyle="butt")
    ax.set_xlim(-pad[0], L[0] + pad[0])
    ax.set_ylim(-pad[1], L[1] + pad[1])
    ax.set_aspect("equal")
    ax.set_xticks([]); ax.set_yticks([])
    for s in ax.spines.values():
        s.set_visible(False)

    if color_by == "orientation":
        cb = fig.colorbar(coll, ax=ax, fraction=0.04, pad=0.02, ticks=[-math.pi, -math.pi / 2, 0, math.pi / 2, math.pi])
        cb.ax.set_yticklabels(["−π", "−π/2", "0", "π/2", "π"])
        cb.set_label("heading θ" if angle_field == "boids.heading"
                     else "orientation: azimuth φ in the x-y plane" if dim == 3 else "orientation θ")
    elif color_by == "depth":
        cb = fig.colorbar(coll, ax=ax, fraction=0.04, pad=0.02)
        cb.set_label("z / σ (far → near)")
    elif scale is not None:
        import matplotlib.cm as cm
        mappable = cm.ScalarMappable(norm=scale[1], cmap=scale[0])
        integer = np.issubdtype(field_values.dtype, np.integer)
        cb = fig.colorbar(mappable, ax=ax, fraction=0.04, pad=0.02,
                          ticks=np.arange(field_values.min(), field_values.max() + 1) if integer else None)
        cb.set_label(quantity_label(color_by))
    elif color_by == "species" and n_species > 1:
        from matplotlib.lines import Line2D
        handles = [Line2D([], [], marker="o", linestyle="", markerfacecolor=colors[s], markeredgewidth=0,
                          label=names[s] if s < len(names) else f"species {s}") for s in range(n_species)]
        ax.legend(handles=handles, **LEGEND_BESIDE)
    elif categories is not None:
        from matplotlib.lines import Line2D
        handles = [Line2D([], [], marker="o", linestyle="", markerfacecolor=c, markeredgewidth=0, label=lab)
                   for c, lab in categories[1]]
        ax.legend(handles=handles, **LEGEND_BESIDE, title=color_by,
                  title_fontsize="small")
    elif color_by == "touched":
        from matplotlib.lines import Line2D
        handles = [Line2D([], [], marker="o", linestyle="", markerfacecolor=c, markeredgewidth=0, label=lab)
                   for c, lab in (((0.85, 0.1, 0.1), f"touched ({int(touched.sum())})"), ((0.75, 0.75, 0.75), "not touched"))]
        ax.legend(handles=handles, **LEGEND_BESIDE)

    if args.title is not None:
        title = args.title
    else:
        bits = [os.path.basename(args.file), f"N = {n}"]
        if step is not None:
            bits.append(f"step {step}")
        if time is not None:
            bits.append(f"t = {time:g}")
        bits.append(f"box {L[0]:g} × {L[1]:g}" + (f" × {edges[2]:g}, {view}" if view else ""))
        title = ", ".join(bits)
    if title:
        fit_title(fig, ax, title)
    else:
        fig.tight_layout()

    # The default name says what is drawn, so that the pictures of one frame suggested side by side
    # (hard-disks-slab.yaml: --color-by touched, --voronoi --color-by voronoi.area) do not overwrite
    # each other.
    out = args.out or default_out(args.file, "-".join(
        [f"step{step}" if step is not None else f"frame{k}", color_by] + (["cells"] if args.voronoi else [])
        + ([f"slice{args.slice:g}"] if view.startswith("slice") else [])))
    if args.all_frames and args.out:
        out = args.out.format(frame=k, step=step if step is not None else k)
    save(fig, out, args)
    said = "heading (boids.heading)" if color_by == "orientation" and angle_field == "boids.heading" else color_by
    print(f"{out}: frame {k} (N = {n}, diameters from {diam_source}, colour by {said}"
          + (f" ({categories[2]})" if categories is not None else "")
          + (f"; 3D, {view}: {n_drawn} " + ("cross-sections" if args.slice is not None else "spheres") + " drawn"
             if view else "")
          + (f"; Voronoi cells of {n_drawn} points" + (f", walls ⟂ {'xy'[wall_axis]}" if wall_axis is not None else "")
             if args.voronoi else f"; walls ⟂ {'xy'[wall_axis]}" if wall_axis is not None else "")
          + (f"; drawn cell areas vs voronoi.area: {len(area_check)} cells, largest difference {max(area_check):.2g}"
             if area_check else "") + ")")
    if area_check:
        # The picture is of scipy's cells of the frame's positions; the colours are the file's
        # areas. When they disagree the colours belong to other cells, and the summary line's
        # number alone is easy to miss.
        mean_area = float(np.mean(np.abs(field_values))) if field_values.size else 0.0
        worst = max(area_check)
        if worst > 1e-6 * mean_area:
            zeros = not np.any(field_values)
            print(f"{PROG}: warning: {args.file} frame {k}" + (f" (step {step})" if step is not None else "")
                  + ": the file's cells are not the Voronoi cells of the frame's positions ("
                  + (f"voronoi.area differs from the drawn cells' areas by up to {worst:.2g}, {worst / mean_area:.2g} "
                     f"of the mean area {mean_area:.4g})" if mean_area > 0 else "voronoi.area is all 0)"),
                  file=sys.stderr)
            print(f"{PROG}: the usual reasons: the frame was written before the voronoi stage first ran (frame 0 "
                  f"of a voronoi.geometry run: all areas 0{', as here' if zeros else ''}), or voronoi.geometry with `positions: current` "
                  f"runs after overlap_correct without a `delaunay.lawson` step after the correction (the cells "
                  f"are then those of a triangulation not quite Delaunay for the corrected positions), or the "
                  f"walls differ: " + (f"the picture's cells are clipped by walls ⟂ {'xy'[wall_axis]} (the pipeline's "
                  f"`walls:` or --walls), and the file's are not (voronoi.geometry's cells are periodic: list "
                  f"voronoi.mirror with the walls, or draw with --walls none) or are clipped elsewhere"
                  if wall_axis is not None else "the picture's cells are periodic, and the file's may be clipped by "
                  "walls (voronoi.mirror): --walls x|y draws them so"),
                  file=sys.stderr)
