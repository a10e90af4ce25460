"""Type hints of the atmosim package (docs/python.md).

Units (docs/outputs.md, CONVENTIONS.md): wavelengths in nm; altitudes,
distances and visibilities in km (sky models: view points and distances in
m); angles in degrees; radiances per unit extraterrestrial solar irradiance
(sr^-1), or W m^-2 sr^-1 nm^-1 with ``output.units = "absolute"`` and for
sky models; irradiances likewise without sr^-1; transmittances and degrees
of polarisation dimensionless.

Results are ``xarray.Dataset`` objects when xarray is installed, else dicts
of numpy arrays with the same names (plus ``"attrs"``).
"""

import os
from typing import Any, Callable, Dict, List, Mapping, Optional, Union

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["Job", "render", "atmosphere", "transmittance", "read", "SkyModel", "__version__"]

__version__: str

# An xarray.Dataset, or without xarray a dict of numpy arrays.
_Result = Any
_JobSource = Union["Job", str, "os.PathLike[str]", Mapping[str, Any]]

class Job:
    """A validated job: a TOML file path, a TOML string or a dict of the
    same schema. Bad values raise ValueError naming the key and the valid
    range (the binary's exit 2); a missing file FileNotFoundError."""

    def __init__(self, source: _JobSource = "", *, dir: Optional[Union[str, "os.PathLike[str]"]] = None) -> None: ...
    @property
    def text(self) -> str:
        """The job's TOML text."""
    @property
    def file(self) -> str:
        """The job file's path, or ``<string>`` / ``<dict>``."""
    @property
    def hash(self) -> str:
        """FNV-1a hash of the job text (hex), naming the job in its outputs."""
    @property
    def wavelengths_nm(self) -> np.ndarray:
        """The channels' wavelengths (band centres), nm."""
    @property
    def band_widths_nm(self) -> np.ndarray:
        """The channels' full band widths, nm (0: one wavelength)."""
    @property
    def albedos(self) -> np.ndarray:
        """The ground albedos (dimensionless)."""
    @property
    def sensor(self) -> str:
        """``"directions"`` or ``"image"``."""
    @property
    def tasks(self) -> List[Dict[str, Any]]:
        """Per task: name, visibility_km (km or None), sun_zenith_deg (deg),
        observer_altitude_km (km)."""

def render(
    job: _JobSource,
    threads: Optional[int] = None,
    progress: Union[bool, Callable[[int, int], Any]] = True,
    out: Optional[Union[str, "os.PathLike[str]"]] = None,
    overwrite: bool = False,
) -> _Result:
    """Renders every task of ``job`` as ``atmosim render`` does (the same
    files, bit for bit) and returns them labelled.

    Directions: ``radiance``, ``radiance_se`` (wavelength [nm], albedo,
    direction, stokes), ``samples``; fluxes ``e_dir``, ``e_down``, ``e_up``
    and ``*_se`` (wavelength, albedo). Images: ``radiance``,
    ``radiance_se`` (wavelength, albedo, stokes, y, x; float32) with
    ``view_zenith_deg``, ``azimuth_deg`` (deg) per pixel. Radiance sr^-1
    per unit solar irradiance, or W m^-2 sr^-1 nm^-1 (absolute units).
    Several tasks: a leading ``task`` dimension. ``threads``: None or 0 for
    one per core. Ctrl-C stops within about a second (KeyboardInterrupt);
    the GIL is released while rendering."""

def atmosphere(job: _JobSource = "") -> _Result:
    """Per wavelength (nm) and layer (bottom_km, top_km; km): optical depths
    ``tau_rayleigh``, ``tau_ozone``, ``tau_aerosol_ext``, ``tau_aerosol_sca``
    (dimensionless), ``aerosol_g``, ``rayleigh_depolarization``; the
    ``atmosim atmosphere`` table. Default: the built-in default job."""

def transmittance(job: _JobSource, threads: Optional[int] = None) -> _Result:
    """``T``, ``T_se``, ``sqrt_T`` (wavelength [nm], altitude [km], distance
    [km]; dimensionless) and ``blocked`` (altitude, distance) on the table's
    nodes, as ``atmosim transmittance`` computes them (full double
    precision). Several tables: a leading ``task`` dimension."""

def read(path: Union[str, "os.PathLike[str]"], job: Optional[_JobSource] = None) -> _Result:
    """Any output atmosim writes (image.exr, transmittance.exr, radiance.csv,
    fluxes.csv, sun.csv, noise.csv, transmittance.csv, an ``atmosim
    atmosphere --format csv`` table, an ``atmosim eval --queries`` answer,
    a task directory or a directory of tasks) as the same labelled arrays;
    ``task.toml`` as a dict. With ``job``, an image's pixel directions."""

class SkyModel:
    """A fitted sky-model dataset in the Prague sky model runtime's format,
    evaluated with ``atmosim eval``'s semantics. Arguments broadcast
    together: ``view_point_m`` (..., 3) in m (z up, ground at 0; the runtime
    adds 50 m), ``direction`` (..., 3) any length > 0,
    ``sun_elevation_deg``, ``sun_azimuth_deg`` (deg), ``visibility_km``
    (km), ``albedo`` (0 to 1), ``wavelength_nm`` (nm). Results float64 of
    the broadcast shape."""

    path: str
    def __init__(self, path: Union[str, "os.PathLike[str]"]) -> None: ...
    @property
    def info(self) -> str:
        """What ``atmosim eval DATASET --info`` prints."""
    @property
    def axes(self) -> Dict[str, Any]:
        """visibilities_km, albedos, altitudes_m, elevations_deg,
        channel_start_nm, channel_width_nm, channels, has_polarisation."""
    def sky_radiance(
        self,
        view_point_m: ArrayLike,
        direction: ArrayLike,
        sun_elevation_deg: ArrayLike,
        sun_azimuth_deg: ArrayLike,
        visibility_km: ArrayLike,
        albedo: ArrayLike,
        wavelength_nm: ArrayLike,
    ) -> np.ndarray:
        """Sky radiance, W m^-2 sr^-1 nm^-1 (0 outside the channels)."""
    def sun_radiance(
        self,
        view_point_m: ArrayLike,
        direction: ArrayLike,
        sun_elevation_deg: ArrayLike,
        sun_azimuth_deg: ArrayLike,
        visibility_km: ArrayLike,
        albedo: ArrayLike,
        wavelength_nm: ArrayLike,
    ) -> np.ndarray:
        """The transmitted sun's radiance within its 0.2667° disc, W m^-2
        sr^-1 nm^-1 (0 elsewhere)."""
    def polarisation(
        self,
        view_point_m: ArrayLike,
        direction: ArrayLike,
        sun_elevation_deg: ArrayLike,
        sun_azimuth_deg: ArrayLike,
        visibility_km: ArrayLike,
        albedo: ArrayLike,
        wavelength_nm: ArrayLike,
    ) -> np.ndarray:
        """The runtime's degree of linear polarisation (Q/I in the sun–view
        frame), dimensionless; ValueError without a polarisation part."""
    def transmittance(
        self,
        view_point_m: ArrayLike,
        direction: ArrayLike,
        sun_elevation_deg: ArrayLike,
        sun_azimuth_deg: ArrayLike,
        visibility_km: ArrayLike,
        albedo: ArrayLike,
        wavelength_nm: ArrayLike,
        distance_m: ArrayLike = ...,
    ) -> np.ndarray:
        """Transmittance along the direction over ``distance_m`` (m; inf:
        the whole way), dimensionless."""
