#!/usr/bin/env python3
"""A dataset against independent direction renders, through the runtime's API.

Usage:  python3 scripts/sky_model_queries.py DATASET DIRECTIONS_DIR [--atmosim PATH]

DIRECTIONS_DIR is the output of a `directions` render of the dataset's
atmosphere (one task per sun elevation, from the ground, visibility and
albedos of the dataset's nodes: examples/sky_model_wide_mini_directions.toml).
A job of several tasks writes one folder per task; a job of one task
writes its radiance.csv and task.toml into DIRECTIONS_DIR itself, and the
task's name is then read from its task.toml. Both are read.
Every row of each task's radiance.csv becomes a query of
`atmosim eval DATASET --queries` (written beside the dataset as
<dataset>.queries.csv, its answers as <dataset>.answers.csv); per band it
prints the median and largest |dataset − I| / I, the reference's median
relative standard error and the median |dataset − I| / I_se, then the
figures over all rows and the error of the degree of polarisation
(the runtime's polarisation against Q/I in the sun–view frame). Only the
standard library is used.
"""

import argparse
import csv
import glob
import math
import os
import re
import statistics
import subprocess

HEADER = ("view_x_m,view_y_m,view_z_m,dir_x,dir_y,dir_z,sun_elevation_deg,sun_azimuth_deg,"
          "visibility_km,albedo,wavelength_nm,distance_m")


def task_name(path):
    """The task's name: its folder's, or for a one-task job its task.toml's `task`."""
    folder = os.path.dirname(path)
    task_toml = os.path.join(folder, "task.toml")
    if os.path.isfile(task_toml):
        with open(task_toml) as f:
            match = re.search(r'^task = "([^"]*)"$', f.read(), re.MULTILINE)
        if match:
            return match.group(1)
    return os.path.basename(folder)


def references(directions_dir):
    """(elevation, visibility, row) for every row of every task's radiance.csv."""
    out = []
    single = os.path.join(directions_dir, "radiance.csv")
    if os.path.isfile(single):
        paths = [single]
    else:
        paths = sorted(glob.glob(os.path.join(directions_dir, "*", "radiance.csv")))
    for path in paths:
        task = task_name(path)
        match = re.match(r"vis([0-9.]+)_elev([+-][0-9.]+)_alt00000m$", task)
        if not match:
            raise SystemExit(f"{path}: not a ground-level task named vis…_elev…_alt00000m")
        visibility, elevation = float(match.group(1)), float(match.group(2))
        with open(path) as f:
            for row in csv.DictReader(line for line in f if not line.startswith("#")):
                out.append((elevation, visibility, row))
    if not out:
        raise SystemExit(f"{directions_dir}: no task with a radiance.csv")
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset")
    parser.add_argument("directions_dir")
    parser.add_argument("--atmosim", default="target/release/atmosim")
    args = parser.parse_args()
    refs = references(args.directions_dir)
    lines = [HEADER]
    for elevation, visibility, row in refs:
        zenith, azimuth = math.radians(float(row["view_zenith_deg"])), math.radians(float(row["azimuth_deg"]))
        d = (math.sin(zenith) * math.cos(azimuth), math.sin(zenith) * math.sin(azimuth), math.cos(zenith))
        lines.append(f"0,0,0,{d[0]:.12f},{d[1]:.12f},{d[2]:.12f},{elevation},0,{visibility},"
                     f"{row['albedo']},{row['wavelength_nm']},inf")
    queries, answers = args.dataset + ".queries.csv", args.dataset + ".answers.csv"
    with open(queries, "w") as f:
        f.write("\n".join(lines) + "\n")
    text = subprocess.run([args.atmosim, "eval", args.dataset, "--queries", queries],
                          capture_output=True, text=True, check=True).stdout
    with open(answers, "w") as f:
        f.write(text)
    rows = list(csv.DictReader(text.splitlines()))
    by_band, relative, z, polarisation = {}, [], [], []
    for (_, _, ref), answer in zip(refs, rows, strict=True):
        i, se = float(ref["I"]), float(ref["I_se"])
        if i <= 0.0 or se <= 0.0:
            continue
        sky = float(answer["sky_radiance"])
        rel = (sky - i) / i
        by_band.setdefault(float(ref["wavelength_nm"]), []).append((rel, (sky - i) / se, se / i))
        relative.append(abs(rel))
        z.append(abs(sky - i) / se)
        if answer["polarisation"]:
            polarisation.append(abs(float(answer["polarisation"]) - float(ref["Q"]) / i))
    median = statistics.median
    print("band_nm,rows,median_abs_rel,max_abs_rel,median_rel_se,median_abs_z")
    for band, v in sorted(by_band.items()):
        print(f"{band:g},{len(v)},{median(abs(x[0]) for x in v):.4f},{max(abs(x[0]) for x in v):.4f},"
              f"{median(x[2] for x in v):.4f},{median(abs(x[1]) for x in v):.2f}")
    relative.sort()
    print(f"# {len(relative)} rows: |dataset - I| / I median {median(relative):.4f}, "
          f"90th percentile {relative[int(0.9 * (len(relative) - 1))]:.4f}, max {relative[-1]:.4f}; "
          f"|dataset - I| / I_se median {median(z):.2f}")
    if polarisation:
        print(f"# degree of polarisation, |P - Q/I|: median {median(polarisation):.4f}, max {max(polarisation):.4f}")


if __name__ == "__main__":
    main()
