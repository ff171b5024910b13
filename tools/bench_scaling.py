#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Scaling benchmark of pkss-align: wall time, peak memory and pose error
against input size (points per cloud) and against m (--points, the resample
size), on generated pairs, written as a markdown table and a PNG plot.

    python3 tools/bench_scaling.py --align build/tools/pkss-align \\
        --sizes 10000,50000,100000,200000,500000,1000000,2000000 \\
        --ms 1000,2000,3000,6000,12000 --repeats 3 \\
        --md docs/scaling.md --png docs/scaling.png

A pair is two independent area-weighted samplings of the Stanford bunny
mesh (../shared/data/stanford_bunny/reconstruction), the target mapped by a
seeded similarity (rotation, scale in [0.5, 2], translation); both clouds
are written as binary little-endian PLY (float64). Each configuration runs
--repeats times, alternating configurations, and the medians are reported;
peak memory is the maximum resident set size of the pkss-align process
(/usr/bin/time). The commit and the machine are stamped into the table.
--baseline ALIGN adds a second pkss-align (e.g. an older build), run
alternately with the first on every pair, for A/B comparisons.
Needs numpy; the plot needs matplotlib (skipped with a note without it).
"""
import argparse
import datetime
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
MESH = os.path.join(ROOT, "..", "shared", "data", "stanford_bunny",
                    "reconstruction", "bun_zipper_res2.ply")


def read_ascii_mesh(path):
    """Vertices and triangles of an ASCII PLY mesh (x y z first)."""
    with open(path, "rb") as f:
        n_v = n_f = 0
        while True:
            line = f.readline().decode("ascii").strip()
            if line.startswith("element vertex"):
                n_v = int(line.split()[2])
            elif line.startswith("element face"):
                n_f = int(line.split()[2])
            elif line == "end_header":
                break
        v = np.array([f.readline().split()[:3] for _ in range(n_v)], dtype=float)
        faces = [f.readline().split() for _ in range(n_f)]
    tri = np.array([r[1:4] for r in faces if r and r[0] == b"3"], dtype=np.int64)
    return v, tri


def sample_surface(v, tri, n, rng):
    """n points uniformly on the mesh surface (area-weighted)."""
    a, b, c = v[tri[:, 0]], v[tri[:, 1]], v[tri[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    pick = rng.choice(len(tri), size=n, p=area / area.sum())
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    w0, w1, w2 = 1 - s, s * (1 - r2), s * r2
    return (w0[:, None] * a[pick] + w1[:, None] * b[pick] + w2[:, None] * c[pick])


def random_similarity(rng, diam):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    s = float(np.exp(rng.uniform(np.log(0.5), np.log(2.0))))
    T = np.eye(4)
    T[:3, :3] = s * R
    T[:3, 3] = rng.uniform(-diam, diam, size=3)
    return T


def write_ply(path, x):
    with open(path, "wb") as f:
        f.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\n"
                 "property double x\nproperty double y\nproperty double z\n"
                 "end_header\n" % len(x)).encode("ascii"))
        f.write(np.ascontiguousarray(x, dtype="<f8").tobytes())


def make_pair(n, seed, folder, mesh):
    """Writes src/tgt PLY for n points each; returns paths, T_gt, diameter."""
    rng = np.random.default_rng(seed)
    v, tri = mesh
    src = sample_surface(v, tri, n, rng)
    tgt0 = sample_surface(v, tri, n, rng)
    diam = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    T = random_similarity(rng, diam)
    tgt = tgt0 @ T[:3, :3].T + T[:3, 3]
    ps = os.path.join(folder, f"n{n}_s{seed}_src.ply")
    pt = os.path.join(folder, f"n{n}_s{seed}_tgt.ply")
    write_ply(ps, src)
    write_ply(pt, tgt)
    return ps, pt, T, diam * float(np.cbrt(np.linalg.det(T[:3, :3])))


def pose_error(T_est, T_gt, diam_tgt):
    """Rotation (degrees), relative scale and translation / target diameter."""
    def split(T):
        s = np.cbrt(np.linalg.det(T[:3, :3]))
        return s, T[:3, :3] / s
    s_e, R_e = split(T_est)
    s_g, R_g = split(T_gt)
    c = np.clip((np.trace(R_e.T @ R_g) - 1) / 2, -1, 1)
    return (float(np.degrees(np.arccos(c))), float(abs(s_e / s_g - 1)),
            float(np.linalg.norm(T_est[:3, 3] - T_gt[:3, 3]) / diam_tgt))


def run_align(align, ps, pt, m, folder):
    """One pkss-align run: wall seconds, peak RSS MB, prepare seconds, T."""
    mat = os.path.join(folder, "T.txt")
    cmd = ["/usr/bin/time", "-f", "@@%e %M", align, ps, pt, "-q", "-v",
           "--matrix", mat]
    if m:
        cmd += ["--points", str(m)]
    t0 = time.perf_counter()  # /usr/bin/time's %e has 10 ms steps
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed: {p.stderr[-800:]}")
    rss = prep = None
    for line in p.stderr.splitlines():
        if line.startswith("@@"):
            rss = float(line[2:].split()[1]) / 1024.0
        if "times (s):" in line and "prepare" in line:
            prep = float(line.split("prepare")[1].split(",")[0])
    return wall, rss, prep, np.loadtxt(mat).reshape(4, 4)


def stamp():
    def git(*a):
        try:
            return subprocess.run(["git", "-C", ROOT] + list(a), capture_output=True,
                                  text=True).stdout.strip()
        except OSError:
            return "?"
    commit = git("rev-parse", "--short", "HEAD")
    if git("status", "--porcelain", "--untracked-files=no"):
        commit += " (with uncommitted changes)"
    cpu = platform.processor() or "?"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    return (f"commit {commit}, {datetime.datetime.utcnow():%Y-%m-%d %H:%M} UTC, "
            f"{cpu}, {os.cpu_count()} logical CPUs, {platform.system()} "
            f"{platform.release()}, load average {load} at the start")



def measure(aligns, configs, repeats, folder, mesh, seed):
    """configs: list of (n, m). Returns {(label, n, m): list of runs}."""
    pairs = {}
    for n, _ in configs:
        if n not in pairs:
            pairs[n] = make_pair(n, seed, folder, mesh)
    out = {}
    for rep in range(repeats):
        for n, m in configs:
            ps, pt, T_gt, diam_t = pairs[n]
            order = aligns if rep % 2 == 0 else aligns[::-1]
            for label, align in order:
                wall, rss, prep, T = run_align(align, ps, pt, m, folder)
                err = pose_error(T, T_gt, diam_t)
                out.setdefault((label, n, m), []).append((wall, rss, prep) + err)
                print(f"{label:8s} n={n:>8d} m={m or 'default':>7} wall {wall:.3f} s "
                      f"rss {rss:.0f} MB prep {prep} rot {err[0]:.3f} deg "
                      f"scale {err[1]:.2e} trans {err[2]:.2e}", file=sys.stderr)
    return out


def med(runs, i):
    return statistics.median(r[i] for r in runs)


def table(rows, key_name):
    lines = [f"| {key_name} | build | wall s (median) | peak RSS MB | prepare s | "
             "rotation error deg | scale error | translation error / diameter |",
             "|---:|---|---:|---:|---:|---:|---:|---:|"]
    for (label, n, m), runs in rows:
        key = n if key_name == "points per cloud" else m
        lines.append(f"| {key} | {label} | {med(runs, 0):.3f} | {med(runs, 1):.0f} | "
                     f"{med(runs, 2):.3f} | {med(runs, 3):.3f} | {med(runs, 4):.1e} | "
                     f"{med(runs, 5):.1e} |")
    return "\n".join(lines)


def plot(png, by_n, by_m):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return "(plot skipped: matplotlib is not installed)"
    fig, ax = plt.subplots(1, 3, figsize=(14, 4))
    for label in sorted({k[0] for k, _ in by_n}):
        pts = [(k[1], v) for k, v in by_n if k[0] == label]
        ns = [p[0] for p in pts]
        ax[0].loglog(ns, [med(p[1], 0) for p in pts], "o-", label=label)
        ax[1].loglog(ns, [med(p[1], 1) for p in pts], "o-", label=label)
    for label in sorted({k[0] for k, _ in by_m}):
        pts = [(k[2], v) for k, v in by_m if k[0] == label]
        ax[2].plot([p[0] for p in pts], [med(p[1], 0) for p in pts], "o-", label=label)
    ax[0].set(xlabel="points per cloud", ylabel="wall time (s)", title="time vs input size")
    ax[1].set(xlabel="points per cloud", ylabel="peak RSS (MB)", title="memory vs input size")
    ax[2].set(xlabel="m (--points)", ylabel="wall time (s)", title="time vs m")
    for a in ax:
        a.grid(True, which="both", alpha=0.3)
        a.legend()
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    return ""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--align", default=os.path.join(ROOT, "build", "tools", "pkss-align"))
    ap.add_argument("--baseline", help="a second pkss-align, run alternately (A/B)")
    ap.add_argument("--labels", default="this,baseline",
                    help="names of --align and --baseline in the table")
    ap.add_argument("--sizes", default="10000,50000,100000,200000,500000,1000000,2000000")
    ap.add_argument("--ms", default="1000,2000,3000,6000,12000",
                    help="m values, at --m-size points per cloud")
    ap.add_argument("--m-size", type=int, default=100000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--md", help="markdown file to write (e.g. docs/scaling.md)")
    ap.add_argument("--png", help="plot to write (e.g. docs/scaling.png)")
    ap.add_argument("--workdir", help="folder for the generated pairs (default: a temp folder)")
    a = ap.parse_args()
    if not os.path.exists(MESH):
        sys.exit(f"bench_scaling: the bunny mesh is missing: {MESH}")
    mesh = read_ascii_mesh(MESH)
    names = (a.labels.split(",") + ["this", "baseline"])[:2]
    aligns = [(names[0], a.align)] + ([(names[1], a.baseline)] if a.baseline else [])
    sizes = [int(x) for x in a.sizes.split(",") if x]
    ms = [int(x) for x in a.ms.split(",") if x]
    header = stamp()
    with tempfile.TemporaryDirectory(dir=a.workdir) as folder:
        by_n = measure(aligns, [(n, 0) for n in sizes], a.repeats, folder, mesh, a.seed)
        by_m = measure(aligns, [(a.m_size, m) for m in ms], a.repeats, folder, mesh,
                       a.seed) if ms else {}
    by_n = sorted(by_n.items(), key=lambda kv: (kv[0][1], kv[0][0]))
    by_m = sorted(by_m.items(), key=lambda kv: (kv[0][2], kv[0][0]))
    note = plot(a.png, by_n, by_m) if a.png else ""
    header += ", %s at the end" % " ".join(f"{x:.2f}" for x in os.getloadavg())
    text = ["# Scaling: time and memory against input size and m", "",
            "Written by `tools/bench_scaling.py` (do not edit by hand); "
            f"{header}.", "",
            f"Command: `python3 tools/bench_scaling.py {' '.join(sys.argv[1:])}`", "",
            "Generated pairs: two independent area-weighted samplings of the "
            "Stanford bunny mesh, the target under a seeded similarity; binary PLY "
            "(float64); the whole `pkss-align` process is measured (reading, "
            "device preparation, pre-processing, search, refinement). Medians of "
            f"{a.repeats} runs, configurations alternated. Inputs above "
            "max_raw_points (200 000) are voxel-thinned to about that first.", "",
            "## Against input size (default m = 3000)", "", table(by_n, "points per cloud"), ""]
    if by_m:
        text += [f"## Against m (`--points`), {a.m_size} points per cloud", "",
                 table(by_m, "m"), ""]
    if a.png:
        text += [f"![scaling]({os.path.basename(a.png)})" + (" " + note if note else ""), ""]
    out = "\n".join(text)
    if a.md:
        with open(a.md, "w") as f:
            f.write(out)
    print(out)


if __name__ == "__main__":
    main()
