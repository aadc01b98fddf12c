"""goo's benchmark suite: runs every section on this machine and writes
JSON, CSV and PNG results under the output folder, then report.md (the
tables of docs/benchmarks.md) and a summary on stdout.

    python3 bench/harness/run.py --build build/release --out bench/results [--quick] [--threads N]
                                 [--only meshers,scenes,...]
"""
import argparse
import datetime
import os
import platform
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import accuracy  # noqa: E402
import hard_cases  # noqa: E402
import meshers  # noqa: E402
import micro  # noqa: E402
import scaling  # noqa: E402
import scenes  # noqa: E402
from common import Context, log, write_json  # noqa: E402

SECTIONS = {"hard_cases": hard_cases, "meshers": meshers, "scaling": scaling, "scenes": scenes,
            "accuracy": accuracy, "micro": micro}


def machine():
    cpu = "unknown"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    compiler = subprocess.run(["c++", "--version"], capture_output=True, text=True).stdout.split("\n")[0]
    return {"cpu": cpu, "cores": os.cpu_count(), "system": platform.platform(), "compiler": compiler,
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--build", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--quick", action="store_true", help="smaller ladders, one model: under 5 minutes on 2 cores")
    parser.add_argument("--threads", type=int, default=2, help="worker threads of goo (default 2)")
    parser.add_argument("--only", default="", help="comma-separated sections: " + ", ".join(SECTIONS))
    args = parser.parse_args()
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    ctx = Context(root, os.path.abspath(args.build), os.path.abspath(args.out), args.quick, args.threads)
    chosen = [s for s in args.only.split(",") if s] or list(SECTIONS)
    unknown = [s for s in chosen if s not in SECTIONS]
    if unknown:
        parser.error(f"unknown section(s) {', '.join(unknown)}; known: {', '.join(SECTIONS)}")
    info = {**machine(), "mode": "quick" if args.quick else "full", "threads": args.threads}
    report = [f"# goo benchmark report ({info['mode']})", "",
              f"Machine: {info['cpu']}, {info['cores']} cores, {info['system']}; {info['compiler']}; "
              f"goo threads: {args.threads}; {info['date']}.", ""]
    timings = {}
    for name in chosen:
        start = time.perf_counter()
        try:
            report.append(SECTIONS[name].run_section(ctx))
        except Exception as e:  # one broken section does not lose the others
            log(f"{name}: failed: {e}")
            report.append(f"### {name}\n\nfailed: {e}\n")
        timings[name] = time.perf_counter() - start
        log(f"{name}: {timings[name]:.0f} s")
    report.append("Section wall times: " + ", ".join(f"{k} {v:.0f} s" for k, v in timings.items()) + ".\n")
    write_json(ctx.path("machine.json"), {**info, "section_seconds": timings})
    text = "\n".join(report)
    with open(ctx.path("report.md"), "w") as f:
        f.write(text)
    print(text)
    print(f"results in {ctx.out} (report.md, *.json, *.csv, *.png)")


if __name__ == "__main__":
    main()
