#!/usr/bin/env python3
"""Make the gallery, docs/gallery/: every picture in it and its captions.

Usage:  python3 scripts/gallery.py [--threads N]

Run from anywhere; it works in the repository root. It builds atmosim
(`cargo build --release`, honouring CARGO_TARGET_DIR), renders the jobs in
examples/gallery/ into out/gallery/ (rendering again what is there), fits
and evaluates the sky model of one of them, runs two validation cases for
their plots, copies the PNG files into docs/gallery/ and writes
docs/gallery/README.md, whose captions name the command of each picture
and the commit it was made at. It fails if the gallery exceeds 3 MB.
Only the standard library is used.
"""

import argparse
import os
import shutil
import struct
import subprocess
import sys
import time
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GALLERY = os.path.join(ROOT, "docs", "gallery")
LIMIT_BYTES = 3 * 1024 * 1024

# The skies of examples/gallery/skies.toml, by sun elevation: task names.
SKY_ELEVATIONS = ["+60.0", "+20.0", "+05.0", "+00.0", "-02.0", "-04.2"]
SKY_TASK = "vis059.1_elev{}_alt00000m"
DOLP_ELEVATION = "+20.0"
VALIDATION_CASES = [
    ("libradtran_B_disort_pp", "DISORT (plane-parallel, libRadtran 2.0.3): OPAC continental_average "
     "with Mie phase matrices, 540 nm, scalar; from the ground and from 10 km"),
    ("mystic_twilight", "MYSTIC (libRadtran, full spherical geometry, polarised): the sun 2° below "
     "the horizon, 620 nm, US-standard gases with ozone; from the ground and from 10 km"),
]


def run(cmd, log, check=True):
    """Runs a command in the repository root, timing it into `log`."""
    print("+", " ".join(cmd), flush=True)
    start = time.time()
    result = subprocess.run(cmd, cwd=ROOT)
    log.append((cmd, time.time() - start))
    if check and result.returncode != 0:
        sys.exit(f"gallery: {' '.join(cmd)} failed with exit code {result.returncode}")
    return result.returncode


def png_text(path):
    """The tEXt chunks of a PNG file, as a dict."""
    out = {}
    with open(path, "rb") as f:
        data = f.read()
    pos = 8
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"tEXt":
            key, _, value = body.partition(b"\0")
            out[key.decode("latin-1")] = value.decode("latin-1")
        elif kind == b"zTXt":
            key, _, rest = body.partition(b"\0")
            out[key.decode("latin-1")] = zlib.decompress(rest[1:]).decode("latin-1")
        pos += 12 + length
    return out


def png_size(path):
    with open(path, "rb") as f:
        head = f.read(24)
    return struct.unpack(">II", head[16:24])


def commit():
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                          capture_output=True, text=True).stdout.strip() or "unknown"
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", "src",
                            "examples", "Cargo.toml", "Cargo.lock", "spectra", "atmospheres",
                            "validation"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    return head + ("+changes" if dirty else "")


def copy(src, name):
    dst = os.path.join(GALLERY, name)
    shutil.copyfile(os.path.join(ROOT, src), dst)
    return name


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", type=int, default=0, help="worker threads (0: one per core)")
    args = parser.parse_args()
    start = time.time()
    log = []
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    run(["cargo", "build", "--release", "--quiet"], log)
    exe = os.path.join(target, "release", "atmosim")
    threads = ["--threads", str(args.threads)] if args.threads else []
    atmosim = lambda *a: [exe, *a]  # noqa: E731

    # The renders.
    jobs = {name: f"examples/gallery/{name}.toml" for name in ("skies", "panorama_15km", "fit_render")}
    for job in jobs.values():
        run(atmosim("render", job, "--force", "--overwrite", "--quiet", *threads), log)
    # The fitted sky, evaluated where it was rendered.
    run(atmosim("fit", "examples/gallery/fit.toml", "--quiet", *threads), log)
    run(atmosim("eval", "out/gallery/fit/sky.dat", "--elevation", "20", "--visibility", "40",
                "--albedo", "0.3", "--resolution", "128", "--out", "out/gallery/fit/eval"), log)
    # Validation plots (a failing case still has its plot: the caption says).
    cases = [c for c, _ in VALIDATION_CASES]
    status = run(atmosim("validate", *cases, "--out", "out/gallery/validate", *threads), log, check=False)

    # Copy into docs/gallery/, from a clean folder.
    if os.path.isdir(GALLERY):
        for f in os.listdir(GALLERY):
            if f.endswith(".png"):
                os.remove(os.path.join(GALLERY, f))
    os.makedirs(GALLERY, exist_ok=True)
    rev = commit()
    skies = []
    for elev in SKY_ELEVATIONS:
        task = SKY_TASK.format(elev)
        name = copy(f"out/gallery/skies/{task}/preview.png", f"sky_elev{elev}.png")
        skies.append((elev, name, png_text(os.path.join(GALLERY, name)).get("exposure", "?")))
    dolp = copy(f"out/gallery/skies/{SKY_TASK.format(DOLP_ELEVATION)}/dolp.png", f"dolp_elev{DOLP_ELEVATION}.png")
    panorama = copy("out/gallery/panorama_15km/preview.png", "panorama_15km.png")
    fit_render = copy("out/gallery/fit/render/preview.png", "fit_render.png")
    fit_eval = copy("out/gallery/fit/eval/sphere.png", "fit_eval.png")
    plots = [(copy(f"out/gallery/validate/{c}.png", f"validate_{c}.png"), c, what) for c, what in VALIDATION_CASES]
    with open(os.path.join(ROOT, "out/gallery/validate/report.md")) as f:
        report = f.read()

    elapsed = time.time() - start
    total = sum(os.path.getsize(os.path.join(GALLERY, f)) for f in os.listdir(GALLERY) if f.endswith(".png"))
    exposure = lambda name: png_text(os.path.join(GALLERY, name)).get("exposure", "?")  # noqa: E731
    w, h = png_size(os.path.join(GALLERY, skies[0][1]))
    pw, ph = png_size(os.path.join(GALLERY, panorama))
    fw, fh = png_size(os.path.join(GALLERY, fit_render))
    ew, eh = png_size(os.path.join(GALLERY, fit_eval))
    verdicts = []
    for c, _ in VALIDATION_CASES:
        line = next((l for l in report.splitlines() if l.startswith(f"| {c} ")), "")
        verdicts.append("pass" if "pass" in line.lower() else ("FAIL" if line else "?"))

    lines = [
        "# Gallery",
        "",
        "What atmosim makes, at small sizes. Every picture here is made by one command,",
        "",
        "```sh",
        "python3 scripts/gallery.py",
        "```",
        "",
        f"which rendered them at commit `{rev}` in {elapsed / 60:.1f} minutes on this project's",
        f"2-core machine ({len(os.listdir(GALLERY)) - ('README.md' in os.listdir(GALLERY))} files,"
        f" {total / 1e6:.2f} MB). The jobs are in `examples/gallery/`; each caption names the",
        "command that made the picture (run from the repository root). Colour images are sRGB of",
        "the CIE 1931 XYZ of the 11 bands of 40 nm from 320 to 760 nm (`src/io/srgb.rs`, the",
        "tabulated 2° observer), each with its own automatic exposure (the median pixel at middle",
        "grey), stated in the caption as the factor on the radiance (W m⁻² sr⁻¹ nm⁻¹). How images",
        "are laid out: [images](../images.md).",
        "",
        "## From day to twilight",
        "",
        f"Up-looking fisheyes ({w}×{h}, equidistant; the sun's azimuth at the top) from the ground,",
        "OPAC continental_average aerosol at 59 km visibility, ground albedo 0.3,",
        "`atmosim render examples/gallery/skies.toml` (128 samples per pixel; the noise grows",
        f"toward twilight). Commit `{rev}`.",
        "",
        "| " + " | ".join(f"sun {float(e):+.1f}°" for e, _, _ in skies[:3]) + " |",
        "|---|---|---|",
        "| " + " | ".join(f"![sun {float(e):+.1f}°]({n})" for e, n, _ in skies[:3]) + " |",
        "| " + " | ".join(f"exposure {x}" for _, _, x in skies[:3]) + " |",
        "",
        "| " + " | ".join(f"sun {float(e):+.1f}°" for e, _, _ in skies[3:]) + " |",
        "|---|---|---|",
        "| " + " | ".join(f"![sun {float(e):+.1f}°]({n})" for e, n, _ in skies[3:]) + " |",
        "| " + " | ".join(f"exposure {x}" for _, _, x in skies[3:]) + " |",
        "",
        "## Degree of polarisation",
        "",
        f"![degree of linear polarisation, sun 20°]({dolp})",
        "",
        "√(Q² + U²)/I at 540 nm (the band nearest 550 nm), 0 black to 1 white, of the sky with",
        "the sun 20° up above: the bright band 90° from the sun is where single Rayleigh",
        "scattering polarises most, the neutral points near the sun and opposite it.",
        f"`atmosim render examples/gallery/skies.toml` (its `dolp.png`), commit `{rev}`.",
        "",
        "## From 15 km",
        "",
        f"![panorama from 15 km]({panorama})",
        "",
        f"The 180° × 180° panorama ({pw}×{ph}) facing the sun's azimuth, sun 10° up, from 15 km:",
        "the zenith at the top, the nadir at the bottom, the horizon 3.9° below the middle row.",
        f"`atmosim render examples/gallery/panorama_15km.toml`, exposure {exposure(panorama)},",
        f"commit `{rev}`.",
        "",
        "## A fitted sky beside its render",
        "",
        "| render | sky model |",
        "|---|---|",
        f"| ![render]({fit_render}) | ![sky model]({fit_eval}) |",
        f"| exposure {exposure(fit_render)} | exposure {exposure(fit_eval)} |",
        "",
        f"Left, the render ({fw}×{fh}, the whole sphere, the sun's azimuth at the centre; sun 20°,",
        "40 km visibility, albedo 0.3, from the ground): `atmosim render",
        "examples/gallery/fit_render.toml`. Right, the dataset fitted from it alone",
        "(`atmosim fit examples/gallery/fit.toml`, rank 9, the Prague sky model's runtime",
        f"format) evaluated at the same configuration ({ew}×{eh}): `atmosim eval",
        "out/gallery/fit/sky.dat --elevation 20 --visibility 40 --albedo 0.3 --resolution 128",
        f"--out out/gallery/fit/eval`. Commit `{rev}`. How the fit works and how well it",
        "does on a real grid: [sky models](../sky-models.md).",
        "",
        "## Against DISORT and MYSTIC",
        "",
    ]
    for (name, case, what), verdict in zip(plots, verdicts):
        lines += [
            f"![{case}]({name})",
            "",
            f"`{case}`: {what}. atmosim over the reference per intensity with ±2 combined standard",
            "errors, the values in case order grouped by output level (grey: outside the",
            f"statistics). Verdict: {verdict}. `atmosim validate {' '.join(cases)} --out",
            f"out/gallery/validate` (each case's own paths), commit `{rev}`. The cases:",
            "[validation](../validation.md).",
            "",
        ]
    lines += [
        "## Timings of this run",
        "",
        "| command | seconds |",
        "|---|---|",
    ]
    for cmd, seconds in log:
        shown = " ".join(os.path.relpath(c, ROOT) if c == exe else c for c in cmd)
        shown = shown.replace(os.path.relpath(exe, ROOT), "atmosim")
        lines.append(f"| `{shown}` | {seconds:.0f} |")
    lines.append("")
    with open(os.path.join(GALLERY, "README.md"), "w") as f:
        f.write("\n".join(lines))
    print(f"gallery: {total / 1e6:.2f} MB in docs/gallery/, {elapsed / 60:.1f} minutes; validate exit {status}")
    if total > LIMIT_BYTES:
        sys.exit(f"gallery: {total} bytes, over the limit of {LIMIT_BYTES}")


if __name__ == "__main__":
    main()
