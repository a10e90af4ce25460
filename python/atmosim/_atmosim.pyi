"""The Rust extension (python/src/lib.rs): what the package calls; use the
package's API (atmosim/__init__.pyi) instead."""

from typing import Any, Callable, List, Optional, Tuple, final

import numpy as np

__all__ = ["_Job", "_SkyModel", "render", "atmosphere", "transmittance", "read_exr_file", "QUERY_COLUMNS", "VERSION"]

VERSION: str
QUERY_COLUMNS: List[str]

@final
class _Job:
    @staticmethod
    def from_file(path: str) -> "_Job": ...
    @staticmethod
    def from_text(text: str, file: str, dir: str) -> "_Job": ...
    @staticmethod
    def dict_to_toml(dict: Any) -> str: ...
    text: str
    file: str
    hash: str
    wavelengths_nm: List[float]
    band_widths_nm: List[float]
    albedos: List[float]
    sensor: str
    tasks: List[Tuple[str, Optional[float], float, float]]
    transmittance_tasks: List[Tuple[str, Optional[float], float]]
    def pixel_directions(self) -> Tuple[List[float], List[float], int, int]: ...

@final
class _SkyModel:
    def __new__(cls, path: str) -> "_SkyModel": ...
    info: str
    axes: Tuple[List[float], List[float], List[float], List[float], float, float, int, bool]
    def evaluate(self, quantity: str, columns: List[np.ndarray]) -> np.ndarray: ...

def render(
    job: _Job,
    out: str,
    threads: Optional[int] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
    overwrite: bool = False,
) -> List[Tuple[str, str]]: ...
def atmosphere(job: _Job) -> dict: ...
def transmittance(
    job: _Job, threads: Optional[int] = None
) -> Tuple[List[Tuple[str, List[float], List[float], List[bool]]], List[float], List[float], str, str, bool, int]: ...
def read_exr_file(path: str) -> Tuple[int, int, List[Tuple[str, np.ndarray]], List[Tuple[str, str]]]: ...
