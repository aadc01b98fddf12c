"""Re-meshing against conforming meshers (W&T sec. 5 claims an order of
magnitude): goo's mesh generation and whole re-mesh against CGAL Mesh_3,
TetGen and gmsh at matched tet counts, on real models.

(a) conforming to the same fine surface: TetGen (-p, -Y keeps every input
    triangle) and gmsh (the surface as a discrete model, kept);
(b) free to coarsen the surface: CGAL Mesh_3 (it resamples the surface to
    its size criteria) and gmsh after surface classification and
    reparametrisation. TetGen cannot coarsen (it keeps the input facets).
Each mesher is first calibrated (untimed) to goo's tet count; where the
fine surface forces more tets than that, the smallest mesh is used and
timed, and tets per second compares them."""
import json
import os
import re
import shutil
import tempfile

import numpy as np

from common import (dihedral_range, log, median, read_off, run, save_figure, table, write_binary_stl, write_csv,
                    write_json, plt)

REPS = 5


def calibrate(make, target, start, exponent=1.0, attempts=6):
    """Finds a size parameter s with make(s) → tets within 15% of target
    (tets ∝ s^(−exponent·3) for a length, s^(−exponent) for a volume).
    Returns (s, tets)."""
    s = start
    tets = make(s)
    for _ in range(attempts):
        ratio = tets / target
        if abs(ratio - 1.0) < 0.15:
            break
        s *= ratio ** exponent
        tets = make(s)
    return s, tets


def tetgen(model_off, target, work, volume):
    """TetGen on the fine surface, every input triangle kept (-pqY: PLC,
    radius-edge quality 2, no Steiner points on the boundary), calibrated
    with a maximum tet volume (-a). Timed without output (-NEF)."""
    base = os.path.join(work, "tg.off")
    shutil.copy(model_off, base)

    def count(flags):
        run(["tetgen", flags, base], timeout=600)
        with open(os.path.join(work, "tg.1.ele")) as f:
            return int(f.readline().split()[0])

    smallest = count("-pqYQ")
    if smallest >= 0.85 * target:
        flags = "-pqYQ"
        tets = smallest
    else:
        a, tets = calibrate(lambda a: count(f"-pqYQa{a:.6g}"), target, volume / target * 8.0, exponent=1.0)
        flags = f"-pqYQa{a:.6g}"
    seconds = [run(["tetgen", flags + "NEF", base], timeout=600)[1] for _ in range(REPS)]
    count(flags)
    nodes = np.loadtxt(os.path.join(work, "tg.1.node"), skiprows=1, comments="#")
    tets_array = np.loadtxt(os.path.join(work, "tg.1.ele"), skiprows=1, comments="#", dtype=np.int64)[:, 1:5]
    # TetGen numbers nodes from the first index of its input (0 or 1).
    points = nodes[:, 1:4]
    tets_array = tets_array - int(nodes[:, 0].min())
    lo, hi = dihedral_range(points, tets_array)
    return {"tets": int(len(tets_array)), "seconds": seconds, "min_dihedral_degrees": lo, "max_dihedral_degrees": hi,
            "flags": flags, "timing": "process wall, no output files"}


GMSH_WALL = re.compile(r"Done (meshing 3D|optimizing mesh) \(Wall ([0-9.eE+-]+)s")


def gmsh_geo(stl, size, coarsen):
    lines = [f'Merge "{stl}";']
    if coarsen:
        # Classify the triangles into smooth patches and reparametrise them,
        # so that gmsh may remesh the surface at its own size.
        lines += ["ClassifySurfaces{40 * Pi / 180, 1, 1, Pi};", "CreateGeometry;",
                  "Surface Loop(1) = Surface{:};", "Volume(1) = {1};"]
    else:
        lines += ["Surface Loop(1) = {1};", "Volume(1) = {1};"]
    lines += [f"Mesh.MeshSizeMax = {size:.6g};", "Mesh.Algorithm3D = 1;"]
    return "\n".join(lines) + "\n"


def gmsh(stl, target, work, volume, coarsen):
    """gmsh on one thread, calibrated with Mesh.MeshSizeMax. Timed by its
    own report of 3D meshing plus optimisation (reading and writing excluded)."""
    geo = os.path.join(work, "g.geo")
    msh = os.path.join(work, "g.msh")

    def mesh(size):
        with open(geo, "w") as f:
            f.write(gmsh_geo(stl, size, coarsen))
        out, wall = run(["gmsh", "-3", "-nt", "1", geo, "-o", msh, "-format", "msh22"], timeout=900)
        inner = sum(float(m.group(2)) for m in GMSH_WALL.finditer(out))
        return inner or wall

    def count():
        tets = 0
        with open(msh) as f:
            lines = f.read().split("$Elements\n")[1].split("\n")
        for line in lines[1:int(lines[0]) + 1]:
            if line.split()[1] == "4":
                tets += 1
        return tets

    def make(size):
        mesh(size)
        return count()

    # The fewest tets gmsh makes (no size bound inside): when the surface
    # already forces as many as the target, that mesh is the one timed.
    size = 1e3 * volume ** (1.0 / 3.0)
    tets = make(size)
    if tets < 0.85 * target:
        size, tets = calibrate(make, target, (8.5 * volume / target) ** (1.0 / 3.0), exponent=1.0 / 3.0)
    seconds = [mesh(size) for _ in range(REPS)]
    tets = count()
    with open(msh) as f:
        text = f.read()
    node_lines = text.split("$Nodes\n")[1].split("$EndNodes")[0].split("\n")
    n = int(node_lines[0])
    nodes = np.array([l.split() for l in node_lines[1:n + 1]], dtype=float)
    index = {int(i): k for k, i in enumerate(nodes[:, 0])}
    points = nodes[:, 1:4]
    element_lines = text.split("$Elements\n")[1].split("$EndElements")[0].split("\n")
    tet_rows = []
    for line in element_lines[1:]:
        w = line.split()
        if len(w) > 2 and w[1] == "4":
            tags = int(w[2])
            tet_rows.append([index[int(v)] for v in w[3 + tags:7 + tags]])
    lo, hi = dihedral_range(points, np.array(tet_rows, dtype=np.int64))
    return {"tets": tets, "seconds": seconds, "min_dihedral_degrees": lo, "max_dihedral_degrees": hi,
            "size": size, "timing": "gmsh's own wall time of 3D meshing and optimisation"}


def run_section(ctx):
    models = ["hand"] if ctx.quick else ["bunny00", "armadillo", "hand"]
    targets = [8000, 20000] if ctx.quick else [8000, 20000, 60000]
    rows = []
    for model in models:
        off = os.path.join(ctx.assets, model + ".off")
        vertices, faces = read_off(off)
        work = tempfile.mkdtemp(prefix="goo-meshers-")
        stl = os.path.join(work, model + ".stl")
        write_binary_stl(stl, vertices, faces)
        a, b, c = (vertices[faces[:, k]] for k in range(3))
        volume = abs(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)
        for target in targets:
            log(f"meshers: {model} at {target} tets")
            out, _ = run([ctx.mesher_bench, "goo", off, str(target), str(REPS)], timeout=900)
            goo = json.loads(out.strip().splitlines()[-1])
            matched = goo["tets"]
            base = {"model": model, "target_tets": target, "input_triangles": int(len(faces))}
            rows.append({**base, "mesher": "goo (generate)", "mode": "lattice", "tets": matched,
                         "median_seconds": goo["median_seconds"], "min_dihedral_degrees": goo["min_dihedral_degrees"],
                         "max_dihedral_degrees": goo["max_dihedral_degrees"], "seconds": goo["seconds"]})
            rows.append({**base, "mesher": "goo (first mesh + exact masses)", "mode": "lattice", "tets": matched,
                         "median_seconds": goo["mesh_body_median_seconds"],
                         "min_dihedral_degrees": goo["min_dihedral_degrees"],
                         "max_dihedral_degrees": goo["max_dihedral_degrees"]})
            rows.append({**base, "mesher": "goo (whole re-mesh)", "mode": "lattice", "tets": matched,
                         "median_seconds": goo["remesh_median_seconds"], "seconds": goo["remesh_seconds"],
                         "min_dihedral_degrees": goo["min_dihedral_degrees"],
                         "max_dihedral_degrees": goo["max_dihedral_degrees"]})
            attempts = [
                ("cgal_mesh3", "(b) coarsened", lambda: json.loads(run(
                    [ctx.mesher_bench, "cgal", off, str(matched), str(REPS)], timeout=1800)[0].strip().splitlines()[-1])),
                ("tetgen", "(a) conforming", lambda: tetgen(off, matched, work, volume)),
                ("gmsh", "(a) conforming", lambda: gmsh(stl, matched, work, volume, coarsen=False)),
                ("gmsh", "(b) coarsened", lambda: gmsh(stl, matched, work, volume, coarsen=True)),
            ]
            for name, mode, attempt in attempts:
                try:
                    r = attempt()
                    r["median_seconds"] = median(r["seconds"])
                except Exception as e:  # a mesher that fails on a model is reported, not fatal
                    log(f"meshers: {name} {mode} failed on {model}: {e}")
                    r = {"error": str(e)[:300]}
                rows.append({**r, **base, "mesher": name, "mode": mode})
        shutil.rmtree(work, ignore_errors=True)
    # Ratios at matched counts: time per tet of the mesher over goo's.
    timed = [r for r in rows if "median_seconds" in r and "tets" in r]
    for r in timed:
        r["tets_per_second"] = r["tets"] / r["median_seconds"]
    for r in timed:
        for goo_stage, key in (("goo (generate)", "per_tet_ratio_to_goo_generate"),
                               ("goo (whole re-mesh)", "per_tet_ratio_to_goo_remesh")):
            g = next(g for g in timed if g["model"] == r["model"] and g["target_tets"] == r["target_tets"]
                     and g["mesher"] == goo_stage)
            r[key] = g["tets_per_second"] / r["tets_per_second"]
        gen = next(g for g in timed if g["model"] == r["model"] and g["target_tets"] == r["target_tets"]
                   and g["mesher"] == "goo (generate)")
        r["wall_ratio_to_goo_generate"] = r["median_seconds"] / gen["median_seconds"]
    write_json(ctx.path("meshers.json"), rows)
    write_csv(ctx.path("meshers.csv"), [{k: v for k, v in r.items() if k != "seconds"} for r in rows])
    plot(ctx, rows)
    return table([r for r in rows if "median_seconds" in r], [
        ("model", "model", "{}"), ("target_tets", "target", "{}"), ("mesher", "mesher", "{}"), ("mode", "mode", "{}"),
        ("tets", "tets", "{}"), ("median_seconds", "median s", "{:.3g}"), ("tets_per_second", "tets/s", "{:.3g}"),
        ("wall_ratio_to_goo_generate", "wall × goo generate", "{:.1f}"),
        ("per_tet_ratio_to_goo_generate", "per tet × goo generate", "{:.1f}"),
        ("per_tet_ratio_to_goo_remesh", "per tet × goo re-mesh", "{:.1f}"),
        ("min_dihedral_degrees", "min dihedral °", "{:.1f}"), ("max_dihedral_degrees", "max dihedral °", "{:.1f}")],
        f"Mesh generation against conforming meshers (median of {REPS}; ratios: time per tet over goo's)")


def plot(ctx, rows):
    fig, ax = plt.subplots(figsize=(9, 5))
    labels = sorted({f"{r['mesher']} {r['mode']}" for r in rows if "tets_per_second" in r})
    for label in labels:
        pts = sorted((r["tets"], r["median_seconds"]) for r in rows
                     if "tets_per_second" in r and f"{r['mesher']} {r['mode']}" == label)
        ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o", label=label)
    ax.set_xlabel("tetrahedra")
    ax.set_ylabel("median wall seconds")
    ax.set_title("Mesh generation time against tet count (all models)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    save_figure(fig, ctx.path("meshers.png"))
