"""Reading atmosim's outputs back as labelled arrays (docs/outputs.md), and
the small container the package labels its results with before handing
them out as an xarray.Dataset or a dict of numpy arrays."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from . import _atmosim

STOKES = ["I", "Q", "U", "V"]


class _Labelled:
    """Variables and coordinates as (dims, array, attrs), and attributes."""

    def __init__(self, attrs=None):
        self.vars = {}
        self.coords = {}
        self.attrs = dict(attrs or {})

    def var(self, name, dims, values, **attrs):
        self.vars[name] = (tuple(dims), np.asarray(values), attrs)

    def coord(self, name, dims, values, **attrs):
        self.coords[name] = (tuple(dims), np.asarray(values), attrs)

    def update(self, other):
        self.vars.update(other.vars)
        for k, v in other.coords.items():
            self.coords.setdefault(k, v)
        for k, v in other.attrs.items():
            self.attrs.setdefault(k, v)


def _use_xarray() -> bool:
    if os.environ.get("ATMOSIM_NO_XARRAY"):
        return False
    try:
        import xarray  # noqa: F401
    except ImportError:
        return False
    return True


def _finish(lab: _Labelled):
    """An xarray.Dataset when xarray is installed (and ATMOSIM_NO_XARRAY is
    not set), else a dict of numpy arrays of the same names (variables and
    coordinates; the attributes under ``"attrs"``)."""
    if _use_xarray():
        import xarray as xr

        return xr.Dataset(
            {k: (d, v, a) for k, (d, v, a) in lab.vars.items()},
            coords={k: (d, v, a) for k, (d, v, a) in lab.coords.items()},
            attrs=lab.attrs,
        )
    out = {k: v for k, (_, v, _) in lab.coords.items()}
    out.update({k: v for k, (_, v, _) in lab.vars.items()})
    out["attrs"] = dict(lab.attrs)
    return out


def _stack_tasks(parts, names):
    """Tasks' results along a leading ``task`` dimension: coordinates that
    differ between tasks (the sun, the observer) become per-task ones."""
    first = parts[0]
    lab = _Labelled()
    lab.coord("task", ("task",), np.array(names))
    for k, (d, v, a) in first.vars.items():
        lab.var(k, ("task",) + d, np.stack([p.vars[k][1] for p in parts]), **a)
    for k, (d, v, a) in first.coords.items():
        values = [p.coords[k][1] for p in parts]
        if all(np.array_equal(values[0], x, equal_nan=values[0].dtype.kind == "f") for x in values[1:]):
            lab.coord(k, d, v, **a)
        else:
            lab.coord(k, ("task",) + d, np.stack(values), **a)
    for k, v in first.attrs.items():
        values = [p.attrs.get(k) for p in parts]
        if all(x == v for x in values):
            lab.attrs[k] = v
        elif all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in values):
            lab.coord(k, ("task",), np.array(values, dtype=float))
    return lab


# --- small parsers -------------------------------------------------------


def _transmittance_coords(lab, w, widths, alts, dists):
    """The coordinates of a transmittance table (nm, km)."""
    lab.coord("wavelength", ("wavelength",), np.asarray(w, dtype=float), units="nm")
    if widths is not None:
        lab.coord("band_width_nm", ("wavelength",), np.asarray(widths, dtype=float), units="nm")
    lab.coord("altitude", ("altitude",), np.asarray(alts, dtype=float), units="km")
    lab.coord("distance", ("distance",), np.asarray(dists, dtype=float), units="km")


def _number(s: str) -> float:
    return float(s) if s.strip() != "" else math.nan


def _csv(path: Path):
    """Header and columns (lists of strings) of a CSV atmosim wrote;
    ``#`` lines are comments."""
    lines = [l for l in path.read_text().splitlines() if l.strip() and not l.startswith("#")]
    if not lines:
        raise ValueError(f"{path}: empty: no header row")
    header = [h.strip() for h in lines[0].split(",")]
    cols: dict = {h: [] for h in header}
    for n, line in enumerate(lines[1:], start=2):
        cells = line.split(",")
        if len(cells) != len(header):
            raise ValueError(f"{path}: line {n}: {len(cells)} values for {len(header)} columns")
        for h, c in zip(header, cells):
            cols[h].append(c.strip())
    return header, cols


def _floats(cells):
    return np.array([_number(c) for c in cells], dtype=float)


def _unique(values):
    seen = []
    for v in values:
        if v not in seen:
            seen.append(v)
    return seen


def _task_toml(path: Path) -> dict:
    """task.toml's keys (strings, numbers, booleans, lists of numbers)."""
    try:
        import tomllib

        with open(path, "rb") as f:
            return tomllib.load(f)
    except ImportError:  # Python < 3.11: the file is flat `key = value` lines
        out: dict = {}
        for line in path.read_text().splitlines():
            if not line.strip() or line.startswith("#") or " = " not in line:
                continue
            k, v = line.split(" = ", 1)
            v = v.strip()
            if v.startswith('"'):
                out[k.strip()] = v[1:-1].replace('\\"', '"').replace("\\\\", "\\")
            elif v.startswith("["):
                out[k.strip()] = [float(x) for x in v[1:-1].split(",") if x.strip()]
            elif v in ("true", "false"):
                out[k.strip()] = v == "true"
            else:
                out[k.strip()] = float(v) if any(c in v for c in ".eE") else int(v)
        return out


def _attr_value(v: str):
    try:
        return int(v)
    except ValueError:
        pass
    try:
        return float(v)
    except ValueError:
        return v


# --- the outputs ---------------------------------------------------------

RADIANCE = "wavelength_nm,albedo,view_zenith_deg,azimuth_deg,I,Q,U,V,I_se,Q_se,U_se,V_se,samples"
FLUX = "wavelength_nm,albedo,altitude_km,e_dir,e_down,e_up,e_down_se,e_up_se,samples"
SUN_START = "wavelength_nm,sun_zenith_deg,transmittance,direct_normal_irradiance"
NOISE_START = "wavelength_nm,albedo,counted,median_rel_se_I"
TRANSMITTANCE_START = "wavelength_nm,altitude_km,distance_km,T,T_se,blocked"
ATMOSPHERE = "wavelength_nm,bottom_km,top_km,tau_rayleigh,tau_ozone,tau_aerosol_ext,tau_aerosol_sca,aerosol_g,rayleigh_depolarization"
QUERIES_END = "sky_radiance,sun_radiance,polarisation,transmittance"


def _grid2(path, cols, names):
    """(wavelength, albedo) of rows nested wavelength then albedo."""
    w = _unique(_floats(cols["wavelength_nm"]).tolist())
    a = _unique(_floats(cols["albedo"]).tolist())
    n = len(cols["wavelength_nm"])
    if n % (len(w) * len(a)):
        raise ValueError(f"{path}: {n} rows are not whole blocks of {len(w)} wavelengths × {len(a)} albedos")
    return np.array(w), np.array(a), n // (len(w) * len(a))


def _radiance_csv(path, header, cols, units):
    w, a, ndir = _grid2(path, cols, None)
    lab = _Labelled()
    lab.coord("wavelength", ("wavelength",), w, units="nm")
    lab.coord("albedo", ("albedo",), a, units="1")
    lab.coord("stokes", ("stokes",), np.array(STOKES))
    lab.coord("view_zenith_deg", ("direction",), _floats(cols["view_zenith_deg"][:ndir]), units="deg")
    lab.coord("azimuth_deg", ("direction",), _floats(cols["azimuth_deg"][:ndir]), units="deg")
    shape = (len(w), len(a), ndir)
    stokes = np.stack([_floats(cols[s]).reshape(shape) for s in STOKES], axis=-1)
    se = np.stack([_floats(cols[s + "_se"]).reshape(shape) for s in STOKES], axis=-1)
    dims = ("wavelength", "albedo", "direction", "stokes")
    lab.var("radiance", dims, stokes, units=units, long_name="Stokes vector (I, Q, U, V), direct sun excluded")
    lab.var("radiance_se", dims, se, units=units, long_name="standard error of the mean")
    lab.var("samples", dims[:3], np.array([int(x) for x in cols["samples"]]).reshape(shape), units="1")
    return lab


def _flux_csv(path, header, cols, units):
    w, a, one = _grid2(path, cols, None)
    if one != 1:
        raise ValueError(f"{path}: more than one row per wavelength and albedo")
    lab = _Labelled()
    lab.coord("wavelength", ("wavelength",), w, units="nm")
    lab.coord("albedo", ("albedo",), a, units="1")
    lab.coord("altitude_km", (), float(cols["altitude_km"][0]), units="km")
    shape = (len(w), len(a))
    irr = units.replace(" sr-1", "") if units else units
    for k in ["e_dir", "e_down", "e_up", "e_down_se", "e_up_se"]:
        lab.var(k, ("wavelength", "albedo"), _floats(cols[k]).reshape(shape), units=irr)
    lab.var("flux_samples", ("wavelength", "albedo"), np.array([int(x) for x in cols["samples"]]).reshape(shape), units="1")
    return lab


def _sun_csv(path, header, cols, units):
    lab = _Labelled()
    lab.coord("wavelength", ("wavelength",), _floats(cols["wavelength_nm"]), units="nm")
    lab.coord("sun_zenith_deg", (), float(cols["sun_zenith_deg"][0]), units="deg")
    lab.var("sun_transmittance", ("wavelength",), _floats(cols["transmittance"]), units="1")
    lab.var("direct_normal_irradiance", ("wavelength",), _floats(cols["direct_normal_irradiance"]),
            units=units.replace(" sr-1", "") if units else units)
    for k, name in [("sun_radiance", "sun_radiance"), ("image_x", "sun_image_x"), ("image_y", "sun_image_y")]:
        if k in cols:
            lab.var(name, ("wavelength",), _floats(cols[k]), units=units if k == "sun_radiance" else "pixels")
    return lab


def _noise_csv(path, header, cols, units):
    w, a, one = _grid2(path, cols, None)
    lab = _Labelled()
    lab.coord("wavelength", ("wavelength",), w, units="nm")
    lab.coord("albedo", ("albedo",), a, units="1")
    for k in header:
        if k in ("wavelength_nm", "albedo"):
            continue
        lab.var("noise_" + k, ("wavelength", "albedo"), _floats(cols[k]).reshape(len(w), len(a)), units="1")
    return lab


def _transmittance_csv(path, header, cols, units):
    w = np.array(_unique(_floats(cols["wavelength_nm"]).tolist()))
    alts = np.array(_unique(_floats(cols["altitude_km"]).tolist()))
    dists = np.array(_unique(_floats(cols["distance_km"]).tolist()))
    shape = (len(w), len(alts), len(dists))
    if len(cols["T"]) != np.prod(shape):
        raise ValueError(f"{path}: the rows are not a grid of wavelengths × altitudes × distances")
    lab = _Labelled()
    _transmittance_coords(lab, w, None, alts, dists)
    dims = ("wavelength", "altitude", "distance")
    lab.var("T", dims, _floats(cols["T"]).reshape(shape), units="1")
    lab.var("T_se", dims, _floats(cols["T_se"]).reshape(shape), units="1")
    lab.var("blocked", dims[1:], np.array([int(x) for x in cols["blocked"]], dtype=np.uint8).reshape(shape)[0], units="1")
    if "sqrt_T" in cols:
        lab.var("sqrt_T", dims, _floats(cols["sqrt_T"]).reshape(shape), units="1")
    return lab


def _atmosphere_csv(path, header, cols, units):
    w = np.array(_unique(_floats(cols["wavelength_nm"]).tolist()))
    n = len(cols["wavelength_nm"]) // len(w)
    lab = _Labelled()
    lab.coord("wavelength", ("wavelength",), w, units="nm")
    lab.coord("bottom_km", ("layer",), _floats(cols["bottom_km"][:n]), units="km")
    lab.coord("top_km", ("layer",), _floats(cols["top_km"][:n]), units="km")
    for k in header[3:]:
        lab.var(k, ("wavelength", "layer"), _floats(cols[k]).reshape(len(w), n), units="1")
    return lab


def _queries_csv(path, header, cols, units):
    lab = _Labelled()
    for k in header:
        lab.var(k, ("query",), _floats(cols[k]))
    return lab


# Tables of one row per image: `atmosim fit`'s <out>.fit.csv and
# `atmosim fit-report`'s images.csv, reference.csv and twin.csv.
PER_IMAGE = ("images.csv", "reference.csv", "twin.csv")


def _per_image_csv(path, header, cols):
    lab = _Labelled()
    for k in header:
        try:
            values = _floats(cols[k])
        except ValueError:
            values = np.array(cols[k])
        lab.var(k, ("image",), values)
    return lab


def _read_csv(path: Path, units=""):
    header, cols = _csv(path)
    h = ",".join(header)
    if path.name.endswith(".fit.csv") or path.name in PER_IMAGE:
        return _per_image_csv(path, header, cols)
    if h == RADIANCE:
        return _radiance_csv(path, header, cols, units)
    if h == FLUX:
        return _flux_csv(path, header, cols, units)
    if h.startswith(SUN_START):
        return _sun_csv(path, header, cols, units)
    if h.startswith(NOISE_START):
        return _noise_csv(path, header, cols, units)
    if h.startswith(TRANSMITTANCE_START):
        return _transmittance_csv(path, header, cols, units)
    if h == ATMOSPHERE:
        return _atmosphere_csv(path, header, cols, units)
    if h.endswith(QUERIES_END):
        return _queries_csv(path, header, cols, units)
    raise ValueError(f"{path}: not a CSV atmosim writes (header {h[:80]!r})")


def _label(x: float) -> str:
    """A wavelength as an EXR layer label (`wavelength_label`): Rust's `{}`
    of the number (shortest round trip, no exponent), the point as `p`."""
    s = repr(float(x))
    if "e" in s or "E" in s:
        s = np.format_float_positional(float(x), trim="-")
    if s.endswith(".0"):
        s = s[:-2]
    return s.replace(".", "p")


def _planes(channels, names, shape):
    """The channels `names` as images stacked along a first axis, or None
    if one is missing."""
    if not all(n in channels for n in names):
        return None
    return np.stack([channels[n].reshape(shape) for n in names])


def _read_exr(path: Path, job=None):
    width, height, channel_list, attributes = _atmosim.read_exr_file(str(path))
    attrs = {k: _attr_value(v) for k, v in sorted(attributes)}
    channels = dict(channel_list)
    lab = _Labelled(attrs=attrs)
    shape = (height, width)
    if "blocked" in channels:  # a transmittance table
        w = [float(x) for x in str(attrs["wavelengths_nm"]).split()]
        alts = [float(x) for x in str(attrs["altitudes_km"]).split()]
        dists = [float(x) for x in str(attrs["distances_km"]).split()]
        widths = [float(x) for x in str(attrs.get("band_width_nm", "")).split()] or None
        _transmittance_coords(lab, w, widths, alts, dists)
        dims = ("wavelength", "altitude", "distance")
        for suffix, name in [("T", "T"), ("T_se", "T_se"), ("sqrtT", "sqrt_T")]:
            cube = _planes(channels, [f"{_label(x)}nm.{suffix}" for x in w], shape)
            if cube is not None:
                lab.var(name, dims, cube, units="1")
        lab.var("blocked", dims[1:], channels["blocked"].reshape(shape), units="1")
        return lab
    if any(name.endswith(".I") and "_a" not in name for name in channels):
        return _eval_image(lab, channels, shape)
    # A Stokes image: <λ>nm_a<albedo×100>.<S>[_se].
    w = [float(x) for x in str(attrs["wavelengths_nm"]).split()]
    a = [float(x) for x in str(attrs["albedos"]).split()]
    units = _units(str(attrs.get("units", "")))
    lab.coord("wavelength", ("wavelength",), np.array(w), units="nm")
    lab.coord("albedo", ("albedo",), np.array(a), units="1")
    lab.coord("stokes", ("stokes",), np.array(STOKES))
    lab.coord("y", ("y",), np.arange(height), long_name="row, 0 at the top")
    lab.coord("x", ("x",), np.arange(width), long_name="column, 0 at the left")
    for suffix, name in [("", "radiance"), ("_se", "radiance_se")]:
        cube = np.empty((len(w), len(a), 4, height, width), dtype=np.float32)
        for i, wl in enumerate(w):
            for j, al in enumerate(a):
                layer = f"{_label(wl)}nm_a{al * 100:03.0f}"
                for k, s in enumerate(STOKES):
                    key = f"{layer}.{s}{suffix}"
                    if key not in channels:
                        raise ValueError(f"{path}: no channel {key} for {wl} nm, albedo {al}")
                    cube[i, j, k] = channels[key].reshape(shape)
        lab.var(name, ("wavelength", "albedo", "stokes", "y", "x"), cube, units=units)
    if "samples" in channels:
        lab.var("samples", ("y", "x"), channels["samples"].reshape(shape), units="1")
    per = _planes(channels, [f"{_label(x)}nm.samples" for x in w], shape)
    if per is not None:
        lab.var("samples", ("wavelength", "y", "x"), per, units="1")
    if job is not None:
        zen, az, jw, jh = job._job.pixel_directions()
        if (jw, jh) == (width, height):
            lab.coord("view_zenith_deg", ("y", "x"), np.array(zen).reshape(shape), units="deg")
            lab.coord("azimuth_deg", ("y", "x"), np.array(az).reshape(shape), units="deg")
    return lab


def _eval_image(lab, channels, shape):
    """`atmosim eval`'s sphere or fisheye: <λ>nm.I, .P (with polarisation), .T."""
    labels = sorted({n[: -len(".I")] for n in channels if n.endswith(".I")},
                    key=lambda l: float(l[:-2].replace("p", ".")))
    lab.coord("wavelength", ("wavelength",), np.array([float(l[:-2].replace("p", ".")) for l in labels]), units="nm")
    lab.coord("y", ("y",), np.arange(shape[0]), long_name="row, 0 at the top")
    lab.coord("x", ("x",), np.arange(shape[1]), long_name="column, 0 at the left")
    for suffix, name, units in [("I", "sky_radiance", "W m-2 sr-1 nm-1"), ("P", "polarisation", "1"),
                                ("T", "transmittance", "1")]:
        cube = _planes(channels, [f"{l}.{suffix}" for l in labels], shape)
        if cube is not None:
            lab.var(name, ("wavelength", "y", "x"), cube, units=units)
    return lab


def _units(text: str) -> str:
    """The radiance units of a task.toml's or an EXR's `units` text."""
    if text.startswith("absolute") or text.startswith("W m-2"):
        return "W m-2 sr-1 nm-1"
    return "sr-1 (per unit extraterrestrial irradiance)"


TASK_FILES = ["image.exr", "radiance.csv", "fluxes.csv", "sun.csv", "noise.csv"]


def _read_task_dir(path: Path, job=None):
    meta = _task_toml(path / "task.toml")
    units = _units(str(meta.get("units", "")))
    lab = _Labelled(attrs={k: v for k, v in meta.items() if not isinstance(v, list)})
    for name in TASK_FILES:
        f = path / name
        if not f.exists():
            continue
        part = _read_exr(f, job) if name.endswith(".exr") else _read_csv(f, units)
        lab.update(part)
    if "band_width_nm" in meta and "wavelength" in lab.coords:
        widths = dict(zip(meta["wavelengths_nm"], meta["band_width_nm"]))
        w = lab.coords["wavelength"][1]
        lab.coord("band_width_nm", ("wavelength",), np.array([widths.get(x, math.nan) for x in w]), units="nm")
    return lab


def read(path, job=None):
    """Reads any output atmosim writes back as labelled arrays (the names
    and dimensions that :func:`atmosim.render` and
    :func:`atmosim.transmittance` return): an ``image.exr``,
    ``transmittance.exr`` or ``atmosim eval`` image (``sky_radiance``,
    ``polarisation``, ``transmittance`` per wavelength, y, x; with its
    text attributes as attributes), a
    ``radiance.csv``, ``fluxes.csv``, ``sun.csv``, ``noise.csv``,
    ``transmittance.csv``, ``atmosim atmosphere --format csv`` table,
    ``atmosim eval --queries`` answer, ``atmosim fit``'s ``<out>.fit.csv``
    or ``atmosim fit-report``'s ``images.csv``, ``reference.csv`` and
    ``twin.csv`` (one row per image along ``image``); a task directory (every file in it,
    with ``task.toml`` as attributes); or an output directory of several
    tasks (stacked along ``task``). With ``job`` (an :class:`atmosim.Job`
    or what makes one) an image gets its pixels' ``view_zenith_deg`` and
    ``azimuth_deg``.
    """
    from . import Job

    if job is not None and not isinstance(job, Job):
        job = Job(job)
    p = Path(path)
    if p.is_dir():
        if (p / "task.toml").exists():
            return _finish(_read_task_dir(p, job))
        if (p / "transmittance.csv").exists():
            return _finish(_read_transmittance_dir(p))
        tasks = sorted(d for d in p.iterdir() if (d / "task.toml").exists())
        if tasks:
            parts = [_read_task_dir(d, job) for d in tasks]
            order = sorted(range(len(parts)), key=lambda i: parts[i].attrs.get("task_index", i))
            return _finish(_stack_tasks([parts[i] for i in order], [tasks[i].name for i in order]))
        tables = sorted(d for d in p.iterdir() if (d / "transmittance.csv").exists())
        if tables:
            return _finish(_stack_tasks([_read_transmittance_dir(d) for d in tables], [d.name for d in tables]))
        raise ValueError(f"{p}: no atmosim output here (no task.toml, no transmittance.csv)")
    if not p.exists():
        raise FileNotFoundError(f"{p}: no such file or directory")
    if p.suffix == ".exr":
        return _finish(_read_exr(p, job))
    if p.name == "task.toml":
        return _task_toml(p)
    units = ""
    if (p.parent / "task.toml").exists():
        units = _units(str(_task_toml(p.parent / "task.toml").get("units", "")))
    return _finish(_read_csv(p, units))


def _read_transmittance_dir(p: Path):
    """transmittance.csv (full printed precision) with the EXR's attributes."""
    lab = _read_csv(p / "transmittance.csv")
    exr = p / "transmittance.exr"
    if exr.exists():
        _, _, _, attributes = _atmosim.read_exr_file(str(exr))
        lab.attrs.update({k: _attr_value(v) for k, v in sorted(attributes)})
        widths = [float(x) for x in str(lab.attrs.get("band_width_nm", "")).split()]
        if len(widths) == len(lab.coords["wavelength"][1]):
            lab.coord("band_width_nm", ("wavelength",), np.array(widths), units="nm")
    return lab
