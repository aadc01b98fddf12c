"""Google Benchmark microbenchmarks (bench/*.cpp), medians of repetitions."""
import json
import re

from common import log, run, table, write_csv, write_json

QUICK = ("BM_Svd3$|BM_Svd3Batch/|BM_ElasticForces/12/|BM_DampingApply/12/|BM_DampingApplyModel/0/10/|BM_VolumeProjection/12/|BM_LoopAfterSerialGap/|BM_SurfaceTension/0/|BM_Collisions/|BM_FloorContact/|BM_AssembleHessian/10/|"
         "BM_CholmodFactor/10/|BM_CholmodSolve/10/|BM_(Voxelize|BuildTets|Embed|ExactMass|Transfer|Remesh|SurfaceUpkeep)/0/8$")


# The performance issue's kernel targets (docs/benchmarks.md): the
# benchmark, what is compared, the figure when the issue was filed (for that
# benchmark), the target, and the value of a result row.
TARGETS = (
    ("re-mesh of the bunny", r"BM_Remesh/0/20$", "ms", 435.0, "≤ 30", lambda r: r["median"]),
    ("re-mesh of the bunny (quick size)", r"BM_Remesh/0/8$", "ms", None, "–", lambda r: r["median"]),
    ("elastic forces, one core", r"BM_ElasticForces/(12|26)/1/", "M tets/s", 2.05, "≥ 10",
     lambda r: r["items_per_second"] / 1e6),
    ("damping operator, one core", r"BM_DampingApply/12/1/", "M tets/s", None, "–",
     lambda r: r["items_per_second"] / 1e6),
)


def target_rows(rows):
    out = []
    for what, pattern, unit, filed, target, value in TARGETS:
        for r in rows:
            if re.search(pattern, r["benchmark"]):
                out.append({"what": what, "benchmark": r["benchmark"], "unit": unit, "filed": filed,
                            "target": target, "now": value(r)})
    return out


def run_section(ctx):
    reps = 3 if ctx.quick else 5
    out = ctx.path("micro.json")
    cmd = [ctx.goo_bench, f"--benchmark_repetitions={reps}", "--benchmark_report_aggregates_only=true",
           f"--benchmark_out={out}", "--benchmark_out_format=json"]
    if ctx.quick:
        cmd += [f"--benchmark_filter={QUICK}", "--benchmark_min_time=0.1"]
    log(f"micro: goo_bench, {reps} repetitions")
    run(cmd, timeout=7200)
    with open(out) as f:
        data = json.load(f)
    rows = []
    for b in data["benchmarks"]:
        if b.get("aggregate_name") != "median":
            continue
        row = {"benchmark": b["run_name"], "median": b["real_time"], "unit": b["time_unit"]}
        for counter in ("tets", "items_per_second", "cg_iterations"):
            if counter in b:
                row[counter] = b[counter]
        rows.append(row)
    cv = {b["run_name"]: b["real_time"] for b in data["benchmarks"] if b.get("aggregate_name") == "cv"}
    for r in rows:
        r["cv_percent"] = 100.0 * cv.get(r["benchmark"], float("nan"))
    write_json(ctx.path("micro_medians.json"), {"context": data["context"], "medians": rows})
    write_csv(ctx.path("micro.csv"), rows)
    targets = target_rows(rows)
    write_csv(ctx.path("micro_targets.csv"), targets)
    return (table(rows, [("benchmark", "benchmark", "{}"), ("median", "median", "{:.4g}"), ("unit", "unit", "{}"),
                         ("cv_percent", "CV %", "{:.1f}"), ("tets", "tets", "{:.0f}")],
                  f"Microbenchmarks (median of {reps})") + "\n" +
            table(targets, [("what", "what", "{}"), ("benchmark", "benchmark", "{}"), ("unit", "unit", "{}"),
                            ("filed", "when filed", "{:.3g}"), ("now", "now", "{:.3g}"), ("target", "target", "{}")],
                  "The performance issue's kernel targets"))
