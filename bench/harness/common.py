"""What the benchmark sections share: running commands, medians, results
files, plots, and reading goo's output (summary.json, binary PLY frames)."""
import csv
import json
import os
import statistics
import struct
import subprocess
import sys
import time

import numpy as np

import matplotlib

matplotlib.use("Agg")  # no display: files only
import matplotlib.pyplot as plt  # noqa: E402


class Context:
    """Where things are and how the run was asked for."""

    def __init__(self, root, build, out, quick, threads):
        self.root = root
        self.build = build
        self.out = out
        self.quick = quick
        self.threads = threads
        self.goo = os.path.join(build, "app", "goo")
        self.goo_bench = os.path.join(build, "bench", "goo_bench")
        self.mesher_bench = os.path.join(build, "bench", "goo_mesher_bench")
        self.assets = os.path.join(root, "assets")
        os.makedirs(out, exist_ok=True)

    def path(self, *parts):
        p = os.path.join(self.out, *parts)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        return p


def log(message):
    print(message, file=sys.stderr, flush=True)


def run(cmd, timeout=None, cwd=None, env=None):
    """Runs a command; returns (stdout, wall seconds). Raises on failure with its stderr."""
    start = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=cwd, env=env)
    seconds = time.perf_counter() - start
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))} exited with {p.returncode}: {p.stderr.strip()[-2000:]}")
    return p.stdout + p.stderr, seconds


def median(values):
    return statistics.median(values) if values else float("nan")


def write_json(path, obj):
    with open(path, "w") as f:
        json.dump(obj, f, indent=2, sort_keys=True)
        f.write("\n")


def write_csv(path, rows):
    fields = []
    for r in rows:
        for k in r:
            if k not in fields:
                fields.append(k)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        for r in rows:
            w.writerow(r)


def table(rows, columns, title):
    """A Markdown table of the rows (columns: list of (key, header, format))."""
    lines = [f"### {title}", "", "| " + " | ".join(h for _, h, _ in columns) + " |",
             "|" + "---|" * len(columns)]
    for r in rows:
        cells = []
        for key, _, fmt in columns:
            v = r.get(key)
            cells.append("–" if v is None or (isinstance(v, float) and v != v) else fmt.format(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def save_figure(fig, path):
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def read_ply(path):
    """Vertices (#V×3) and triangles (#T×3) of a binary little-endian PLY as goo writes it."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").split("\n")
    nv = nf = 0
    for line in header:
        words = line.split()
        if words[:2] == ["element", "vertex"]:
            nv = int(words[2])
        elif words[:2] == ["element", "face"]:
            nf = int(words[2])
    vertices = np.frombuffer(data, dtype="<f8", count=3 * nv, offset=end).reshape(nv, 3)
    faces = np.frombuffer(data, dtype=np.dtype([("n", "u1"), ("i", "<i4", 3)]), count=nf, offset=end + 24 * nv)
    return vertices, faces["i"]


def volume_and_centroid(vertices, triangles):
    """Enclosed volume and its centroid (divergence theorem over the triangles)."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    v6 = np.einsum("ij,ij->i", a, np.cross(b, c))
    volume = v6.sum() / 6.0
    centroid = ((a + b + c) * v6[:, None]).sum(axis=0) / (24.0 * volume)
    return volume, centroid


def dihedral_range(points, tets):
    """Smallest and largest dihedral angles (degrees) of tetrahedra."""
    p = points[tets]  # T×4×3
    worst_min, worst_max = 180.0, 0.0
    for i, j, k, l in ((0, 1, 2, 3), (0, 2, 1, 3), (0, 3, 1, 2), (1, 2, 0, 3), (1, 3, 0, 2), (2, 3, 0, 1)):
        axis = p[:, j] - p[:, i]
        axis /= np.linalg.norm(axis, axis=1)[:, None]
        u = p[:, k] - p[:, i]
        w = p[:, l] - p[:, i]
        u -= np.einsum("ij,ij->i", u, axis)[:, None] * axis
        w -= np.einsum("ij,ij->i", w, axis)[:, None] * axis
        angle = np.degrees(np.arctan2(np.linalg.norm(np.cross(u, w), axis=1), np.einsum("ij,ij->i", u, w)))
        worst_min = min(worst_min, float(angle.min()))
        worst_max = max(worst_max, float(angle.max()))
    return worst_min, worst_max


def read_off(path):
    words = open(path).read().split()
    assert words[0] == "OFF", path
    nv, nf = int(words[1]), int(words[2])
    at = 4
    vertices = np.array(words[at:at + 3 * nv], dtype=float).reshape(nv, 3)
    at += 3 * nv
    faces = np.array(words[at:at + 4 * nf], dtype=np.int64).reshape(nf, 4)[:, 1:]
    return vertices, faces


def write_binary_stl(path, vertices, faces):
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1)[:, None] + 1e-300
    record = np.zeros(len(faces), dtype=[("n", "<f4", 3), ("a", "<f4", 3), ("b", "<f4", 3), ("c", "<f4", 3),
                                         ("attr", "<u2")])
    record["n"], record["a"], record["b"], record["c"] = n, a, b, c
    with open(path, "wb") as f:
        f.write(b"goo".ljust(80, b"\0"))
        f.write(struct.pack("<I", len(faces)))
        f.write(record.tobytes())


def goo_run(ctx, scene_path, out_dir, frames=None, threads=None, timeout=None):
    """Runs `goo run` quietly into out_dir (overwriting); returns its summary.json."""
    cmd = [ctx.goo, "run", scene_path, "--out", out_dir, "--quiet", "--overwrite",
           "--threads", str(threads or ctx.threads)]
    if frames is not None:
        cmd += ["--frames", str(frames)]
    run(cmd, timeout=timeout)
    with open(os.path.join(out_dir, "summary.json")) as f:
        return json.load(f)
