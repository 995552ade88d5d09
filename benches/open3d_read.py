#!/usr/bin/env python3
"""Times Open3D's read_point_cloud on the files benches/ply_read.rs generates (the peer figure
for `cargo bench --bench ply_read`). Usage: python3 benches/open3d_read.py [FILE.ply ...]
(default: the two files in $TMPDIR/uvms-bench/). Prints median and best seconds and MB/s."""
import os, statistics, sys, tempfile, time
import open3d as o3d

files = sys.argv[1:] or [
    os.path.join(tempfile.gettempdir(), "uvms-bench", n)
    for n in ("points_1m_float_rgb.ply", "points_1m_double.ply")
]
for f in files:
    size = os.path.getsize(f)
    o3d.io.read_point_cloud(f)  # warm-up (page cache)
    times = []
    for _ in range(15):
        t0 = time.perf_counter()
        pc = o3d.io.read_point_cloud(f)
        times.append(time.perf_counter() - t0)
    med, best = statistics.median(times), min(times)
    print(f"{os.path.basename(f)}: {len(pc.points)} points, {size/1e6:.1f} MB, "
          f"median {med*1e3:.1f} ms ({size/med/2**20:.0f} MiB/s), best {best*1e3:.1f} ms")
