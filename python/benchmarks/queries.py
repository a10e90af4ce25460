"""10^6 sky-model queries: `atmosim.SkyModel` from numpy against
`atmosim eval DATASET --queries Q.csv` on the same queries, paired (one
run of each per round, alternating which goes first), the median of the
rounds.

    python python/benchmarks/queries.py DATASET [--n 1000000] [--rounds 5]

The binary reads the CSV, answers each row (all four quantities) and
prints the answers; Python evaluates the four quantities (four calls) on
arrays already in memory. Python's threads: rayon's default (one per core)
unless RAYON_NUM_THREADS is set; run it with RAYON_NUM_THREADS=1 for the
binary's single thread.
"""

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import atmosim


def queries(n, axes, seed=1):
    rng = np.random.default_rng(seed)
    w0, dw, nc = axes["channel_start_nm"], axes["channel_width_nm"], axes["channels"]
    return dict(
        view_point_m=np.stack([np.zeros(n), np.zeros(n), rng.uniform(0, 2000, n)], -1),
        direction=rng.normal(size=(n, 3)),
        sun_elevation_deg=rng.uniform(axes["elevations_deg"].min(), axes["elevations_deg"].max(), n),
        sun_azimuth_deg=rng.uniform(-180, 180, n),
        visibility_km=rng.uniform(axes["visibilities_km"].min(), axes["visibilities_km"].max(), n),
        albedo=rng.uniform(0, 1, n),
        wavelength_nm=w0 + dw * (rng.integers(0, nc, n) + 0.5),
        distance_m=np.full(n, np.inf),
    )


def write_csv(path, q):
    cols = [q["view_point_m"][:, 0], q["view_point_m"][:, 1], q["view_point_m"][:, 2],
            q["direction"][:, 0], q["direction"][:, 1], q["direction"][:, 2],
            q["sun_elevation_deg"], q["sun_azimuth_deg"], q["visibility_km"], q["albedo"],
            q["wavelength_nm"], q["distance_m"]]
    np.savetxt(path, np.stack(cols, -1), fmt="%.17g", delimiter=",",
               header=",".join(atmosim._atmosim.QUERY_COLUMNS), comments="")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dataset")
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--binary", default=os.environ.get("ATMOSIM_BIN") or shutil.which("atmosim")
                    or str(Path(__file__).resolve().parents[2] / "target" / "release" / "atmosim"))
    args = ap.parse_args()
    model = atmosim.SkyModel(args.dataset)
    has_pol = model.axes["has_polarisation"]
    q = queries(args.n, model.axes)
    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / "q.csv"
        write_csv(csv, q)

        def run_binary():
            t = time.perf_counter()
            subprocess.run([args.binary, "eval", args.dataset, "--queries", str(csv)],
                           stdout=subprocess.DEVNULL, check=True)
            return time.perf_counter() - t

        def run_python():
            t = time.perf_counter()
            a = {k: v for k, v in q.items() if k != "distance_m"}
            model.sky_radiance(**a)
            model.sun_radiance(**a)
            if has_pol:
                model.polarisation(**a)
            model.transmittance(**a, distance_m=q["distance_m"])
            return time.perf_counter() - t

        b, p = [], []
        for r in range(args.rounds):
            pair = [(b, run_binary), (p, run_python)]
            for times, f in (pair if r % 2 == 0 else pair[::-1]):
                times.append(f())
    mb, mp = statistics.median(b), statistics.median(p)
    threads = os.environ.get("RAYON_NUM_THREADS", f"default ({os.cpu_count()} cores)")
    print(f"{args.n} queries, {args.rounds} rounds, Python threads: {threads}")
    print(f"atmosim eval --queries: median {mb:.3f} s  (runs {', '.join(f'{x:.3f}' for x in b)})")
    print(f"atmosim.SkyModel:       median {mp:.3f} s  (runs {', '.join(f'{x:.3f}' for x in p)})")
    print(f"Python / binary: {mp / mb:.3f}")


if __name__ == "__main__":
    sys.exit(main())
