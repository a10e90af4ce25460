#!/usr/bin/env python3
"""Regenerate atmosim's data files from the public source data.

Usage:  python3 scripts/derive_data.py [SHARED_DIR]

SHARED_DIR defaults to ../shared (the folder beside the checkout that holds
data/ and validation/). Only the standard library is used. The script writes

  atmospheres/afgl/<profile>.txt          AFGL gas profiles, levels ascending
  atmospheres/opac/mixtures/<name>.txt    OPAC mixtures, mass density per component
  atmospheres/opac/components/<c>.txt     OPAC component optics (ext/mass, ssa, g)
  atmospheres/opac/refractive/<c>.txt     OPAC refractive indices, all humidities of <c>
  atmospheres/opac/size_distributions.txt OPAC log-normal size distributions (size_distr.cfg)
  spectra/ozone_bogumil.txt               O3 cross-section coefficients (Bogumil 2003)
  spectra/ozone_molina.txt                O3 cross-section coefficients (Molina 1986)
  spectra/solar_kurucz_1nm.txt            Kurucz 1992 solar irradiance, W m-2 nm-1
  validation/libradtran/*_layers.txt      libRadtran 2.0.3 per-layer optical depths
  validation/libradtran/columns.txt       libRadtran column optical depths

spectra/cie1931_2deg_5nm.txt (the CIE 1931 colour-matching functions of the
previews) is not written here: the shared data holds no CIE table, so it was
entered from CIE 15:2004, Table T.4, and src/io/srgb.rs tests it against
published chromaticities.

Every output starts with '#' lines naming the source file and what was changed
(only re-ordering, unit conversion and column selection: no number is altered
beyond the stated unit conversions). atmosim embeds these files at compile time.
"""

import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

AFGL = {
    "us_standard": ("afglus.dat", "U.S. standard atmosphere 1976"),
    "midlatitude_summer": ("afglms.dat", "AFGL mid-latitude summer"),
    "midlatitude_winter": ("afglmw.dat", "AFGL mid-latitude winter"),
    "subarctic_summer": ("afglss.dat", "AFGL subarctic summer"),
    "subarctic_winter": ("afglsw.dat", "AFGL subarctic winter"),
    "tropical": ("afglt.dat", "AFGL tropical"),
}

MIXTURES = [
    "antarctic", "continental_average", "continental_clean",
    "continental_polluted", "desert", "desert_spheroids", "maritime_clean",
    "maritime_polluted", "maritime_tropical", "urban",
]

COMPONENTS = ["inso", "waso", "soot", "suso"]

# OPAC component numbers of size_distr.cfg, in order 1..10 (libRadtran's
# numbering; checked by refractive_and_sizes() against the refractive-index
# files present and the densities of the optical-property tables).
ALL_COMPONENTS = ["inso", "waso", "soot", "ssam", "sscm", "minm", "miam", "micm", "mitr", "suso"]


def rows(path):
    """Numeric rows of a whitespace table, skipping '#' comments and blanks."""
    out = []
    with open(path) as f:
        for line in f:
            s = line.strip()
            if not s or s.startswith("#"):
                continue
            out.append(s.split())
    return out


def comments(path):
    with open(path) as f:
        return [line.rstrip("\n") for line in f if line.startswith("#")]


def write(rel, header, body):
    path = os.path.join(ROOT, rel)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        for h in header:
            f.write("# " + h + "\n" if h else "#\n")
        for line in body:
            f.write(line + "\n")
    os.replace(tmp, path)
    print("wrote", rel)


def afgl(shared):
    for name, (src, title) in AFGL.items():
        path = os.path.join(shared, "data", "afgl", src)
        data = sorted(rows(path), key=lambda r: float(r[0]))
        header = [
            f"atmosim gas profile '{name}': {title}",
            f"source: libRadtran data file {src} (AFGL-TR-86-0110, Anderson et al. 1986)",
            f"derived by scripts/derive_data.py from shared/data/afgl/{src}:",
            "levels re-ordered to ascending altitude, numbers unchanged",
            "columns: z_km p_hPa T_K n_air_cm-3 n_o3_cm-3 n_o2_cm-3 n_h2o_cm-3 n_co2_cm-3 n_no2_cm-3",
        ]
        body = ["  ".join(r) for r in data]
        write(f"atmospheres/afgl/{name}.txt", header, body)


def mixtures(shared):
    for name in MIXTURES:
        path = os.path.join(shared, "data", "opac", "mixtures", name + ".dat")
        names = None
        for c in comments(path):
            if c.lstrip("# ").startswith("z(km)"):
                names = c.lstrip("# ").split()[1:]
        if names is None:
            raise SystemExit(f"{path}: no '# z(km) ...' column line")
        data = sorted(rows(path), key=lambda r: float(r[0]))
        header = [
            f"atmosim OPAC aerosol mixture '{name}' (Hess et al. 1998, as defined in libRadtran)",
            f"source: shared/data/opac/mixtures/{name}.dat (libRadtran standard_aerosol_files)",
            "derived by scripts/derive_data.py: levels re-ordered to ascending altitude, numbers unchanged",
            "aerosol mass density in g m-3 (waso, suso: wet mass at 50 % RH); the row at altitude z",
            "applies to the layer from z up to the next listed altitude (libRadtran's rule)",
            "components: " + " ".join(names),
            "columns: z_km " + " ".join(names),
        ]
        body = ["  ".join(r) for r in data]
        write(f"atmospheres/opac/mixtures/{name}.txt", header, body)


def components(shared):
    for c in COMPONENTS:
        src = f"opac_{c}_optprop.txt"
        path = os.path.join(shared, "data", "opac", "optical_properties", src)
        data = sorted(rows(path), key=lambda r: (float(r[0]), float(r[1])))
        header = [
            f"atmosim OPAC component '{c}': optical properties per unit aerosol mass",
            f"source: shared/data/opac/optical_properties/{src}, computed with libRadtran's mie tool",
            "(MIEV0) from the OPAC log-normal size distributions and refractive indices (Hess et al. 1998)",
            "derived by scripts/derive_data.py: columns 1-5 of the source, numbers unchanged",
            "columns: wavelength_nm rh_pct ext_km-1_per_g_m-3 ssa g",
        ]
        body = ["  ".join(r[:5]) for r in data]
        write(f"atmospheres/opac/components/{c}.txt", header, body)


def refractive_and_sizes(shared):
    opac = os.path.join(shared, "data", "opac")
    cfg = rows(os.path.join(opac, "size_distr.cfg"))
    humidities = {}
    for r in cfg:
        humidities.setdefault(ALL_COMPONENTS[int(r[0]) - 1], []).append(r[1])
    # The numbering must match the refractive-index files present ...
    for c, rhs in humidities.items():
        for rh in rhs:
            f = os.path.join(opac, "refractive_indices", f"{c}{int(rh):02d}_refr.dat")
            if not os.path.isfile(f):
                raise SystemExit(f"size_distr.cfg names {c} at RH {rh} but {f} is missing")
    # ... and the densities the libRadtran optical-property tables list (rho column).
    for c in COMPONENTS:
        src = os.path.join(opac, "optical_properties", f"opac_{c}_optprop.txt")
        rho = {float(r[1]): float(r[5]) for r in rows(src)}
        for r in cfg:
            if ALL_COMPONENTS[int(r[0]) - 1] == c and float(r[1]) in rho:
                if abs(rho[float(r[1])] - float(r[5])) > 1e-9:
                    raise SystemExit(f"{c} RH {r[1]}: density {r[5]} in size_distr.cfg, {rho[float(r[1])]} in {src}")
    header = [
        "atmosim OPAC log-normal size distributions (Hess, Koepke and Schult 1998, as used by libRadtran)",
        "source: shared/data/opac/size_distr.cfg (libRadtran's OPAC mie-tool configuration)",
        "derived by scripts/derive_data.py: rows and numbers unchanged; the density column is in",
        "g cm-3 (the source's header says g/m**3, but the values, e.g. 2.0 for inso and 1.8 for dry",
        "waso, are the densities in g cm-3 that the libRadtran optical-property tables list)",
        "dN/dln r = N / (sqrt(2 pi) ln sigma) exp(-(ln r - ln r_mod)^2 / (2 ln^2 sigma)), r_min <= r <= r_max",
        "component numbers: " + " ".join(f"{i + 1}={c}" for i, c in enumerate(ALL_COMPONENTS)),
        "columns: component rh_pct r_min_um r_max_um r_mod_um rho_g_cm-3 sigma",
    ]
    write("atmospheres/opac/size_distributions.txt", header, ["  ".join(r) for r in cfg])
    for c, rhs in humidities.items():
        body = []
        for rh in rhs:
            src = f"{c}{int(rh):02d}_refr.dat"
            for r in rows(os.path.join(opac, "refractive_indices", src)):
                body.append("  ".join([r[0], rh, r[1], r[2]]))
        header = [
            f"atmosim OPAC refractive index of component '{c}' (Hess, Koepke and Schult 1998)",
            "source: shared/data/opac/refractive_indices/" + ", ".join(f"{c}{int(rh):02d}_refr.dat" for rh in rhs),
            "derived by scripts/derive_data.py: the files for each humidity joined, with the humidity",
            "(from the file name) as the second column; numbers unchanged. As in the source, n_im is",
            "negative for an absorbing medium (m = n_re + i n_im with time dependence e^(+i omega t));",
            "atmosim reads k = -n_im >= 0",
            "columns: wavelength_um rh_pct n_re n_im",
        ]
        write(f"atmospheres/opac/refractive/{c}.txt", header, body)


def ozone(shared):
    for name, src, t0, ref in [
        ("bogumil", "crs_O3_UBremen_cf.dat", "273.15",
         "Bogumil, Orphal and Burrows 2003 (IUP Bremen, SCIAMACHY flight model)"),
        ("molina", "crs_o3_mol_cf.dat", "273.13",
         "Molina and Molina 1986, JGR 91, 14501-14508 (Ackerman 1971 below 185 nm)"),
    ]:
        path = os.path.join(shared, "data", "ozone", src)
        data = rows(path)
        header = [
            f"atmosim ozone absorption cross section '{name}': {ref}",
            f"source: shared/data/ozone/{src} (libRadtran data file)",
            "derived by scripts/derive_data.py: numbers unchanged",
            "sigma(lambda, T) = (c0 + c1 (T - t0) + c2 (T - t0)^2) * 1e-20 cm^2, lambda in nm (air)",
            f"t0_K: {t0}",
            "columns: wavelength_nm c0 c1 c2",
        ]
        body = ["  ".join(r[:4]) for r in data]
        write(f"spectra/ozone_{name}.txt", header, body)


def solar(shared):
    path = os.path.join(shared, "data", "solar", "kurudz_1.0nm.dat")
    data = rows(path)
    header = [
        "atmosim extraterrestrial solar spectral irradiance: Kurucz 1992, 1 nm averages",
        "source: shared/data/solar/kurudz_1.0nm.dat (libRadtran, from LBLRTM 5.21)",
        "derived by scripts/derive_data.py: converted from mW m-2 nm-1 to W m-2 nm-1 (divided by 1000)",
        "columns: wavelength_nm irradiance_W_m-2_nm-1",
    ]
    body = [f"{r[0]}  {float(r[1]) / 1000.0:.6e}" for r in data]
    write("spectra/solar_kurucz_1nm.txt", header, body)


def libradtran(shared):
    vdir = os.path.join(shared, "validation", "libradtran")
    for case in ["A", "B"]:
        src = f"{case}_540nm_sza45_layers.txt"
        data = sorted(rows(os.path.join(vdir, src)), key=lambda r: float(r[0]))
        header = [
            f"libRadtran 2.0.3 (uvspec) per-layer optical depths, atmosphere {case}, 540 nm",
            "A: afglus + Bodhaine Rayleigh + Bogumil ozone; B: A + OPAC continental_average",
            f"source: shared/validation/libradtran/{src} (uvspec verbose output)",
            "derived by scripts/derive_data.py: layers re-ordered to ascending altitude",
            "columns: z_bot_km z_top_km dtau_rayleigh dtau_aer_sca dtau_aer_abs g_aer dtau_o3",
        ]
        write(f"validation/libradtran/{case}_540nm_layers.txt", header, ["  ".join(r) for r in data])
    src = "B_540nm_aerosol_layers_fullprec.txt"
    data = rows(os.path.join(vdir, src))
    header = [
        "libRadtran OPAC continental_average per-layer aerosol at 540 nm, full precision",
        f"source: shared/validation/libradtran/{src} (uvspec's layering rules)",
        "derived by scripts/derive_data.py: columns z_bot z_top RH and the mixture totals",
        "rh_pct is the layer humidity uvspec used; -1 where it reported none (nan)",
        "columns: z_bot_km z_top_km rh_pct dtau_ext dtau_sca ssa g",
    ]
    body = ["  ".join([r[0], r[1], "-1" if r[2] == "nan" else r[2]] + r[-4:]) for r in data]
    write("validation/libradtran/B_540nm_aerosol_fullprec.txt", header, body)
    header = [
        "libRadtran column optical depths for afglus (345.3 DU ozone), Bogumil ozone,",
        "Bodhaine Rayleigh and OPAC continental_average, top 120 km",
        "source: shared/data/README.md, 'How libRadtran turns these into layer optical depths'",
        "columns: wavelength_nm tau_rayleigh tau_o3 tau_aerosol_ext aerosol_ssa",
    ]
    body = [
        "420  0.294172  0.000343  0.168761  0.9060",
        "540  0.104640  0.027305  0.123695  0.8987",
        "620  0.059602  0.038213  0.102579  0.8926",
    ]
    write("validation/libradtran/columns.txt", header, body)


def main():
    shared = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(ROOT), "shared")
    if not os.path.isdir(os.path.join(shared, "data")):
        raise SystemExit(f"{shared}: no data/ folder (pass the shared folder as the argument)")
    afgl(shared)
    mixtures(shared)
    components(shared)
    refractive_and_sizes(shared)
    ozone(shared)
    solar(shared)
    libradtran(shared)


if __name__ == "__main__":
    main()
