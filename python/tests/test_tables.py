"""`atmosim.atmosphere` and `atmosim.transmittance` against the binary's
tables: the same numbers to the last digit the binary prints, and the
EXR's float32 values exactly."""

import numpy as np

import atmosim
from conftest import TRANSMITTANCE_JOB, run_binary


def test_atmosphere_is_the_binary_table(job_file):
    path = job_file("[spectrum]\nwavelengths_nm = [320.0, 550.0]\n[atmosphere]\nvisibility_km = 20.0\n")
    text = run_binary("atmosphere", path, "--format", "csv").stdout
    rows = [l.split(",") for l in text.splitlines()[1:] if l and not l.startswith("#")]
    ds = atmosim.atmosphere(path)
    assert ds.tau_rayleigh.dims == ("wavelength", "layer")
    n = ds.sizes["layer"]
    assert len(rows) == 2 * n
    for r, row in enumerate(rows):
        w, i = divmod(r, n)
        assert float(row[0]) == ds.wavelength.values[w]
        assert float(row[1]) == ds.bottom_km.values[i] and float(row[2]) == ds.top_km.values[i]
        for k, name in enumerate(["tau_rayleigh", "tau_ozone", "tau_aerosol_ext", "tau_aerosol_sca"]):
            assert f"{ds[name].values[w, i]:.6e}" == _python_e(row[3 + k]), (name, r)
        assert f"{ds.aerosol_g.values[w, i]:.6f}" == row[7]
        assert f"{ds.rayleigh_depolarization.values[w, i]:.6f}" == row[8]
    # The default job's, as `atmosim atmosphere` with no job.
    default = run_binary("atmosphere", "--format", "csv").stdout.splitlines()[1].split(",")
    assert f"{atmosim.atmosphere().tau_rayleigh.values[0, 0]:.6e}" == _python_e(default[3])


def _python_e(rust: str) -> str:
    """Rust's `{:.6e}` (1.234560e-1) as Python writes it (1.234560e-01)."""
    mantissa, exp = rust.split("e")
    return f"{mantissa}e{int(exp):+03d}"


def test_transmittance_is_the_binary_table(job_file, tmp_path):
    path = job_file(TRANSMITTANCE_JOB)
    out = tmp_path / "bin"
    run_binary("transmittance", path, "--out", out, "--quiet")
    ds = atmosim.transmittance(path)
    assert ds.T.dims == ("wavelength", "altitude", "distance")
    assert ds.T.shape == (2, 4, 5)
    lines = (out / "transmittance.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert len(lines) - 1 == 2 * 4 * 5
    for r, line in enumerate(lines[1:]):
        row = dict(zip(header, line.split(",")))
        w, k = divmod(r, 20)
        a, d = divmod(k, 5)
        assert float(row["altitude_km"]) == ds.altitude.values[a]
        assert float(row["distance_km"]) == ds.distance.values[d]
        assert float(f"{ds.T.values[w, a, d]:.9e}") == float(row["T"])
        assert float(f"{ds.T_se.values[w, a, d]:.4e}") == float(row["T_se"])
        assert float(f"{ds.sqrt_T.values[w, a, d]:.9e}") == float(row["sqrt_T"])
        assert ds.blocked.values[a, d] == int(row["blocked"])
    # The EXR holds the same values in float32, and reads back labelled.
    exr = atmosim.read(out / "transmittance.exr")
    np.testing.assert_array_equal(exr.T.values, ds.T.values.astype(np.float32))
    np.testing.assert_array_equal(exr.sqrt_T.values, ds.sqrt_T.values.astype(np.float32))
    np.testing.assert_array_equal(exr.altitude.values, ds.altitude.values)
    assert exr.attrs["estimator"] == ds.attrs["estimator"] == "ratio_tracking"
    # The directory reads back as the CSV's numbers with the EXR's attributes.
    back = atmosim.read(out)
    np.testing.assert_array_equal(back.T.values, [[[float(f"{x:.9e}") for x in r] for r in p] for p in ds.T.values])
    assert back.attrs["job_hash"] == atmosim.Job(path).hash


def test_several_tables_stack_along_task(job_file, tmp_path):
    path = job_file(TRANSMITTANCE_JOB + "\n[observer]\naltitude_km = [0.0, 2.0]\n")
    ds = atmosim.transmittance(path)
    assert ds.T.dims == ("task", "wavelength", "altitude", "distance")
    assert list(ds.observer_altitude_km.values) == [0.0, 2.0]
    run_binary("transmittance", path, "--out", tmp_path, "--quiet")
    back = atmosim.read(tmp_path)
    assert list(back.task.values) == list(ds.task.values)
    assert np.array_equal(back.blocked.values, ds.blocked.values)
