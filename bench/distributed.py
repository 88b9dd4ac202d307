"""Speed-up of distributed rendering from 1 to 2 Dask workers on this machine.

    python bench/distributed.py [--samples 256] [--width 160 --height 120]

Starts a Dask LocalCluster of worker processes (one Dask thread and one render thread
each, so two workers use the two cores), renders the same scene with 1 and then 2
workers, checks the two images equal the local one, and prints the wall times and the
ratio, and the CPU seconds each worker process spent (on a shared machine the wall-time
ratio depends on what else runs; equal CPU sums show the split costs nothing). Both runs
are in one invocation; the load average is printed at the end."""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

# This file is named distributed.py: its folder must not shadow Dask's `distributed`.
HERE = Path(__file__).resolve().parent
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != HERE]
sys.path.insert(0, str(HERE.parent / "tests"))

import polychrome as pc  # noqa: E402
from test_distributed import box_scene  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=256)
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--height", type=int, default=120)
    args = ap.parse_args()
    from distributed import Client, LocalCluster

    scene = box_scene()
    settings = dict(
        width=args.width, height=args.height, samples=args.samples, quality="FINAL", wavelength_count=16, max_bounces=8, seed=1, threads=1
    )
    t = time.perf_counter()
    local = pc.render(scene, **settings)
    local_s = time.perf_counter() - t
    times = {}
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, Client(cluster) as client:
        for n in (1, 2):
            cluster.scale(n)
            client.wait_for_workers(n, timeout=120)
            pc.render(scene, scheduler=client, **{**settings, "samples": 2})  # compile on every worker, warm up
            cpu0 = client.run(time.process_time)
            t = time.perf_counter()
            result = pc.render(scene, scheduler=client, **settings)
            times[n] = time.perf_counter() - t
            cpu = {w: v - cpu0.get(w, 0.0) for w, v in client.run(time.process_time).items()}
            err = float(np.abs(result.rgba - local.rgba).max())
            assert err <= 1e-5 * float(np.abs(local.rgba).max()), err
            print(
                f"{n} worker(s): {times[n]:.2f} s, {result.stats['distributed']['tasks']} tasks, samples per worker "
                f"{list(result.stats['distributed']['workers'].values())}, worker CPU s {[round(c, 2) for c in cpu.values()]} "
                f"(sum {sum(cpu.values()):.2f})"
            )
    print(f"local (1 render thread): {local_s:.2f} s")
    load = os.getloadavg()
    print(f"load average (1, 5, 15 min): {load[0]:.1f} {load[1]:.1f} {load[2]:.1f} on {os.cpu_count()} cores")
    print(f"speed-up 1 -> 2 workers: {times[1] / times[2]:.2f}x   ({platform.machine()}, {args.width}x{args.height}, {args.samples} spp)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
