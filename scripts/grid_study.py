#!/usr/bin/env python3
"""The sky-model grid sized by the dataset it makes (docs: grid-sizing).

Renders the validation sub-grid (sun -4.2, -1, 2, 10, 45 deg; observer 0
and 15 km; visibility 20 and 131.8 km; albedos 0.3 and 1; 11 bands of 40 nm
from 320 nm; polarised; OPAC continental_average with its Mie phase
matrices, the default) once as a reference and, per study row (a render
resolution and a noise level), twice with independent seeds; fits every
render set with `atmosim fit`; and compares each row's first dataset with
the reference renders and with its twin by `atmosim fit-report --reference
--twin`. Prints a table per row:

- the dataset against the converged sky (the reference's noise taken out):
  SNR mean / minimum over the images, the polarisation error;
- the seed-to-seed SNR and the noise one dataset inherits (+3.01 dB);
- the fit's own error (the error against the converged sky less the
  inherited noise) and what the render noise costs in dB;
- core-hours per task (the process CPU time of each task's render, mean
  and max over the 20 tasks), at the row's resolution.

Every step is skipped when its output exists (a task complete, a dataset,
a report), so the study can be stopped and run again. Usage:

    cargo build --release
    scripts/grid_study.py [--out out/grid_study] [--rows NAME ...] [--threads N]

Needs Python 3.9+ alone (no packages). Each row's commands are printed as
they run.
"""

import argparse
import csv
import json
import math
import os
import resource
import subprocess
import sys
from pathlib import Path

BANDS = "[340.0, 380.0, 420.0, 460.0, 500.0, 540.0, 580.0, 620.0, 660.0, 700.0, 740.0]"
TASKS = 20

JOB = """# The validation sub-grid of the sky model's grid (scripts/grid_study.py).
[planet]
radius_km = 6378.0
top_km = 100.0
[atmosphere]
profile = "us_standard"
ozone = "bogumil"
aerosol = "continental_average"
visibility_km = [20.0, 131.8]
[spectrum]
wavelengths_nm = {bands}
band_width_nm = 40.0
[sun]
elevation_deg = [-4.2, -1.0, 2.0, 10.0, 45.0]
[observer]
altitude_km = [0.0, 15.0]
[ground]
albedo = [0.3, 1.0]
[sensor]
type = "sphere"
resolution = [{width}, {height}]
stokes_frame = "sun_view"
[render]
{render}
polarized = true
seed = {seed}
[output]
directory = "{out}"
units = "absolute"
preview = false
"""


def image_target(t, pilot=8):
    return (f'noise_target = {t}\nnoise_target_per = "image"\nnoise_target_albedos = "above_zero"\n'
            f"pilot_samples = {pilot}\nmax_samples = 1000000")


# name: (width, render keys). The reference comes first; the rows are
# rendered with seeds 1 and 2.
REFERENCE = ("ref512_s256", 512, "samples = 256", 1001)
ROWS = {
    "r256_s16": (256, "samples = 16"),
    "r512_s16": (512, "samples = 16"),
    "r256_s64": (256, "samples = 64"),
    "r512_s64": (512, "samples = 64"),
    "r256_img10": (256, image_target(0.1)),
    "r512_img10": (512, image_target(0.1)),
    "r256_img05": (256, image_target(0.05)),
}


def run(cmd, cwd):
    print("+ (cd {}; {})".format(cwd, " ".join(cmd)), flush=True)
    subprocess.run(cmd, cwd=cwd, check=True)


def cpu_of_children():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def render(atmosim, out, name, width, keys, seed, threads):
    """Renders a job task by task; returns {task: cpu seconds}."""
    job = out / f"{name}.toml"
    # A job file that exists is kept (its tasks' results name its hash).
    if not job.exists():
        job.write_text(JOB.format(bands=BANDS, width=width, height=width // 2, render=keys, seed=seed, out=name))
    cache = out / f"{name}.cpu.json"
    cpu = json.loads(cache.read_text()) if cache.exists() else {}
    for task in range(TASKS):
        if str(task) in cpu:
            continue
        done = [d for d in (out / name).glob("*/task.toml")] if (out / name).is_dir() else []
        before = cpu_of_children()
        cmd = [atmosim, "render", job.name, "--task", str(task), "-q"]
        if threads:
            cmd += ["--threads", str(threads)]
        run(cmd, out)
        now_done = list((out / name).glob("*/task.toml"))
        # A task complete before this run (rendered elsewhere) has no time.
        cpu[str(task)] = cpu_of_children() - before if len(now_done) > len(done) else None
        cache.write_text(json.dumps(cpu))
    return cpu


def fit(atmosim, out, name):
    dataset = out / f"{name}.dat"
    (out / f"fit_{name}.toml").write_text(f'renders = "{name}"\nout = "{name}.dat"\n')
    if not dataset.exists():
        run([atmosim, "fit", f"fit_{name}.toml", "-q"], out)
    return dataset


def rows_of(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def number(text):
    return float(text) if text not in ("", None) else float("nan")


def paths_of(out, name):
    """Paths per task (by task directory name)."""
    paths = {}
    for d in sorted((out / name).iterdir()):
        meta = d / "task.toml"
        if meta.exists():
            for line in meta.read_text().splitlines():
                if line.startswith("paths = "):
                    paths[d.name] = int(line.split("=")[1])
    return paths


def image_key(r):
    """An image of a report's CSV: its configuration and channel."""
    return tuple(float(r[k]) for k in ("visibility_km", "albedo", "altitude_m", "elevation_deg", "wavelength_nm"))


def task_name(r):
    """The task directory of a report's CSV row."""
    return "vis{:05.1f}_elev{:+05.1f}_alt{:05.0f}m".format(
        float(r["visibility_km"]), float(r["elevation_deg"]), float(r["altitude_m"]))


def summarise(out, row, reference):
    """The row's figures from its report."""
    report = out / f"{row}.report"
    ref = rows_of(report / "reference.csv")
    twin_all = rows_of(report / "twin.csv")
    # The reference may cover a subset of the configurations (a reference
    # render costs 16 times a row's): the figures against it are over that
    # subset, the seed-to-seed figures over every image and over the subset.
    by_key = {image_key(t): t for t in twin_all}
    twin = [by_key[image_key(r)] for r in ref]
    # The debiased SNR, or its lower bound where the reference does not
    # resolve the error.
    debiased = [number(r["debiased_snr_db"]) if r["debiased_snr_db"] else number(r["debiased_snr_lower_db"])
                for r in ref]
    inherited = [number(t["inherited_snr_db"]) for t in twin]
    pol = [number(r["polarisation_error"]) for r in ref if r["polarisation_error"]]
    # Per image: error power over signal e = 10^(-S/10); the inherited part
    # n; the fit's own b = e - n (floored at a tenth of e: the two
    # estimates are noisy).
    fit_own, cost = [], []
    for s, i in zip(debiased, inherited):
        e, n = 10 ** (-s / 10), 10 ** (-i / 10)
        b = max(e - n, 0.1 * e)
        fit_own.append(-10 * math.log10(b))
        cost.append(10 * math.log10(e / b))
    mean = lambda v: sum(v) / len(v)
    per_image = {}
    for r, s, i in zip(ref, debiased, inherited):
        per_image[image_key(r)] = (10 ** (-s / 10), 10 ** (-i / 10), task_name(r))
    return per_image, {
        "images": len(ref),
        "snr_mean": mean(debiased),
        "snr_min": min(debiased),
        "raw_snr_mean": mean([number(r["snr_db"]) for r in ref]),
        "reference_floor_mean": mean([number(r["noise_floor_db"]) for r in ref]),
        "unresolved": sum(1 for r in ref if not r["debiased_snr_db"]),
        "pol_error_mean": mean(pol) if pol else float("nan"),
        "seed_to_seed_mean": mean([number(t["seed_to_seed_snr_db"]) for t in twin_all]),
        "seed_to_seed_min": min(number(t["seed_to_seed_snr_db"]) for t in twin_all),
        "inherited_mean": mean([number(t["inherited_snr_db"]) for t in twin_all]),
        "inherited_min": min(number(t["inherited_snr_db"]) for t in twin_all),
        "twin_images": len(twin_all),
        "inherited_mean_on_reference": mean(inherited),
        "inherited_min_on_reference": min(inherited),
        "fit_own_mean": mean(fit_own),
        "render_noise_cost_db_mean": mean(cost),
        "render_noise_cost_db_max": max(cost),
    }


def converged_gap(out, ref_name, results, per_image, paths):
    """Per row, how far its mean SNR against the converged sky falls short
    of the dataset fitted from converged renders.

    The latter is estimated per image as the fit's own error at the
    reference's resolution (the median over the rows of that resolution of
    e - n, the error against the converged sky less the inherited noise,
    floored at a tenth of e). Beside it, the dataset the reference's own
    renders would make: that plus the noise their paths would pass on, a
    row's inherited noise scaled by the row's paths over the reference's
    for that task (inherited noise power falls as 1/paths at a given
    allocation).
    """
    ref_paths = paths_of(out, ref_name)
    ref_width = REFERENCE[1]
    same = [r for r in per_image if results[r]["width"] == ref_width]
    if not same:
        return
    keys = per_image[same[0]].keys()
    converged, from_reference = {}, {}
    for k in keys:
        own = sorted(max(per_image[r][k][0] - per_image[r][k][1], 0.1 * per_image[r][k][0]) for r in same)
        b = own[len(own) // 2]
        task = per_image[same[0]][k][2]
        n = min(per_image[r][k][1] * paths[r][task] / ref_paths[task] for r in same)
        converged[k] = -10 * math.log10(b)
        from_reference[k] = -10 * math.log10(b + n)
    c_mean = sum(converged.values()) / len(converged)
    for row, f in results.items():
        f["converged_snr_mean"] = c_mean
        f["converged_snr_min"] = min(converged.values())
        f["gap_to_converged_db"] = c_mean - f["snr_mean"]
        f["reference_renders_snr_mean"] = sum(from_reference.values()) / len(from_reference)
        f["reference_renders_snr_min"] = min(from_reference.values())


def required_target(out, row, rows, allowed_db=0.5):
    """The loosest image noise target (`noise_target_per = "image"`, the
    worst band and albedo of a task held to it) at which the render noise
    costs at most `allowed_db` on the mean over the images (dB) of the SNR
    against the converged sky, at the row's resolution.

    Per image the fit's own error b (the error against the converged sky
    less the inherited noise, floored at a tenth of the error) stays, and
    the inherited noise n scales with the task's paths: a target t scales a
    task's paths by (ν_max / t)², ν_max the task's worst image noise in the
    row's renders (their noise floor in the report's images.csv). That
    keeps the row's allocation within each image; the image target's own
    allocation does better, so the target errs tight. Returns (target,
    mean cost, worst image's cost)."""
    images = {image_key(r): r for r in rows_of(out / f"{row}.report" / "images.csv")}
    worst = {}
    for k, r in images.items():
        task = task_name(r)
        worst[task] = max(worst.get(task, 0.0), 10 ** (-number(r["noise_floor_db"]) / 20))
    own = [(max(e - n, 0.1 * e), n, worst[task]) for e, n, task in rows.values()]

    def cost(t):
        costs = [10 * math.log10((b + n * (t / w) ** 2) / b) for b, n, w in own]
        return sum(costs) / len(costs), max(costs)

    lo, hi = 1e-4, 1.0
    for _ in range(60):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if cost(mid)[0] <= allowed_db else (lo, mid)
    return (lo,) + cost(lo)


def region_table(out, row):
    """Per sun elevation and observer altitude: the share of the fit's own
    error (against the reference) and of the inherited noise (seed to seed)
    in each region, averaged over the images."""
    report = out / f"{row}.report"
    names = ("aureole", "horizon", "below", "sky")
    lines = ["| sun | observer | fit's error vs converged sky: aureole / horizon / below / sky "
             "| inherited noise: aureole / horizon / below / sky |", "|---|---|---|---|"]
    ref, twin = rows_of(report / "reference.csv"), rows_of(report / "twin.csv")
    configs = sorted({(float(r["elevation_deg"]), float(r["altitude_m"])) for r in twin})
    for elev, alt in configs:
        def shares(rows, prefix):
            rs = [r for r in rows if float(r["elevation_deg"]) == elev and float(r["altitude_m"]) == alt]
            if not rs:
                return "–"
            return " / ".join("{:.2f}".format(sum(number(r[prefix + n]) for r in rs) / len(rs)) for n in names)
        lines.append(f"| {elev:g}° | {alt / 1000:g} km | {shares(ref, 'excess_')} | {shares(twin, 'difference_')} |")
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="out/grid_study")
    parser.add_argument("--rows", nargs="*", default=list(ROWS))
    parser.add_argument("--threads", type=int, default=0)
    parser.add_argument("--reference", help="an existing reference render directory under --out (not rendered)")
    parser.add_argument("--no-report", action="store_true", help="render and fit the rows only")
    parser.add_argument("--atmosim", default=str(Path(__file__).resolve().parent.parent / "target/release/atmosim"))
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    atmosim = os.path.abspath(args.atmosim)

    ref_name, ref_width, ref_keys, ref_seed = REFERENCE
    if args.reference:
        ref_name = args.reference
    elif not args.no_report:
        render(atmosim, out, ref_name, ref_width, ref_keys, ref_seed, args.threads)
    results, per_image, paths = {}, {}, {}
    for row in args.rows:
        width, keys = ROWS[row]
        cpu = {}
        for seed, suffix in ((1, "a"), (2, "b")):
            cpu[suffix] = render(atmosim, out, f"{row}_{suffix}", width, keys, seed, args.threads)
            fit(atmosim, out, f"{row}_{suffix}")
        if args.no_report:
            continue
        report = out / f"{row}.report"
        if not (report / "twin.csv").exists():
            run([atmosim, "fit-report", f"fit_{row}_a.toml", "--reference", ref_name, "--twin", f"{row}_b.dat",
                 "--out", report.name], out)
        per_image[row], figures = summarise(out, row, ref_name)
        paths[row] = paths_of(out, f"{row}_a")
        hours = [c / 3600 for c in list(cpu["a"].values()) + list(cpu["b"].values()) if c is not None]
        figures["core_hours_mean"] = sum(hours) / len(hours) if hours else float("nan")
        figures["core_hours_max"] = max(hours) if hours else float("nan")
        figures["timed_tasks"] = len(hours)
        figures["width"] = width
        figures["render"] = keys.replace("\n", "; ")
        results[row] = figures
        (out / "study.json").write_text(json.dumps(results, indent=1))
        print(json.dumps({row: figures}, indent=1), flush=True)

    converged_gap(out, ref_name, results, per_image, paths)
    for row, f in results.items():
        t, mean_cost, max_cost = required_target(out, row, per_image[row])
        f["required_image_target"] = t
        f["required_target_cost_db_mean"] = mean_cost
        f["required_target_cost_db_max"] = max_cost
    (out / "study.json").write_text(json.dumps(results, indent=1))
    print("\n| row | resolution | render | vs converged sky: SNR mean / min (dB) | below the converged renders' "
          "dataset (dB) | pol. error | seed-to-seed mean / min (dB) | inherited mean / min (dB) "
          "| fit's own error, mean (dB) | render noise costs, mean / max (dB) | core-hours per task, mean / max |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for row, f in results.items():
        print(f"| {row} | {f['width']}x{f['width'] // 2} | {f['render']} | {f['snr_mean']:.2f} / {f['snr_min']:.2f} "
              f"| {f.get('gap_to_converged_db', float('nan')):.2f} "
              f"| {f['pol_error_mean']:.4f} | {f['seed_to_seed_mean']:.2f} / {f['seed_to_seed_min']:.2f} "
              f"| {f['inherited_mean']:.2f} / {f['inherited_min']:.2f} | {f['fit_own_mean']:.2f} "
              f"| {f['render_noise_cost_db_mean']:.2f} / {f['render_noise_cost_db_max']:.2f} "
              f"| {f['core_hours_mean']:.3f} / {f['core_hours_max']:.3f} |")
    for row, f in results.items():
        if "required_image_target" in f:
            print(f"\n{row}: render noise costs at most 0.5 dB of the mean SNR against the converged sky at an image "
                  f"noise target of {f['required_image_target']:.4f} at {f['width']}x{f['width'] // 2} (the worst "
                  f"image then loses {f['required_target_cost_db_max']:.2f} dB).")
        print(f"\nWhere the error is, {row}:\n\n" + region_table(out, row))
    if results:
        f = next(iter(results.values()))
        if "converged_snr_mean" in f:
            print(f"\nThe dataset of the converged renders (estimated, the fit's own error alone): SNR mean "
                  f"{f['converged_snr_mean']:.2f} dB, minimum {f['converged_snr_min']:.2f} dB against the converged "
                  f"sky; the reference's own renders would make {f['reference_renders_snr_mean']:.2f} / "
                  f"{f['reference_renders_snr_min']:.2f} dB.")


if __name__ == "__main__":
    sys.exit(main())
