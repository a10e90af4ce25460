"""`atmosim.SkyModel` against `atmosim eval --queries` on the same
queries: equal to the last printed digit (the binary prints 10 significant
digits of the same double)."""

import csv

import numpy as np
import pytest

import atmosim
from conftest import run_binary

# The smallest grid `atmosim fit` takes: full spheres in absolute units in
# the sun–view frame, two sun elevations, two bands as wide as their spacing.
RENDERS = """
[atmosphere]
visibility_km = 40.0

[spectrum]
wavelengths_nm = [450.0, 550.0]
band_width_nm = 100.0

[sun]
elevation_deg = [10.0, 30.0]

[ground]
albedo = [0.0, 0.5]

[sensor]
type = "sphere"
resolution = [16, 8]
stokes_frame = "sun_view"

[render]
samples = 2
seed = 5

[output]
directory = "renders"
units = "absolute"
preview = false
"""

FIT = """
renders = "renders"
out = "tiny.dat"
rank = 2
polarisation_rank = {pol}
transmittance_rank = 2
resolution = 9
sun_breaks = 5
zenith_breaks = 5
emph_breaks = 5
impute_iterations = 1
"""


def fit(d, pol):
    (d / "renders.toml").write_text(RENDERS)
    run_binary("render", "renders.toml", "--quiet", cwd=d)
    (d / "fit.toml").write_text(FIT.format(pol=pol))
    run_binary("fit", "fit.toml", cwd=d)
    return d / "tiny.dat"


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    return fit(tmp_path_factory.mktemp("fit"), pol=2)


def queries(n, seed=1):
    """Random queries over and past the dataset's axes (clamping and
    channels outside the dataset included)."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    return dict(
        view_point_m=np.stack([rng.uniform(-500, 500, n), rng.uniform(-500, 500, n), rng.uniform(0, 3000, n)], -1),
        direction=d,
        sun_elevation_deg=rng.uniform(-5, 45, n),
        sun_azimuth_deg=rng.uniform(-180, 180, n),
        visibility_km=rng.uniform(20, 80, n),
        albedo=rng.uniform(0, 1, n),
        wavelength_nm=rng.choice([380.0, 420.0, 450.0, 520.0, 599.0, 650.0], n),
        distance_m=np.where(rng.uniform(size=n) < 0.3, np.inf, rng.uniform(10, 1e5, n)),
    )


def write_queries(path, q):
    with open(path, "w") as f:
        f.write(",".join(atmosim._atmosim.QUERY_COLUMNS) + "\n")
        for i in range(len(q["albedo"])):
            v = [*q["view_point_m"][i], *q["direction"][i], q["sun_elevation_deg"][i], q["sun_azimuth_deg"][i],
                 q["visibility_km"][i], q["albedo"][i], q["wavelength_nm"][i], q["distance_m"][i]]
            f.write(",".join(repr(float(x)) for x in v) + "\n")


def printed(x):
    """x as the binary prints it ({:.9e}), read back."""
    return float(f"{x:.9e}")


def test_equal_to_atmosim_eval(dataset, tmp_path):
    q = queries(500)
    write_queries(tmp_path / "q.csv", q)
    answer = run_binary("eval", dataset, "--queries", tmp_path / "q.csv").stdout
    rows = list(csv.DictReader(answer.splitlines()))
    assert len(rows) == 500
    model = atmosim.SkyModel(dataset)
    args = {k: v for k, v in q.items() if k != "distance_m"}
    got = {
        "sky_radiance": model.sky_radiance(**args),
        "sun_radiance": model.sun_radiance(**args),
        "polarisation": model.polarisation(**args),
        "transmittance": model.transmittance(**args, distance_m=q["distance_m"]),
    }
    for name, values in got.items():
        want = np.array([float(r[name]) for r in rows])
        assert values.shape == (500,)
        mismatch = [i for i in range(500) if printed(values[i]) != want[i]]
        assert not mismatch, f"{name}: {len(mismatch)} differ, e.g. query {mismatch[0]}"
        # Not all zero: the queries reach the dataset's values.
        assert np.count_nonzero(want) > 100 or name == "sun_radiance"


def test_broadcasting_and_the_axes(dataset):
    model = atmosim.SkyModel(dataset)
    axes = model.axes
    assert list(axes["elevations_deg"]) == [10.0, 30.0]
    assert axes["channels"] == 2 and axes["channel_width_nm"] == 100.0
    assert axes["has_polarisation"]
    assert model.info.strip() == run_binary("eval", dataset, "--info").stdout.strip()
    # One view point, a fan of directions, two wavelengths: (2, 7).
    az = np.radians(np.linspace(0, 180, 7))
    dirs = np.stack([np.cos(az), np.sin(az), np.full(7, 0.3)], -1)
    L = model.sky_radiance([0, 0, 0], dirs[None, :, :], 20.0, 0.0, 40.0, 0.0, np.array([450.0, 550.0])[:, None])
    assert L.shape == (2, 7)
    one = model.sky_radiance([0, 0, 0], dirs[3], 20.0, 0.0, 40.0, 0.0, 550.0)
    assert one.shape == () and one == L[1, 3]


def test_bad_queries_name_the_column(dataset):
    model = atmosim.SkyModel(dataset)
    good = dict(view_point_m=[0, 0, 0], direction=[1, 0, 0.2], sun_elevation_deg=10.0, sun_azimuth_deg=0.0,
                visibility_km=40.0, albedo=0.0, wavelength_nm=450.0)
    with pytest.raises(ValueError, match=r"query 1: `albedo` = 1.5 is outside 0 to 1"):
        model.sky_radiance(**{**good, "albedo": [0.2, 1.5]})
    with pytest.raises(ValueError, match="zero vector"):
        model.sky_radiance(**{**good, "direction": [0, 0, 0]})
    with pytest.raises(ValueError, match="view_z_m"):
        model.sky_radiance(**{**good, "view_point_m": [0, 0, -1]})
    with pytest.raises(ValueError, match="distance_m"):
        model.transmittance(**good, distance_m=0.0)
    with pytest.raises(FileNotFoundError):
        atmosim.SkyModel("no-such.dat")


def test_a_dataset_without_polarisation(tmp_path):
    model = atmosim.SkyModel(fit(tmp_path, pol=0))
    assert not model.axes["has_polarisation"]
    with pytest.raises(ValueError, match="no polarisation part"):
        model.polarisation([0, 0, 0], [1, 0, 0.2], 10.0, 0.0, 40.0, 0.0, 450.0)


def test_an_eval_image_reads_back_as_the_model(dataset, tmp_path):
    """`atmosim eval`'s fisheye, read back, is the model at its pixels'
    directions (float32 as stored)."""
    run_binary("eval", dataset, "--camera", "fisheye", "--resolution", "16", "--elevation", "20",
               "--visibility", "40", "--albedo", "0.5", "--out", tmp_path)
    img = atmosim.read(tmp_path / "fisheye.exr")
    assert img.sky_radiance.dims == ("wavelength", "y", "x")
    assert list(img.wavelength.values) == [450.0, 550.0]
    assert set(img.data_vars) == {"sky_radiance", "polarisation", "transmittance"}
    assert img.attrs["albedo"] == 0.5
    # The corner outside the circle, and pixels across the circle at
    # their centres' directions (CONVENTIONS.md: equidistant, ρ = θ/90°,
    # φ = atan2(dx, dy), image up the sun's azimuth, here 0).
    assert img.sky_radiance.values[1, 0, 0] == 0.0
    model = atmosim.SkyModel(dataset)
    for j, i in [(7, 7), (7, 8), (8, 7), (8, 8), (2, 8), (8, 13), (12, 4)]:
        dx, dy = (i + 0.5 - 8) / 8, (8 - (j + 0.5)) / 8
        theta, phi = np.radians(90 * np.hypot(dx, dy)), np.arctan2(dx, dy)
        d = [np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)]
        want = model.sky_radiance([0, 0, 0], d, 20.0, 0.0, 40.0, 0.5, 550.0)
        assert abs(img.sky_radiance.values[1, j, i] / want - 1) < 1e-6, (j, i)


def test_the_fit_table_reads_back(dataset):
    """`atmosim fit`'s <out>.fit.csv: one row per image."""
    path = dataset.parent / (dataset.name + ".fit.csv")
    table = atmosim.read(path)
    with open(path) as f:
        rows = list(csv.DictReader(f))
    assert table.sizes["image"] == len(rows) == 2 * 2 * 2  # elevations × albedos × channels
    assert list(table.kappa.values) == [float(r["kappa"]) for r in rows]
    assert list(table.wavelength_nm.values) == [float(r["wavelength_nm"]) for r in rows]


def test_the_fit_report_table_reads_back(dataset):
    """`atmosim fit-report`'s images.csv: one row per image."""
    run_binary("fit-report", "fit.toml", cwd=dataset.parent)
    path = dataset.parent / (dataset.name + ".report") / "images.csv"
    table = atmosim.read(path)
    with open(path) as f:
        rows = list(csv.DictReader(f))
    assert table.sizes["image"] == len(rows) == 8
    assert "debiased_snr_db" in rows[0]  # empty without --reference: NaN
    for name in rows[0]:
        want = [float(r[name]) if r[name] else np.nan for r in rows]
        np.testing.assert_array_equal(table[name].values, want, err_msg=name)
