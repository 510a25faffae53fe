#!/usr/bin/env python3
"""Per-call cost of the Python API against the solve itself and against `freeloc pose` per call.

A seeded synthetic two-view problem (500 correspondences, 0.5 px noise, 20 % outliers, depth maps for the metric
scale) is solved 1000 times through freeloc.estimate_relative_pose; the time per call is compared with the solver's
own time (solve_ms of each result) and with one `freeloc pose` process per call on the same correspondences.
Prints Markdown tables. Run from the repository root after building:

    PYTHONPATH=build/python /usr/bin/python3 bench/python_overhead.py --freeloc build/freeloc
"""

import argparse
import os
import platform
import statistics
import subprocess
import tempfile
import time

import numpy as np

import freeloc


def cpu_model():
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def blas_path():
    for p in ("/usr/lib/x86_64-linux-gnu/libblas.so.3", "/usr/lib/aarch64-linux-gnu/libblas.so.3"):
        if os.path.exists(p):
            return os.path.realpath(p)
    return "unknown"


def problem(seed, n=500, w=640, h=480):
    rng = np.random.default_rng(seed)
    f = 500.0
    K = np.array([[f, 0, (w - 1) / 2], [0, f, (h - 1) / 2], [0, 0, 1]])
    # A fronto-parallel plane at 3 m behind scattered points at 2-6 m; the query moved 0.4 m and turned 5°.
    u = rng.uniform(0, w - 1, n)
    v = rng.uniform(0, h - 1, n)
    z = rng.uniform(2, 6, n)
    X = np.stack([(u - K[0, 2]) / f * z, (v - K[1, 2]) / f * z, z], 1)
    a = np.deg2rad(5)
    R = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    t = np.array([0.4, 0.05, 0.1])
    Y = X @ R.T + t
    q = Y[:, :2] / Y[:, 2:] * f + K[:2, 2]
    x_ref = np.stack([u, v], 1) + rng.normal(0, 0.5, (n, 2))
    x_query = q + rng.normal(0, 0.5, (n, 2))
    out = rng.random(n) < 0.2
    x_query[out] = rng.uniform([0, 0], [w - 1, h - 1], (out.sum(), 2))
    # Depth maps: each correspondence's depth painted into a 3×3 patch (the rest invalid).
    d_ref = np.zeros((h, w), np.float32)
    d_query = np.zeros((h, w), np.float32)
    for i in range(n):
        for d, (x, y), zz in ((d_ref, x_ref[i], z[i]), (d_query, q[i], Y[i, 2])):
            xi, yi = int(round(x)), int(round(y))
            if 1 <= xi < w - 1 and 1 <= yi < h - 1:
                d[yi - 1:yi + 2, xi - 1:xi + 2] = zz
    return x_ref, x_query, K, d_ref, d_query


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--freeloc", default="build/freeloc")
    ap.add_argument("--calls", type=int, default=1000)
    ap.add_argument("--cli-calls", type=int, default=20)
    args = ap.parse_args()
    x_ref, x_query, K, d_ref, d_query = problem(7)
    print(f"CPU: {cpu_model()}; BLAS: {blas_path()}; Python {platform.python_version()}; freeloc {freeloc.__version__}")
    print(f"problem: {len(x_ref)} correspondences (20 % outliers), 640x480 depth maps; {args.calls} Python calls, "
          f"{args.cli_calls} CLI calls\n")
    for _ in range(50):  # warm-up: allocator, caches
        freeloc.estimate_relative_pose(x_ref, x_query, K, K, d_ref, d_query)
    results = []
    t0 = time.perf_counter()
    for _ in range(args.calls):
        results.append(freeloc.estimate_relative_pose(x_ref, x_query, K, K, d_ref, d_query))
    py_ms = (time.perf_counter() - t0) * 1000 / args.calls
    solve_ms = statistics.fmean(r.as_dict()["solve_ms"] for r in results)
    assert all(r.status == results[0].status for r in results)
    with tempfile.TemporaryDirectory() as tmp:
        m = os.path.join(tmp, "m.txt")
        np.savetxt(m, np.hstack([x_ref, x_query]), fmt="%.17g")
        dr, dq = os.path.join(tmp, "r.png"), os.path.join(tmp, "q.png")
        # The CLI reads uint16 mm PNGs: write them with freeloc's own writer through a run-free path.
        _write_depth_png(dr, d_ref)
        _write_depth_png(dq, d_query)
        kt = f"{K[0, 0]},{K[1, 1]},{K[0, 2]},{K[1, 2]}"
        cmd = [args.freeloc, "pose", "--matches", m, "--ref-intrinsics", kt, "--query-intrinsics", kt, "--ref-depth",
               dr, "--query-depth", dq, "--json"]
        t0 = time.perf_counter()
        for _ in range(args.cli_calls):
            subprocess.run(cmd, capture_output=True, check=False)
        cli_ms = (time.perf_counter() - t0) * 1000 / args.cli_calls
    print("| path | ms per call | of which the solve (ms) | overhead per call (ms) |")
    print("|---|---|---|---|")
    print(f"| freeloc.estimate_relative_pose | {py_ms:.3f} | {solve_ms:.3f} | {py_ms - solve_ms:.3f} |")
    print(f"| `freeloc pose` (one process per call) | {cli_ms:.1f} | {solve_ms:.3f} | {cli_ms - solve_ms:.1f} |")
    print(f"\nstatus {results[0].status}, {results[0].num_inliers} inliers; Python overhead "
          f"{100 * (py_ms - solve_ms) / max(solve_ms, 1e-9):.1f} % of the solve; the CLI costs "
          f"{cli_ms / py_ms:.0f}x the Python call")


def _write_depth_png(path, depth):
    import struct
    import zlib
    mm = np.clip(np.round(depth * 1000), 0, 65535).astype(">u2")
    h, w = mm.shape
    raw = b"".join(b"\x00" + mm[y].tobytes() for y in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, 0, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
    open(path, "wb").write(png)


if __name__ == "__main__":
    main()
