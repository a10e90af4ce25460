#!/usr/bin/env python3
"""How much of an image's noise is the ground's light.

Reads the `image.exr` of a render with several albedos, albedo 0 among
them (every albedo rides on the same paths, so albedo 0's variance is
the variance of the path radiance alone, the light that never met the
ground), and asks what the paths would be if the ground's reflected
light were known exactly, e.g. from an estimate shared by every pixel:

- per pixel, band and albedo a > 0, a path's variance of I over I^2,
  I_se(a)^2 * samples / I(a)^2, as rendered, and with albedo 0's
  variance in the numerator, I_se(0)^2 * samples / I(a)^2 (the ground's
  part of the variance, and its covariance with the path radiance,
  gone);
- per pixel and spectral group (the bands whose `samples` channels are
  equal: a noise target allocates each group its own, while a
  fixed-sample render's groups look like one), the worst of those over the group's bands and the albedos
  above 0: the paths that pixel needs to reach a relative standard error
  of `target`, worst over 1/target^2 (the same for both, so the ratio
  does not depend on it);
- summed over the traced pixels (the mirrored columns left out, as the
  `symmetry` attribute says), the two, their ratio over all rows and
  over the upper and lower halves of the image (looking up and looking
  down, for a sphere or panorama), and the medians per band of four
  rows. The rows of a ground observer's shared ground view (the
  `ground_view` attribute) are one estimate at a quarter of the target,
  counted once at 16 times a pixel's need (none with the ground exact).

The ratio is a bound on what any shared or exact estimate of the ground's
light could buy an image whose every pixel is rendered to the target.

Needs numpy and the OpenEXR Python bindings (pip install numpy OpenEXR).

Usage: noise_decomposition.py image.exr
"""
import re
import sys

import numpy as np
import OpenEXR


def main(path):
    image = OpenEXR.File(path)
    channels = image.channels()
    header = image.header()
    layers = sorted({name.split(".")[0] for name in channels if "nm_a" in name})
    bands = sorted({layer.split("_a")[0] for layer in layers}, key=lambda b: float(b[:-2].replace("p", ".")))
    albedos = sorted({layer.split("_a")[1] for layer in layers})
    if "000" not in albedos or len(albedos) < 2:
        sys.exit(f"{path}: needs albedo 0 and at least one albedo above it (has {', '.join(albedos)})")

    def plane(name):
        return channels[name].pixels.astype(np.float64)

    need, exact = {}, {}
    for band in bands:
        samples = plane(f"{band}.samples")
        group = samples.tobytes()
        var0 = plane(f"{band}_a000.I_se") ** 2 * samples
        for albedo in albedos:
            if albedo == "000":
                continue
            mean = plane(f"{band}_a{albedo}.I")
            lit = mean > 0
            safe = np.where(lit, mean, 1.0) ** 2
            rendered = np.where(lit, plane(f"{band}_a{albedo}.I_se") ** 2 * samples / safe, 0.0)
            ground_exact = np.where(lit, var0 / safe, 0.0)
            need[group] = np.maximum(need.get(group, 0.0), rendered)
            exact[group] = np.maximum(exact.get(group, 0.0), ground_exact)
    need_all = sum(need.values())
    exact_all = sum(exact.values())
    height, width = need_all.shape
    traced = re.match(r"mirror: columns 0 to (\d+) are traced", str(header.get("symmetry", "")))
    columns = int(traced.group(1)) + 1 if traced else width
    shared = re.match(r"rows (\d+) to (\d+)", str(header.get("ground_view", "")))
    per_row = need_all[:, :columns].sum(axis=1)
    per_row_exact = exact_all[:, :columns].sum(axis=1)
    if shared:
        first, last = int(shared.group(1)), int(shared.group(2))
        per_row[first:last + 1] = 0.0
        per_row_exact[first:last + 1] = 0.0
        per_row[first] = 16.0 * need_all[first, 0]
        per_row_exact[first] = 16.0 * exact_all[first, 0]
        print(f"rows {first} to {last}: the shared ground view, counted once")
    up = np.arange(height) < height // 2

    def ratio(rows):
        return per_row_exact[rows].sum() / per_row[rows].sum()

    print(f"{path}: {height} rows, {len(bands)} bands in {len(need)} spectral group(s), albedos {' '.join(albedos)}")
    print("paths to the target with the ground's light exact, over those as rendered:")
    print(f"  all rows {ratio(slice(None)):.3f}, upper half {ratio(up):.3f}, lower half {ratio(~up):.3f}")
    print(f"  the lower half's share of the paths: {per_row[~up].sum() / per_row.sum():.3f} as rendered, "
          f"{per_row_exact[~up].sum() / per_row_exact.sum():.3f} with the ground exact")
    print("rows,median_variance_over_I2_as_rendered,median_with_ground_exact (per pixel, summed over the groups)")
    for r in range(0, height, 4):
        rows = slice(r, r + 4)
        print(f"{r}-{min(r + 3, height - 1)},{np.median(need_all[rows, :columns]):.3g},"
              f"{np.median(exact_all[rows, :columns]):.3g}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
