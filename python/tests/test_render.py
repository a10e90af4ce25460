"""`atmosim.render` against `atmosim render` on the same jobs: the same
files byte for byte, and the arrays read back from the binary's files
equal to the ones render returns."""

import numpy as np
import pytest

import atmosim
from conftest import DIRECTIONS_JOB, IMAGE_JOB, run_binary


def files(d):
    return {p.relative_to(d).as_posix(): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


def assert_same_dataset(a, b):
    assert sorted(a.data_vars) == sorted(b.data_vars)
    for k in a.data_vars:
        assert a[k].dims == b[k].dims, k
        np.testing.assert_array_equal(a[k].values, b[k].values, err_msg=k)
    for k in a.coords:
        np.testing.assert_array_equal(a[k].values, b[k].values, err_msg=k)


@pytest.mark.parametrize("text", [DIRECTIONS_JOB, IMAGE_JOB], ids=["directions", "image"])
def test_the_same_files_as_the_binary(job_file, tmp_path, text):
    path = job_file(text)
    run_binary("render", path, "--out", tmp_path / "bin", "--quiet")
    ds = atmosim.render(str(path), out=tmp_path / "py", progress=False)
    bin_files, py_files = files(tmp_path / "bin"), files(tmp_path / "py")
    assert sorted(bin_files) == sorted(py_files)
    for name in bin_files:
        assert bin_files[name] == py_files[name], f"{name} differs"
    assert_same_dataset(ds, atmosim.read(tmp_path / "bin", job=str(path)))


def test_directions_are_the_binary_csv(job_file, tmp_path):
    """The labelled arrays hold the CSV's numbers where the CSV's header says."""
    path = job_file(DIRECTIONS_JOB)
    out = tmp_path / "bin"
    run_binary("render", path, "--out", out, "--quiet")
    ds = atmosim.render(atmosim.Job(path), progress=False)
    lines = (out / "radiance.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert ds.radiance.dims == ("wavelength", "albedo", "direction", "stokes")
    assert ds.radiance.shape == (2, 2, 5, 4)
    assert len(lines) - 1 == 2 * 2 * 5
    for line in lines[1:]:
        row = dict(zip(header, line.split(",")))
        w = list(ds.wavelength.values).index(float(row["wavelength_nm"]))
        a = list(ds.albedo.values).index(float(row["albedo"]))
        d = [i for i in range(5)
             if ds.view_zenith_deg.values[i] == float(row["view_zenith_deg"])
             and ds.azimuth_deg.values[i] == float(row["azimuth_deg"])]
        assert len(d) == 1
        for k, s in enumerate("IQUV"):
            assert ds.radiance.values[w, a, d[0], k] == float(row[s])
            assert ds.radiance_se.values[w, a, d[0], k] == float(row[s + "_se"])
        assert ds.samples.values[w, a, d[0]] == int(row["samples"])
    flux = (out / "fluxes.csv").read_text().splitlines()
    row = dict(zip(flux[0].split(","), flux[2].split(",")))  # 450 nm, albedo 0.3
    assert ds.e_down.sel(wavelength=450.0, albedo=0.3).item() == float(row["e_down"])
    assert ds.radiance.attrs["units"].startswith("sr-1")
    assert ds.attrs["job_hash"] == atmosim.Job(path).hash


def test_a_dict_job_renders_as_its_toml(tmp_path):
    job = {
        "spectrum": {"wavelengths_nm": [500.0]},
        "sensor": {"type": "directions", "directions": [[10.0, 0.0], [80.0, 90.0]], "fluxes": False},
        "render": {"samples": 500, "seed": 11},
    }
    ds = atmosim.render(job, progress=False)
    text = atmosim.Job(job).text
    path = tmp_path / "job.toml"
    path.write_text(text)
    out = run_binary("render", path, "--stdout", "--quiet").stdout.splitlines()
    values = [float(line.split(",")[4]) for line in out[1:]]
    assert list(ds.radiance.sel(stokes="I").values.ravel()) == values
    assert "e_down" not in ds


def test_the_same_sums_at_any_thread_count():
    a = atmosim.render(IMAGE_JOB, threads=1, progress=False)
    b = atmosim.render(IMAGE_JOB, threads=2, progress=False)
    assert_same_dataset(a, b)


def test_an_image_is_labelled():
    ds = atmosim.render(IMAGE_JOB, progress=False)
    assert ds.radiance.dims == ("wavelength", "albedo", "stokes", "y", "x")
    assert ds.radiance.shape == (3, 2, 4, 24, 24)
    assert list(ds.wavelength.values) == [420.0, 537.5, 680.0]
    assert list(ds.albedo.values) == [0.0, 0.5]
    assert ds.radiance.dtype == np.float32
    # Pixel directions: the zenith at the centre, the horizon at the rim.
    zen = ds.view_zenith_deg.values
    assert zen[11:13, 11:13].max() < 6.0
    assert np.isnan(zen[0, 0])
    # The channels land where their labels say: a clear sky is bluer at
    # the zenith (I at 420 nm above I at 680 nm) and brighter over a
    # brighter ground; a pixel wholly outside the fisheye's circle is 0.
    I = ds.radiance.sel(stokes="I").values
    assert I[0, 0, 12, 12] > 1.5 * I[2, 0, 12, 12]
    inside = ~np.isnan(zen)
    assert I[1, 1][inside].mean() > I[1, 0][inside].mean()
    assert np.all(I[:, :, 0, 0] == 0) and np.all(I[:, :, -1, -1] == 0)  # corners: wholly outside
    # The sun's pixel (sun.csv) and the sun's azimuth (image up).
    assert ds.sun_image_x.values[0] == pytest.approx(12.0, abs=0.5)
    assert ds.sun_zenith_deg.item() == pytest.approx(60.0)


def test_several_tasks_stack_along_task(tmp_path):
    job = DIRECTIONS_JOB.replace("elevation_deg = 20.0", "elevation_deg = [10.0, 40.0]")
    ds = atmosim.render(job, progress=False, out=tmp_path)
    assert ds.radiance.dims == ("task", "wavelength", "albedo", "direction", "stokes")
    assert ds.sizes["task"] == 2
    assert list(ds.sun_zenith_deg.values) == [80.0, 50.0]
    back = atmosim.read(tmp_path)
    assert_same_dataset(ds, back)


def test_a_dict_of_arrays_without_xarray(monkeypatch):
    monkeypatch.setenv("ATMOSIM_NO_XARRAY", "1")
    d = atmosim.render(DIRECTIONS_JOB, progress=False)
    assert isinstance(d, dict)
    assert d["radiance"].shape == (2, 2, 5, 4)
    assert list(d["stokes"]) == ["I", "Q", "U", "V"]
    assert d["attrs"]["samples"] == 2000


def test_progress_reaches_the_total():
    seen = []
    atmosim.render(DIRECTIONS_JOB, progress=lambda done, total: seen.append((done, total)))
    assert seen and seen[-1][0] == seen[-1][1] > 0
    assert all(a[0] <= b[0] for a, b in zip(seen, seen[1:]))


def test_an_output_directory_of_another_job_is_refused(tmp_path):
    atmosim.render(DIRECTIONS_JOB, out=tmp_path, progress=False)
    other = DIRECTIONS_JOB.replace("seed = 7", "seed = 8")
    with pytest.raises(ValueError, match="overwrite"):
        atmosim.render(other, out=tmp_path, progress=False)
    atmosim.render(other, out=tmp_path, progress=False, overwrite=True)


def on_a_terminal(tmp_path, prelude=""):
    """stderr of a child that renders with progress=True on a pseudo-terminal."""
    import fcntl
    import os
    import pty
    import struct
    import subprocess
    import sys
    import termios

    script = prelude + f"import atmosim\natmosim.render({DIRECTIONS_JOB!r})\n"
    main, child = pty.openpty()
    fcntl.ioctl(child, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))  # 24 × 100 characters
    p = subprocess.Popen([sys.executable, "-c", script], stderr=child, cwd=tmp_path)
    os.close(child)
    out = b""
    while True:
        try:
            chunk = os.read(main, 4096)
        except OSError:  # the child has closed the terminal
            break
        if not chunk:
            break
        out += chunk
    os.close(main)
    assert p.wait(timeout=60) == 0
    return out.decode()


def test_a_progress_bar_with_tqdm(tmp_path):
    """progress=True on a terminal: tqdm's bar (tqdm.auto: a notebook's in a notebook)."""
    pytest.importorskip("tqdm")
    text = on_a_terminal(tmp_path)
    assert "atmosim render" in text and "100%" in text, text


def test_a_progress_line_on_a_terminal_without_tqdm(tmp_path):
    """Without tqdm, on a terminal: a bar redrawn on stderr."""
    text = on_a_terminal(tmp_path, "import sys; sys.modules['tqdm'] = None\n")  # as if not installed
    assert "paths [" in text and "100.0%" in text, text


def test_no_progress_in_a_log(capfd):
    """Where stderr is not a terminal (a log, a pipe), progress=True shows nothing."""
    atmosim.render(DIRECTIONS_JOB, progress=True)
    assert capfd.readouterr().err == ""
