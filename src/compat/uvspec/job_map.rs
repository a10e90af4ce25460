//! A parsed uvspec input as an atmosim job: its viewing directions
//! (θ = acos(−umu), φ = phi − phi0), output levels, profile top, aerosol
//! layers and the job file (TOML) it maps to (module docs of `uvspec`).

use crate::error::{Error, Result};
use crate::job::Job;
use crate::sensor::direction::Direction;

use super::input::*;

impl UvspecInput {
    /// atmosim's viewing direction for uvspec's (umu, phi):
    /// θ = acos(−umu), φ = (phi − phi0) mod 360 (module docs).
    pub fn direction(&self, umu: f64, phi_deg: f64) -> Direction {
        Direction {
            view_zenith_deg: (-umu).clamp(-1.0, 1.0).acos().to_degrees(),
            azimuth_deg: (phi_deg - self.phi0_deg).rem_euclid(360.0),
        }
    }

    /// Every (umu, phi) of the input, umu-major, with its direction.
    pub fn directions(&self) -> Vec<(f64, f64, Direction)> {
        self.umu
            .iter()
            .flat_map(|&u| self.phi_deg.iter().map(move |&p| (u, p)))
            .map(|(u, p)| (u, p, self.direction(u, p)))
            .collect()
    }

    /// The atmosim job (TOML) this input maps to, with `samples` paths per
    /// direction. `full_spherical` runs `pseudospherical` inputs in full
    /// spherical geometry instead.
    pub fn job_toml(&self, samples: u64, seed: u64, full_spherical: bool) -> String {
        let geometry = match self.geometry {
            UvspecGeometry::PlaneParallel => "plane_parallel",
            UvspecGeometry::PseudoSpherical if !full_spherical => "pseudo_spherical",
            _ => "spherical",
        };
        let mut s = format!(
            "# From the uvspec input {} (atmosim uvspec).\n[planet]\nradius_km = {:?}\ngeometry = \"{geometry}\"\n",
            self.file, self.radius_km
        );
        // uvspec uses the whole profile (atmosim's default top is 100 km).
        if let Some(top) = self.profile_top_km() {
            s.push_str(&format!("top_km = {top:?}\n"));
        }
        s.push_str("[atmosphere]\n");
        match &self.profile {
            ProfileChoice::Builtin(name) => s.push_str(&format!("profile = \"{name}\"\n")),
            ProfileChoice::File(path) => s.push_str(&format!("profile_file = {}\n", toml_string(path))),
        }
        s.push_str(&format!("ozone = \"{}\"\nrayleigh = \"bodhaine\"\n", self.ozone_model));
        if let Some(du) = self.ozone_column_du {
            s.push_str(&format!("ozone_column_du = {du:?}\n"));
        }
        match (&self.aerosol_species, &self.aerosol_files) {
            (Some(name), _) => {
                s.push_str(&format!("aerosol = {}\n", toml_string(name)));
                if let Some(v) = self.aerosol_visibility_km {
                    s.push_str(&format!("visibility_km = {v:?}\n"));
                }
            }
            (None, Some(_)) => {}
            (None, None) => s.push_str("aerosol = \"none\"\n"),
        }
        for l in self.aerosol_layers() {
            s.push_str(&format!(
                "[[atmosphere.aerosol_layers]]\nbottom_km = {:?}\ntop_km = {:?}\ntau = {:?}\nssa = {:?}\ng = {:?}\n",
                l.bottom_km, l.top_km, l.tau, l.ssa, l.g
            ));
        }
        s.push_str(&format!(
            "[spectrum]\nwavelengths_nm = [{:?}]\n[sun]\nzenith_deg = {:?}\n[ground]\nalbedo = {:?}\n",
            self.wavelength_nm, self.sza_deg, self.albedo
        ));
        let altitudes: Vec<String> = self.zout.iter().map(|z| format!("{:?}", self.zout_km(*z))).collect();
        s.push_str(&format!("[observer]\naltitude_km = [{}]\n", altitudes.join(", ")));
        let dirs: Vec<String> = self
            .directions()
            .iter()
            .map(|(_, _, d)| format!("[{:?}, {:?}]", d.view_zenith_deg, d.azimuth_deg))
            .collect();
        s.push_str("[sensor]\ntype = \"directions\"\n");
        if !dirs.is_empty() {
            s.push_str(&format!("directions = [{}]\n", dirs.join(", ")));
        }
        s.push_str(&format!(
            "[render]\nsamples = {samples}\nseed = {seed}\npolarized = {}\n",
            self.polarized
        ));
        s
    }

    /// The atmosim job of this input (see [`UvspecInput::job_toml`]). A value
    /// the job refuses is reported at the line of the uvspec keyword it
    /// came from.
    pub fn job(&self, samples: u64, seed: u64, full_spherical: bool) -> Result<Job> {
        let text = self.job_toml(samples, seed, full_spherical);
        Job::parse(&text, &self.file, &self.dir).map_err(|e| {
            let message = e.to_string();
            let keyword = [
                ("spectrum.wavelengths_nm", "wavelength"),
                ("atmosphere.visibility_km", "aerosol_visibility"),
                ("atmosphere.ozone_column_du", "mol_modify"),
                ("atmosphere.aerosol_layers", "aerosol_file"),
                ("atmosphere.profile_file", "atmosphere_file"),
                ("atmosphere.aerosol", "aerosol_species_file"),
                ("observer.altitude_km", "zout"),
                ("planet.radius_km", "earth_radius"),
            ]
            .iter()
            .find(|(key, _)| message.contains(&format!("`{key}")));
            match keyword {
                Some((_, k)) if self.line_of(k) > 0 => Error::Uvspec {
                    file: self.file.clone(),
                    line: self.line_of(k),
                    message: format!("`{k}`: {}", message.trim_start_matches(&format!("{}: ", self.file))),
                },
                _ => e,
            }
        })
    }

    /// An output altitude in km above the ground: `sur` is the ground
    /// (0 km), `toa` the top of the profile (120 km for AFGL).
    pub fn zout_km(&self, z: Zout) -> f64 {
        match z {
            Zout::Km(v) => v,
            Zout::Surface => 0.0,
            Zout::Top => self.profile_top_km().unwrap_or(120.0),
        }
    }

    /// The top of the input's profile, the top of the atmosphere uvspec
    /// uses; `None` for a file that cannot be read (the job reports it).
    pub fn profile_top_km(&self) -> Option<f64> {
        let profile = match &self.profile {
            ProfileChoice::Builtin(name) => crate::physics::profile::GasProfile::builtin(name)?.ok()?,
            ProfileChoice::File(path) => {
                let text = std::fs::read_to_string(self.dir.join(path)).ok()?;
                crate::physics::profile::GasProfile::parse(path, &text).ok()?
            }
        };
        Some(profile.top_km())
    }

    /// The explicit aerosol layers of `aerosol_file tau|ssa|gg`, ascending.
    pub fn aerosol_layers(&self) -> Vec<crate::atmosphere::AerosolLayer> {
        let Some(AerosolFiles {
            tau: Some(tau),
            ssa: Some(ssa),
            gg: Some(gg),
            ..
        }) = &self.aerosol_files
        else {
            return Vec::new();
        };
        let value = |list: &[(f64, f64)], z: f64| list.iter().find(|(zz, _)| *zz == z).map_or(0.0, |(_, v)| *v);
        let mut levels: Vec<f64> = tau.iter().map(|(z, _)| *z).collect();
        levels.sort_by(f64::total_cmp);
        levels.dedup();
        levels
            .windows(2)
            .map(|w| crate::atmosphere::AerosolLayer {
                bottom_km: w[0],
                top_km: w[1],
                tau: value(tau, w[0]),
                ssa: value(ssa, w[0]),
                g: value(gg, w[0]),
            })
            .filter(|l| l.tau > 0.0)
            .collect()
    }
}

fn toml_string(s: &str) -> String {
    format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""))
}
