//! The statements of CONVENTIONS.md, pinned through the library's public
//! API. Every test names the section it pins and checks a closed form that
//! changes when the convention does (a sign, a factor, an axis), so that a
//! change of convention in the code fails here before it reaches an output.
//!
//! The single-scattering reference below is written from the definitions
//! in CONVENTIONS.md alone (the frame vectors, the Stokes parameters as
//! polariser intensities, the Rayleigh and Henyey–Greenstein elements) and
//! shares no code with the tracer.
//!
//! (Over 600 lines: one file so that CONVENTIONS.md has one place its
//! sections are pinned, in its order.)

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI, SQRT_2};
use std::path::Path;

use atmosim::film::directions::render_directions;
use atmosim::film::fluxes::render_fluxes;
use atmosim::film::tally::{BLOCK, Tally, tally, tally_blocks};
use atmosim::geometry::shell::Geometry;
use atmosim::geometry::sun::Sun;
use atmosim::job::{GeometryKind, Job};
use atmosim::physics::rayleigh;
use atmosim::physics::solar::SolarSpectrum;
use atmosim::polarization::phase::PhaseFunction;
use atmosim::polarization::phase_mixture::PhaseMixture;
use atmosim::polarization::phase_table_set::PhaseTableSet;
use atmosim::polarization::stokes::{Stokes, StokesRotation, meridian_frame, rotation_angle};
use atmosim::polarization::stokes_frame::{StokesFrame, carry};
use atmosim::run::task::render_directions as render_task;
use atmosim::sampling::sampler::Sampler;
use atmosim::sampling::stream::{Estimate, Render, StreamKey};
use atmosim::sensor::camera::{self, Camera, Hemisphere, Projection};
use atmosim::sensor::direction::Direction;
use atmosim::transport::tracer::ViewRay;
use glam::{DQuat, DVec3};

// Helpers

fn job(text: &str) -> Job {
    Job::parse(text, "conventions.toml", Path::new(".")).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b} (tolerance {tol:e})");
}

fn assert_vec_close(a: DVec3, b: DVec3, tol: f64, what: &str) {
    assert!((a - b).length() <= tol, "{what}: {a} vs {b}");
}

fn dir(view_zenith_deg: f64, azimuth_deg: f64) -> Direction {
    Direction {
        view_zenith_deg,
        azimuth_deg,
    }
}

/// v = (sin θ cos φ, sin θ sin φ, cos θ), angles in degrees (§4).
fn view_vector(theta_deg: f64, phi_deg: f64) -> DVec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// The meridian frame of §5.2, written out: e1 = ∂v/∂θ, e2 = (sin φ, −cos φ, 0).
fn meridian_axes(theta_deg: f64, phi_deg: f64) -> (DVec3, DVec3) {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    (
        DVec3::new(t.cos() * p.cos(), t.cos() * p.sin(), -t.sin()),
        DVec3::new(p.sin(), -p.cos(), 0.0),
    )
}

/// Stokes (I, Q, U) of unpolarised intensity `i_unpol` plus light of
/// intensity `i_pol` linearly polarised along `field`, in the frame
/// (e1, e2), straight from the polariser definitions of §5.1.
fn stokes_from_polarisers(i_unpol: f64, i_pol: f64, field: DVec3, e1: DVec3, e2: DVec3) -> [f64; 3] {
    let through = |axis: DVec3| 0.5 * i_unpol + i_pol * field.dot(axis).powi(2);
    let (d_plus, d_minus) = ((e1 + e2) / SQRT_2, (e1 - e2) / SQRT_2);
    [
        through(e1) + through(e2),
        through(e1) - through(e2),
        through(d_plus) - through(d_minus),
    ]
}

/// A homogeneous plane-parallel slab over a black ground: optical depth
/// `tau`, conservative, Rayleigh (depolarisation `rho`) for the fraction
/// `w_rayleigh` of the scattering, Henyey–Greenstein (`g`) for the rest.
#[derive(Clone, Copy)]
struct Slab {
    tau: f64,
    w_rayleigh: f64,
    rho: f64,
    g: f64,
}

impl Slab {
    /// P11 and P12 of §6 at cos Θ.
    fn p11_p12(&self, c: f64) -> (f64, f64) {
        let d = (1.0 - self.rho) / (1.0 + self.rho / 2.0);
        let rayleigh_p11 = d * 0.75 * (1.0 + c * c) + (1.0 - d);
        let rayleigh_p12 = -d * 0.75 * (1.0 - c * c);
        let g = self.g;
        let hg = (1.0 - g * g) / (1.0 + g * g - 2.0 * g * c).powf(1.5);
        (
            self.w_rayleigh * rayleigh_p11 + (1.0 - self.w_rayleigh) * hg,
            self.w_rayleigh * rayleigh_p12,
        )
    }

    /// The exact single-scattering Stokes (I, Q, U) seen along `v` with
    /// reference axis `e1` (e2 = k × e1, k = −v), per unit irradiance normal
    /// to the sun's beam (§7), by an observer at the ground looking up
    /// (v.z > 0) or at the top looking down (v.z < 0). The scattering angle
    /// is that between the propagation directions −s and −v (§6).
    fn single_scattering(&self, sun: DVec3, v: DVec3, e1: DVec3) -> [f64; 3] {
        let (mu0, mu, tau) = (sun.z, v.z.abs(), self.tau);
        // ∫ over the slab of the sunlit source, attenuated to the observer, per unit P/4π.
        let path = if v.z > 0.0 {
            if (mu - mu0).abs() < 1e-9 {
                tau / mu0 * (-tau / mu0).exp()
            } else {
                mu0 / (mu0 - mu) * ((-tau / mu0).exp() - (-tau / mu).exp())
            }
        } else {
            mu0 / (mu0 + mu) * (1.0 - (-tau * (1.0 / mu0 + 1.0 / mu)).exp())
        };
        let (p11, p12) = self.p11_p12(sun.dot(v));
        let scale = path / (4.0 * PI);
        // The polarised part (−P12) has its E-vector perpendicular to the
        // scattering plane, the plane of s and v.
        let n = sun.cross(v);
        let n = if n.length() > 0.0 { n.normalize() } else { e1 };
        let e2 = (-v).cross(e1);
        let i_pol = -p12 * scale;
        stokes_from_polarisers(p11 * scale - i_pol, i_pol, n, e1, e2)
    }

    /// Job text: the slab as one layer 0–1 km, the sun at `elevation_deg`,
    /// `render` added to the `[render]` table (seed 3 unless it says).
    fn job_text(&self, elevation_deg: f64, render: &str) -> String {
        let (tau_r, tau_a) = (self.tau * self.w_rayleigh, self.tau * (1.0 - self.w_rayleigh));
        format!(
            "[planet]\ngeometry = \"plane_parallel\"\n[[atmosphere.layers]]\nbottom_km = 0.0\ntop_km = 1.0\n\
             tau_rayleigh = {tau_r:?}\nrayleigh_depolarization = {:?}\ntau_aerosol = {tau_a:?}\naerosol_ssa = 1.0\n\
             aerosol_g = {:?}\n[sun]\nelevation_deg = {elevation_deg:?}\n[render]\n{render}{}",
            self.rho,
            self.g,
            if render.contains("seed") { "" } else { "seed = 3\n" }
        )
    }
}

/// The `[render]` line of single scattering only.
const SINGLE: &str = "max_scattering_order = 1\n";

/// Checks a tally against a reference to 4 standard errors, plus `floor`.
fn assert_tally(t: &Tally, reference: [f64; 3], floor: f64, what: &str) {
    let (m, se) = (t.mean(), t.standard_error());
    for k in 0..3 {
        assert!(
            (m[k] - reference[k]).abs() <= 4.0 * se[k] + floor,
            "{what}, Stokes {k}: {} ± {} vs exact {}",
            m[k],
            se[k],
            reference[k]
        );
    }
}

/// Rows of a reference table of the repository, keeping those `keep` accepts.
fn reference_rows(rel: &str, keep: impl Fn(&str) -> bool) -> Vec<Vec<f64>> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty() && keep(l))
        .map(|l| l.split_whitespace().map(|x| x.parse().unwrap()).collect())
        .collect()
}

// §1 Units

#[test]
fn s1_units_wavelengths_in_nm_coefficients_in_per_km() {
    // Explicit layers: an optical depth over a thickness in km gives km⁻¹.
    let j = job(
        "[planet]\ngeometry = \"plane_parallel\"\n[[atmosphere.layers]]\nbottom_km = 0.0\ntop_km = 2.0\n\
         tau_rayleigh = 0.1\ntau_absorption = 0.04\n[spectrum]\nwavelengths_nm = [550.0]\n",
    );
    let a = &j.atmosphere;
    assert_eq!(a.levels_km, vec![0.0, 2.0]);
    assert_eq!(a.wavelengths_nm, vec![550.0]);
    assert_close(a.optics[0][0].sigma_rayleigh, 0.05, 1e-15, "σ_Rayleigh (km⁻¹)");
    assert_close(a.optics[0][0].sigma_absorption, 0.02, 1e-15, "σ_abs (km⁻¹)");

    // A profile: Bodhaine's cross section is per molecule in cm² (its unit
    // in its name), converted once on load; the US-standard Rayleigh
    // optical depth at 550 nm is 0.097 (Bodhaine et al. 1999), which nm
    // read as µm or a coefficient in m⁻¹ would miss by orders of magnitude.
    let sigma = rayleigh::cross_section_cm2(550.0, 3.6e-4);
    assert!((4.3e-27..4.7e-27).contains(&sigma), "{sigma:e} cm²");
    let j = job("[atmosphere]\naerosol = \"none\"\nozone = \"none\"\n[spectrum]\nwavelengths_nm = [550.0]\n");
    let tau = j.atmosphere.column(0).tau_rayleigh;
    assert!((0.095..0.099).contains(&tau), "τ_Rayleigh(550 nm) = {tau}");
    let ground = j.atmosphere.optics[0][0].sigma_rayleigh;
    assert!(
        (0.0105..0.0125).contains(&ground),
        "σ_Rayleigh at the ground = {ground} km⁻¹"
    );
}

#[test]
fn s1_units_angles_in_degrees_at_the_edges_and_radians_inside() {
    // Job keys are in degrees; the resolved sun keeps its zenith angle in
    // degrees (`zenith_deg`) and its disc radius in radians.
    let j = job("[sun]\nelevation_deg = 20.0\nangular_radius_deg = 0.2666\n[atmosphere]\naerosol = \"none\"\n");
    let sun = j.tasks[0].sun;
    assert_close(sun.zenith_deg, 70.0, 1e-12, "zenith_deg");
    assert_close(
        sun.angular_radius,
        0.2666f64.to_radians(),
        1e-15,
        "angular radius (rad)",
    );
    assert!(j.tasks[0].name.contains("elev+20.0"), "{}", j.tasks[0].name);
    // `Direction` (the job's and the outputs' view) is in degrees, the
    // camera's `direction` and a pixel ray's azimuth in radians.
    let d = dir(30.0, 45.0);
    assert_vec_close(
        d.vector(),
        camera::direction(FRAC_PI_2 / 3.0, FRAC_PI_4),
        1e-15,
        "degrees vs radians",
    );
    let fisheye = Camera::Fisheye {
        resolution: 100,
        hemisphere: Hemisphere::Up,
        projection: Projection::Equidistant,
    };
    let right = fisheye.ray_at(100.0, 50.0).unwrap();
    assert_close(right.azimuth, FRAC_PI_2, 1e-15, "pixel azimuth (rad)");
    // Ranges are checked in degrees.
    assert!(Job::parse("[sensor]\nview_zenith_deg = [180.0]\n", "t", Path::new(".")).is_ok());
    assert!(Job::parse("[sensor]\nview_zenith_deg = [181.0]\n", "t", Path::new(".")).is_err());
}

#[test]
fn s1_units_lengths_in_job_files_name_their_unit() {
    let j = job("[observer]\naltitude_km = 1.5\n[atmosphere]\naerosol = \"none\"\n");
    assert_eq!(j.tasks[0].observer_altitude_km, 1.5);
    // Task names give the observer's altitude in metres, and say so.
    assert!(j.tasks[0].name.ends_with("_alt01500m"), "{}", j.tasks[0].name);
    // A length without its unit in the key is refused.
    assert!(Job::parse("[observer]\naltitude = 1.5\n", "t", Path::new(".")).is_err());
    assert!(Job::parse("[planet]\ntop = 100.0\n", "t", Path::new(".")).is_err());
}

// §2 Planet and atmosphere

#[test]
fn s2_planet_default_radius_top_and_a_separate_plane_parallel_geometry() {
    let j = job("[atmosphere]\naerosol = \"none\"\nozone = \"none\"\n[spectrum]\nwavelengths_nm = [550.0]\n");
    assert_eq!(j.planet.radius_km, 6378.0);
    assert_eq!(j.planet.top_km, 100.0);
    assert_eq!(j.atmosphere.top_km(), 100.0);
    assert_eq!(j.atmosphere.levels_km[0], 0.0);
    assert_eq!(j.geometry(), Geometry::Spherical { radius_km: 6378.0 });
    // Spherical: the planet's centre at the origin, the observer on +z, up radial.
    let g = j.geometry();
    assert_vec_close(g.observer_position(2.0), DVec3::new(0.0, 0.0, 6380.0), 0.0, "observer");
    assert_vec_close(g.up(DVec3::new(6380.0, 0.0, 0.0)), DVec3::X, 1e-15, "up");

    // The radius and the top are configurable (libRadtran: 6370 km, 120 km).
    let j = job(
        "[planet]\nradius_km = 6370.0\ntop_km = 120.0\n[atmosphere]\naerosol = \"none\"\nozone = \"none\"\n\
         [spectrum]\nwavelengths_nm = [550.0]\n",
    );
    assert_eq!(j.geometry(), Geometry::Spherical { radius_km: 6370.0 });
    assert_eq!(j.atmosphere.top_km(), 120.0);

    // Plane-parallel: its own geometry, with the same up everywhere.
    let j = job("[planet]\ngeometry = \"plane_parallel\"\n[[atmosphere.layers]]\nbottom_km = 0.0\ntop_km = 1.0\n");
    assert_eq!(j.planet.geometry, GeometryKind::PlaneParallel);
    assert_eq!(j.geometry(), Geometry::PlaneParallel);
    let g = j.geometry();
    assert_vec_close(g.observer_position(0.5), DVec3::new(0.0, 0.0, 0.5), 0.0, "observer");
    assert_eq!(g.up(DVec3::new(1.0e4, -3.0e3, 0.5)), DVec3::Z);
    assert_eq!(g.altitude(DVec3::new(1.0e4, 0.0, 0.25)), 0.25);
}

// §3 The observer's frame and the sun

#[test]
fn s3_sun_vector_from_elevation_with_x_toward_the_sun_azimuth() {
    for elevation in [60.0f64, 5.0, 0.0, -4.0] {
        let j = job(&format!(
            "[sun]\nelevation_deg = {elevation:?}\n[atmosphere]\naerosol = \"none\"\nozone = \"none\"\n\
             [spectrum]\nwavelengths_nm = [550.0]\n"
        ));
        let sun = j.tasks[0].sun;
        let eta = elevation.to_radians();
        assert_vec_close(sun.direction, DVec3::new(eta.cos(), 0.0, eta.sin()), 1e-15, "s");
        assert_eq!(sun.direction.y, 0.0, "the sun's azimuth is the x axis");
        assert_close(sun.zenith_deg, 90.0 - elevation, 1e-12, "solar zenith angle");
        assert_close(sun.mu0(), eta.sin(), 1e-15, "μ0");
    }
    // `zenith_deg` is the other way to say it.
    let s = Sun::new(94.0, 0.0).direction;
    assert_vec_close(
        s,
        DVec3::new(4f64.to_radians().cos(), 0.0, -(4f64.to_radians().sin())),
        1e-15,
        "s",
    );
    // y = z × x: the horizontal direction 90° counter-clockwise (from above)
    // from the sun's azimuth.
    assert_vec_close(dir(90.0, 90.0).vector(), DVec3::Z.cross(DVec3::X), 1e-15, "y");
}

// §4 Viewing directions

#[test]
fn s4_view_directions_from_zenith_angle_and_counter_clockwise_azimuth() {
    for (theta, phi) in [
        (0.0, 0.0),
        (30.0, 0.0),
        (90.0, 0.0),
        (90.0, 90.0),
        (120.0, -45.0),
        (180.0, 10.0),
    ] {
        assert_vec_close(dir(theta, phi).vector(), view_vector(theta, phi), 1e-15, "v(θ, φ)");
    }
    // θ = 0 zenith, 90 horizon, 180 nadir; φ = 0 looks toward the sun's azimuth.
    assert_vec_close(dir(0.0, 0.0).vector(), DVec3::Z, 1e-15, "zenith");
    assert_vec_close(dir(180.0, 0.0).vector(), -DVec3::Z, 1e-15, "nadir");
    let sun = Sun::new(60.0, 0.0).direction;
    assert_vec_close(dir(60.0, 0.0).vector(), sun, 1e-15, "looking at the sun");
    assert!(dir(90.0, 0.0).vector().dot(sun) > 0.0 && dir(90.0, 180.0).vector().dot(sun) < 0.0);
    // The light propagates along k = −v: the frame's e1 × e2.
    let v = dir(50.0, 130.0).vector();
    let (e1, e2) = meridian_frame(v, 0.0);
    assert_vec_close(e1.cross(e2), -v, 1e-15, "e1 × e2 = k = −v");
}

// §5 Stokes vectors

#[test]
fn s5_2_single_scattering_has_the_iprt_signs_in_the_meridian_frame() {
    // Rayleigh with depolarisation: the tracer's single scattering against
    // the closed form, in the meridian frame written out from §5.2. A
    // change of frame, of the sign of Q or U, of the azimuth's sense or of
    // the normalisation fails here.
    let slab = Slab {
        tau: 0.1,
        w_rayleigh: 1.0,
        rho: 0.03,
        g: 0.0,
    };
    let elevation = 30.0f64;
    let j = job(&slab.job_text(elevation, SINGLE));
    let sun = j.tasks[0].sun.direction;
    let up = [
        (0.0, 0.0),
        (0.0, 90.0),
        (30.0, 0.0),
        (60.0, 60.0),
        (60.0, 300.0),
        (75.0, 200.0),
    ];
    let down = [(180.0, 0.0), (120.0, 60.0), (120.0, 300.0), (150.0, 180.0)];
    let mut means = Vec::new();
    for (altitude, set) in [(0.0, &up[..]), (1.0, &down[..])] {
        let dirs: Vec<Direction> = set.iter().map(|&(t, p)| dir(t, p)).collect();
        let tallies = render_directions(&j.scene(0), altitude, &dirs, 2048, 3, Render::channel(0, 0));
        for (&(t, p), tl) in set.iter().zip(&tallies) {
            let (e1, _) = meridian_axes(t, p);
            let exact = slab.single_scattering(sun, view_vector(t, p), e1);
            assert_tally(tl, exact, 1e-12, &format!("θ {t} φ {p}"));
            means.push(((t, p), tl.mean()));
        }
    }
    let at = |t: f64, p: f64| means.iter().find(|(d, _)| *d == (t, p)).unwrap().1;
    // Sun at 30° elevation, observer under the slab. At the zenith with
    // φ = 0 the meridian plane holds the sun: E ⟂ to it, Q < 0, U = 0; the
    // meridian plane of φ = 90° is perpendicular to the sun's: Q > 0.
    assert!(at(0.0, 0.0)[1] < 0.0 && at(0.0, 90.0)[1] > 0.0);
    assert!(at(0.0, 0.0)[2].abs() < 1e-15 && at(30.0, 0.0)[2].abs() < 1e-15);
    // U is odd in φ and positive at φ = +60° (counter-clockwise from the
    // sun's azimuth seen from above), as in the IPRT tables; I and Q even.
    let (a, b) = (at(60.0, 60.0), at(60.0, 300.0));
    assert!(a[2] > 0.0 && b[2] < 0.0, "U(60°, ±60°): {} {}", a[2], b[2]);
    assert_close(a[0], b[0], 1e-2 * a[0], "I even in φ");
    assert_close(a[2], -b[2], 2e-2 * a[2], "U odd in φ");
    // Looking down at the nadir (φ = 0: e1 away from the sun's azimuth).
    assert!(at(180.0, 0.0)[1] < 0.0);
}

#[test]
fn s5_3_zenith_and_nadir_take_the_meridian_plane_of_the_requested_azimuth() {
    for phi in [0.0f64, 35.0, 90.0, 200.0] {
        let (c, s) = (phi.to_radians().cos(), phi.to_radians().sin());
        // Looking up: e1 toward the azimuth φ; looking down: away from it.
        assert_vec_close(dir(0.0, phi).meridian_axis(), DVec3::new(c, s, 0.0), 1e-15, "zenith e1");
        assert_vec_close(
            dir(180.0, phi).meridian_axis(),
            DVec3::new(-c, -s, 0.0),
            1e-15,
            "nadir e1",
        );
        // The limit of the meridian frame of θ → 0 along φ.
        assert_vec_close(
            dir(0.0, phi).meridian_axis(),
            dir(1e-7, phi).meridian_axis(),
            1e-8,
            "continuity",
        );
        assert_vec_close(
            dir(0.0, phi).meridian_axis(),
            StokesFrame::Meridian.axis(DVec3::Z, phi.to_radians(), DVec3::X),
            1e-15,
            "frame",
        );
    }
}

#[test]
fn s5_4_sun_view_output_is_the_meridian_output_rotated() {
    // The same job and streams in both frames: the sun–view output is the
    // meridian one rotated by §5.6, where single Rayleigh scattering is
    // Q = +DoLP·I, U = 0 (the sky model's signed degree of polarisation).
    // Along the sun the plane is undefined and the meridian axis is kept.
    let slab = Slab {
        tau: 0.1,
        w_rayleigh: 1.0,
        rho: 0.0,
        g: 0.0,
    };
    let render = |frame: &str| {
        let text = slab.job_text(30.0, "max_scattering_order = 1\nsamples = 512\n")
            + "[spectrum]\nwavelengths_nm = [550.0]\n[sensor]\nfluxes = false\n\
               directions = [[0.0, 0.0], [60.0, 0.0], [40.0, 120.0], [80.0, 250.0]]\n"
            + &format!("stokes_frame = \"{frame}\"\n");
        let j = job(&text);
        let task = &j.tasks[0];
        (render_task(&j, task, &|_| {}).unwrap().radiance, task.sun.direction)
    };
    let (meridian, sun) = render("meridian");
    let (sun_view, _) = render("sun_view");
    for (m, s) in meridian.iter().zip(&sun_view) {
        let v = m.direction.vector();
        let e1_m = m.direction.axis(StokesFrame::Meridian, sun);
        let e1_s = s.direction.axis(StokesFrame::SunView, sun);
        let rotated = StokesRotation::between(e1_m, e1_s, -v).apply(Stokes(m.tally.mean()));
        let got = s.tally.mean();
        for k in 0..4 {
            assert_close(
                got[k],
                rotated.0[k],
                1e-12 * got[0],
                &format!("{:?} Stokes {k}", m.direction),
            );
        }
        if v.cross(sun).length() > 1e-6 {
            assert!(
                got[1] > 0.0 && got[2].abs() < 1e-12 * got[0],
                "{:?}: {got:?}",
                s.direction
            );
            assert_vec_close(e1_s, sun.cross(v).normalize(), 1e-12, "e1 ∥ s × v");
        } else {
            assert_vec_close(e1_s, e1_m, 1e-15, "along the sun: the meridian axis");
        }
    }
}

#[test]
fn s5_5_a_pixel_frame_is_its_centre_frame_carried_by_the_shortest_rotation() {
    // The carried axis is the centre's axis turned by the rotation that
    // takes the centre direction c to the sample direction d about c × d.
    let sun = Sun::new(60.0, 0.0).direction;
    for (c, d) in [
        (view_vector(0.0, 0.0), view_vector(3.0, 70.0)),
        (view_vector(45.0, 10.0), view_vector(47.0, 14.0)),
        (view_vector(170.0, -30.0), view_vector(178.0, 100.0)),
        (view_vector(89.0, 200.0), view_vector(92.0, 195.0)),
    ] {
        for frame in [StokesFrame::Meridian, StokesFrame::SunView] {
            let e1 = frame.axis(c, 0.0, sun);
            let expected = DQuat::from_rotation_arc(c, d) * e1;
            assert_vec_close(carry(e1, c, d), expected, 1e-12, "carried axis");
        }
    }
    // A fisheye pixel centred on the pole takes the meridian plane of
    // azimuth 0: e1 toward the sun's azimuth looking up, away from it looking down.
    for (hemisphere, e1) in [(Hemisphere::Up, DVec3::X), (Hemisphere::Down, -DVec3::X)] {
        let cam = Camera::Fisheye {
            resolution: 21,
            hemisphere,
            projection: Projection::Equisolid,
        };
        let centre = cam.centre_ray(10, 10).unwrap();
        assert_vec_close(centre.direction.abs(), DVec3::Z, 1e-15, "pole pixel");
        let axis = StokesFrame::Meridian.axis(centre.direction, centre.azimuth, sun);
        assert_vec_close(axis, e1, 1e-15, "pole pixel axis");
    }
}

#[test]
fn s5_6_rotation_turns_the_axis_counter_clockwise_about_k() {
    // Light polarised along (e1 + e2)/√2 is U = +1. Turning the axis by
    // +45° (from e1 toward e2) puts it on the field: Q' = +1, U' = 0;
    // turning it by −45° puts it across: Q' = −1.
    let v = view_vector(50.0, 30.0);
    let (e1, e2) = meridian_axes(50.0, 30.0);
    let k = -v;
    let diagonal = (e1 + e2) / SQRT_2;
    let psi = rotation_angle(e1, diagonal, k);
    assert_close(psi, FRAC_PI_4, 1e-15, "ψ from e1 toward e2");
    let u = Stokes::new(1.0, 0.0, 1.0, 0.0);
    let turned = u.rotated(psi);
    assert_close(turned.q(), 1.0, 1e-15, "Q'");
    assert_close(turned.u(), 0.0, 1e-15, "U'");
    let across = u.rotated(rotation_angle(e1, (e1 - e2) / SQRT_2, k));
    assert_close(across.q(), -1.0, 1e-15, "Q'");
    // The tracer's trigonometry-free form turns the same way.
    let fast = StokesRotation::between(e1, diagonal, k).apply(u);
    assert_close(fast.q(), 1.0, 1e-15, "Q' (StokesRotation)");
    assert_close(fast.u(), 0.0, 1e-15, "U' (StokesRotation)");
    // The same from the polariser definitions in the new frame.
    let new_e2 = k.cross(diagonal);
    let direct = stokes_from_polarisers(0.0, 1.0, diagonal, diagonal, new_e2);
    assert_close(direct[1], turned.q(), 1e-15, "Q' by definition");
    assert_close(direct[2], turned.u(), 1e-15, "U' by definition");
}

#[test]
fn s5_7_reference_tables_agree_with_the_single_scattering_signs() {
    // The reference files in validation/published are converted to these
    // conventions (validation/README.md). In the thinnest Natraj 2009 slab
    // (τ = 0.02, black ground) single scattering is nearly everything: I,
    // Q and U agree with the closed form to within 0.1·I (multiple
    // scattering is at most 0.074·I here), so the π and the sign of Q
    // (Q = −Q_Natraj/π) and of U (U = +U_Natraj/π) are right: a wrong sign
    // would miss by at least 0.5·I, a wrong π by 0.68·I.
    let slab = Slab {
        tau: 0.02,
        w_rayleigh: 1.0,
        rho: 0.0,
        g: 0.0,
    };
    let rows = reference_rows("validation/published/natraj2009.txt", |l| l.starts_with("0.02 0.00 "));
    let mut checked = [0usize; 3];
    for r in &rows {
        let (mu0, theta, phi) = (r[2], r[4], r[5]);
        let sun = DVec3::new((1.0 - mu0 * mu0).sqrt(), 0.0, mu0);
        let v = view_vector(theta, phi);
        if v.z.abs() < 0.2 || mu0 < 0.2 {
            continue;
        }
        let exact = slab.single_scattering(sun, v, meridian_axes(theta, phi).0);
        for k in 0..3 {
            if k == 0 || exact[k].abs() > 0.25 * exact[0] {
                let what = format!("Natraj μ0 {mu0} θ {theta:.2} φ {phi} Stokes {k}");
                assert_close(r[6 + k], exact[k], 0.1 * exact[0], &what);
                checked[k] += 1;
            }
        }
    }
    assert!(checked.iter().all(|&n| n > 50), "{checked:?}");

    // IPRT A1 (τ 0.5, depolarisation 0.03, sun zenith 30°, MYSTIC): φ is
    // rel_az and Q, U are IPRT's own: where single scattering polarises
    // strongly (|Q| or |U| > 0.3·I), MYSTIC's value is the single-scattering
    // one plus 14–50 % of multiple scattering, never of the other sign.
    let slab = Slab {
        tau: 0.5,
        w_rayleigh: 1.0,
        rho: 0.03,
        g: 0.0,
    };
    let sun = Sun::new(30.0, 0.0).direction;
    let rows = reference_rows("validation/published/iprt_a1_depol0.03.txt", |_| true);
    let mut checked = [0usize; 2];
    for r in &rows {
        let (theta, phi) = (r[1], r[2]);
        let v = view_vector(theta, phi);
        if v.z.abs() < 0.2 || (r[0] == 0.0) != (v.z > 0.0) {
            continue;
        }
        let exact = slab.single_scattering(sun, v, meridian_axes(theta, phi).0);
        for k in 1..3 {
            if exact[k].abs() > 0.3 * exact[0] {
                let ratio = r[3 + k] / exact[k];
                assert!(
                    (1.0..2.0).contains(&ratio),
                    "IPRT A1 zout {} θ {theta} φ {phi} Stokes {k}: {} vs single scattering {}",
                    r[0],
                    r[3 + k],
                    exact[k]
                );
                checked[k - 1] += 1;
            }
        }
    }
    assert!(checked.iter().all(|&n| n > 50), "{checked:?}");
}

// §6 Phase matrices

#[test]
fn s6_phase_functions_and_their_mixtures_integrate_to_four_pi() {
    // (1/4π)∫P11 dΩ = ½∫P11 dμ by composite Gauss–Legendre (4 points on
    // each of 400 intervals), for each function and a σ_s-weighted mixture.
    let nodes = [
        (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
        (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
        (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
        (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    ];
    let integrate = |f: &dyn Fn(f64) -> f64| {
        let n = 400;
        let h = 2.0 / n as f64;
        (0..n)
            .map(|i| {
                let mid = -1.0 + (i as f64 + 0.5) * h;
                nodes.iter().map(|&(x, w)| w * f(mid + 0.5 * h * x)).sum::<f64>() * 0.5 * h
            })
            .sum::<f64>()
    };
    let rayleigh = PhaseFunction::Rayleigh { depolarization: 0.0279 };
    let hg = PhaseFunction::HenyeyGreenstein { g: 0.7 };
    let mixture = PhaseMixture::new(0.4, 0.0279, 0.6, 0.7);
    for (what, f) in [
        ("Rayleigh", &(|mu| rayleigh.p11(mu)) as &dyn Fn(f64) -> f64),
        ("HG", &|mu| hg.p11(mu)),
        ("mixture", &|mu| mixture.matrix(&PhaseTableSet::EMPTY.locate(mu)).p11),
    ] {
        assert_close(0.5 * integrate(f), 1.0, 1e-10, what);
    }
    // The sampling density per steradian is P11/4π.
    assert_close(2.0 * PI * integrate(&|mu| hg.pdf(mu)), 1.0, 1e-10, "pdf");
}

#[test]
fn s6_depolarisation_factor_from_the_king_factor() {
    // ρ = 6(F − 1)/(3 + 7F), with Bodhaine's King factor of air: ρ ≈ 0.028 at 550 nm.
    let f = rayleigh::king_factor(550.0, 3.6e-4);
    let rho = rayleigh::depolarization(550.0, 3.6e-4);
    assert_close(rho, 6.0 * (f - 1.0) / (3.0 + 7.0 * f), 1e-15, "ρ(F)");
    assert!((0.0275..0.0285).contains(&rho), "ρ(550 nm) = {rho}");
}

#[test]
fn s6_scattering_angle_forward_and_henyey_greenstein_unpolarised() {
    // An aerosol slab (HG g = 0.7) and a mixed one: cos Θ = s·v, so looking
    // toward the sun is the forward peak (Θ = 0); HG adds no polarisation.
    for w_rayleigh in [0.0, 0.5] {
        let slab = Slab {
            tau: 0.1,
            w_rayleigh,
            rho: 0.03,
            g: 0.7,
        };
        let j = job(&slab.job_text(30.0, SINGLE));
        let sun = j.tasks[0].sun.direction;
        let set = [(55.0, 0.0), (60.0, 10.0), (30.0, 180.0), (70.0, 120.0), (0.0, 45.0)];
        let dirs: Vec<Direction> = set.iter().map(|&(t, p)| dir(t, p)).collect();
        let tallies = render_directions(&j.scene(0), 0.0, &dirs, 2048, 5, Render::channel(0, 0));
        for (&(t, p), tl) in set.iter().zip(&tallies) {
            let exact = slab.single_scattering(sun, view_vector(t, p), meridian_axes(t, p).0);
            assert_tally(tl, exact, 1e-12, &format!("w_R {w_rayleigh} θ {t} φ {p}"));
            if w_rayleigh == 0.0 {
                assert_eq!([tl.mean()[1], tl.mean()[2]], [0.0, 0.0], "HG alone: unpolarised");
            }
        }
        // Forward (5° from the sun) far brighter than backward.
        assert!(tallies[0].mean()[0] > 5.0 * tallies[2].mean()[0]);
    }
}

// §7 Radiance normalisation

#[test]
fn s7_sky_radiance_excludes_the_sun_which_is_reported_apart() {
    // A sun disc (α = 0.2666°) behind a thin Rayleigh slab, looking at its
    // centre: the radiance is the single-scattering closed form, ~0.02
    // sr⁻¹, not the disc's e^(−τ/μ0)/(πα²) ≈ 4e4 sr⁻¹. The direct beam is
    // the scene's direct irradiance, per unit E0: T normal to the beam,
    // μ0·T on a horizontal plane.
    let slab = Slab {
        tau: 0.1,
        w_rayleigh: 1.0,
        rho: 0.0,
        g: 0.0,
    };
    let text = slab
        .job_text(30.0, SINGLE)
        .replace("[sun]\n", "[sun]\nangular_radius_deg = 0.2666\n");
    let j = job(&text);
    let scene = j.scene(0);
    let sun = j.tasks[0].sun.direction;
    let t = &render_directions(&scene, 0.0, &[dir(60.0, 0.0)], 1024, 3, Render::channel(0, 0))[0];
    let exact = slab.single_scattering(sun, sun, meridian_axes(60.0, 0.0).0);
    // The disc blurs the forward scattering by O(α²).
    assert_tally(t, exact, 1e-4 * exact[0], "looking at the sun");
    let transmittance = (-0.1f64 / 0.5).exp();
    assert_close(scene.direct_normal(0.0, 0, true), transmittance, 1e-14, "direct normal");
    assert_close(
        scene.direct_horizontal(0.0, 0),
        0.5 * transmittance,
        1e-14,
        "direct horizontal",
    );
}

#[test]
fn s7_absolute_units_scale_by_the_extraterrestrial_irradiance_at_output() {
    let base = "[atmosphere]\naerosol = \"none\"\nozone = \"none\"\n[spectrum]\nwavelengths_nm = [550.0]\n";
    let normalised = job(base);
    assert!(normalised.solar.is_none());
    assert_eq!(normalised.unit_scale(550.0), 1.0);
    let absolute = job(&format!("{base}[output]\nunits = \"absolute\"\n"));
    let e0 = SolarSpectrum::kurucz().unwrap().irradiance(550.0).unwrap();
    // W m⁻² nm⁻¹: about 1.9 at 550 nm.
    assert!((1.7..2.1).contains(&e0), "E0(550 nm) = {e0}");
    assert_eq!(absolute.unit_scale(550.0), e0);
    // The scene itself stays normalised (the tracer weights by the source
    // only for bands, whose average of E0·L is not a product).
    assert!(!absolute.tracer_weights_by_solar());
}

// §8 Fluxes

#[test]
fn s8_fluxes_are_horizontal_irradiances_per_unit_e0() {
    // e_down = ∫ I μ dΩ over the upper hemisphere, against the quadrature
    // of the closed-form single-scattering radiance; e_dir = μ0·e^(−τ/μ0);
    // nothing comes up from a black ground.
    let slab = Slab {
        tau: 0.1,
        w_rayleigh: 1.0,
        rho: 0.03,
        g: 0.0,
    };
    let j = job(&slab.job_text(30.0, SINGLE));
    let sun = j.tasks[0].sun.direction;
    let (n_mu, n_phi) = (2000, 180);
    let mut e_down = 0.0;
    for a in 0..=n_mu {
        let mu = a as f64 / n_mu as f64;
        if mu == 0.0 {
            continue; // the integrand is 0 at the horizon (μ factor)
        }
        let simpson = if a == n_mu {
            1.0
        } else if a % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let ring: f64 = (0..n_phi)
            .map(|b| {
                let phi = 2.0 * PI * (b as f64 + 0.5) / n_phi as f64;
                let (theta, phi) = (mu.acos().to_degrees(), phi.to_degrees());
                slab.single_scattering(sun, view_vector(theta, phi), meridian_axes(theta, phi).0)[0]
            })
            .sum::<f64>()
            * 2.0
            * PI
            / n_phi as f64;
        e_down += simpson * ring * mu / (3.0 * n_mu as f64);
    }
    let f = render_fluxes(&j.scene(0), 0.0, 8192, 7, Render::channel(0, 0));
    assert!(
        (f.e_down - e_down).abs() < 4.0 * f.e_down_se,
        "e_down {} ± {} vs {e_down}",
        f.e_down,
        f.e_down_se
    );
    assert_close(f.e_dir, 0.5 * (-0.2f64).exp(), 1e-14, "e_dir");
    assert_eq!(f.e_up, 0.0);
}

// §9 Images

#[test]
fn s9_fisheye_panorama_and_sphere_pixels_map_to_known_directions() {
    // Pixel centres at known image points, against the projections of §9
    // written out: dx = (x − N/2)/(N/2), dy = (N/2 − y)/(N/2).
    let fisheye = |hemisphere, projection| Camera::Fisheye {
        resolution: 20,
        hemisphere,
        projection,
    };
    let rho = 0.55 * SQRT_2; // pixel centres (4.5 or 15.5, 4.5 or 15.5)
    let equisolid = 2.0 * (rho / SQRT_2).asin();
    let stereographic = 2.0 * rho.atan();
    let equidistant = rho * FRAC_PI_2;
    let deg = f64::to_degrees;
    for (cam, (i, j), theta, phi) in [
        // Up: image up is the sun's azimuth, image right φ = +90°.
        (
            fisheye(Hemisphere::Up, Projection::Equisolid),
            (15, 4),
            deg(equisolid),
            45.0,
        ),
        (
            fisheye(Hemisphere::Up, Projection::Stereographic),
            (4, 4),
            deg(stereographic),
            -45.0,
        ),
        (
            fisheye(Hemisphere::Up, Projection::Equidistant),
            (4, 15),
            deg(equidistant),
            -135.0,
        ),
        // Down: image up is the sun's azimuth, image right φ = −90°.
        (
            fisheye(Hemisphere::Down, Projection::Equisolid),
            (15, 4),
            180.0 - deg(equisolid),
            -45.0,
        ),
        (
            fisheye(Hemisphere::Down, Projection::Equidistant),
            (4, 15),
            180.0 - deg(equidistant),
            135.0,
        ),
        // Panorama 180 × 90: φ = 90° − 180°·x/w, elevation 90° − 180°·y/h.
        (Camera::Panorama { width: 180, height: 90 }, (44, 29), 90.0 - 31.0, 45.5),
        // Sphere 360 × 180: φ = 180° − 360°·x/w.
        (
            Camera::Sphere {
                width: 360,
                height: 180,
            },
            (270, 45),
            90.0 - 44.5,
            -90.5,
        ),
    ] {
        let ray = cam.centre_ray(i, j).unwrap();
        assert_vec_close(
            ray.direction,
            view_vector(theta, phi),
            1e-12,
            &format!("{cam:?} ({i}, {j})"),
        );
    }
}

// §10 Randomness and determinism

#[test]
fn s10_a_sample_is_a_function_of_its_keys() {
    // A task's direction estimate is the sum over sample indices i of the
    // sample drawn from the stream (seed, task · 2³² + channel, direction
    // index, i): recomputed here one sample at a time.
    let slab = Slab {
        tau: 0.3,
        w_rayleigh: 0.7,
        rho: 0.03,
        g: 0.6,
    };
    let text = slab.job_text(40.0, "seed = 77\nsamples = 200\n")
        + "[sensor]\ndirections = [[20.0, 30.0], [65.0, 250.0]]\nfluxes = false\n[spectrum]\nwavelengths_nm = [500.0]\n";
    let j = job(&text);
    let rows = render_task(&j, &j.tasks[0], &|_| {}).unwrap().radiance;
    let scene = j.scene(0);
    for (d, row) in rows.iter().enumerate() {
        let mut by_hand = Tally::default();
        let mut out = vec![Stokes::zero(); scene.value_count()];
        for i in 0..200 {
            let mut s = Sampler::new(&[77, 0, d as u64, i]);
            let v = row.direction.vector();
            scene.radiance_sample(
                0.0,
                v,
                row.direction.meridian_axis(),
                ViewRay::Repeated,
                &mut s,
                &mut out,
            );
            by_hand.add(&out[0]);
        }
        assert_eq!(row.tally, by_hand, "direction {d}");
    }
}

#[test]
fn s10_thread_count_changes_no_bit_and_shards_merge_to_rounding() {
    let slab = Slab {
        tau: 0.3,
        w_rayleigh: 0.7,
        rho: 0.03,
        g: 0.6,
    };
    let j = job(&slab.job_text(20.0, ""));
    let scene = j.scene(0);
    // Fluxes in pools of 1 and 3 threads.
    let fluxes = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| render_fluxes(&scene, 0.0, 3000, 9, Render::channel(0, 4)))
    };
    assert_eq!(fluxes(1), fluxes(3));
    // A direction estimate split into two shards of blocks, each summed on
    // its own and then merged, equals the whole to 1e-12 (relative).
    let samples = 3 * BLOCK + 100;
    let (v, e1) = (dir(50.0, 140.0).vector(), dir(50.0, 140.0).meridian_axis());
    let f = |s: &mut Sampler, out: &mut [Stokes]| scene.radiance_sample(0.0, v, e1, ViewRay::Repeated, s, out);
    let keys = StreamKey::new(9, Render::channel(0, 0), Estimate::Direction(0));
    let whole = tally(samples, keys, 1, f)[0];
    let mut first = vec![Tally::default()];
    let mut second = vec![Tally::default()];
    tally_blocks(0..2, samples, keys, &mut first, f);
    tally_blocks(2..4, samples, keys, &mut second, f);
    let mut merged = first[0];
    merged.merge(&second[0]);
    assert_eq!(merged.samples, whole.samples);
    for k in 0..4 {
        let scale = whole.sum[k].abs().max(1e-300);
        assert!((merged.sum[k] - whole.sum[k]).abs() <= 1e-12 * scale, "Σ Stokes {k}");
        assert!((merged.sum_sq[k] - whole.sum_sq[k]).abs() <= 1e-12 * whole.sum_sq[k].max(1e-300));
    }
}
