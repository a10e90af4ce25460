"""atmosim from Python: jobs from files, TOML text or dicts; renders,
atmospheres and transmittance tables as labelled arrays; every output
atmosim writes read back; fitted sky models evaluated over numpy arrays.

A thin layer over the Rust library (the extension ``atmosim._atmosim``):
every number comes from the same code as the ``atmosim`` binary's. Results
are ``xarray.Dataset`` objects when xarray is installed, otherwise dicts of
numpy arrays with the same names. Units follow the book
(docs/outputs.md): wavelengths in nm, lengths in km, angles in degrees,
radiances per unit extraterrestrial solar irradiance (sr^-1) unless the
job asks for absolute units (W m^-2 sr^-1 nm^-1).
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from . import _atmosim
from ._read import read, _Labelled, _finish, _read_task_dir, _stack_tasks, _transmittance_coords

__all__ = ["Job", "render", "atmosphere", "transmittance", "read", "SkyModel", "__version__"]

__version__ = _atmosim.VERSION


class Job:
    """A validated job: the same schema, defaults and errors as a job file.

    ``Job(source)`` takes a path to a TOML job file (``str`` or
    ``os.PathLike``), a TOML string, or a dict of the same tables and keys
    (``{"sun": {"elevation_deg": 5.0}, ...}``; ``None`` values are left
    out). A key outside its range or unknown raises ``ValueError`` with the
    message the binary prints before exiting with code 2 (it names the key
    and the valid range); a missing file raises ``FileNotFoundError``.
    Relative paths inside a string or dict job resolve from ``dir``
    (default: the current directory).
    """

    def __init__(self, source="", *, dir=None):
        if isinstance(source, Job):
            self._job = source._job
            return
        base = str(dir if dir is not None else os.getcwd())
        if isinstance(source, dict):
            text = _atmosim._Job.dict_to_toml(source)
            self._job = _atmosim._Job.from_text(text, "<dict>", base)
        elif isinstance(source, os.PathLike) or (isinstance(source, str) and _looks_like_path(source)):
            self._job = _atmosim._Job.from_file(os.fspath(source))
        elif isinstance(source, str):
            self._job = _atmosim._Job.from_text(source, "<string>", base)
        else:
            raise TypeError(f"a job is a path, a TOML string or a dict, not a {type(source).__name__}")

    @property
    def text(self) -> str:
        """The job's TOML text (for a dict, the TOML it was turned into)."""
        return self._job.text

    @property
    def file(self) -> str:
        """The job file's path, or ``<string>`` / ``<dict>``."""
        return self._job.file

    @property
    def hash(self) -> str:
        """The FNV-1a hash of the job text that names the job in its outputs."""
        return self._job.hash

    @property
    def wavelengths_nm(self) -> np.ndarray:
        """The channels' wavelengths (band centres), nm."""
        return np.array(self._job.wavelengths_nm)

    @property
    def band_widths_nm(self) -> np.ndarray:
        """The channels' full band widths, nm (0: one wavelength)."""
        return np.array(self._job.band_widths_nm)

    @property
    def albedos(self) -> np.ndarray:
        """The ground albedos rendered."""
        return np.array(self._job.albedos)

    @property
    def sensor(self) -> str:
        """``"directions"`` or ``"image"``."""
        return self._job.sensor

    @property
    def tasks(self) -> list:
        """The job's tasks (visibility × sun × observer altitude), as dicts of
        ``name``, ``visibility_km`` (None without aerosol scaling),
        ``sun_zenith_deg`` and ``observer_altitude_km``."""
        return [
            dict(name=n, visibility_km=v, sun_zenith_deg=z, observer_altitude_km=a)
            for n, v, z, a in self._job.tasks
        ]

    def __repr__(self) -> str:
        return f"atmosim.Job({self.file!r}, hash {self.hash}, {len(self._job.tasks)} task(s), {self.sensor})"


def _looks_like_path(s: str) -> bool:
    if s == "" or "\n" in s or "=" in s or s.lstrip().startswith("["):
        return False
    return True


def _job(job) -> Job:
    return job if isinstance(job, Job) else Job(job)


def _progress_callback(progress):
    """What ``render`` calls with (paths done, paths in all), and what it
    calls at the end. ``progress=True`` shows a bar in a terminal (on
    stderr) and in a notebook (tqdm's, where tqdm is installed); in a log
    or a pipe, nothing."""
    if callable(progress):
        return progress, None
    if not progress:
        return None, None
    notebook = "ipykernel" in sys.modules
    if not (notebook or sys.stderr.isatty()):
        return None, None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        tqdm = None
    if tqdm is not None:
        state = {}

        def update(done, total):
            bar = state.get("bar")
            if bar is None:  # made once the total is known
                bar = state["bar"] = tqdm(total=total, unit="paths", unit_scale=True, desc="atmosim render")
            if bar.total != total:
                bar.total = total
            bar.update(done - bar.n)

        def close():
            if "bar" in state:
                state["bar"].close()

        return update, close
    if notebook:
        return None, None
    import time

    start = time.monotonic()

    def line(done, total):
        frac = done / total if total else 0.0
        filled = int(30 * frac)
        rate = done / max(time.monotonic() - start, 1e-9)
        sys.stderr.write(f"\rpaths [{'=' * filled}{' ' * (30 - filled)}] {100 * frac:5.1f}% {rate:,.0f}/s")
        sys.stderr.flush()

    def close():
        sys.stderr.write("\n")

    return line, close


def render(job, threads=None, progress=True, out=None, overwrite=False):
    """Renders every task of ``job`` and returns its results as labelled arrays.

    The same library calls as ``atmosim render JOB --out OUT``: the same
    sums and the same files, bit for bit, for the same job and seed. The
    files go to ``out`` when given (and stay there), else to a temporary
    directory that is removed after they are read back with :func:`read`.

    ``threads``: worker threads (None or 0: one per core). ``progress``:
    True for a progress bar (tqdm's when installed, in terminals and
    notebooks; else a line on a terminal's stderr), False for none, or a
    callable ``f(done, total)`` in paths; nothing is shown where stderr
    is not a terminal (a log, a pipe) outside a notebook. The GIL is
    released while rendering; Ctrl-C (KeyboardInterrupt) stops within
    about a second.

    A ``directions`` sensor gives ``radiance`` and ``radiance_se``
    (wavelength, albedo, direction, stokes), ``samples`` and, with fluxes,
    ``e_dir``, ``e_down``, ``e_up`` and their errors (wavelength, albedo);
    an image gives ``radiance`` and ``radiance_se`` (wavelength, albedo,
    stokes, y, x) with the pixel centres' ``view_zenith_deg`` and
    ``azimuth_deg`` (y, x). Radiances in sr^-1 per unit solar irradiance,
    or W m^-2 sr^-1 nm^-1 with ``output.units = "absolute"``. A job of
    several tasks adds a leading ``task`` dimension.
    """
    job = _job(job)
    callback, close = _progress_callback(progress)
    with tempfile.TemporaryDirectory(prefix="atmosim-") as tmp:
        target = Path(out) if out is not None else Path(tmp)
        try:
            dirs = _atmosim.render(job._job, str(target), threads, callback, overwrite)
        finally:
            if close is not None:
                close()
        parts = [_read_task_dir(Path(d), job) for _, d in dirs]
    if len(parts) == 1:
        return _finish(parts[0])
    return _finish(_stack_tasks(parts, [n for n, _ in dirs]))


def atmosphere(job=""):
    """The optical properties of the job's atmosphere (``atmosim atmosphere``):
    per ``wavelength`` (nm) and ``layer`` (bottom_km, top_km), the optical
    depths ``tau_rayleigh``, ``tau_ozone`` (gas absorption),
    ``tau_aerosol_ext``, ``tau_aerosol_sca`` (dimensionless), the aerosol
    asymmetry ``aerosol_g`` and ``rayleigh_depolarization``. ``job``
    defaults to the built-in default job."""
    job = _job(job)
    d = _atmosim.atmosphere(job._job)
    w = np.array(d["wavelength_nm"])
    n = len(d["bottom_km"])
    lab = _Labelled(attrs={"job_hash": job.hash, "job_file": job.file})
    lab.coord("wavelength", ("wavelength",), w, units="nm")
    lab.coord("bottom_km", ("layer",), np.array(d["bottom_km"]), units="km")
    lab.coord("top_km", ("layer",), np.array(d["top_km"]), units="km")
    for name in ["tau_rayleigh", "tau_ozone", "tau_aerosol_ext", "tau_aerosol_sca", "aerosol_g", "rayleigh_depolarization"]:
        lab.var(name, ("wavelength", "layer"), np.array(d[name]).reshape(len(w), n), units="1")
    return _finish(lab)


def transmittance(job, threads=None):
    """The job's transmittance tables (``atmosim transmittance``), on the
    table's nodes: ``T`` and ``T_se`` (wavelength, altitude, distance),
    ``blocked`` (altitude, distance; 1 where the line of sight passes
    below the ground) and, with ``export_sqrt``, ``sqrt_T``. Coordinates
    ``altitude`` and ``distance`` in km, ``wavelength`` in nm. Several
    tables (visibilities × observer altitudes) add a leading ``task``
    dimension. Values are the binary's in full double precision (its CSV
    prints them to 10 significant digits)."""
    job = _job(job)
    tables, alts, dists, grid, estimator, sqrt, samples = _atmosim.transmittance(job._job, threads)
    w = job.wavelengths_nm
    alts, dists = np.array(alts), np.array(dists)
    shape = (len(w), len(alts), len(dists))
    parts = []
    for (name, t, se, blocked), (_, vis, alt) in zip(tables, job._job.transmittance_tasks):
        lab = _Labelled(
            attrs=dict(task=name, grid=grid, estimator=estimator, samples=samples, job_hash=job.hash,
                       observer_altitude_km=alt, visibility_km="none" if vis is None else vis)
        )
        _transmittance_coords(lab, w, job.band_widths_nm, alts, dists)
        T = np.array(t).reshape(shape)
        lab.var("T", ("wavelength", "altitude", "distance"), T, units="1")
        lab.var("T_se", ("wavelength", "altitude", "distance"), np.array(se).reshape(shape), units="1")
        lab.var("blocked", ("altitude", "distance"), np.array(blocked, dtype=np.uint8).reshape(shape[1:]), units="1")
        if sqrt:
            lab.var("sqrt_T", ("wavelength", "altitude", "distance"), np.sqrt(np.maximum(T, 0.0)), units="1")
        parts.append(lab)
    if len(parts) == 1:
        return _finish(parts[0])
    return _finish(_stack_tasks(parts, [t[0] for t in tables]))


class SkyModel:
    """A fitted sky-model dataset (``atmosim fit``'s, or any file in the
    Prague sky model runtime's format), evaluated with the semantics of
    ``atmosim eval --queries``.

    Every method takes numpy arrays (or scalars) that broadcast together:
    ``view_point_m`` (..., 3), the view point in the runtime's frame (m, z
    up, the ground at z = 0; the runtime adds 50 m); ``direction`` (..., 3),
    the view direction (any length > 0); ``sun_elevation_deg`` and
    ``sun_azimuth_deg`` (degrees, at the origin); ``visibility_km``;
    ``albedo`` (0 to 1); ``wavelength_nm``. Results have the broadcast
    shape, float64. Every query is checked before any is answered (a
    ``ValueError`` naming the query's flat index and the column);
    evaluation runs in parallel with the GIL released.
    """

    def __init__(self, path):
        self._model = _atmosim._SkyModel(os.fspath(path))
        self.path = os.fspath(path)

    @property
    def info(self) -> str:
        """What ``atmosim eval DATASET --info`` prints."""
        return self._model.info

    @property
    def axes(self) -> dict:
        """The dataset's axes: visibilities_km, albedos, altitudes_m,
        elevations_deg, channel_start_nm, channel_width_nm, channels, and
        has_polarisation."""
        v, a, h, e, start, width, n, pol = self._model.axes
        return dict(visibilities_km=np.array(v), albedos=np.array(a), altitudes_m=np.array(h),
                    elevations_deg=np.array(e), channel_start_nm=start, channel_width_nm=width,
                    channels=n, has_polarisation=pol)

    def _evaluate(self, quantity, view_point_m, direction, sun_elevation_deg, sun_azimuth_deg,
                  visibility_km, albedo, wavelength_nm, distance_m=np.inf):
        p = np.asarray(view_point_m, dtype=float)
        d = np.asarray(direction, dtype=float)
        if p.shape[-1:] != (3,) or d.shape[-1:] != (3,):
            raise ValueError("view_point_m and direction need a last axis of 3 (x, y, z)")
        cols = [p[..., 0], p[..., 1], p[..., 2], d[..., 0], d[..., 1], d[..., 2],
                sun_elevation_deg, sun_azimuth_deg, visibility_km, albedo, wavelength_nm, distance_m]
        cols = np.broadcast_arrays(*[np.asarray(c, dtype=float) for c in cols])
        shape = cols[0].shape
        flat = [np.ascontiguousarray(c, dtype=np.float64).reshape(-1) for c in cols]
        return self._model.evaluate(quantity, flat).reshape(shape)

    def sky_radiance(self, view_point_m, direction, sun_elevation_deg, sun_azimuth_deg,
                     visibility_km, albedo, wavelength_nm):
        """The sky's radiance (W m^-2 sr^-1 nm^-1, the dataset's units) of
        each query; 0 outside the dataset's channels."""
        return self._evaluate("sky_radiance", view_point_m, direction, sun_elevation_deg,
                              sun_azimuth_deg, visibility_km, albedo, wavelength_nm)

    def sun_radiance(self, view_point_m, direction, sun_elevation_deg, sun_azimuth_deg,
                     visibility_km, albedo, wavelength_nm):
        """The transmitted sun's radiance (W m^-2 sr^-1 nm^-1) where the
        direction is within the 0.2667° disc, else 0 (Kurucz spectrum)."""
        return self._evaluate("sun_radiance", view_point_m, direction, sun_elevation_deg,
                              sun_azimuth_deg, visibility_km, albedo, wavelength_nm)

    def polarisation(self, view_point_m, direction, sun_elevation_deg, sun_azimuth_deg,
                     visibility_km, albedo, wavelength_nm):
        """The runtime's polarisation (dimensionless): the degree of linear
        polarisation as Q/I in the sun–view frame, positive where the light
        is polarised across the plane of the sun and the view (as fitted
        from renders, docs/sky-models.md); ``ValueError`` for a dataset
        without a polarisation part."""
        return self._evaluate("polarisation", view_point_m, direction, sun_elevation_deg,
                              sun_azimuth_deg, visibility_km, albedo, wavelength_nm)

    def transmittance(self, view_point_m, direction, sun_elevation_deg, sun_azimuth_deg,
                      visibility_km, albedo, wavelength_nm, distance_m=np.inf):
        """The transmittance (dimensionless) along the direction over
        ``distance_m`` (m, > 0; ``inf`` for the whole way)."""
        return self._evaluate("transmittance", view_point_m, direction, sun_elevation_deg,
                              sun_azimuth_deg, visibility_km, albedo, wavelength_nm, distance_m)

    def __repr__(self) -> str:
        return f"atmosim.SkyModel({self.path!r})"
