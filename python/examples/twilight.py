"""A low-sun sky in 11 bands, and a fitted sky model beside it.

Renders an up-looking fisheye with the sun 2° above the horizon in 11 bands
of 40 nm (340-740 nm), takes the radiance and the degree of linear
polarisation along the solar almucantar (the circle of view zenith angle
equal to the sun's, 88°, from the sun's azimuth to the opposite one),
evaluates a fitted sky-model dataset at the same pixel directions and
plots both (python/examples/twilight.png).

    python python/examples/twilight.py [--dataset DATASET.dat] [--out twilight.png]

Without --dataset a small dataset is fitted first, with the `atmosim`
binary (`cargo build --release`): sphere renders of the same atmosphere at
1°, 2° and 3° elevation, 64 × 32 pixels, `atmosim fit` with its defaults;
about two minutes on two cores. The renders are cheap (64 samples per
pixel), so both curves carry Monte Carlo noise of a few per cent.
"""

import argparse
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

import atmosim

HERE = Path(__file__).resolve().parent
SUN_ELEVATION_DEG = 2.0
VISIBILITY_KM = 40.0
ALBEDO = 0.3
BANDS = {"wavelengths_nm": [340.0 + 40.0 * k for k in range(11)], "band_width_nm": 40.0}

# The fisheye: absolute units (the dataset's), the sun–view Stokes frame.
FISHEYE = {
    "atmosphere": {"visibility_km": VISIBILITY_KM},
    "spectrum": BANDS,
    "sun": {"elevation_deg": SUN_ELEVATION_DEG},
    "ground": {"albedo": ALBEDO},
    "sensor": {"type": "fisheye", "resolution": 96, "stokes_frame": "sun_view"},
    "render": {"samples": 64, "seed": 1},
    "output": {"units": "absolute", "preview": False},
}

# The grid a dataset is fitted from (without --dataset).
SPHERES = {
    **FISHEYE,
    "sun": {"elevation_deg": [SUN_ELEVATION_DEG - 1.0, SUN_ELEVATION_DEG, SUN_ELEVATION_DEG + 1.0]},
    "sensor": {"type": "sphere", "resolution": [64, 32], "stokes_frame": "sun_view"},
    "output": {"units": "absolute", "preview": False, "directory": "renders"},
}


def atmosim_binary():
    built = HERE.parents[1] / "target" / "release" / "atmosim"
    return os.environ.get("ATMOSIM_BIN") or (str(built) if built.exists() else shutil.which("atmosim"))


def fit_dataset(work: Path) -> Path:
    """Renders SPHERES and fits a dataset from them with the binary."""
    (work / "renders.toml").write_text(atmosim.Job(SPHERES).text)
    atmosim.render(atmosim.Job(work / "renders.toml"), out=work / "renders")
    (work / "fit.toml").write_text('renders = "renders"\nout = "twilight.dat"\n')
    subprocess.run([atmosim_binary(), "fit", "fit.toml"], cwd=work, check=True, stdout=subprocess.DEVNULL)
    return work / "twilight.dat"


def almucantar(sky, zenith_deg, azimuths_deg):
    """(row, column) of the pixel centre nearest each azimuth on the circle
    of view zenith `zenith_deg`."""
    zen, az = sky.view_zenith_deg.values, sky.azimuth_deg.values
    picks = []
    for phi in azimuths_deg:
        d = np.abs(zen - zenith_deg) + 0.1 * np.abs(((az - phi + 180.0) % 360.0) - 180.0)
        picks.append(np.unravel_index(np.nanargmin(d), d.shape))
    return np.array(picks)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--dataset", help="a fitted dataset (default: fit a small one first)")
    parser.add_argument("--out", default=str(HERE / "twilight.png"))
    parser.add_argument("--work", help="keep the fitted dataset's renders and files here (default: a temporary directory)")
    args = parser.parse_args()

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # The render and the almucantar: pixel directions come with the result.
    sky = atmosim.render(FISHEYE)
    pix = almucantar(sky, 90.0 - SUN_ELEVATION_DEG, np.arange(0.0, 181.0, 4.0))
    rows, cols = pix[:, 0], pix[:, 1]
    zen = sky.view_zenith_deg.values[rows, cols]
    # Azimuths in [0, 180] (the sky is mirror-symmetric about the sun's vertical).
    phi = np.abs(((sky.azimuth_deg.values[rows, cols] + 180.0) % 360.0) - 180.0)
    order = np.argsort(phi, kind="stable")
    rows, cols, zen, phi = rows[order], cols[order], zen[order], phi[order]
    stokes = sky.radiance.sel(albedo=ALBEDO).values[:, :, rows, cols]  # (band, stokes, point)
    I, Q, U = stokes[:, 0], stokes[:, 1], stokes[:, 2]
    dolp = np.hypot(Q, U) / I

    # The fitted model at the same directions (the runtime's frame: z up,
    # the sun at azimuth 0; a view at the ground).
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(args.work or tmp)
        work.mkdir(parents=True, exist_ok=True)
        dataset = args.dataset or fit_dataset(work)
        model = atmosim.SkyModel(dataset)
        t, p = np.radians(zen), np.radians(phi)
        dirs = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
        w = sky.wavelength.values[:, None]
        query = ([0.0, 0.0, 0.0], dirs, SUN_ELEVATION_DEG, 0.0, VISIBILITY_KM, ALBEDO, w)
        I_model = model.sky_radiance(*query)
        # The runtime's polarisation: Q/I in the sun–view frame, the degree
        # of linear polarisation where U is 0 (docs/sky-models.md).
        dolp_model = model.polarisation(*query)

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    colours = plt.cm.turbo(np.linspace(0.05, 0.95, len(w)))
    for k, c in enumerate(colours):
        lam = f"{sky.wavelength.values[k]:.0f} nm"
        ax1.semilogy(phi, I[k], color=c, lw=1.4, label=lam)
        ax1.semilogy(phi, I_model[k], color=c, lw=1.0, ls="--")
        ax2.plot(phi, dolp[k], color=c, lw=1.4)
        ax2.plot(phi, dolp_model[k], color=c, lw=1.0, ls="--")
    ax1.set(xlabel="azimuth from the sun (°)", ylabel="radiance I (W m⁻² sr⁻¹ nm⁻¹)",
            title=f"Solar almucantar, sun at {SUN_ELEVATION_DEG:g}°: render (solid), model (dashed)")
    ax2.set(xlabel="azimuth from the sun (°)", ylabel="degree of linear polarisation",
            title="Degree of polarisation: render (solid), model (dashed)", ylim=(0, 1))
    ax1.legend(fontsize=7, ncol=2)
    fig.savefig(args.out, dpi=80)
    # A palette PNG: a quarter of the bytes, the same picture.
    from PIL import Image

    Image.open(args.out).convert("RGB").quantize(colors=128).save(args.out, optimize=True)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
