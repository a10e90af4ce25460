#!/usr/bin/env python3
"""How well N paths estimate a direction's per-path variance.

Reads the radiance.csv (or `render --stdout` output) of a directions job
that lists one direction many times (each copy has random streams of its
own, so the copies are independent estimates of the same radiance, each
from `samples` paths), and prints per wavelength and albedo:

- the median over the copies of their own estimate of the per-path
  relative standard deviation of I, sqrt(samples)·I_se/I (what a render
  of `samples` paths per pixel reports, pixel by pixel);
- the same quantity pooled over every path of every copy (within-copy
  and between-copy variance), the estimate from all paths together.

Where the per-path distribution is heavy-tailed, the median of the small
estimates falls short of the pooled one: the paths that carry most of
the variance are rarer than one in `samples`.

Usage: variance_by_samples.py radiance.csv
"""
import csv
import math
import statistics
import sys


def main(path):
    groups = {}
    with open(path) as f:
        for row in csv.DictReader(f):
            key = (row["wavelength_nm"], row["albedo"])
            groups.setdefault(key, []).append(
                (float(row["I"]), float(row["I_se"]), int(row["samples"]))
            )
    print("wavelength_nm,albedo,copies,samples_each,median_relstd_each,pooled_relstd,paths")
    for (wl, albedo), rows in groups.items():
        n = rows[0][2]
        means = [m for m, _, _ in rows]
        total = len(rows) * n
        grand = sum(means) / len(means)
        if grand <= 0.0:
            continue
        each = [se * math.sqrt(n) / m for m, se, _ in rows if m > 0.0]
        # Σ (x − x̄)² over all paths: within each copy (n − 1)·s², where
        # s² = n·se², plus n·(copy mean − grand mean)².
        ss = sum((n - 1) * n * se * se + n * (m - grand) ** 2 for m, se, _ in rows)
        pooled = math.sqrt(ss / (total - 1)) / grand
        print(f"{wl},{albedo},{len(rows)},{n},{statistics.median(each):.3f},{pooled:.3f},{total}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
