#!/usr/bin/env python3
"""atmosim's variance per path against MYSTIC's per photon, on MYSTIC's own case.

The one MYSTIC reference in the validation data
(`validation/mystic/A_620nm_sun-2_spherical_mystic.csv`: spherical,
polarised, US standard gases with Bogumil ozone, 620 nm, sun 2 deg below
the horizon, albedo 0.2, observers at 0 and 10 km) gives each direction's
standard error and photon count, but not MYSTIC's CPU time, so the figure
of merit of the two cannot be paired. What can be: the relative variance
per path, (se / I)^2 x paths, of each, and so the ratio

    r = MYSTIC's relative variance per photon / atmosim's per path,

which is the ratio of the figures of merit if a MYSTIC photon costs what
an atmosim path does. For a goal of G times MYSTIC's figure of merit,
MYSTIC would have to spend at least G x (atmosim's CPU seconds per path)
/ r per photon; the script prints that break-even per direction.

This renders the case with the given build, one thread, `--samples` paths
per direction (rows that MYSTIC ran twice are pooled by photon count),
and takes atmosim's CPU seconds per path as its whole process's over all
of an observer's directions.

    python3 scripts/mystic_per_path.py --mystic SHARED/validation/mystic/A_620nm_sun-2_spherical_mystic.csv \
        --atmosim target/release/atmosim [--samples 40000] [--goal 30]

Standard library only.
"""

import argparse
import csv
import os
import statistics
import subprocess
import tempfile

JOB = """[planet]
radius_km = 6370.0
top_km = 120.0
[atmosphere]
profile = "us_standard"
ozone = "bogumil"
aerosol = "none"
[spectrum]
wavelengths_nm = [620.0]
[sun]
elevation_deg = -2.0
[ground]
albedo = 0.2
[observer]
altitude_km = {altitude}
[sensor]
directions = {directions}
fluxes = false
[render]
samples = {samples}
seed = 9
polarized = true
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mystic", required=True)
    ap.add_argument("--atmosim", required=True)
    ap.add_argument("--samples", type=int, default=40000)
    ap.add_argument("--goal", type=float, default=30.0)
    args = ap.parse_args()
    with open(args.mystic) as f:
        rows = list(csv.DictReader(l for l in f if not l.startswith("#")))
    observers = sorted({float(r["observer_km"]) for r in rows})
    print("observer_km, view_zenith_deg, azimuth_deg, I_atmosim / I_mystic - 1, "
          "rel_var_per_path_atmosim, rel_var_per_photon_mystic, ratio, "
          f"mystic_us_per_photon_for_{args.goal:g}x")
    for z in observers:
        # MYSTIC's rows per direction, pooled by photon count.
        pooled = {}
        for r in rows:
            if float(r["observer_km"]) != z:
                continue
            key = (float(r["view_zenith_deg"]), float(r["azimuth_deg"]))
            pooled.setdefault(key, []).append((float(r["I"]), float(r["I_std"]), float(r["photons"])))
        directions = list(pooled)
        with tempfile.TemporaryDirectory() as tmp:
            job = os.path.join(tmp, "mystic_case.toml")
            with open(job, "w") as f:
                f.write(JOB.format(altitude=repr(z), samples=args.samples,
                                   directions=[list(d) for d in directions]))
            proc = subprocess.Popen([args.atmosim, "render", job, "--stdout", "--threads", "1", "-q"],
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=tmp)
            out, err = proc.communicate()
        if proc.returncode != 0:
            raise SystemExit(f"{args.atmosim} failed:\n{err.decode(errors='replace')}")
        cpu = resource_cpu_of_children()
        ours = {(float(r["view_zenith_deg"]), float(r["azimuth_deg"])): r
                for r in csv.DictReader(out.decode().splitlines())}
        per_path = cpu / (len(directions) * args.samples)
        ratios = []
        for d in directions:
            runs = pooled[d]
            n = sum(p for _, _, p in runs)
            i_m = sum(i * p for i, _, p in runs) / n
            var_m = sum(se * se * p * p for _, se, p in runs) / n / (i_m * i_m)
            a = ours[d]
            i_a = float(a["I"])
            var_a = (float(a["I_se"]) / i_a) ** 2 * float(a["samples"])
            r = var_m / var_a
            ratios.append(r)
            print(f"{z:g}, {d[0]:g}, {d[1]:g}, {i_a / i_m - 1:+.4f}, {var_a:.4g}, {var_m:.4g}, {r:.4g}, "
                  f"{args.goal * per_path / r * 1e6:.3g}")
        print(f"# observer {z:g} km: atmosim {per_path * 1e6:.3g} us per path (CPU), ratio median "
              f"{statistics.median(ratios):.4g}, min {min(ratios):.4g}; MYSTIC would need "
              f"{args.goal * per_path / statistics.median(ratios) * 1e6:.3g} us per photon for "
              f"{args.goal:g}x in the median")


_last_children_cpu = [0.0]


def resource_cpu_of_children():
    """CPU seconds (user + system) of the children since the last call."""
    import resource
    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    total = u.ru_utime + u.ru_stime
    spent = total - _last_children_cpu[0]
    _last_children_cpu[0] = total
    return spent


if __name__ == "__main__":
    main()
