#!/usr/bin/env python3
"""Convert the external validation references into atmosim's own text format.

Usage:  python3 scripts/derive_validation.py [SHARED_DIR]

SHARED_DIR defaults to ../shared relative to the repository root (the folder
that holds validation/ and CONVENTIONS.md). Only the standard library is used.

Every reference is converted INTO ATMOSIM'S CONVENTION (CONVENTIONS.md):

  * radiance per unit solar irradiance on a plane normal to the beam (E0 = 1,
    unit sr^-1), unscattered direct beam excluded;
  * viewing direction = the direction the sensor LOOKS: view zenith theta
    (0 = looking at the zenith, 180 = nadir) and relative azimuth phi
    (0 = looking toward the sun's azimuth, counter-clockwise seen from above);
  * Stokes (I, Q, U, V) in the meridian frame of the view direction:
    e1 = d v / d theta (in the meridian plane), e2 = (sin phi, -cos phi, 0),
    Q = I(e1) - I(e2), U = I((e1+e2)/sqrt2) - I((e1-e2)/sqrt2);
  * radiance leaving the TOP of a slab is seen by an observer at the top looking
    down (theta = 180 - acos(mu)); radiance leaving the BOTTOM by an observer at
    the bottom looking up (theta = acos(mu)).

No number is changed beyond the conversion stated in each output header (sign
flips, division by pi or by the beam normalisation, mu0 factors, angle
mapping). Unconverted numbers keep their original digits; converted numbers
are written as repr() of the double result.

Outputs (relative to the repository root):

  validation/published/natraj2009.txt
  validation/published/iprt_a1_depol{0.00,0.03,0.10}.txt, iprt_a2.txt,
      iprt_b1.txt, iprt_b2.txt, iprt_b_layers.txt
  validation/published/korkin_b2_single_scatter.txt
  validation/published/kokhanovsky2010.txt
  validation/published/disort_tests_radiance.txt, disort_tests_flux.txt
  validation/disort/pydisort.txt
  validation/libradtran/uvspec_540nm_sza45.txt
  validation/libradtran/H_540nm_aer_{tau,ssa,gg}.txt
  validation/published/mystic_twilight_620nm.txt
  validation/opac_mie/optprop.txt, validation/opac_mie/phase_<c>_<wl>nm_rh<rh>.txt

At the end the script runs self-checks (assertions) on what it wrote:
row counts, physics-based sign checks against an independent single-scattering
calculation done directly in atmosim's geometric convention, the IPRT A1
azimuth independence at sza 0, and Natraj 2009 versus IPRT A1.
"""

import csv
import math
import os
import sys
from decimal import Decimal

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPT = "scripts/derive_validation.py"

# What was written: rel path -> (number of data rows, short description)
WRITTEN = {}


# ---------------------------------------------------------------------------
# reading / writing helpers
# ---------------------------------------------------------------------------

def read_csv(path):
    """Return (comment lines without the newline, list of dict rows)."""
    comments = []
    body = []
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.startswith("#"):
                comments.append(line.rstrip("\n"))
            elif line.strip():
                body.append(line)
    rows = list(csv.DictReader(body))
    return comments, rows


def read_dat(path):
    """Whitespace table: (comment lines, list of token lists)."""
    comments = []
    rows = []
    with open(path, encoding="utf-8") as f:
        for line in f:
            s = line.strip()
            if not s:
                continue
            if s.startswith("#"):
                comments.append(line.rstrip("\n"))
            else:
                rows.append(s.split())
    return comments, rows


def num(x):
    """repr of a float, never '-0.0'."""
    x = float(x)
    if x == 0.0:
        return "0.0"
    return repr(x)


def keep(s):
    """Original digits of a source number (only '-0.0'-style zeros normalised)."""
    s = s.strip()
    float(s)  # must be numeric
    if s.startswith("-") and float(s) == 0.0:
        return s[1:]
    return s


def neg(s):
    """Sign flip of a source number, keeping its digits."""
    s = keep(s)
    if float(s) == 0.0:
        return s
    return s[1:] if s.startswith("-") else "-" + s


def dec_sub(a, b):
    """a - b in exact decimal arithmetic (keeps the source digits)."""
    return str(Decimal(a) - Decimal(b))


def acos_deg(mu):
    return math.degrees(math.acos(mu))


def write_table(rel, header, columns, rows, what):
    """Write '# ' header lines, '# columns: ...', then the rows; atomically."""
    path = os.path.join(ROOT, rel)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    for r in rows:
        assert len(r) == len(columns), (rel, r)
        for v in r:
            float(v)  # numeric only
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8", newline="\n") as f:
        for h in header:
            f.write(("# " + h).rstrip() + "\n")
        f.write("# rows: %d\n" % len(rows))
        f.write("# columns: " + " ".join(columns) + "\n")
        for r in rows:
            f.write(" ".join(r) + "\n")
    os.replace(tmp, path)
    WRITTEN[rel] = (len(rows), what)


def quote_source(comments):
    """The source's own '#' lines, quoted (they use the SOURCE's convention)."""
    out = ["", "Source header, quoted verbatim (it describes the SOURCE's own "
           "convention, not this file's):"]
    for c in comments:
        out.append("> " + c.lstrip("#").strip())
    return out


COMMON = [
    "units: radiance per unit solar irradiance on a plane normal to the beam "
    "(E0 = 1), sr^-1; unscattered direct beam excluded",
    "",
    "Convention (atmosim, CONVENTIONS.md): view_zenith_deg = zenith angle of the "
    "direction the sensor LOOKS (0 = zenith, 180 = nadir); azimuth_deg = relative "
    "azimuth of that direction from the sun's azimuth, counter-clockwise seen "
    "from above (0 = looking toward the sun's azimuth). Stokes vector in the "
    "meridian frame of the view direction: Q = I(e1) - I(e2), e1 = dv/dtheta in "
    "the meridian plane (Q > 0: E-vector in the meridian plane), "
    "U = I((e1+e2)/sqrt2) - I((e1-e2)/sqrt2), e2 = (sin phi, -cos phi, 0). At "
    "exact zenith/nadir the meridian plane is the one of azimuth_deg.",
]


# ---------------------------------------------------------------------------
# 1. Natraj 2009
# ---------------------------------------------------------------------------

def natraj(shared):
    src = "validation/published/natraj2009_rayleigh_IQU_all.csv"
    comments, rows = read_csv(os.path.join(shared, src))
    out = []
    for r in rows:
        mu = float(r["mu"])
        if r["direction"] == "UP":
            level = "1"
            theta = 180.0 - acos_deg(mu)
        elif r["direction"] == "DN":
            level = "0"
            theta = acos_deg(mu)
        else:
            raise ValueError(r["direction"])
        out.append([
            keep(r["tau"]), keep(r["albedo"]), keep(r["mu0"]), level,
            num(theta), keep(r["phi_deg"]),
            num(float(r["I"]) / math.pi),
            num(-float(r["Q"]) / math.pi),
            num(float(r["U"]) / math.pi),
        ])
    header = [
        "Natraj, Li & Yung (2009) ApJ 691:1909: corrected Coulson-Dave-Sekera "
        "tables, homogeneous conservative Rayleigh slab (no depolarisation) over "
        "a Lambert ground, diffuse I, Q, U leaving the top and the bottom.",
        "source_file: shared/%s" % src,
        "upstream: CDS archive web.gps.caltech.edu/~vijay/Rayleigh_Scattering_Tables/"
        "CDS/CDS.tar.gz, via github RemoteSensingTools/vSmartMOM.jl commit "
        "d6051b7ba4b4727fee7c4ec720c23b6aa95e677a test/benchmarks/natraj_cds/CDS/",
        "derived by %s" % SCRIPT,
        "conversion: I = I_natraj/pi, Q = -Q_natraj/pi, U = +U_natraj/pi "
        "(tables are for incident flux pi normal to the beam; natraj Q = I_ph - I_th "
        "is the opposite of atmosim's, natraj U and basis e_th = e1, e_ph = e2 are "
        "atmosim's); level 1 = top (UP: radiance leaving the top, observer at the "
        "top looking down, view_zenith_deg = 180 - acos(mu)), level 0 = bottom "
        "(DN: radiance leaving the bottom, observer at the ground looking up, "
        "view_zenith_deg = acos(mu)); azimuth_deg = table phi (phi = 0: observer "
        "looks toward the sun's azimuth; natraj's frame is atmosim's rotated by "
        "180 deg about the vertical, same handedness).",
        "geometry: plane_parallel",
        "phase: rayleigh",
        "depolarization: 0",
        "single_scattering_albedo: 1",
        "absorption: 0",
        "surface: lambert (albedo column)",
        "level_code: 1 = top, 0 = bottom",
        "accuracy: 8 decimals in natraj units, absolute ~1e-8 (~3.2e-9 here after /pi); "
        "exact (deterministic) reference",
    ] + COMMON + quote_source(comments)
    cols = "tau albedo mu0 level view_zenith_deg azimuth_deg I Q U".split()
    write_table("validation/published/natraj2009.txt", header, cols, out,
                "Natraj 2009 Rayleigh slab I, Q, U")
    return rows, out


# ---------------------------------------------------------------------------
# 2. IPRT phase A (MYSTIC)
# ---------------------------------------------------------------------------

IPRT_CONV = (
    "conversion: none for the numbers (IPRT/MYSTIC already use atmosim's "
    "normalisation E0 = 1 and Stokes frame: Q = I_l - I_r with l in the meridian "
    "plane, U as atmosim); view_zenith_deg = va (line of sight zenith angle; "
    "'-0.0' written as 0.0); azimuth_deg = rel_az = (phi - saa) mod 360 "
    "(0 = looking toward the sun's azimuth; the header says rel_az = natraj 'phi' "
    "= atmosim phi, and the sign of U against an independent single-scattering "
    "calculation in atmosim's counter-clockwise convention confirms it, see the "
    "self-checks of the script); I_se..V_se = MYSTIC's Istd..Vstd, the standard "
    "deviation of the estimate (their spread over phi at sza 0 matches them). "
    "Rows where the source has phi = 0 and phi = 360 both map to the same "
    "azimuth_deg and are kept as separate estimates.")

IPRT_COLS = ("zout_km view_zenith_deg azimuth_deg I Q U V "
             "I_se Q_se U_se V_se").split()


def iprt_rows(rows):
    out = []
    for r in rows:
        va = float(r["va"])
        mu = float(r["mu"])
        # consistency of the source's own columns
        assert abs(abs(math.cos(math.radians(va))) - mu) < 2e-6, r
        assert (r["direction"] == "DN") == (va < 90.0), r
        assert int(r["rel_az"]) == int(round(float(r["phi"]) - float(r["saa"]))) % 360, r
        out.append([
            keep(r["zout_km"]), keep(r["va"]), keep(r["rel_az"]),
            keep(r["I"]), keep(r["Q"]), keep(r["U"]), keep(r["V"]),
            keep(r["Istd"]), keep(r["Qstd"]), keep(r["Ustd"]), keep(r["Vstd"]),
        ])
    return out


def iprt_common_header(src, case_text, comments):
    return [
        case_text,
        "source_file: shared/%s" % src,
        "upstream: IPRT phase A (www.meteo.physik.uni-muenchen.de/~iprt ; Emde et "
        "al. 2015 JQSRT 164:8-36), model MYSTIC, copied from github hygeos/smartg "
        "commit 1e3eb694f37e0f1efa06a9ef3db2a1535b1d5246 tests/IPRT_data/phaseA/",
        "derived by %s" % SCRIPT,
        IPRT_CONV,
    ]


def iprt(shared):
    results = {}
    # --- A1, split by depolarisation
    src = "validation/published/iprt_phaseA_a1_mystic.csv"
    comments, rows = read_csv(os.path.join(shared, src))
    total = 0
    for depol in ("0.00", "0.03", "0.10"):
        sub = [r for r in rows if r["depol"] == depol]
        szas = {r["sza"] for r in sub}
        saas = {r["saa"] for r in sub}
        assert len(szas) == 1 and len(saas) == 1
        sza, saa = szas.pop(), saas.pop()
        out = iprt_rows(sub)
        header = iprt_common_header(
            src, "IPRT case A1 (sub-case depolarisation %s): one homogeneous "
            "Rayleigh layer 0-1 km, optical thickness 0.5, no absorption, black "
            "surface; observers at zout 0 km (bottom, looking up) and 1 km (top, "
            "looking down)." % depol, comments) + [
            "geometry: plane_parallel",
            "phase: rayleigh",
            "depolarization: %s" % depol,
            "tau: 0.5",
            "layer_bottom_km: 0",
            "layer_top_km: 1",
            "absorption: 0",
            "albedo: 0",
            "sza_deg: %s" % keep(sza),
            "saa_deg: %s" % keep(saa),
            "uncertainty: Monte Carlo, standard errors in I_se Q_se U_se V_se",
        ] + COMMON + quote_source(comments)
        rel = "validation/published/iprt_a1_depol%s.txt" % depol
        write_table(rel, header, IPRT_COLS, out,
                    "IPRT A1 depol %s (MYSTIC)" % depol)
        results["a1_" + depol] = (sub, out)
        total += len(out)
    assert total == len(rows)

    # --- A2
    src = "validation/published/iprt_phaseA_a2_mystic.csv"
    comments, rows = read_csv(os.path.join(shared, src))
    out = iprt_rows(rows)
    header = iprt_common_header(
        src, "IPRT case A2: homogeneous Rayleigh layer 0-1 km, optical thickness "
        "0.1, depolarisation 0.03, Lambertian surface albedo 0.3, sza 50.",
        comments) + [
        "geometry: plane_parallel",
        "phase: rayleigh",
        "depolarization: 0.03",
        "tau: 0.1",
        "layer_bottom_km: 0",
        "layer_top_km: 1",
        "absorption: 0",
        "albedo: 0.3",
        "surface: lambert",
        "sza_deg: 50",
        "saa_deg: 0",
        "uncertainty: Monte Carlo, standard errors in I_se Q_se U_se V_se",
    ] + COMMON + quote_source(comments)
    write_table("validation/published/iprt_a2.txt", header, IPRT_COLS, out,
                "IPRT A2 (MYSTIC)")
    results["a2"] = (rows, out)

    # --- B1
    src = "validation/published/iprt_phaseA_b1_mystic.csv"
    comments, rows = read_csv(os.path.join(shared, src))
    out = iprt_rows(rows)
    header = iprt_common_header(
        src, "IPRT case B1: 30 layers of 1 km (0-30 km), Rayleigh at 450 nm "
        "(layer optical thicknesses: column dtau_ray_450 of iprt_b_layers.txt), "
        "no absorption, depolarisation 0.03, black surface, sza 60; outputs at "
        "zout 0, 1 and 30 km (30 km = TOA).", comments) + [
        "geometry: plane_parallel",
        "phase: rayleigh",
        "depolarization: 0.03",
        "wavelength_nm: 450",
        "layers: iprt_b_layers.txt dtau_ray_450",
        "absorption: 0",
        "top_km: 30",
        "albedo: 0",
        "sza_deg: 60",
        "saa_deg: 0",
        "uncertainty: Monte Carlo, standard errors in I_se Q_se U_se V_se",
    ] + COMMON + quote_source(comments)
    write_table("validation/published/iprt_b1.txt", header, IPRT_COLS, out,
                "IPRT B1 (MYSTIC)")
    results["b1"] = (rows, out)

    # --- B2
    src = "validation/published/iprt_phaseA_b2_mystic.csv"
    comments, rows = read_csv(os.path.join(shared, src))
    assert {r["depol"] for r in rows} == {"0.00"}
    out = iprt_rows(rows)
    header = iprt_common_header(
        src, "IPRT case B2: 30 layers of 1 km (0-30 km), Rayleigh at 325 nm "
        "(dtau_ray_325) + ozone absorption (dtau_abs_325) of iprt_b_layers.txt, "
        "black surface, sza 60; outputs at zout 0, 1 and 30 km (30 km = TOA).",
        comments) + [
        "CAVEAT (from the source header): the MYSTIC file labels depolarisation "
        "0.00 although the IPRT case definition uses 0.03 (SMART-G notebook: "
        "'mistake in MYSTIC depol'); treat the depolarisation of this reference "
        "as uncertain (0 or 0.03). No single 'depolarization' key is given on "
        "purpose.",
        "geometry: plane_parallel",
        "phase: rayleigh",
        "depolarization_file_label: 0.00",
        "depolarization_case_definition: 0.03",
        "wavelength_nm: 325",
        "layers: iprt_b_layers.txt dtau_ray_325 (scattering) + dtau_abs_325 (absorption)",
        "top_km: 30",
        "albedo: 0",
        "sza_deg: 60",
        "saa_deg: 0",
        "uncertainty: Monte Carlo, standard errors in I_se Q_se U_se V_se",
    ] + COMMON + quote_source(comments)
    write_table("validation/published/iprt_b2.txt", header, IPRT_COLS, out,
                "IPRT B2 (MYSTIC), depolarisation uncertain")
    results["b2"] = (rows, out)

    # --- B layer profiles
    src = "validation/published/iprt_phaseA_B_layer_profiles.csv"
    comments, rows = read_csv(os.path.join(shared, src))
    names = ["dtau_ray_450", "dtau_ray_325", "dtau_abs_325", "dtau_ray_350",
             "dtau_abs_350", "dtau_aer_350", "dtau_ray_800"]
    out = []
    for r in rows:
        assert float(r["z_top_km"]) - float(r["z_bottom_km"]) == 1.0
        out.append([keep(r["z_bottom_km"]), keep(r["z_top_km"])] +
                   [keep(r[n]) for n in names])
    # column sums stated in the source header
    sums = {}
    for c in comments:
        if "Column sums:" in c:
            for part in c.split("Column sums:")[1].split(","):
                k, v = part.strip().split("=")
                sums[k] = v
    assert set(sums) == set(names), sums
    for n in names:
        s = sum(float(r[n]) for r in rows)
        assert abs(s - float(sums[n])) <= 1e-5, (n, s, sums[n])
    header = [
        "IPRT phase A case B layer optical thicknesses (homogeneous 1 km layers "
        "0-30 km) for B1 (dtau_ray_450) and B2 (dtau_ray_325 + dtau_abs_325); the "
        "350 and 800 nm columns belong to the other B cases.",
        "source_file: shared/%s" % src,
        "upstream: IPRT files tau_*.dat, github hygeos/smartg commit "
        "1e3eb694f37e0f1efa06a9ef3db2a1535b1d5246 tests/IPRT_data/phaseA/",
        "derived by %s" % SCRIPT,
        "conversion: none (columns renamed z_bottom_km -> bottom_km, z_top_km -> "
        "top_km; the raw files' 30 km row (= 0) was already dropped in the source); "
        "row with bottom_km = z is the layer [z, z + 1 km]",
        "accuracy: exact model inputs",
    ] + ["column_sum_%s: %s" % (n, sums[n]) for n in names] + quote_source(comments)
    cols = ["bottom_km", "top_km"] + names
    write_table("validation/published/iprt_b_layers.txt", header, cols, out,
                "IPRT B layer optical thicknesses")
    results["layers"] = rows
    return results


# ---------------------------------------------------------------------------
# 4. Korkin single scattering (IPRT B2 atmosphere)
# ---------------------------------------------------------------------------

def korkin(shared):
    src = "validation/published/korkin_iprtB2_single_scatter_TOA.csv"
    comments, rows = read_csv(os.path.join(shared, src))
    out = []
    for r in rows:
        mu = float(r["mu_view"])
        assert abs(math.cos(math.radians(float(r["vza"]))) - mu) < 1e-4, r
        out.append([
            keep(r["sza"]), dec_sub("180", keep(r["vza"])), keep(r["rel_az"]),
            keep(r["I"]), keep(r["Q"]), neg(r["U"]), keep(r["V"]),
        ])
    header = [
        "Single-scattering-ONLY Stokes vector reflected at the top (30 km) of the "
        "IPRT B2 atmosphere: 325 nm Rayleigh (dtau_ray_325) + ozone absorption "
        "(dtau_abs_325) of iprt_b_layers.txt, depolarisation 0.03, black surface.",
        "source_file: shared/%s" % src,
        "upstream: github korkins/SphericalShell_GasAbsorption commit "
        "faf862dd18c52ca53a7bc06a70a05518390ef065 SS_IQUV.txt (used by "
        "TEST_SGLSCAT_TOA_PS.f90 'test VS IPRT B2 - SS only')",
        "derived by %s" % SCRIPT,
        "conversion: I, Q unchanged (E0 = 1; Q = I_th - I_ph = atmosim's Q); "
        "U = -U_source (source uses the Hovenier/IPOL sign, opposite to natraj2009 "
        "and to atmosim); V unchanged (all 0); view_zenith_deg = 180 - vza "
        "(observer at the top looking down); azimuth_deg = rel_az (0 = looking "
        "toward the sun's azimuth); mu_view column dropped (= cos vza, 4 digits). "
        "Verified by this script: an independent single-scattering sum over the 30 "
        "layers in atmosim's convention reproduces I, Q, U to <= 2e-5 of I.",
        "geometry: plane_parallel",
        "phase: rayleigh",
        "depolarization: 0.03",
        "wavelength_nm: 325",
        "layers: iprt_b_layers.txt dtau_ray_325 (scattering) + dtau_abs_325 (absorption)",
        "top_km: 30",
        "level: top",
        "altitude_km: 30",
        "albedo: 0",
        "scattering_orders: 1",
        "accuracy: exact single scattering, 6 significant digits (source: "
        "reproduced independently to 5e-6 relative in I, 1e-6 in |U|)",
    ] + COMMON + quote_source(comments)
    cols = "sza_deg view_zenith_deg azimuth_deg I Q U V".split()
    write_table("validation/published/korkin_b2_single_scatter.txt", header,
                cols, out, "single scattering for IPRT B2 (Korkin)")
    return rows, out


# ---------------------------------------------------------------------------
# 5. Kokhanovsky 2010
# ---------------------------------------------------------------------------

KOKH_MU0 = 0.5


def kokhanovsky(shared):
    src = "validation/published/kokhanovsky2010_rayleigh_reflection.csv"
    comments, rows = read_csv(os.path.join(shared, src))
    c = KOKH_MU0 / math.pi
    out = []
    for r in rows:
        out.append([
            dec_sub("180", keep(r["vza_deg"])), keep(r["phi_deg"]),
            num(float(r["R_I"]) * c), num(-float(r["R_Q"]) * c),
            num(float(r["R_U"]) * c), num(float(r["R_V"]) * c),
        ])
    header = [
        "Kokhanovsky et al. 2010 JQSRT 111:1931 Rayleigh benchmark: pure Rayleigh "
        "layer tau 0.3262, no depolarisation, conservative, black ground, sza 60, "
        "412 nm; Stokes vector reflected at the top (observer at the top looking "
        "down).",
        "source_file: shared/%s" % src,
        "upstream: github hygeos/smartg commit 8841f7a3e418f78ddba99822117e6668be505458 "
        "smartg/validation/Rayleigh_refl_N_60.dat (Ramon et al. 2019 JQSRT 222:89 "
        "validation set)",
        "derived by %s" % SCRIPT,
        "conversion: the source gives the reflection function R = pi*L/(mu0*F0); "
        "radiance per E0 = 1 is L = R*mu0/pi with mu0 = cos 60 deg = 0.5: "
        "I = R_I*0.5/pi, Q = -R_Q*0.5/pi (source Q has the natraj2009 sign, "
        "Q > 0 for E perpendicular to the meridian plane), U = +R_U*0.5/pi "
        "(natraj2009 U sign = atmosim's), V = +R_V*0.5/pi (numerical noise "
        "~1e-17; no source states a V sign convention); view_zenith_deg = "
        "180 - vza; azimuth_deg = phi (0 = looking toward the sun's azimuth). "
        "Source gives phi = 0, 90, 180 only; U(360 - phi) = -U(phi).",
        "geometry: plane_parallel",
        "phase: rayleigh",
        "depolarization: 0",
        "tau: 0.3262",
        "single_scattering_albedo: 1",
        "absorption: 0",
        "albedo: 0",
        "sza_deg: 60",
        "mu0: 0.5",
        "wavelength_nm: 412",
        "level: top",
        "accuracy: 7 significant digits (shared/validation/README.md); source "
        "header: agrees with natraj2009 interpolated to tau 0.3262, mu0 0.5 to ~0.2%",
    ] + COMMON + quote_source(comments)
    cols = "view_zenith_deg azimuth_deg I Q U V".split()
    write_table("validation/published/kokhanovsky2010.txt", header, cols, out,
                "Kokhanovsky 2010 Rayleigh reflection")
    return rows, out


# ---------------------------------------------------------------------------
# 6. DISORT test problems 1-3
# ---------------------------------------------------------------------------

DISORT_PHASE = {"01": "isotropic", "02": "rayleigh_scalar", "03": "henyey_greenstein"}


def disort_common(r):
    """Shared columns and the normaliser (divisor, source code)."""
    assert DISORT_PHASE[r["test"]] == r["phase"], r
    fbeam = float(r["fbeam"])
    fisot = float(r["fisot"])
    if fbeam != 0.0:
        assert fisot == 0.0
        div, source = fbeam, "0"
    else:
        assert fisot != 0.0
        div, source = fisot, "1"
    level = r["level"]
    if level.startswith("top"):
        lev = "1"
        assert level == "top(tau=0)"
    else:
        lev = "0"
        assert level.startswith("bottom(tau=")
        assert float(level[len("bottom(tau="):-1]) == float(r["tau"])
    g = keep(r["g"]) if r["g"].strip() else "0"
    cols = [str(int(r["test"])), str(ord(r["case"]) - ord("a")), g,
            keep(r["tau"]), keep(r["ssa"]), keep(r["umu0"]),
            keep(r["ground_albedo"]), lev]
    return cols, div, source


def disort_header_common(src, comments):
    return [
        "DISORT test problems 1-3 (scalar, no polarisation): single homogeneous "
        "plane-parallel layer, black ground; test 1 = isotropic phase function "
        "(VH1 Table 12, van de Hulst 1980), test 2 = scalar Rayleigh (3/4)(1+cos^2) "
        "without polarisation (SW Table 1, Sweigart 1970 ApJS 22,1), test 3 = "
        "Henyey-Greenstein g = 0.75 (VH2 Table 37, van de Hulst 1980; DISORT uses 32 "
        "Legendre moments + intensity correction).",
        "source_file: shared/%s" % src,
        "upstream: libRadtran libsrc_c/disotest.c (github ashiklom/libradtran "
        "commit 208f5465d6edbbdcef9ad36540316958b0f5d00e), 'correct answers' = "
        "DISORT 16-stream results reproducing the published tables",
        "derived by %s" % SCRIPT,
        "test: 1 = isotropic, 2 = rayleigh_scalar, 3 = henyey_greenstein "
        "(phase function set by the test number)",
        "case_index: 0 = case a, 1 = b, 2 = c, ... (per test)",
        "g: asymmetry parameter; 0 where the source leaves it empty (tests 1 and 2: "
        "isotropic and scalar Rayleigh both have g = 0; the phase function is the "
        "one of the test, NOT Henyey-Greenstein)",
        "mu0: the source's umu0 (cosine of the solar zenith angle); meaningless for "
        "source = 1 rows",
        "level_code: 1 = top (tau = 0), 0 = bottom (tau = tau)",
        "source_code: 0 = collimated beam (fbeam > 0, fisot = 0), 1 = isotropic "
        "illumination at the top (fbeam = 0, fisot = 1)",
        "normalisation source 0: per unit beam irradiance on a plane NORMAL to the "
        "beam (fbeam; DISORT's fbeam is the flux normal to the beam, horizontal "
        "incident flux = fbeam*umu0): divided by fbeam (10*pi for test 1, pi for "
        "tests 2 and 3) = atmosim's E0 = 1",
        "normalisation source 1: per unit incident isotropic radiance fisot at the "
        "top (incident downward flux pi*fisot): divided by fisot (= 1: values "
        "unchanged); NOT an E0 = 1 normalisation",
        "geometry: plane_parallel",
        "albedo: 0",
        "accuracy: 6 significant digits (DISORT 16 streams reproducing the cited "
        "tables); exact (deterministic) reference",
    ]


def disort_tests(shared):
    src = "validation/published/disort_scalar_tests_1to3_radiance.csv"
    comments, rows = read_csv(os.path.join(shared, src))
    out = []
    for r in rows:
        cols, div, source = disort_common(r)
        umu = float(r["umu"])
        # umu = cosine of the PROPAGATION direction; the sensor looks along -k,
        # so cos(view zenith) = -umu.
        theta = acos_deg(-umu)
        assert float(r["phi_deg"]) == 0.0
        out.append(cols + [num(theta), keep(r["phi_deg"]),
                           num(float(r["I"]) / div), source])
    header = [h for h in disort_header_common(src, comments)] + [
        "conversion (radiance): I = I_source/fbeam (source 0) or I_source/fisot "
        "(source 1); view_zenith_deg = acos(-umu) in degrees (umu is the cosine of "
        "the PROPAGATION direction: umu > 0 upward-travelling = reflected, seen at "
        "the top looking down, view_zenith_deg > 90; umu < 0 downward-travelling = "
        "transmitted, seen at the bottom looking up, view_zenith_deg < 90); "
        "azimuth_deg = DISORT's phi (azimuth between the propagation directions of "
        "the emergent and the incident beam; 0 = the sensor looks toward the sun's "
        "azimuth; all rows have phi = 0). The rows at the top with view_zenith_deg "
        "< 90 are the incident boundary values (0, or fisot/fisot = 1) and those at "
        "the bottom with view_zenith_deg > 90 are 0 (black ground): kept as in the "
        "source. Direct beam excluded. The reference column (citation) is dropped: "
        "it is fixed by the test number.",
    ] + COMMON + quote_source(comments)
    cols = ("test case_index g tau ssa mu0 albedo level view_zenith_deg "
            "azimuth_deg I source").split()
    write_table("validation/published/disort_tests_radiance.txt", header, cols,
                out, "DISORT tests 1-3 radiances")
    rad = (rows, out)

    src = "validation/published/disort_scalar_tests_1to3_fluxes.csv"
    comments, rows = read_csv(os.path.join(shared, src))
    out = []
    for r in rows:
        cols, div, source = disort_common(r)
        out.append(cols + [num(float(r[k]) / div)
                           for k in ("rfldir", "rfldn", "flup", "dfdt")] + [source])
    header = [h for h in disort_header_common(src, comments)] + [
        "conversion (fluxes): rfldir, rfldn, flup, dfdt divided by fbeam (source 0) "
        "or by fisot (source 1); the fluxes are per unit HORIZONTAL area.",
        "flux_columns_meaning: rfldir = direct-beam flux through a horizontal surface (so "
        "rfldir at the top = mu0 for source 0); rfldn = diffuse downward flux; "
        "flup = diffuse upward flux; dfdt = flux divergence d(net flux)/d(tau); "
        "the reference column (citation) is dropped.",
    ] + quote_source(comments)
    cols = ("test case_index g tau ssa mu0 albedo level rfldir rfldn flup dfdt "
            "source").split()
    write_table("validation/published/disort_tests_flux.txt", header, cols, out,
                "DISORT tests 1-3 fluxes")
    return rad, (rows, out)


# ---------------------------------------------------------------------------
# 7. pydisort
# ---------------------------------------------------------------------------

PYDISORT_CASES = {"rayleigh": "0", "two_layer_R_over_HG": "1", "mixed_R_HG": "2"}


def pydisort(shared):
    src = "validation/disort/pydisort_scalar_radiance.csv"
    comments, rows = read_csv(os.path.join(shared, src))
    out = []
    for r in rows:
        assert r["nstr"] == "128"
        mu_view = float(r["mu_view"])
        assert abs(math.cos(math.radians(float(r["vza_deg"]))) - mu_view) < 1e-7
        assert abs(math.cos(math.radians(float(r["sza_deg"]))) - float(r["mu0"])) < 1e-7
        if r["level"] == "TOA_up":
            level, theta = "1", dec_sub("180", keep(r["vza_deg"]))
        elif r["level"] == "BOA_down":
            level, theta = "0", keep(r["vza_deg"])
        else:
            raise ValueError(r["level"])
        ssa = keep(r["ssa_aer"]) if r["ssa_aer"].strip() else "0"
        g = keep(r["g"]) if r["g"].strip() else "0"
        if not r["ssa_aer"].strip():
            assert float(r["tau_aer"]) == 0.0
        out.append([PYDISORT_CASES[r["case"]], keep(r["tau_R"]),
                    keep(r["tau_aer"]), ssa, g, keep(r["albedo"]),
                    keep(r["sza_deg"]), level, theta, keep(r["raa_deg"]),
                    keep(r["L_over_Eperp"])])
    header = [
        "pydisort 1.8.13 (DISORT 2.1.3, 128 streams, Nakajima-Tanaka intensity "
        "correction), plane-parallel SCALAR radiances (no polarisation).",
        "source_file: shared/%s" % src,
        "derived by %s" % SCRIPT,
        "case_id: 0 = rayleigh (one conservative scalar-Rayleigh layer, phase "
        "3/4(1+cos^2), no depolarisation, optical depth tau_R); 1 = "
        "two_layer_R_over_HG (TWO layers: the Rayleigh layer tau_R on TOP, above "
        "the aerosol layer tau_aer, single-scattering albedo ssa_aer, "
        "Henyey-Greenstein asymmetry g; i.e. Rayleigh above the aerosol, the "
        "aerosol layer touches the ground); 2 = mixed_R_HG (ONE layer holding "
        "both: optical depth tau_R + tau_aer).",
        "layers: only optical depths are given (tau_R, tau_aer); the source gives "
        "no geometric thicknesses (plane-parallel: irrelevant).",
        "ssa_aer, g: 0 where the source leaves them empty (case_id 0, tau_aer = 0, "
        "no aerosol).",
        "conversion: I = L_over_Eperp unchanged (already E0 = 1, 1/sr, direct beam "
        "excluded); level 0 = bottom (BOA_down: diffuse radiance reaching the "
        "ground, observer at the ground looking up, view_zenith_deg = vza_deg); "
        "level 1 = top (TOA_up: radiance leaving the top, observer looking down, "
        "vza_deg is the nadir angle there, view_zenith_deg = 180 - vza_deg); "
        "azimuth_deg = raa_deg (0 = looking toward the sun's azimuth); dropped "
        "columns: mu0 (= cos sza_deg), nstr (= 128), mu_view (= cos vza_deg), "
        "I_natraj_norm (= pi * L_over_Eperp, checked).",
        "geometry: plane_parallel",
        "streams: 128",
        "surface: lambert (albedo column)",
        "level_code: 1 = top, 0 = bottom",
        "accuracy: 32 and 128 streams agree to 5e-6 relative (source header); "
        "8 significant digits; exact (deterministic) reference",
    ] + COMMON + quote_source(comments)
    cols = ("case_id tau_R tau_aer ssa_aer g albedo sza_deg level "
            "view_zenith_deg azimuth_deg I").split()
    write_table("validation/disort/pydisort.txt", header, cols, out,
                "pydisort scalar radiances")
    return rows, out


# ---------------------------------------------------------------------------
# 8. libRadtran uvspec
# ---------------------------------------------------------------------------

UVSPEC_ATM = {"A": "0", "B": "1", "H": "2"}
UVSPEC_SOLVER = {"disort_pp": "0", "disort_ps": "1", "polrad": "2"}


def uvspec(shared):
    src = "validation/libradtran/uvspec_540nm_sza45.csv"
    comments, rows = read_csv(os.path.join(shared, src))
    out = []
    for r in rows:
        assert r["wavelength_nm"] == "540.0" and r["sun_zenith_deg"] == "45.0"
        pol = r["solver"] == "polrad"
        if pol:
            q, u = keep(r["Q"]), keep(r["U"])
        else:
            assert r["Q"] == "" and r["U"] == ""
            q, u = "0", "0"
        out.append([UVSPEC_ATM[r["atmosphere"]], UVSPEC_SOLVER[r["solver"]],
                    keep(r["observer_km"]), keep(r["view_zenith_deg"]),
                    keep(r["azimuth_deg"]), keep(r["I"]), q, u,
                    "1" if pol else "0"])
    header = [
        "libRadtran 2.0.3 uvspec reference runs: afglus profile, Bodhaine Rayleigh "
        "with depolarisation (rho = 0.02837 at 540 nm), Bogumil ozone (the only "
        "absorber), Lambertian albedo 0.2, 540 nm, sun zenith 45, observers at 0 "
        "and 10 km; diffuse radiance only (no direct sun).",
        "source_file: shared/%s (described in shared/validation/README.md)" % src,
        "derived by %s" % SCRIPT,
        "atmosphere: 0 = A (gases only), 1 = B (A + OPAC continental_average, full "
        "Mie phase functions), 2 = H (B with each layer's aerosol replaced by "
        "Henyey-Greenstein of the same tau, ssa, g: H_540nm_aer_{tau,ssa,gg}.txt)",
        "solver: 0 = disort_pp (scalar DISORT, plane-parallel, 32 streams), 1 = "
        "disort_ps (scalar DISORT, pseudo-spherical, 32 streams), 2 = polrad "
        "(polRadtran, vector, plane-parallel, 16 streams: I, Q, U)",
        "polarized: 1 = polrad row (Q, U computed), 0 = scalar DISORT row (the "
        "source's Q, U are empty; written as 0, NOT a computed zero)",
        "conversion: none for the numbers (the source states it is already in "
        "atmosim's convention: E0 = 1, view_zenith_deg 0 = zenith, azimuth_deg "
        "0 = looking toward the sun's azimuth; checked here: polrad Q, U signs "
        "agree with an independent single-scattering calculation in atmosim's "
        "convention); codes for atmosphere and solver as above; empty Q, U -> 0 "
        "with polarized = 0; dropped columns wavelength_nm (540.0), "
        "sun_zenith_deg (45.0).",
        "wavelength_nm: 540",
        "sza_deg: 45",
        "albedo: 0.2",
        "surface: lambert",
        "depolarization: 0.02837",
        "profile: afglus (US standard), top 120 km",
        "accuracy: deterministic solvers, 7 significant digits; known limits of "
        "the reference (shared/validation/README.md): polrad intensity for aerosol "
        "cases is poor near the sun (forward peak truncated: -80 % looking at the "
        "sun); pseudo-spherical DISORT treats only the direct beam spherically; B "
        "(Mie) and H (HG) differ by up to x6 looking at the sun and <= 12 % "
        "elsewhere; polarisation changes I by 2-8 % (polrad vs disort) in the "
        "gas-only case: compare polarised runs with solver 2, scalar runs with "
        "solvers 0/1.",
    ] + COMMON + quote_source(comments)
    cols = ("atmosphere solver observer_km view_zenith_deg azimuth_deg I Q U "
            "polarized").split()
    write_table("validation/libradtran/uvspec_540nm_sza45.txt", header, cols,
                out, "libRadtran uvspec 540 nm runs (A, B, H)")

    h = {}
    for q, what in (("tau", "extinction optical depth of the layer"),
                    ("ssa", "single-scattering albedo of the layer"),
                    ("gg", "asymmetry parameter g of the layer "
                           "(-> Henyey-Greenstein phase function)")):
        srcq = "validation/libradtran/H_540nm_aer_%s.dat" % q
        comments_q, rows_q = read_dat(os.path.join(shared, srcq))
        outq = []
        for t in rows_q:
            assert len(t) == 2
            outq.append([keep(t[0]), keep(t[1])])
        header = [
            "Aerosol of libRadtran atmosphere H at 540 nm: %s (uvspec "
            "'aerosol_file %s' layer file; OPAC continental_average as used by "
            "uvspec in case B, 12-35 km layer split per afglus layer)." % (what, q),
            "source_file: shared/%s" % srcq,
            "derived by %s" % SCRIPT,
            "conversion: none (copied; order kept: altitudes DESCENDING as in the "
            "uvspec file)",
            "meaning: the value on the line of altitude z_km belongs to the layer "
            "[z_km, next higher z_km]; the 120 km line only closes the grid "
            "(its value is not used)",
            "quantity: %s" % {"tau": "aerosol_tau_ext", "ssa": "aerosol_ssa",
                              "gg": "aerosol_g"}[q],
            "wavelength_nm: 540",
            "accuracy: as printed by the source (%s)" % (
                "10 significant digits" if q == "tau" else
                "9 decimals" if q == "ssa" else "6 decimals"),
        ] + quote_source(comments_q)
        rel = "validation/libradtran/H_540nm_aer_%s.txt" % q
        write_table(rel, header, ["z_km", "value"], outq,
                    "libRadtran case H aerosol %s per layer" % q)
        h[q] = (rows_q, outq)
    return (rows, out), h


# ---------------------------------------------------------------------------
# Independent single scattering in atmosim's convention (for the self-checks)
# ---------------------------------------------------------------------------

def ss_stokes(layers, sza, theta, phi, depol, tau_obs):
    """Single-scattered (I, Q, U), E0 = 1, plane-parallel, black ground.

    layers: [(dtau_sca, dtau_ext)] from the TOP down; observer at optical depth
    tau_obs (from the top), looking along view zenith theta, azimuth phi (deg).
    Built from vectors only: sun s = (sin sza, 0, cos sza) (x toward the sun's
    azimuth), v = (sin t cos p, sin t sin p, cos t), k = -v, e1 = dv/dtheta,
    e2 = (sin p, -cos p, 0). The scattered light is partially polarised with the
    polarised part -P12 along n = k0 x k (perpendicular to the scattering plane).
    """
    d2r = math.pi / 180.0
    s = (math.sin(sza * d2r), 0.0, math.cos(sza * d2r))
    mu0 = s[2]
    th, ph = theta * d2r, phi * d2r
    v = (math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th))
    e1 = (math.cos(th) * math.cos(ph), math.cos(th) * math.sin(ph), -math.sin(th))
    e2 = (math.sin(ph), -math.cos(ph), 0.0)
    k = tuple(-x for x in v)
    k0 = tuple(-x for x in s)
    c = sum(a * b for a, b in zip(k0, k))
    d = (1.0 - depol) / (1.0 + depol / 2.0)
    p11 = d * 0.75 * (1.0 + c * c) + (1.0 - d)
    p12 = -d * 0.75 * (1.0 - c * c)
    mu = abs(v[2])
    geo = 0.0
    top = 0.0
    for sca, ext in layers:
        a, b = top, top + ext
        top = b
        w = sca / ext if ext > 0 else 0.0
        if v[2] < 0:  # looking down: photon goes up, layers below the observer
            a = max(a, tau_obs)
            if b <= a:
                continue
            cc = 1.0 / mu0 + 1.0 / mu
            val = math.exp(tau_obs / mu) / mu * (math.exp(-a * cc) - math.exp(-b * cc)) / cc
        else:  # looking up: layers above the observer
            b = min(b, tau_obs)
            if b <= a:
                continue
            dd = 1.0 / mu0 - 1.0 / mu
            integ = (b - a) if abs(dd) < 1e-12 else (math.exp(-a * dd) - math.exp(-b * dd)) / dd
            val = math.exp(-tau_obs / mu) / mu * integ
        geo += w * val
    i = p11 * geo / (4.0 * math.pi)
    p = -p12 * geo / (4.0 * math.pi)
    n = (k0[1] * k[2] - k0[2] * k[1], k0[2] * k[0] - k0[0] * k[2],
         k0[0] * k[1] - k0[1] * k[0])
    nn = math.sqrt(sum(x * x for x in n))
    if nn < 1e-12:
        return i, 0.0, 0.0
    n = tuple(x / nn for x in n)
    a1 = sum(x * y for x, y in zip(e1, n))
    a2 = sum(x * y for x, y in zip(e2, n))
    return i, p * (a1 * a1 - a2 * a2), 2.0 * p * a1 * a2


def sign_agreement(triples, frac=0.05):
    """triples: (I, Q, U, Iss, Qss, Uss). Count sign agreements where the single-
    scattering |Q| or |U| exceeds frac * Iss (away from neutral points)."""
    nq = okq = nu = oku = 0
    for i, q, u, iss, qss, uss in triples:
        if abs(qss) > frac * iss:
            nq += 1
            okq += (q * qss > 0)
        if abs(uss) > frac * iss:
            nu += 1
            oku += (u * uss > 0)
    return okq, nq, oku, nu


# ---------------------------------------------------------------------------
# self-checks
# ---------------------------------------------------------------------------

def read_output(rel):
    """Re-read a written file: (header dict of 'key: value', columns, rows)."""
    keys = {}
    cols = None
    rows = []
    with open(os.path.join(ROOT, rel), encoding="utf-8") as f:
        for line in f:
            if line.startswith("#"):
                t = line[1:].strip()
                if t.startswith("columns:"):
                    assert cols is None, (rel, "two 'columns:' lines")
                    cols = t[len("columns:"):].split()
                elif ": " in t and " " not in t.split(": ")[0]:
                    keys[t.split(": ")[0]] = t.split(": ", 1)[1]
            else:
                vals = [float(x) for x in line.split()]
                assert len(vals) == len(cols), (rel, line)
                rows.append(dict(zip(cols, vals)))
    assert int(keys["rows"]) == len(rows), rel
    return keys, cols, rows


def lagrange(xs, ys, x):
    tot = 0.0
    for j, (xj, yj) in enumerate(zip(xs, ys)):
        w = 1.0
        for m, xm in enumerate(xs):
            if m != j:
                w *= (x - xm) / (xj - xm)
        tot += w * yj
    return tot


def self_checks(shared, res):
    report = []
    # ---- row counts: every output row count equals the source data row count
    src_counts = {
        "validation/published/natraj2009.txt": len(res["natraj"][0]),
        "validation/published/iprt_a1_depol0.00.txt": len(res["iprt"]["a1_0.00"][0]),
        "validation/published/iprt_a1_depol0.03.txt": len(res["iprt"]["a1_0.03"][0]),
        "validation/published/iprt_a1_depol0.10.txt": len(res["iprt"]["a1_0.10"][0]),
        "validation/published/iprt_a2.txt": len(res["iprt"]["a2"][0]),
        "validation/published/iprt_b1.txt": len(res["iprt"]["b1"][0]),
        "validation/published/iprt_b2.txt": len(res["iprt"]["b2"][0]),
        "validation/published/iprt_b_layers.txt": len(res["iprt"]["layers"]),
        "validation/published/korkin_b2_single_scatter.txt": len(res["korkin"][0]),
        "validation/published/kokhanovsky2010.txt": len(res["kokh"][0]),
        "validation/published/disort_tests_radiance.txt": len(res["disort"][0][0]),
        "validation/published/disort_tests_flux.txt": len(res["disort"][1][0]),
        "validation/disort/pydisort.txt": len(res["pydisort"][0]),
        "validation/libradtran/uvspec_540nm_sza45.txt": len(res["uvspec"][0]),
    }
    for q in ("tau", "ssa", "gg"):
        src_counts["validation/libradtran/H_540nm_aer_%s.txt" % q] = len(res["h"][q][0])
    # independent count of the raw source data lines (non-comment, minus CSV header)
    raw = {
        "validation/published/natraj2009.txt": ("validation/published/natraj2009_rayleigh_IQU_all.csv", 1),
        "validation/published/iprt_b_layers.txt": ("validation/published/iprt_phaseA_B_layer_profiles.csv", 1),
        "validation/published/korkin_b2_single_scatter.txt": ("validation/published/korkin_iprtB2_single_scatter_TOA.csv", 1),
        "validation/published/kokhanovsky2010.txt": ("validation/published/kokhanovsky2010_rayleigh_reflection.csv", 1),
        "validation/published/disort_tests_radiance.txt": ("validation/published/disort_scalar_tests_1to3_radiance.csv", 1),
        "validation/published/disort_tests_flux.txt": ("validation/published/disort_scalar_tests_1to3_fluxes.csv", 1),
        "validation/disort/pydisort.txt": ("validation/disort/pydisort_scalar_radiance.csv", 1),
        "validation/libradtran/uvspec_540nm_sza45.txt": ("validation/libradtran/uvspec_540nm_sza45.csv", 1),
        "validation/published/iprt_a2.txt": ("validation/published/iprt_phaseA_a2_mystic.csv", 1),
        "validation/published/iprt_b1.txt": ("validation/published/iprt_phaseA_b1_mystic.csv", 1),
        "validation/published/iprt_b2.txt": ("validation/published/iprt_phaseA_b2_mystic.csv", 1),
    }
    for q in ("tau", "ssa", "gg"):
        raw["validation/libradtran/H_540nm_aer_%s.txt" % q] = (
            "validation/libradtran/H_540nm_aer_%s.dat" % q, 0)

    def raw_count(p, nhead):
        with open(os.path.join(shared, p), encoding="utf-8") as f:
            return sum(1 for l in f if l.strip() and not l.startswith("#")) - nhead

    outputs = {}
    for rel, n in src_counts.items():
        outputs[rel] = read_output(rel)
        got = len(outputs[rel][2])
        assert got == n, (rel, got, n)
        if rel in raw:
            assert raw_count(*raw[rel]) == n, rel
    a1_raw = raw_count("validation/published/iprt_phaseA_a1_mystic.csv", 1)
    assert a1_raw == sum(len(outputs["validation/published/iprt_a1_depol%s.txt" % d][2])
                         for d in ("0.00", "0.03", "0.10"))
    report.append("row counts: all %d files equal their source data row counts "
                  "(A1 split: %d = sum of the 3 files)" % (len(src_counts), a1_raw))

    # ---- Natraj physics sign checks (tau 0.02, single scattering dominates)
    _, _, nat = outputs["validation/published/natraj2009.txt"]

    def nat_get(tau, alb, mu0, level, theta, phi):
        m = [r for r in nat if r["tau"] == tau and r["albedo"] == alb and
             r["mu0"] == mu0 and r["level"] == level and
             abs(r["view_zenith_deg"] - theta) < 1e-9 and r["azimuth_deg"] == phi]
        assert len(m) == 1
        return m[0]

    # (a) mu0 = 1 (sun at zenith): the scattering plane of every view direction
    # is its meridian plane; Rayleigh single scattering polarises perpendicular
    # to the scattering plane => E perpendicular to the meridian plane => Q < 0
    # (atmosim Q = I(e1) - I(e2), e1 in the meridian plane), U = 0. Strongest at
    # scattering angle ~90 deg, i.e. grazing views (mu = 0.02).
    n = 0
    for r in nat:
        if r["tau"] == 0.02 and r["albedo"] == 0.0 and r["mu0"] == 1.0 and \
                abs(abs(math.cos(math.radians(r["view_zenith_deg"]))) - 1.0) > 1e-9:
            assert r["Q"] < 0.0, r
            assert r["U"] == 0.0, r
            n += 1
    g = nat_get(0.02, 0.0, 1.0, 1, 180.0 - acos_deg(0.02), 0.0)
    assert g["Q"] < -0.8 * g["I"], g  # ~90 deg scattering: nearly fully polarised
    report.append("natraj tau 0.02 mu0 1: Q < 0 and U = 0 in all %d off-vertical "
                  "views (E perpendicular to the meridian = scattering plane); at "
                  "mu 0.02 (top) -Q/I = %.3f" % (n, -g["Q"] / g["I"]))
    # (b) mu0 = 0.1, observer at the top looking at nadir (theta = 180): the
    # scattering plane is the sun's vertical plane (phi = 0/180), scattering
    # angle ~96 deg, the E-vector is along y (perpendicular to it). Meridian
    # frame of azimuth phi at nadir: e1 = (-cos phi, -sin phi, 0),
    # e2 = (sin phi, -cos phi, 0) => Q = -P cos 2phi, U = +P sin 2phi.
    # So Q < 0 at phi = 0 and 180, Q > 0 at phi = 90, U > 0 at phi = 30, 60
    # and U < 0 at phi = 120, 150.
    q0 = nat_get(0.02, 0.0, 0.1, 1, 180.0, 0.0)
    q90 = nat_get(0.02, 0.0, 0.1, 1, 180.0, 90.0)
    u30 = nat_get(0.02, 0.0, 0.1, 1, 180.0, 30.0)
    u60 = nat_get(0.02, 0.0, 0.1, 1, 180.0, 60.0)
    u120 = nat_get(0.02, 0.0, 0.1, 1, 180.0, 120.0)
    assert q0["Q"] < 0 and q90["Q"] > 0, (q0, q90)
    assert u30["U"] > 0 and u60["U"] > 0 and u120["U"] < 0
    # exact cos 2phi / sin 2phi pattern (a fixed linear polarisation seen in
    # frames rotating with phi), to the tables' 8 decimals (/pi)
    pol = math.hypot(u30["Q"], u30["U"])
    assert abs(u30["Q"] + 0.5 * pol) < 2e-8 and abs(u60["Q"] - 0.5 * pol) < 2e-8
    report.append("natraj tau 0.02 mu0 0.1 nadir (theta 180): Q(phi 0) = %.3e < 0, "
                  "Q(phi 90) = %.3e > 0, U(phi 30) = %.3e > 0, U(phi 120) = %.3e < 0 "
                  "(Q = -P cos 2phi, U = P sin 2phi)" %
                  (q0["Q"], q90["Q"], u30["U"], u120["U"]))
    # (c) all tau 0.02, albedo 0 entries against independent single scattering
    trip = []
    maxrel = 0.0
    for r in nat:
        if r["tau"] != 0.02 or r["albedo"] != 0.0:
            continue
        sza = acos_deg(r["mu0"])
        tau_obs = 0.0 if r["level"] == 1 else 0.02
        i, q, u = ss_stokes([(0.02, 0.02)], sza, r["view_zenith_deg"],
                            r["azimuth_deg"], 0.0, tau_obs)
        trip.append((r["I"], r["Q"], r["U"], i, q, u))
        maxrel = max(maxrel, abs(r["I"] - i) / i)
    okq, nq, oku, nu = sign_agreement(trip)
    assert okq == nq and oku == nu and nq > 1000 and nu > 500, (okq, nq, oku, nu)
    assert maxrel < 0.1, maxrel
    report.append("natraj tau 0.02 albedo 0 vs independent single scattering: Q "
                  "sign %d/%d, U sign %d/%d, max |I/I_ss - 1| = %.3f" %
                  (okq, nq, oku, nu, maxrel))

    # ---- IPRT A1 depol 0, sza 0: azimuth independence
    _, _, a10 = outputs["validation/published/iprt_a1_depol0.00.txt"]
    groups = {}
    for r in a10:
        groups.setdefault((r["zout_km"], r["view_zenith_deg"]), []).append(r)
    worst = {"I": 0.0, "Q": 0.0, "U": 0.0}
    for key, rs in groups.items():
        for comp in ("I", "Q"):
            mean = sum(r[comp] for r in rs) / len(rs)
            for r in rs:
                z = abs(r[comp] - mean) / r[comp + "_se"]
                worst[comp] = max(worst[comp], z)
                assert z <= 5.0, (key, comp, r)
        for r in rs:
            z = abs(r["U"]) / r["U_se"]
            worst["U"] = max(worst["U"], z)
            assert z <= 5.0, (key, r)
    report.append("IPRT A1 depol 0 sza 0: I and Q independent of phi within 5 se "
                  "(max %.2f, %.2f se), U = 0 within 5 se (max %.2f) over %d "
                  "(zout, theta) groups" % (worst["I"], worst["Q"], worst["U"],
                                           len(groups)))

    # ---- Natraj vs IPRT A1 depol 0 sza 0 (tau 0.5, mu0 1, albedo 0)
    def a1_mean(zout, theta):
        rs = groups[(zout, theta)]
        m = sum(r["I"] for r in rs) / len(rs)
        se = math.sqrt(sum(r["I_se"] ** 2 for r in rs)) / len(rs)
        return m, se

    lines = []
    for level, zout, theta in ((0, 0.0, 0.0), (1, 1.0, 180.0)):
        n_ = nat_get(0.5, 0.0, 1.0, level, theta, 0.0)["I"]
        m, se = a1_mean(zout, theta)
        rel = abs(m - n_) / n_
        assert rel <= 1e-4, (level, n_, m, rel)
        lines.append("theta %g: natraj %.6e, IPRT mean over phi %.6e (+-%.1e), rel %.1e"
                     % (theta, n_, m, se, rel))
    report.append("natraj vs IPRT A1 (exactly common directions, tau 0.5 mu0 1): "
                  + "; ".join(lines) + " (<= 1e-4)")
    # near-vertical directions: natraj interpolated in mu (cubic through
    # mu 0.92, 0.96, 0.98, 1.00) to the IPRT va = 5..20 deg
    worst_i = 0.0
    worst_q = 0.0
    for level, zout in ((0, 0.0), (1, 1.0)):
        xs = [0.92, 0.96, 0.98, 1.0]
        ys_i, ys_q = [], []
        for mu in xs:
            th = acos_deg(mu) if level == 0 else 180.0 - acos_deg(mu)
            rr = nat_get(0.5, 0.0, 1.0, level, th, 0.0)
            ys_i.append(rr["I"])
            ys_q.append(rr["Q"])
        for va in (5.0, 10.0, 15.0, 20.0):
            theta = va if level == 0 else 180.0 - va
            mu = math.cos(math.radians(va))
            ni = lagrange(xs, ys_i, mu)
            nq_ = lagrange(xs, ys_q, mu)
            rs = groups[(zout, theta)]
            mi = sum(r["I"] for r in rs) / len(rs)
            mq = sum(r["Q"] for r in rs) / len(rs)
            worst_i = max(worst_i, abs(mi - ni) / ni)
            worst_q = max(worst_q, abs(mq - nq_) / ni)
    assert worst_i <= 2e-4 and worst_q <= 2e-4, (worst_i, worst_q)
    report.append("natraj (cubic in mu) vs IPRT A1 at view zenith 5-20 deg from "
                  "the vertical, both levels: max |dI|/I = %.1e, max |dQ|/I = %.1e"
                  % (worst_i, worst_q))

    # ---- IPRT vs independent single scattering: sign of Q and U (confirms that
    # rel_az is atmosim's counter-clockwise phi and the Stokes frame)
    lay_rows = res["iprt"]["layers"]
    b_layers = {
        "b1": [(float(p["dtau_ray_450"]), float(p["dtau_ray_450"])) for p in reversed(lay_rows)],
        "b2": [(float(p["dtau_ray_325"]), float(p["dtau_ray_325"]) + float(p["dtau_abs_325"]))
               for p in reversed(lay_rows)],
    }
    iprt_cases = [
        ("validation/published/iprt_a1_depol0.00.txt", [(0.5, 0.5)], 1.0, 0.0, 0.0),
        ("validation/published/iprt_a1_depol0.03.txt", [(0.5, 0.5)], 1.0, 30.0, 0.03),
        ("validation/published/iprt_a1_depol0.10.txt", [(0.5, 0.5)], 1.0, 30.0, 0.10),
        ("validation/published/iprt_a2.txt", [(0.1, 0.1)], 1.0, 50.0, 0.03),
        ("validation/published/iprt_b1.txt", b_layers["b1"], 30.0, 60.0, 0.03),
        ("validation/published/iprt_b2.txt", b_layers["b2"], 30.0, 60.0, 0.03),
    ]
    for rel, lay, top_km, sza, depol in iprt_cases:
        _, _, rs = outputs[rel]
        trip = []
        for r in rs:
            if r["I"] <= 0.0:
                continue
            zout = r["zout_km"]
            # optical depth from the top to the observer
            if len(lay) == 1:
                tau_obs = lay[0][1] * (top_km - zout) / top_km
            else:
                tau_obs = sum(e for (s_, e), p in zip(lay, reversed(lay_rows))
                              if float(p["z_bottom_km"]) >= zout - 1e-9)
            # skip views with no scattering medium in the line of sight
            if (r["view_zenith_deg"] > 90 and zout == 0.0) or \
                    (r["view_zenith_deg"] < 90 and zout == top_km):
                continue
            i, q, u = ss_stokes(lay, sza, r["view_zenith_deg"], r["azimuth_deg"],
                                depol, tau_obs)
            trip.append((r["I"], r["Q"], r["U"], i, q, u))
        okq, nq, oku, nu = sign_agreement(trip, 0.05)
        # U: single scattering fixes its sign wherever it is not small; multiple
        # scattering (tau up to 0.97 in B2) can move the neutral points of Q.
        assert oku == nu, (rel, oku, nu)
        assert okq >= 0.95 * nq, (rel, okq, nq)
        if rel.endswith(("depol0.00.txt", "depol0.03.txt", "depol0.10.txt", "a2.txt")):
            assert okq == nq, (rel, okq, nq)
        report.append("%s vs single scattering (atmosim convention): U sign %d/%d, "
                      "Q sign %d/%d" % (os.path.basename(rel), oku, nu, okq, nq))

    # ---- Korkin vs independent single scattering (magnitudes)
    _, _, kk = outputs["validation/published/korkin_b2_single_scatter.txt"]
    worst = [0.0, 0.0, 0.0]
    for r in kk:
        i, q, u = ss_stokes(b_layers["b2"], r["sza_deg"], r["view_zenith_deg"],
                            r["azimuth_deg"], 0.03, 0.0)
        worst = [max(worst[0], abs(r["I"] - i) / i), max(worst[1], abs(r["Q"] - q) / i),
                 max(worst[2], abs(r["U"] - u) / i)]
    assert max(worst) <= 2e-5, worst
    report.append("korkin vs independent single scattering (depol 0.03, B2 layers): "
                  "max |dI|/I = %.1e, |dQ|/I = %.1e, |dU|/I = %.1e (U sign flip "
                  "confirmed)" % tuple(worst))

    # ---- Kokhanovsky: signs vs single scattering, and I vs natraj at tau ~0.3
    _, _, ko = outputs["validation/published/kokhanovsky2010.txt"]
    trip = []
    for r in ko:
        i, q, u = ss_stokes([(0.3262, 0.3262)], 60.0, r["view_zenith_deg"],
                            r["azimuth_deg"], 0.0, 0.0)
        trip.append((r["I"], r["Q"], r["U"], i, q, u))
    okq, nq, oku, nu = sign_agreement(trip, 0.05)
    assert oku == nu and okq >= 0.95 * nq, (okq, nq, oku, nu)
    # nadir: Q = -P cos 2 phi pattern as for natraj
    nad = {r["azimuth_deg"]: r for r in ko if r["view_zenith_deg"] == 180.0}
    assert nad[0.0]["Q"] < 0 and nad[90.0]["Q"] > 0 and nad[180.0]["Q"] < 0
    report.append("kokhanovsky2010 vs single scattering: U sign %d/%d, Q sign %d/%d "
                  "(mismatches only near neutral points); nadir Q(phi 0) < 0 < "
                  "Q(phi 90)" % (oku, nu, okq, nq))

    # ---- libRadtran polrad (atmosphere A) signs vs single scattering
    lay_a = []
    with open(os.path.join(shared, "validation/libradtran/A_540nm_sza45_layers.txt"),
              encoding="utf-8") as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            zb, zt, r_, _s, _a, _g, o3 = (float(x) for x in line.split())
            lay_a.append((zb, r_, r_ + o3))
    lay_a.sort(key=lambda t: -t[0])
    _, _, uv = outputs["validation/libradtran/uvspec_540nm_sza45.txt"]
    trip = []
    for r in uv:
        if r["solver"] != 2 or r["atmosphere"] != 0:
            continue
        if r["view_zenith_deg"] > 90 and r["observer_km"] == 0.0:
            continue  # looking at the ground from the ground
        tau_obs = sum(e for zb, s_, e in lay_a if zb >= r["observer_km"] - 1e-9)
        i, q, u = ss_stokes([(s_, e) for zb, s_, e in lay_a], 45.0,
                            r["view_zenith_deg"], r["azimuth_deg"], 0.02837, tau_obs)
        trip.append((r["I"], r["Q"], r["U"], i, q, u))
    okq, nq, oku, nu = sign_agreement(trip, 0.05)
    assert oku == nu and nu > 0 and okq >= 0.9 * nq, (okq, nq, oku, nu)
    for r in uv:
        if r["solver"] == 2:
            assert r["polarized"] == 1
        if r["solver"] in (0, 1):
            assert r["polarized"] == 0 and r["Q"] == 0 and r["U"] == 0
    report.append("uvspec polrad atmosphere A vs single scattering: U sign %d/%d, "
                  "Q sign %d/%d" % (oku, nu, okq, nq))

    # ---- H aerosol files: column optical depth = libRadtran's 540 nm column
    _, _, ht = outputs["validation/libradtran/H_540nm_aer_tau.txt"]
    tsum = sum(r["value"] for r in ht)
    assert abs(tsum - 0.123698) < 1e-6, tsum
    report.append("H_540nm_aer_tau column sum %.7f (= tau_ext 0.123698 of "
                  "B_540nm_aerosol_layers_fullprec.txt)" % tsum)

    # ---- DISORT tests: boundary rows and flux normalisation
    _, _, dr = outputs["validation/published/disort_tests_radiance.txt"]
    for r in dr:
        if r["level"] == 1 and r["view_zenith_deg"] < 90:
            assert r["I"] == (1.0 if r["source"] == 1 else 0.0), r
        if r["level"] == 0 and r["view_zenith_deg"] > 90:
            assert r["I"] == 0.0, r
    _, _, df = outputs["validation/published/disort_tests_flux.txt"]
    for r in df:
        if r["source"] == 0 and r["level"] == 1:
            assert abs(r["rfldir"] - r["mu0"]) <= 1e-5 * r["mu0"] + 1e-6, r
            assert r["rfldn"] == 0.0
        if r["source"] == 1 and r["level"] == 1:
            assert abs(r["rfldn"] - math.pi) < 1e-5, r
    report.append("DISORT tests: incident boundary rows = 0 (beam) / 1 (isotropic), "
                  "rfldir(top)/fbeam = mu0 and rfldn(top)/fisot = pi to 6 digits")

    # ---- pydisort: L_over_Eperp * pi = I_natraj_norm (source consistency)
    worst = 0.0
    for r in res["pydisort"][0]:
        a = float(r["L_over_Eperp"]) * math.pi
        b = float(r["I_natraj_norm"])
        worst = max(worst, abs(a - b) / max(abs(b), 1e-30))
    assert worst < 1e-6, worst
    report.append("pydisort: pi*L_over_Eperp = I_natraj_norm to %.1e (E0 = 1 confirmed)"
                  % worst)
    return report


# ---------------------------------------------------------------------------
# 8. Spherical MYSTIC at twilight (libRadtran 2.0.3)
# ---------------------------------------------------------------------------

def mystic_twilight(shared):
    src = "validation/mystic/A_620nm_sun-2_spherical_mystic.csv"
    comments, rows = read_csv(os.path.join(shared, src))
    out = []
    for r in rows:
        # One set-up throughout: atmosphere A, 620 nm, sun at -2 degrees.
        assert (r["atmosphere"], r["wavelength_nm"], r["sun_elevation_deg"]) == ("A", "620", "-2"), r
        out.append([
            keep(r["observer_km"]), keep(r["view_zenith_deg"]), keep(r["azimuth_deg"]),
            keep(r["I"]), keep(r["Q"]), keep(r["U"]),
            keep(r["I_std"]), keep(r["Q_std"]), keep(r["U_std"]),
        ])
    header = [
        "Spherical MYSTIC at twilight: libRadtran 2.0.3 MYSTIC in full spherical "
        "geometry (mc_spherical 1D), polarised, backward; atmosphere A (afglus.dat, "
        "Bodhaine Rayleigh, Bogumil O3, no other absorber, no aerosol), Lambertian "
        "albedo 0.2, earth radius 6370 km, top 120 km, 620 nm, sun elevation -2 deg; "
        "observers at 0 and 10 km.",
        "source_file: shared/%s" % src,
        "derived by %s" % SCRIPT,
        "conversion: none (the source is already in atmosim's directions, Stokes "
        "frame, signs and normalisation, as its header states); I_se..U_se = "
        "MYSTIC's I_std..U_std, the standard deviation of each estimate; "
        "directions run twice with different seeds are kept as separate rows.",
        "geometry: spherical",
        "radius_km: 6370",
        "top_km: 120",
        "wavelength_nm: 620",
        "sun_elevation_deg: -2",
        "albedo: 0.2",
        "uncertainty: Monte Carlo, standard errors in I_se Q_se U_se",
    ] + COMMON + quote_source(comments)
    cols = "zout_km view_zenith_deg azimuth_deg I Q U I_se Q_se U_se".split()
    write_table("validation/published/mystic_twilight_620nm.txt", header, cols, out,
                "spherical MYSTIC, sun -2 deg, 620 nm")
    return rows, out


# ---------------------------------------------------------------------------
# OPAC component optics from libRadtran's mie tool (Mie solver references)
# ---------------------------------------------------------------------------

# Component numbers as in atmospheres/opac/size_distributions.txt.
OPAC_NUMBER = {"inso": 1, "waso": 2, "soot": 3, "suso": 10}


def opac_mie(shared):
    """ext/ssa/g and phase matrices of inso, waso, soot, suso (libRadtran mie tool)."""
    base = "data/opac/optical_properties"
    out = []
    comments_all = []
    for c, num_c in OPAC_NUMBER.items():
        src = "%s/opac_%s_optprop.txt" % (base, c)
        comments, rows = read_dat(os.path.join(shared, src))
        comments_all = comments
        for r in rows:
            # wavelength RH ext ssa g rho n_re n_im nmom
            out.append([str(num_c), keep(r[0]), keep(r[1]), keep(r[2]), keep(r[3]),
                        keep(r[4]), keep(r[5]), keep(r[6]), keep(r[7])])
    header = [
        "OPAC component optical properties per unit mass computed with libRadtran's mie tool "
        "(MIEV0, OPAC log-normal size distributions and refractive indices, Hess et al. 1998): "
        "reference for atmosim's Mie solver (src/physics/mie)",
        "source_file: shared/%s/opac_{inso,waso,soot,suso}_optprop.txt" % base,
        "derived by %s" % SCRIPT,
        "conversion: none; the four files joined with a component column "
        "(1 inso, 2 waso, 3 soot, 10 suso: the numbering of "
        "atmospheres/opac/size_distributions.txt); the source's nmom_P11 column dropped",
        "units: ext in km^-1 per (g m^-3) of aerosol mass at that humidity; rho in g cm^-3; "
        "n_im as the source writes it (negative = absorbing)",
        "accuracy: as printed (ext 7 digits, ssa and g 6 decimals)",
    ] + quote_source(comments_all)
    cols = "component wavelength_nm rh_pct ext ssa g rho_g_cm3 n_re n_im".split()
    write_table("validation/opac_mie/optprop.txt", header, cols, out,
                "OPAC inso/waso/soot/suso ext, ssa, g (libRadtran mie)")
    phases = {}
    for c in OPAC_NUMBER:
        rh = "0" if c in ("inso", "soot") else "50"
        for wl in ("420", "540", "550", "620"):
            src = "%s/opac_%s_phase_%snm_rh%s.txt" % (base, c, wl, rh)
            comments = []
            elems = {}
            cur = None
            with open(os.path.join(shared, src), encoding="utf-8") as f:
                for line in f:
                    s_ = line.strip()
                    if not s_:
                        continue
                    if s_.startswith("# element P"):
                        cur = s_.split()[2].rstrip(":")
                        elems[cur] = []
                    elif s_.startswith("#"):
                        comments.append(line.rstrip("\n"))
                    else:
                        elems[cur].append(s_.split())
            names = ["P11", "P12", "P33", "P34"]
            assert sorted(elems) == names, (src, sorted(elems))
            grid = [r[0] for r in elems["P11"]]
            for n in names:
                assert [r[0] for r in elems[n]] == grid, (src, n)
            rows = [[keep(grid[i])] + [keep(elems[n][i][1]) for n in names] for i in range(len(grid))]
            rows.sort(key=lambda r: float(r[0]))
            header = [
                "Phase matrix of OPAC %s at %s nm, RH %s %%, computed with libRadtran's mie tool "
                "(MIEV0) from the OPAC size distribution and refractive index" % (c, wl, rh),
                "source_file: shared/%s" % src,
                "derived by %s" % SCRIPT,
                "conversion: none; the source gives each element on its own angle grid, and the four "
                "grids are identical, so they are joined as columns and sorted by ascending angle",
                "convention: scattering-plane frame, theta from the forward direction; P11, P12, P33, "
                "P34 as libRadtran stores them (Evans), each normalised so that "
                "0.5*int_{-1}^{1} P11 dmu = 1 (P12..P34 not divided by P11); "
                "the same as atmosim's (CONVENTIONS.md section 11)",
                "component: %d" % OPAC_NUMBER[c],
                "wavelength_nm: %s" % wl,
                "rh_pct: %s" % rh,
                "accuracy: as printed (7 significant digits)",
            ] + quote_source(comments)
            cols = "theta_deg p11 p12 p33 p34".split()
            rel = "validation/opac_mie/phase_%s_%snm_rh%s.txt" % (c, wl, rh)
            write_table(rel, header, cols, rows, "OPAC %s phase matrix %s nm" % (c, wl))
            phases[rel] = rows
    return out, phases


def main():
    shared = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "..", "shared")
    shared = os.path.abspath(shared)
    if not os.path.isdir(os.path.join(shared, "validation")):
        sys.exit("no validation/ folder under %s" % shared)
    res = {}
    res["natraj"] = natraj(shared)
    res["iprt"] = iprt(shared)
    res["korkin"] = korkin(shared)
    res["kokh"] = kokhanovsky(shared)
    res["disort"] = disort_tests(shared)
    res["pydisort"] = pydisort(shared)
    res["uvspec"], res["h"] = uvspec(shared)
    res["mystic"] = mystic_twilight(shared)
    res["opac_mie"] = opac_mie(shared)
    report = self_checks(shared, res)
    print("wrote (relative to %s):" % ROOT)
    for rel, (n, what) in WRITTEN.items():
        print("  %-52s %6d rows  %s" % (rel, n, what))
    print("self-checks passed:")
    for line in report:
        print("  - " + line)


if __name__ == "__main__":
    main()
