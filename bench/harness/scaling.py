"""Scaling and memory: time per step against the element count (10³ to
10⁶ tets) and against threads (1, 2); peak memory per tet and per surface
triangle on the Newmark and the backward-Euler paths.

A cube of jiggly gelatin falls freely (no floor: no re-mesh, no contact), so
each step costs the same; the time per step is the integrate stage over the
steps taken. Peak memory is the process's maximum resident set; bytes per
tet (per triangle) are the slope between the two largest runs, which
removes what the process holds regardless (libraries, the scene)."""
import json
import os

from common import goo_run, log, plt, save_figure, table, write_csv, write_json

SIZE = 0.2  # m, the cube's edge


def scene(spacing, subdivisions, integrator, steps_per_frame_guess):
    # Each run writes frame 0 and one frame: a few steps (the frame's length
    # is a guess of a few explicit or implicit steps at this spacing).
    frame = steps_per_frame_guess
    body = {"primitive": {"type": "box", "size": [SIZE] * 3, "subdivisions": subdivisions},
            "material": "jiggly_gelatin", "lattice_spacing": spacing}
    s = {"version": 1, "gravity": [0, 0, -9.81], "objects": [body],
         "output": {"fps": 1.0 / frame, "frames": 1}, "checkpoint": {"every_frames": 0}}
    if integrator == "backward_euler":
        s["integrator"] = {"type": "backward_euler", "time_step": frame / 4.0}
    return s


def spacing_for(tets):
    return (12.0 * SIZE ** 3 / tets) ** (1.0 / 3.0)


def one(ctx, label, tets, subdivisions, integrator, threads):
    h = spacing_for(tets)
    # Newmark: about 8 steps (the explicit step of this gelatin is ≈ 0.06 h s);
    # backward Euler: 4 steps of 2 ms.
    frame = 0.5 * h if integrator == "newmark" else 8e-3
    path = ctx.path("scaling", f"{label}.json")
    with open(path, "w") as f:
        json.dump(scene(h, subdivisions, integrator, frame), f)
    s = goo_run(ctx, path, ctx.path("scaling", label, "x")[:-2], threads=threads, timeout=3600)
    steps = max(1, s["steps"])
    return {"integrator": integrator, "target_tets": tets, "threads": threads, "tets": s["elements"],
            "surface_triangles": s["surface_triangles"], "steps": s["steps"],
            "seconds_per_step": s["stages"]["integrate"] / steps,
            "peak_memory_bytes": s["peak_memory_bytes"], "setup_peak_memory_bytes": s["setup_peak_memory_bytes"],
            "stepping_peak_memory_bytes": s["stepping_peak_memory_bytes"],
            "wall_seconds": s["wall_seconds"]}


def run_section(ctx):
    newmark_sizes = [1e3, 1e4, 1e5] if ctx.quick else [1e3, 1e4, 1e5, 1e6]
    implicit_sizes = [1e3, 1e4, 3e4] if ctx.quick else [1e3, 1e4, 1e5]
    rows = []
    for integrator, sizes in (("newmark", newmark_sizes), ("backward_euler", implicit_sizes)):
        for tets in sizes:
            for threads in (1, 2):
                log(f"scaling: {integrator}, {tets:.0e} tets, {threads} thread(s)")
                rows.append(one(ctx, f"{integrator}_{int(tets)}_{threads}", tets, 4, integrator, threads))
    # Per surface triangle: the lattice fixed (the largest size that both
    # paths ran, so that the peak is well above what any process holds),
    # the surface refined from 3k to 110k triangles.
    triangles = []
    for integrator in ("newmark", "backward_euler"):
        for subdivisions in (16, 96):
            log(f"scaling: {integrator}, surface subdivisions {subdivisions}")
            triangles.append(one(ctx, f"surface_{integrator}_{subdivisions}", implicit_sizes[-1], subdivisions,
                                 integrator, 2))
    memory = []
    for integrator in ("newmark", "backward_euler"):
        big = sorted((r for r in rows if r["integrator"] == integrator and r["threads"] == 2), key=lambda r: r["tets"])
        a, b = big[-2], big[-1]
        per_tet = (b["peak_memory_bytes"] - a["peak_memory_bytes"]) / (b["tets"] - a["tets"])
        t = sorted((r for r in triangles if r["integrator"] == integrator), key=lambda r: r["surface_triangles"])
        # The lattice around the finer surface can differ by a few tets: take them out at the per-tet rate.
        def per_triangle_of(key, tet_rate):
            return ((t[1][key] - t[0][key]) - tet_rate * (t[1]["tets"] - t[0]["tets"])) / (
                t[1]["surface_triangles"] - t[0]["surface_triangles"])
        per_triangle = per_triangle_of("peak_memory_bytes", per_tet)
        def slope(key):
            return (b[key] - a[key]) / (b["tets"] - a["tets"])
        setup_per_tet = slope("setup_peak_memory_bytes")
        stepping_per_tet = slope("stepping_peak_memory_bytes")
        memory.append({"integrator": integrator, "bytes_per_tet": per_tet, "bytes_per_triangle": per_triangle,
                       "setup_bytes_per_tet": setup_per_tet, "stepping_bytes_per_tet": stepping_per_tet,
                       "stepping_bytes_per_triangle": per_triangle_of("stepping_peak_memory_bytes", stepping_per_tet),
                       "from_tets": f"{a['tets']}→{b['tets']}",
                       "from_triangles": f"{t[0]['surface_triangles']}→{t[1]['surface_triangles']}"})
    for r in rows:
        one_thread = next(o for o in rows if o["integrator"] == r["integrator"] and o["target_tets"] == r["target_tets"]
                          and o["threads"] == 1)
        r["speedup_over_1_thread"] = one_thread["seconds_per_step"] / r["seconds_per_step"]
        r["microseconds_per_tet_step"] = 1e6 * r["seconds_per_step"] / r["tets"]
    write_json(ctx.path("scaling.json"), {"steps": rows, "surface": triangles, "memory": memory})
    write_csv(ctx.path("scaling.csv"), rows)
    plot(ctx, rows)
    return table(rows, [
        ("integrator", "integrator", "{}"), ("tets", "tets", "{}"), ("threads", "threads", "{}"),
        ("steps", "steps", "{}"), ("seconds_per_step", "s/step", "{:.3g}"),
        ("microseconds_per_tet_step", "µs per tet-step", "{:.3g}"),
        ("speedup_over_1_thread", "speed-up", "{:.2f}"), ("peak_memory_bytes", "peak bytes", "{:.3g}")],
        "Time per step against size and threads") + "\n" + table(memory, [
            ("integrator", "path", "{}"), ("bytes_per_tet", "bytes per tet", "{:.0f}"),
            ("setup_bytes_per_tet", "by setup", "{:.0f}"), ("stepping_bytes_per_tet", "by the last step", "{:.0f}"),
            ("from_tets", "between", "{}"), ("bytes_per_triangle", "bytes per triangle", "{:.0f}"),
            ("stepping_bytes_per_triangle", "by the last step", "{:.0f}"),
            ("from_triangles", "between", "{}")], "Peak memory per element")


def plot(ctx, rows):
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for integrator in ("newmark", "backward_euler"):
        for threads in (1, 2):
            pts = sorted((r["tets"], r["seconds_per_step"]) for r in rows
                         if r["integrator"] == integrator and r["threads"] == threads)
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=f"{integrator}, {threads} thread(s)")
    ax.set_xlabel("tetrahedra")
    ax.set_ylabel("seconds per step")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Time per step against size")
    save_figure(fig, ctx.path("scaling.png"))
