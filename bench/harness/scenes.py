"""Per-frame profile of each example scene: wall time split by stage,
element and surface-triangle counts, and the surface's quality (crossing
triangle pairs, creased edges, enclosed volume) over time (from goo run's
summary.json)."""
import glob
import os

from common import goo_run, log, plt, save_figure, table, write_csv, write_json

# The finest split goo reports: the integrator's stages, the re-mesh's stages, and the rest.
STEP = ["forces", "damping", "hessian", "linear_solve", "collisions", "self_collisions", "volume", "surface", "other"]
REMESH = ["upkeep", "lattice", "transfer", "masses", "separation", "conservation"]
REST = ["remesh_check", "safety_checks", "frames_output", "surface_quality"]


def split(stages, step, remesh):
    """One record's stages, finest first: {name: seconds}."""
    out = {f"step.{k}": step.get(k, 0.0) for k in STEP}
    out.update({f"remesh.{k}": remesh.get(k, 0.0) for k in REMESH})
    out.update({k: stages.get(k, 0.0) for k in REST})
    return out


def run_section(ctx):
    scenes = sorted(glob.glob(os.path.join(ctx.root, "scenes", "*.json")))
    frames = 3 if ctx.quick else None  # None: the scene's own frame count
    rows, per_frame = [], []
    for scene in scenes:
        name = os.path.splitext(os.path.basename(scene))[0]
        log(f"scenes: {name}")
        try:
            s = goo_run(ctx, scene, ctx.path("scenes", name, "x")[:-2], frames=frames, timeout=3600)
        except Exception as e:
            log(f"scenes: {name} failed: {e}")
            rows.append({"scene": name, "error": str(e)[:300]})
            continue
        parts = split(s["stages"], s["integrate_stages"], s["remesh_stages"])
        parts["checkpoints"] = s["stages"]["checkpoints"]
        total = s["wall_seconds"]
        row = {"scene": name, "integrator": s["integrator"], "frames": s["frames"], "steps": s["steps"],
               "remeshes": s["remeshes"], "wall_seconds": s["wall_seconds"],
               "seconds_per_frame": s["wall_seconds"] / max(1, s["frames"]),
               "elements": s["elements"], "surface_triangles": s["surface_triangles"],
               "peak_memory_mb": s["peak_memory_bytes"] / 1e6}
        for stage, seconds in parts.items():
            row[f"{stage}_percent"] = 100.0 * seconds / total if total > 0 else 0.0
        row["solve_percent"] = row["step.hessian_percent"] + row["step.linear_solve_percent"]
        # The performance issue's third target: Newmark's damping solves at
        # most one force evaluation's cost a step (one evaluation a step).
        forces = s["integrate_stages"].get("forces", 0.0)
        row["damping_per_forces"] = s["integrate_stages"].get("damping", 0.0) / forces if forces > 0 else float("nan")
        row["remesh_percent"] = sum(row[f"remesh.{k}_percent"] for k in REMESH)
        # What no stage counts: reading the scene, the first meshes, writing the summary.
        row["setup_percent"] = 100.0 - sum(row[f"{k}_percent"] for k in parts)
        surfaces = [s["initial_surface"]] + [r["surface"] for r in s["per_frame"]]
        row["max_crossing_pairs"] = max(q["self_intersecting_pairs"] for q in surfaces)
        row["max_creased_percent"] = max(100.0 * q["creased_edges"] / max(1, q["edges"]) for q in surfaces)
        row["min_volume_ratio"] = min(q["volume"] for q in surfaces) / surfaces[0]["volume"]
        row["max_volume_ratio"] = max(q["volume"] for q in surfaces) / surfaces[0]["volume"]
        row["last_volume_ratio"] = surfaces[-1]["volume"] / surfaces[0]["volume"]
        row["max_facing_percent"] = max(100.0 * q.get("facing_sheets_area", 0.0) / q["area"] for q in surfaces)
        rows.append(row)
        for record in s["per_frame"]:
            q = record["surface"]
            per_frame.append({"scene": name, "frame": record["frame"], "time": record["time"],
                              "steps": record["steps"], "elements": record["elements"],
                              "surface_triangles": record["surface_triangles"],
                              "crossing_pairs": q["self_intersecting_pairs"],
                              "creased_percent": 100.0 * q["creased_edges"] / max(1, q["edges"]),
                              "volume_ratio": q["volume"] / surfaces[0]["volume"],
                              "facing_percent": 100.0 * q.get("facing_sheets_area", 0.0) / q["area"],
                              "split_elements": record.get("separation", {}).get("split_elements", 0),
                              **{f"{k}_seconds": v for k, v in split(record["stages"], record["integrate_stages"],
                                                                     record["remesh_stages"]).items()}})
    write_json(ctx.path("scenes.json"), {"scenes": rows, "per_frame": per_frame})
    write_csv(ctx.path("scenes_per_frame.csv"), per_frame)
    plot(ctx, rows, per_frame)
    return table(rows, [
        ("scene", "scene", "{}"), ("integrator", "integrator", "{}"), ("frames", "frames", "{}"),
        ("steps", "steps", "{}"), ("remeshes", "re-meshes", "{}"), ("seconds_per_frame", "s/frame", "{:.3g}"),
        ("step.forces_percent", "forces %", "{:.0f}"), ("step.damping_percent", "damping %", "{:.0f}"),
        ("damping_per_forces", "damping / forces", "{:.2f}"), ("solve_percent", "Newton H + solve %", "{:.0f}"),
        ("step.collisions_percent", "collisions %", "{:.1f}"),
        ("step.surface_percent", "surface %", "{:.1f}"), ("step.volume_percent", "volume proj. %", "{:.1f}"),
        ("step.other_percent", "other step %", "{:.1f}"),
        ("remesh_check_percent", "trigger %", "{:.1f}"), ("remesh_percent", "re-mesh %", "{:.1f}"),
        ("frames_output_percent", "output %", "{:.1f}"), ("checkpoints_percent", "checkpoints %", "{:.1f}"),
        ("setup_percent", "setup %", "{:.0f}"), ("elements", "tets (end)", "{}"),
        ("surface_triangles", "triangles (end)", "{}"), ("peak_memory_mb", "peak MB", "{:.0f}"),
        ("max_crossing_pairs", "crossing pairs (max)", "{}"), ("max_creased_percent", "creased % (max)", "{:.2f}"),
        ("min_volume_ratio", "volume (lowest)", "{:.3f}"), ("max_volume_ratio", "volume (highest)", "{:.3f}"),
        ("last_volume_ratio", "volume (last)", "{:.3f}"), ("max_facing_percent", "facing sheets % (max)", "{:.1f}")],
        "Example scenes: where the wall time goes (% of wall)")


def plot(ctx, rows, per_frame):
    names = [r["scene"] for r in rows if "error" not in r]
    if not names:
        return
    fig, axes = plt.subplots(len(names), 3, figsize=(15, 2.2 * len(names)), squeeze=False)
    for i, name in enumerate(names):
        records = [p for p in per_frame if p["scene"] == name]
        x = [p["frame"] for p in records]
        bottom = [0.0] * len(records)
        for stage in [f"step.{k}" for k in STEP] + [f"remesh.{k}" for k in REMESH] + REST:
            y = [p.get(f"{stage}_seconds", 0.0) for p in records]
            axes[i][0].bar(x, y, bottom=bottom, label=stage)
            bottom = [b + v for b, v in zip(bottom, y)]
        axes[i][0].set_ylabel("s")
        axes[i][0].set_title(f"{name}: wall time per frame by stage", fontsize=9)
        axes[i][1].plot(x, [p["elements"] for p in records], label="tets")
        axes[i][1].plot(x, [p["surface_triangles"] for p in records], label="surface triangles")
        axes[i][1].set_title(f"{name}: mesh sizes", fontsize=9)
        axes[i][2].plot(x, [p["crossing_pairs"] for p in records], label="crossing triangle pairs")
        axes[i][2].plot(x, [p["creased_percent"] for p in records], label="edges creased past 90° (%)")
        axes[i][2].plot(x, [p["facing_percent"] for p in records], label="area facing itself within h (%)")
        twin = axes[i][2].twinx()
        twin.plot(x, [p["volume_ratio"] for p in records], "k--", label="volume / frame 0")
        twin.set_ylabel("volume ratio", fontsize=7)
        axes[i][2].set_title(f"{name}: surface quality", fontsize=9)
    axes[0][0].legend(fontsize=6, ncol=3)
    axes[0][1].legend(fontsize=7)
    axes[0][2].legend(fontsize=7)
    for k in range(3):
        axes[-1][k].set_xlabel("frame")
    save_figure(fig, ctx.path("scenes.png"))
