"""Shared pieces of the Python package's tests: the `atmosim` binary the
results are compared with, and small jobs that render in about a second."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def binary() -> str:
    """The binary: $ATMOSIM_BIN, else the repository's release build, else PATH."""
    if os.environ.get("ATMOSIM_BIN"):
        return os.environ["ATMOSIM_BIN"]
    built = REPO / "target" / "release" / "atmosim"
    if built.exists():
        return str(built)
    found = shutil.which("atmosim")
    if found is None:
        pytest.fail("no atmosim binary: run `cargo build --release` or set ATMOSIM_BIN")
    return found


def run_binary(*args, check=True, cwd=None):
    """Runs the binary; returns the CompletedProcess (text)."""
    p = subprocess.run([binary(), *map(str, args)], capture_output=True, text=True, cwd=cwd)
    if check and p.returncode != 0:
        raise AssertionError(f"atmosim {' '.join(map(str, args))} exited {p.returncode}: {p.stderr}")
    return p


# A `directions` job: 2 wavelengths, 2 albedos, 5 directions, fluxes, the sun.
DIRECTIONS_JOB = """
[spectrum]
wavelengths_nm = [450.0, 650.0]

[sun]
elevation_deg = 20.0

[ground]
albedo = [0.0, 0.3]

[sensor]
type = "directions"
directions = [[0.0, 0.0], [45.0, 0.0], [60.0, 90.0], [75.0, 180.0], [120.0, 30.0]]

[render]
samples = 2000
seed = 7

[output]
sun = true
"""

# A fisheye image: 24 × 24 pixels, 3 wavelengths, 2 albedos.
IMAGE_JOB = """
[spectrum]
wavelengths_nm = [420.0, 537.5, 680.0]

[sun]
elevation_deg = 30.0

[ground]
albedo = [0.0, 0.5]

[sensor]
type = "fisheye"
resolution = 24

[render]
samples = 4
seed = 3

[output]
sun = true
"""

# A transmittance job: a small closed grid, ratio tracking, √T exported.
TRANSMITTANCE_JOB = """
[spectrum]
wavelengths_nm = [400.0, 550.0]

[transmittance]
altitude_nodes = 4
distance_nodes = 5
samples = 50
export_sqrt = true
"""


@pytest.fixture
def job_file(tmp_path):
    """Writes a job's text to a file in a fresh directory; returns its path."""

    def write(text, name="job.toml"):
        p = tmp_path / name
        p.write_text(text)
        return p

    return write
