"""`atmosim.read` on every kind of output the binary writes, compared with
the files' own text (parsed here with the csv module) and metadata."""

import csv

import numpy as np
import pytest

import atmosim
from conftest import DIRECTIONS_JOB, IMAGE_JOB, run_binary


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(l for l in f if not l.startswith("#")))


@pytest.fixture(scope="module")
def directions_out(tmp_path_factory):
    d = tmp_path_factory.mktemp("directions")
    (d / "job.toml").write_text(DIRECTIONS_JOB)
    run_binary("render", d / "job.toml", "--out", d / "out", "--quiet")
    return d / "out"


def test_radiance_fluxes_and_sun_csv(directions_out):
    rad = atmosim.read(directions_out / "radiance.csv")
    r = rows(directions_out / "radiance.csv")
    assert rad.radiance.shape == (2, 2, 5, 4)
    # Rows nest wavelength, albedo, direction.
    assert rad.radiance.values[1, 0, 3, 1] == float(r[1 * 10 + 0 * 5 + 3]["Q"])
    assert rad.radiance_se.values[0, 1, 4, 0] == float(r[0 * 10 + 1 * 5 + 4]["I_se"])
    assert list(rad.view_zenith_deg.values) == [0.0, 45.0, 60.0, 75.0, 120.0]
    flux = atmosim.read(directions_out / "fluxes.csv")
    f = rows(directions_out / "fluxes.csv")
    assert flux.e_up.values[1, 1] == float(f[3]["e_up"])
    assert flux.e_up.values[0, 0] == 0.0  # albedo 0 reflects nothing
    sun = atmosim.read(directions_out / "sun.csv")
    s = rows(directions_out / "sun.csv")
    assert list(sun.sun_transmittance.values) == [float(x["transmittance"]) for x in s]
    assert sun.sun_transmittance.values[0] < sun.sun_transmittance.values[1]  # 450 nm below 650 nm
    meta = atmosim.read(directions_out / "task.toml")
    assert meta["samples"] == 2000 and meta["wavelengths_nm"] == [450.0, 650.0]
    # A task directory: every file, task.toml as attributes.
    task = atmosim.read(directions_out)
    assert task.attrs["job_hash"] == meta["job_hash"]
    assert {"radiance", "e_down", "sun_transmittance"} <= set(task.data_vars)
    # Read units from task.toml beside the file.
    assert task.radiance.attrs["units"].startswith("sr-1")


def test_an_image_and_its_attributes(tmp_path):
    (tmp_path / "job.toml").write_text(IMAGE_JOB.replace('[output]', '[output]\nunits = "absolute"'))
    run_binary("render", tmp_path / "job.toml", "--out", tmp_path / "out", "--quiet")
    ds = atmosim.read(tmp_path / "out" / "image.exr")
    assert ds.radiance.shape == (3, 2, 4, 24, 24)
    assert ds.attrs["wavelengths_nm"] == "420 537.5 680"
    assert ds.attrs["seed"] == 3
    assert ds.radiance.attrs["units"] == "W m-2 sr-1 nm-1"
    # The image is its left half mirrored: I even, U odd about the sun's
    # vertical (README "Images").
    I = ds.radiance.sel(stokes="I").values
    U = ds.radiance.sel(stokes="U").values
    np.testing.assert_array_equal(I, I[..., ::-1])
    np.testing.assert_array_equal(U, -U[..., ::-1])
    # Without the job no pixel directions; with it, they come along.
    assert "view_zenith_deg" not in ds.coords
    assert "view_zenith_deg" in atmosim.read(tmp_path / "out" / "image.exr", job=tmp_path / "job.toml").coords


def test_a_noise_target_writes_noise_csv(tmp_path):
    job = DIRECTIONS_JOB.replace("samples = 2000", "noise_target = 0.2\npilot_samples = 16\nmax_samples = 64")
    (tmp_path / "job.toml").write_text(job)
    run_binary("render", tmp_path / "job.toml", "--out", tmp_path / "out", "--quiet")
    noise = atmosim.read(tmp_path / "out" / "noise.csv")
    n = rows(tmp_path / "out" / "noise.csv")
    assert noise.noise_counted.shape == (2, 2)
    assert noise.noise_samples_max.values[1, 0] == float(n[2]["samples_max"])
    assert np.isnan(noise.noise_image_rel_noise.values).all()  # empty for directions


def test_the_atmosphere_csv_and_eval_answers(tmp_path):
    (tmp_path / "atm.csv").write_text(run_binary("atmosphere", "--format", "csv").stdout)
    atm = atmosim.read(tmp_path / "atm.csv")
    direct = atmosim.atmosphere()
    assert atm.tau_rayleigh.shape == direct.tau_rayleigh.shape
    np.testing.assert_allclose(atm.tau_rayleigh.values, direct.tau_rayleigh.values, rtol=1e-6)


def test_what_is_not_an_output(tmp_path):
    (tmp_path / "x.csv").write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="not a CSV atmosim writes"):
        atmosim.read(tmp_path / "x.csv")
    (tmp_path / "x.exr").write_bytes(b"not an exr")
    with pytest.raises(ValueError, match="x.exr"):
        atmosim.read(tmp_path / "x.exr")
    with pytest.raises(FileNotFoundError):
        atmosim.read(tmp_path / "missing.csv")
    with pytest.raises(ValueError, match="no atmosim output"):
        atmosim.read(tmp_path)
