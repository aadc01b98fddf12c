"""Speed against error: ladders of lattice spacing, time step and both
integrators on a dropped cube (several materials) and on the cantilever,
each measured against a fine reference run of the same scene.

Errors, over the frames of the run (the same times in every run):
- surface: the symmetric nearest-vertex RMS distance between the run's
  surface and the reference's (topologies may differ: re-meshing refines
  the surface at its own spacing), over the cube's edge;
- centre: the RMS distance of the enclosed volume's centroid, over the edge;
- volume: the largest |V / V_ref − 1|;
- tip (cantilever): the RMS tip deflection error over the largest reference
  deflection.
The time is the simulation's own (integration and re-meshing; no output)."""
import glob
import json
import os

import numpy as np

from common import goo_run, log, plt, read_ply, save_figure, table, volume_and_centroid, write_csv, write_json

EDGE = 0.2  # m
FPS = 24


def cube_scene(material, spacing, integrator):
    s = {"version": 1, "gravity": [0, 0, -9.81], "ground": {"height": 0, "friction": 0.5},
         "objects": [{"primitive": {"type": "box", "size": [EDGE] * 3, "subdivisions": 12},
                      "material": material, "lattice_spacing": spacing,
                      "transform": {"translate": [0, 0, 0.25]}, "angular_velocity": [0, 2, 0]}],
         "output": {"fps": FPS, "frames": 12}, "checkpoint": {"every_frames": 0}}
    s["integrator"] = integrator
    return s


def cantilever_scene(ctx, integrator):
    with open(os.path.join(ctx.root, "scenes", "cantilever.json")) as f:
        s = json.load(f)
    s["integrator"] = integrator
    s["objects"][0]["tet_mesh"] = os.path.join(ctx.root, "scenes", "beam.mesh")
    s["output"] = {"fps": FPS, "frames": 12, "tet_mesh": False}
    s["checkpoint"] = {"every_frames": 0}
    return s


def frames_of(folder):
    return [read_ply(p) for p in sorted(glob.glob(os.path.join(folder, "frames", "frame_*.ply")))]


def nearest_rms(a, b):
    """RMS of the distances from each point of a to its nearest point of b (chunked brute force)."""
    d2 = []
    for start in range(0, len(a), 512):
        chunk = a[start:start + 512]
        d2.append(((chunk[:, None, :] - b[None, :, :]) ** 2).sum(axis=2).min(axis=1))
    return float(np.sqrt(np.concatenate(d2).mean()))


def compare(run, reference, tip=False):
    surface, centre, volume, tips, ref_tips = [], [], [], [], []
    for (v, t), (rv, rt) in zip(run, reference):
        surface.append(0.5 * (nearest_rms(v, rv) ** 2 + nearest_rms(rv, v) ** 2))
        vol, c = volume_and_centroid(v, t)
        rvol, rc = volume_and_centroid(rv, rt)
        centre.append(float(((c - rc) ** 2).sum()))
        volume.append(abs(vol / rvol - 1.0))
        if tip:
            tips.append(v[v[:, 0] > v[:, 0].max() - 1e-3, 2].mean())
            ref_tips.append(rv[rv[:, 0] > rv[:, 0].max() - 1e-3, 2].mean())
    out = {"surface_error": float(np.sqrt(np.mean(surface))) / EDGE, "centre_error": float(np.sqrt(np.mean(centre))) / EDGE,
           "volume_error": float(max(volume))}
    if tip:
        deflection = np.array(ref_tips) - ref_tips[0]
        out["tip_error"] = float(np.sqrt(np.mean((np.array(tips) - np.array(ref_tips)) ** 2)) / np.abs(deflection).max())
    return out


def simulate(ctx, name, scene):
    path = ctx.path("accuracy", f"{name}.json")
    with open(path, "w") as f:
        json.dump(scene, f)
    folder = ctx.path("accuracy", name, "x")[:-2]
    s = goo_run(ctx, path, folder, timeout=7200)
    seconds = s["stages"]["integrate"] + s["stages"]["remesh"] + s["stages"]["remesh_check"]
    return frames_of(folder), {"steps": s["steps"], "remeshes": s["remeshes"], "seconds": seconds,
                               "elements": s["elements"]}


# The ladders: (materials, spacings, reference spacing).
QUICK = (["jiggly_gelatin"], [0.05, 0.033], 0.025)
FULL = (["jiggly_gelatin", "gooey_jelly", "rigid_brick"], [0.05, 0.04, 0.033, 0.025], 0.0167)


def run_section(ctx, ladder=None):
    materials, spacings, reference_spacing = ladder or (QUICK if ctx.quick else FULL)
    newmark = lambda cfl: {"type": "newmark", "cfl": cfl}
    implicit = lambda dt: {"type": "backward_euler", "time_step": dt}
    integrators = [("newmark cfl 0.5", newmark(0.5)), ("backward_euler Δt 10 ms", implicit(0.01))]
    if not ctx.quick:
        integrators += [("newmark cfl 0.25", newmark(0.25)), ("backward_euler Δt 2 ms", implicit(0.002))]
    rows = []
    for material in materials:
        log(f"accuracy: {material} reference (newmark, h = {reference_spacing}, cfl 0.25)")
        reference, _ = simulate(ctx, f"{material}_reference", cube_scene(material, reference_spacing, newmark(0.25)))
        for h in spacings:
            for label, integrator in integrators:
                name = f"{material}_{h}_{label.replace(' ', '_')}"
                log(f"accuracy: {material}, h = {h}, {label}")
                try:
                    frames, info = simulate(ctx, name, cube_scene(material, h, integrator))
                except Exception as e:
                    rows.append({"case": "cube", "material": material, "spacing": h, "integrator": label,
                                 "error": str(e)[:300]})
                    continue
                rows.append({"case": "cube", "material": material, "spacing": h, "integrator": label, **info,
                             **compare(frames, reference)})
    log("accuracy: cantilever reference (newmark, cfl 0.25)")
    reference, _ = simulate(ctx, "cantilever_reference", cantilever_scene(ctx, newmark(0.25)))
    ladder = [("newmark cfl 0.5", newmark(0.5))] + [(f"backward_euler Δt {dt * 1e3:g} ms", implicit(dt))
                                                    for dt in ((0.02, 0.005) if ctx.quick else (0.02, 0.01, 0.005, 0.002))]
    for label, integrator in ladder:
        log(f"accuracy: cantilever, {label}")
        frames, info = simulate(ctx, f"cantilever_{label.replace(' ', '_')}", cantilever_scene(ctx, integrator))
        rows.append({"case": "cantilever", "material": "beam E = 1e6", "spacing": None, "integrator": label, **info,
                     **compare(frames, reference, tip=True)})
    write_json(ctx.path("accuracy.json"), rows)
    write_csv(ctx.path("accuracy.csv"), rows)
    plot(ctx, rows)
    return table([r for r in rows if "seconds" in r], [
        ("case", "case", "{}"), ("material", "material", "{}"), ("spacing", "h (m)", "{}"),
        ("integrator", "integrator", "{}"), ("steps", "steps", "{}"), ("seconds", "sim s", "{:.3g}"),
        ("surface_error", "surface RMS / edge", "{:.2e}"), ("centre_error", "centre / edge", "{:.2e}"),
        ("volume_error", "max volume error", "{:.2e}"), ("tip_error", "tip error", "{:.2e}")],
        "Speed against error (against a fine reference)") + "\n" + advice(rows)


def advice(rows):
    """The fastest setting within each error budget, per case and material."""
    lines = ["### Which setting for an error budget", "",
             "| case | material | budget | fastest setting within it | its time (s) |", "|---|---|---|---|---|"]
    for case, key in (("cube", "surface_error"), ("cantilever", "tip_error")):
        for material in sorted({r["material"] for r in rows if r["case"] == case}):
            for budget in (0.01, 0.03, 0.1):
                fits = [r for r in rows if r["case"] == case and r["material"] == material and key in r
                        and r[key] <= budget]
                if fits:
                    best = min(fits, key=lambda r: r["seconds"])
                    where = f"h = {best['spacing']}, " if best["spacing"] else ""
                    lines.append(f"| {case} ({key}) | {material} | {budget:.0%} | {where}{best['integrator']} | "
                                 f"{best['seconds']:.3g} |")
                else:
                    lines.append(f"| {case} ({key}) | {material} | {budget:.0%} | none of the ladder | – |")
    return "\n".join(lines) + "\n"


def plot(ctx, rows):
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    for ax, case, key in ((axes[0], "cube", "surface_error"), (axes[1], "cantilever", "tip_error")):
        for label in sorted({r["integrator"].split(" ")[0] for r in rows if r["case"] == case}):
            pts = sorted((r["seconds"], r[key]) for r in rows
                         if r["case"] == case and key in r and r["integrator"].startswith(label))
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o", label=label)
            # The Pareto front: no other point is both faster and more accurate.
            front, best = [], float("inf")
            for s, e in pts:
                if e < best:
                    front.append((s, e))
                    best = e
            ax.loglog([p[0] for p in front], [p[1] for p in front], "-", alpha=0.5)
        ax.set_xlabel("simulation wall seconds")
        ax.set_ylabel(key.replace("_", " "))
        ax.set_title(f"{case}: error against time")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    save_figure(fig, ctx.path("accuracy.png"))
