"""`atmosim.Job` from files, TOML text and dicts, and its errors: those of
the binary, which exits 2 on each."""

import pytest

import atmosim
from conftest import DIRECTIONS_JOB, run_binary


def test_a_file_a_string_and_a_dict_give_the_same_job(job_file):
    path = job_file(DIRECTIONS_JOB)
    from_file = atmosim.Job(path)
    from_string = atmosim.Job(DIRECTIONS_JOB)
    as_dict = {
        "spectrum": {"wavelengths_nm": [450.0, 650.0]},
        "sun": {"elevation_deg": 20.0},
        "ground": {"albedo": [0.0, 0.3]},
        "sensor": {"type": "directions",
                   "directions": [[0.0, 0.0], [45.0, 0.0], [60.0, 90.0], [75.0, 180.0], [120.0, 30.0]]},
        "render": {"samples": 2000, "seed": 7},
        "output": {"sun": True},
    }
    from_dict = atmosim.Job(as_dict)
    assert from_file.hash == from_string.hash  # the same text
    assert from_file.file == str(path)
    for job in (from_string, from_dict):
        assert list(job.wavelengths_nm) == [450.0, 650.0]
        assert list(job.albedos) == [0.0, 0.3]
        assert job.sensor == "directions"
        assert [t["sun_zenith_deg"] for t in job.tasks] == [70.0]
    # The dict's TOML text is a job file the binary reads as the same job.
    assert atmosim.Job(from_dict.text).tasks == from_file.tasks


def test_the_empty_job_is_the_built_in_default():
    job = atmosim.Job("")
    assert list(job.wavelengths_nm) == [420.0, 540.0, 620.0]


@pytest.mark.parametrize(
    "text, key",
    [
        ("[sun]\nelevation_deg = 95.0\n", "sun.elevation_deg"),
        ("[ground]\nalbedo = 1.5\n", "ground.albedo"),
        ("[render]\nsamples = 0\n", "render.samples"),
        ("[spectrum]\nwavelengths_nm = []\n", "spectrum.wavelengths_nm"),
    ],
)
def test_a_bad_value_is_the_binary_error(job_file, text, key):
    path = job_file(text)
    p = run_binary("plan", path, check=False)
    assert p.returncode == 2
    with pytest.raises(ValueError) as e:
        atmosim.Job(path)
    message = str(e.value)
    assert f"`{key}`" in message and "valid:" in message
    assert message in p.stderr  # "error: <the same message>"


def test_a_bad_dict_value_names_the_key_and_range():
    with pytest.raises(ValueError, match=r"`ground\.albedo` = 1\.5.*valid: "):
        atmosim.Job({"ground": {"albedo": 1.5}})


def test_an_unknown_key_is_refused(job_file):
    path = job_file("[sun]\nelevation = 5.0\n")
    p = run_binary("plan", path, check=False)
    assert p.returncode == 2
    with pytest.raises(ValueError, match="unknown field `elevation`") as e:
        atmosim.Job(path)
    assert str(e.value) in p.stderr
    with pytest.raises(ValueError, match="unknown field `elevation`"):
        atmosim.Job({"sun": {"elevation": 5.0}})


def test_not_toml_and_not_a_job_value():
    with pytest.raises(ValueError, match="<string>"):
        atmosim.Job("[sun\nelevation_deg = 5")
    with pytest.raises(TypeError, match="sun.elevation_deg"):
        atmosim.Job({"sun": {"elevation_deg": object()}})


def test_a_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError):
        atmosim.Job(tmp_path / "nothing.toml")
    with pytest.raises(FileNotFoundError):
        atmosim.Job("nothing.toml")


def test_numpy_values_in_a_dict():
    np = pytest.importorskip("numpy")
    job = atmosim.Job({"spectrum": {"wavelengths_nm": np.array([400.0, 500.0])},
                       "ground": {"albedo": np.float64(0.2)}, "render": {"samples": np.int64(10)}})
    assert list(job.wavelengths_nm) == [400.0, 500.0]
