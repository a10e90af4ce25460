//! OPAC aerosols (Hess, Koepke & Schult 1998) as libRadtran layers them:
//! component optical properties per unit mass versus wavelength and relative
//! humidity, mixtures as mass-density profiles, and the per-layer extinction,
//! scattering and asymmetry parameter of a mixture.
//!
//! Rules (libRadtran's, see validation/libradtran):
//! - the mass density listed at altitude z applies to the layer from z up to
//!   the next listed altitude (no interpolation); a gas layer that spans
//!   several mixture rows gets their thickness-weighted mean;
//! - hygroscopic components (waso, suso, …) use the tabulated humidity
//!   (0, 50, 70, 80, 90, 95, 98, 99 %) nearest to the layer's humidity
//!   (ties go to the lower humidity); inso and soot are tabulated at 0 % only;
//! - mixing: σ_ext = Σ M_c·k_ext,c, σ_sca = Σ M_c·k_ext,c·ω_c,
//!   g = Σ σ_sca,c·g_c / σ_sca;
//! - between tabulated wavelengths, k_ext, k_sca = ω·k_ext and g·k_sca are
//!   interpolated linearly in wavelength. These three are the quantities the
//!   mixing rule adds, so interpolating and mixing commute, and at a
//!   tabulated wavelength the table is reproduced exactly.
//!
//! Components: all ten spherical OPAC components. inso, waso, soot and suso
//! take k_ext, ω and g from libRadtran's published MIEV0 tables
//! (`atmospheres/opac/components`) over the wavelengths those cover (inso
//! and soot 250–1000 nm, waso and suso 300–800 nm) and from atmosim's own
//! Mie tables (`atmospheres/opac/mie`, written by `atmosim opac-tables`)
//! outside them; the other six (ssam, sscm, minm, miam, micm, mitr) from
//! atmosim's tables alone. Those agree with libRadtran's to 0.1 % where
//! both exist, and span 250–2500 nm, so every mixture covers that range;
//! every component's phase matrices are atmosim's own.
//! The spheroidal dust of `desert_spheroids` is not spherical, so a Mie
//! solver cannot give its optics: that mixture is refused with an error
//! that names `desert`, its spherical counterpart.

use crate::error::{Error, Result};
use crate::physics::data::{self, Table};
use crate::physics::mie::tables::{PhaseTables, builtin_phase};
use crate::physics::profile::GasProfile;

/// Optical properties of one component per unit mass at one wavelength and
/// humidity: extinction and scattering in km⁻¹ per (g m⁻³), and g.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ComponentOptics {
    pub k_ext: f64,
    pub k_sca: f64,
    pub g: f64,
}

/// How an OPAC aerosol scatters (closed set): by the Mie phase matrices of
/// its components (polarising; atmosim's own tables, `atmosim
/// opac-tables`), or by a Henyey–Greenstein phase function of the mixture's
/// asymmetry parameter that does not polarise (the seed's model).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AerosolPhase {
    #[default]
    Mie,
    HenyeyGreenstein,
}

/// An OPAC component's tables.
#[derive(Debug, Clone)]
pub struct Component {
    pub name: String,
    rh_pct: Vec<f64>,
    /// Per humidity: wavelengths and (k_ext, k_sca, g·k_sca) at each.
    tables: Vec<(Vec<f64>, Vec<[f64; 3]>)>,
}

impl Component {
    /// A built-in component by name: libRadtran's published table where
    /// there is one, extended by atmosim's own Mie table at the wavelengths
    /// outside it; else atmosim's table alone.
    pub fn builtin(name: &str) -> Option<Result<Component>> {
        let ours = data::builtin(data::OPAC_MIE_OPTICS, name).map(|t| Self::parse(name, t));
        match data::builtin(data::OPAC_COMPONENTS, name) {
            Some(published) => Some(Self::parse(name, published).and_then(|c| match ours {
                Some(ours) => c.extended_by(&ours?),
                None => Ok(c),
            })),
            None => ours,
        }
    }

    /// Whether `name` is a built-in component.
    pub fn is_builtin(name: &str) -> bool {
        Self::builtin_text(name).is_some()
    }

    /// The table text of a built-in component (libRadtran's, else ours).
    fn builtin_text(name: &str) -> Option<&'static str> {
        data::builtin(data::OPAC_COMPONENTS, name).or_else(|| data::builtin(data::OPAC_MIE_OPTICS, name))
    }

    /// Parses columns `wavelength_nm rh_pct k_ext ssa g`.
    pub fn parse(name: &str, text: &str) -> Result<Component> {
        let table = Table::parse(name, text, 5)?;
        let mut rh_pct: Vec<f64> = table.column(1);
        rh_pct.sort_by(f64::total_cmp);
        rh_pct.dedup();
        let tables = rh_pct
            .iter()
            .map(|&rh| {
                let mut rows: Vec<&Vec<f64>> = table.rows.iter().filter(|r| r[1] == rh).collect();
                rows.sort_by(|a, b| a[0].total_cmp(&b[0]));
                let wl: Vec<f64> = rows.iter().map(|r| r[0]).collect();
                if wl.windows(2).any(|w| w[1] <= w[0]) {
                    return Err(Error::data(name, format!("duplicate wavelength at RH {rh} %")));
                }
                let v = rows.iter().map(|r| [r[2], r[2] * r[3], r[2] * r[3] * r[4]]).collect();
                Ok((wl, v))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Component {
            name: name.to_string(),
            rh_pct,
            tables,
        })
    }

    /// This table with `other`'s rows at the wavelengths below and above
    /// its own, humidity by humidity: inside its range this table alone
    /// (the values and the interpolation between its nodes unchanged),
    /// between its end and `other`'s next node a linear interpolation from
    /// one to the other. Both must have the same humidities.
    pub fn extended_by(&self, other: &Component) -> Result<Component> {
        if self.rh_pct != other.rh_pct {
            return Err(Error::data(
                format!("OPAC component `{}`", self.name),
                format!(
                    "the published table's humidities {:?} % differ from atmosim's Mie table's {:?} %",
                    self.rh_pct, other.rh_pct
                ),
            ));
        }
        let tables = self
            .tables
            .iter()
            .zip(&other.tables)
            .map(|((wl, v), (wl_o, v_o))| {
                let (lo, hi) = (wl[0], wl[wl.len() - 1]);
                let mut rows: Vec<(f64, [f64; 3])> = wl.iter().copied().zip(v.iter().copied()).collect();
                rows.extend(
                    wl_o.iter()
                        .copied()
                        .zip(v_o.iter().copied())
                        .filter(|&(l, _)| l < lo || l > hi),
                );
                rows.sort_by(|a, b| a.0.total_cmp(&b.0));
                rows.into_iter().unzip()
            })
            .collect();
        Ok(Component {
            name: self.name.clone(),
            rh_pct: self.rh_pct.clone(),
            tables,
        })
    }

    /// Index of the tabulated humidity nearest to `rh_pct` (ties: lower).
    pub fn nearest_rh(&self, rh_pct: f64) -> usize {
        let mut best = 0;
        for (i, &r) in self.rh_pct.iter().enumerate() {
            if (r - rh_pct).abs() < (self.rh_pct[best] - rh_pct).abs() {
                best = i;
            }
        }
        best
    }

    /// The component's Mie phase matrices at the tabulated humidity index
    /// `rh`, per tabulated wavelength.
    pub fn phase_tables(&self, rh: usize) -> Result<PhaseTables> {
        builtin_phase(&self.name, self.rh_pct[rh]).unwrap_or_else(|| {
            Err(Error::data(
                format!("OPAC component `{}`", self.name),
                format!(
                    "no Mie phase matrix table at RH {} % (aerosol_phase = \"hg\" needs none)",
                    self.rh_pct[rh]
                ),
            ))
        })
    }

    /// The tabulated humidities (%).
    pub fn humidities_pct(&self) -> &[f64] {
        &self.rh_pct
    }

    /// The wavelength range (nm) covered at every humidity.
    pub fn range_nm(&self) -> (f64, f64) {
        self.tables.iter().fold((f64::MIN, f64::MAX), |(lo, hi), (wl, _)| {
            (lo.max(wl[0]), hi.min(wl[wl.len() - 1]))
        })
    }

    /// Optics at λ (nm) for the tabulated humidity index `rh`; `None` outside
    /// the tabulated wavelengths.
    pub fn optics(&self, lambda_nm: f64, rh: usize) -> Option<ComponentOptics> {
        let (wl, v) = &self.tables[rh];
        let (i, f) = data::bracket(wl, lambda_nm)?;
        let j = (i + 1).min(wl.len() - 1);
        let lerp = |k: usize| v[i][k] + (v[j][k] - v[i][k]) * f;
        let (k_ext, k_sca, gk) = (lerp(0), lerp(1), lerp(2));
        Some(ComponentOptics {
            k_ext,
            k_sca,
            g: if k_sca > 0.0 { gk / k_sca } else { 0.0 },
        })
    }
}

/// An OPAC mixture: component mass densities (g m⁻³) on altitude rows.
#[derive(Debug, Clone)]
pub struct Mixture {
    pub name: String,
    pub components: Vec<String>,
    z_km: Vec<f64>,
    /// mass[row][component]
    mass: Vec<Vec<f64>>,
}

impl Mixture {
    /// Top (km) of the boundary (mixing) layer that `visibility_km` scales.
    /// In all ten OPAC mixtures as libRadtran defines them the rows at 0 and
    /// 1 km hold the mixture's own boundary-layer aerosol and the rows from
    /// 2 km up are a common free-tropospheric background (inso, waso, soot
    /// decreasing with a 8 km scale height) and stratospheric suso; so for
    /// every mixture the scaled rows are those below 2 km.
    pub const BOUNDARY_LAYER_TOP_KM: f64 = 2.0;

    /// A built-in mixture by name.
    pub fn builtin(name: &str) -> Option<Result<Mixture>> {
        data::builtin(data::OPAC_MIXTURES, name).map(|t| Self::parse(name, t))
    }

    /// Parses a mixture table with a `components:` header and columns
    /// `z_km` plus one mass density per component.
    pub fn parse(name: &str, text: &str) -> Result<Mixture> {
        let table = Table::parse(name, text, 0)?;
        let components: Vec<String> = table
            .header("components")
            .ok_or_else(|| Error::data(name, "missing `# components: …` header line"))?
            .split_whitespace()
            .map(str::to_string)
            .collect();
        if table.rows[0].len() != components.len() + 1 {
            return Err(Error::data(name, "column count does not match the components line"));
        }
        table.require_ascending(0, "altitudes")?;
        if table.rows.iter().flatten().any(|&m| m < 0.0) {
            return Err(Error::data(name, "negative mass density"));
        }
        Ok(Mixture {
            name: name.to_string(),
            components,
            z_km: table.column(0),
            mass: table.rows.iter().map(|r| r[1..].to_vec()).collect(),
        })
    }

    /// Components that carry mass somewhere in the profile.
    pub fn active_components(&self) -> Vec<&str> {
        self.components
            .iter()
            .enumerate()
            .filter(|(c, _)| self.mass.iter().any(|row| row[*c] > 0.0))
            .map(|(_, n)| n.as_str())
            .collect()
    }

    /// Mean mass density of component `c` over [z0, z1] (km), each row
    /// applying from its altitude up to the next row; nothing above the last.
    pub fn mean_mass(&self, c: usize, z0: f64, z1: f64) -> f64 {
        let mut sum = 0.0;
        for (r, w) in self.z_km.windows(2).enumerate() {
            let overlap = z1.min(w[1]) - z0.max(w[0]);
            if overlap > 0.0 {
                sum += overlap * self.mass[r][c];
            }
        }
        sum / (z1 - z0)
    }

    /// Multiplies the mass of every row below the boundary-layer top.
    pub fn scale_boundary_layer(&mut self, factor: f64) {
        for (r, z) in self.z_km.iter().enumerate() {
            if *z < Self::BOUNDARY_LAYER_TOP_KM {
                self.mass[r].iter_mut().for_each(|m| *m *= factor);
            }
        }
    }

    /// A copy holding only the boundary-layer rows (the rest zero).
    pub fn boundary_layer_only(&self) -> Mixture {
        let mut m = self.clone();
        for (r, z) in self.z_km.iter().enumerate() {
            if *z >= Self::BOUNDARY_LAYER_TOP_KM {
                m.mass[r].iter_mut().for_each(|x| *x = 0.0);
            }
        }
        m
    }
}

/// Aerosol optics of one layer: coefficients in km⁻¹ and the asymmetry
/// parameter of the Henyey–Greenstein phase function.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AerosolOptics {
    pub sigma_ext: f64,
    pub sigma_sca: f64,
    pub g: f64,
}

/// A mixture with the component tables it needs.
#[derive(Debug, Clone)]
pub struct Aerosol {
    pub mixture: Mixture,
    /// Per mixture column; `None` for a component without mass anywhere.
    components: Vec<Option<Component>>,
}

impl Aerosol {
    /// Loads a built-in mixture and its components. Fails, naming them, when
    /// a component with mass has no optical properties in atmosim's data.
    pub fn builtin(name: &str) -> Option<Result<Aerosol>> {
        Mixture::builtin(name).map(|m| m.and_then(Self::with_builtin_components))
    }

    fn with_builtin_components(mixture: Mixture) -> Result<Aerosol> {
        let active = mixture.active_components();
        let missing: Vec<&str> = active.iter().copied().filter(|c| !Component::is_builtin(c)).collect();
        if missing.iter().any(|c| c.ends_with("_spheroids")) {
            return Err(Error::data(
                format!("aerosol mixture `{}`", mixture.name),
                format!(
                    "needs non-spherical mineral dust ({}), whose optics a Mie solver for spheres cannot \
                     give; use `desert`, the same mixture with spherical dust",
                    missing.join(", ")
                ),
            ));
        }
        if !missing.is_empty() {
            return Err(Error::data(
                format!("aerosol mixture `{}`", mixture.name),
                format!(
                    "needs OPAC component(s) {} which atmosim has no optical properties for",
                    missing.join(", ")
                ),
            ));
        }
        let components = mixture
            .components
            .iter()
            .map(|c| Component::builtin(c).transpose())
            .collect::<Result<Vec<_>>>()?;
        Ok(Aerosol { mixture, components })
    }

    /// The wavelength range (nm) every component with mass covers, and the
    /// component that limits it.
    pub fn range_nm(&self) -> ((f64, f64), String) {
        let active = self.mixture.active_components();
        let mut range = (f64::MIN, f64::MAX);
        let mut limiting = String::new();
        let present = self.components.iter().flatten();
        for c in present.filter(|c| active.contains(&c.name.as_str())) {
            let (lo, hi) = c.range_nm();
            if lo > range.0 || hi < range.1 {
                limiting = c.name.clone();
            }
            range = (range.0.max(lo), range.1.min(hi));
        }
        (range, limiting)
    }

    /// The parts of gas layer `i` of `profile`: (component, tabulated
    /// humidity index, mean mass density) for each component with mass, at
    /// the layer's own relative humidity. `None` if a component with mass
    /// has no optical properties.
    pub fn layer_parts(&self, profile: &GasProfile, i: usize) -> Option<Vec<(usize, usize, f64)>> {
        let (z0, z1) = (profile.levels[i].z_km, profile.levels[i + 1].z_km);
        let rh = profile.layer_relative_humidity_pct(i);
        let mut parts = Vec::new();
        for (c, comp) in self.components.iter().enumerate() {
            let m = self.mixture.mean_mass(c, z0, z1);
            if m == 0.0 {
                continue;
            }
            let comp = comp.as_ref()?;
            parts.push((c, comp.nearest_rh(rh), m));
        }
        Some(parts)
    }

    /// Component `c`'s optical properties (`None` for one without mass).
    pub fn component(&self, c: usize) -> Option<&Component> {
        self.components[c].as_ref()
    }

    /// Optics of gas layer `i` of `profile` at λ (nm), with the layer's own
    /// relative humidity. `None` if λ is outside a component's table.
    pub fn layer_optics(&self, profile: &GasProfile, i: usize, lambda_nm: f64) -> Option<AerosolOptics> {
        let mut out = AerosolOptics::default();
        let mut g_sca = 0.0;
        for (c, rh, m) in self.layer_parts(profile, i)? {
            let o = self.components[c].as_ref()?.optics(lambda_nm, rh)?;
            out.sigma_ext += m * o.k_ext;
            out.sigma_sca += m * o.k_sca;
            g_sca += m * o.k_sca * o.g;
        }
        out.g = if out.sigma_sca > 0.0 {
            g_sca / out.sigma_sca
        } else {
            0.0
        };
        Some(out)
    }

    /// The same aerosol with its boundary layer scaled by `factor`.
    pub fn with_boundary_scale(&self, factor: f64) -> Aerosol {
        let mut a = self.clone();
        a.mixture.scale_boundary_layer(factor);
        a
    }

    /// The same aerosol reduced to its boundary layer.
    pub fn boundary_layer_only(&self) -> Aerosol {
        Aerosol {
            mixture: self.mixture.boundary_layer_only(),
            components: self.components.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn component_reproduces_its_table_at_nodes() {
        // waso at 540 nm, RH 50 %: 3.269983e3 km⁻¹/(g m⁻³), ω 0.977357, g 0.673793.
        let waso = Component::builtin("waso").unwrap().unwrap();
        let o = waso.optics(540.0, waso.nearest_rh(50.0)).unwrap();
        assert_eq!(o.k_ext, 3.269983e3);
        assert!((o.k_sca / o.k_ext - 0.977357).abs() < 1e-12);
        assert!((o.g - 0.673793).abs() < 1e-12);
    }

    #[test]
    fn wavelength_interpolation_is_linear_in_k_ext_k_sca_and_g_k_sca() {
        // Between the 500 and 540 nm nodes of inso, at 520 nm.
        let inso = Component::builtin("inso").unwrap().unwrap();
        let (a, b) = (inso.optics(500.0, 0).unwrap(), inso.optics(540.0, 0).unwrap());
        let m = inso.optics(520.0, 0).unwrap();
        assert!((m.k_ext - 0.5 * (a.k_ext + b.k_ext)).abs() < 1e-9);
        assert!((m.k_sca - 0.5 * (a.k_sca + b.k_sca)).abs() < 1e-9);
        let g = (a.g * a.k_sca + b.g * b.k_sca) / (a.k_sca + b.k_sca);
        assert!((m.g - g).abs() < 1e-12);
        // Values from the table text: 2.352042e2 and 2.366902e2.
        assert!((m.k_ext - 0.5 * (2.352042e2 + 2.366902e2)).abs() < 1e-9);
    }

    #[test]
    fn nearest_humidity_bins() {
        let waso = Component::builtin("waso").unwrap().unwrap();
        let rh = |x: f64| waso.humidities_pct()[waso.nearest_rh(x)];
        assert_eq!(rh(20.03), 0.0);
        assert_eq!(rh(28.12), 50.0);
        assert_eq!(rh(25.0), 0.0);
        assert_eq!(rh(74.0), 70.0);
        assert_eq!(rh(100.0), 99.0);
        let inso = Component::builtin("inso").unwrap().unwrap();
        assert_eq!(inso.humidities_pct(), &[0.0]);
    }

    #[test]
    fn mixture_rows_apply_up_to_the_next_row() {
        let m = Mixture::builtin("continental_average").unwrap().unwrap();
        let waso = m.components.iter().position(|c| c == "waso").unwrap();
        assert_eq!(m.mean_mass(waso, 0.0, 1.0), 1.487e-5);
        assert_eq!(m.mean_mass(waso, 0.25, 0.75), 1.487e-5);
        assert!((m.mean_mass(waso, 0.5, 1.5) - 0.5 * (1.487e-5 + 1.313e-5)).abs() < 1e-18);
        assert_eq!(m.mean_mass(waso, 35.0, 40.0), 0.0);
    }

    #[test]
    fn every_spherical_mixture_loads_and_the_spheroids_are_refused_by_name() {
        for (name, _) in data::OPAC_MIXTURES.iter().filter(|(n, _)| *n != "desert_spheroids") {
            let a = Aerosol::builtin(name).unwrap().unwrap();
            assert_eq!(a.range_nm().0, (250.0, 2500.0), "{name}");
        }
        let e = Aerosol::builtin("desert_spheroids").unwrap().unwrap_err().to_string();
        assert!(
            e.contains("desert_spheroids") && e.contains("minm_spheroids") && e.contains("use `desert`"),
            "{e}"
        );
    }

    #[test]
    fn range_is_limited_by_the_narrowest_component() {
        let a = Aerosol::builtin("continental_average").unwrap().unwrap();
        let ((lo, hi), _) = a.range_nm();
        assert_eq!((lo, hi), (250.0, 2500.0));
        // A component that ends early limits the mixture and is named.
        let mut short = a.clone();
        let waso = short.mixture.components.iter().position(|c| c == "waso").unwrap();
        let text = data::builtin(data::OPAC_COMPONENTS, "waso").unwrap();
        short.components[waso] = Some(Component::parse("waso", text).unwrap());
        assert_eq!(short.range_nm(), ((300.0, 800.0), "waso".to_string()));
    }

    /// The published tables are extended by atmosim's outside their own
    /// wavelengths only: waso (libRadtran's 300–800 nm) is libRadtran's at
    /// 300 and 800 nm and atmosim's at 250, 900 and 2500 nm, linear in
    /// k_ext, k_sca and g·k_sca from libRadtran's 800 nm to atmosim's
    /// 900 nm; inso (libRadtran's 250–1000 nm) switches after 1000 nm.
    #[test]
    fn published_tables_are_extended_by_atmosims_outside_their_range() {
        let parse = |set, name| Component::parse(name, data::builtin(set, name).unwrap()).unwrap();
        for (name, rh, ends, outside) in [
            ("waso", 50.0, [300.0, 800.0], [250.0, 900.0, 2500.0]),
            ("inso", 0.0, [250.0, 1000.0], [1250.0, 2000.0, 2500.0]),
        ] {
            let c = Component::builtin(name).unwrap().unwrap();
            let (published, ours) = (parse(data::OPAC_COMPONENTS, name), parse(data::OPAC_MIE_OPTICS, name));
            let i = c.nearest_rh(rh);
            assert_eq!(c.humidities_pct()[i], rh);
            assert_eq!(c.range_nm(), (250.0, 2500.0), "{name}");
            // To the rounding of the interpolation's f = 1 at a table's last node.
            let same = |x: ComponentOptics, y: ComponentOptics| {
                let close = |u: f64, v: f64| (u - v).abs() <= 1e-14 * v.abs();
                close(x.k_ext, y.k_ext) && close(x.k_sca, y.k_sca) && close(x.g, y.g)
            };
            for l in ends {
                let (x, y) = (c.optics(l, i).unwrap(), published.optics(l, i).unwrap());
                assert!(same(x, y), "{name} {l} nm: {x:?} vs libRadtran's {y:?}");
            }
            for l in outside {
                let (x, y) = (c.optics(l, i).unwrap(), ours.optics(l, i).unwrap());
                assert!(same(x, y), "{name} {l} nm: {x:?} vs atmosim's {y:?}");
            }
            // Between libRadtran's last node and atmosim's next one.
            let next = *outside.iter().find(|&&l| l > ends[1]).unwrap();
            let (a, b) = (published.optics(ends[1], i).unwrap(), ours.optics(next, i).unwrap());
            let f = 0.25;
            let m = c.optics(ends[1] + f * (next - ends[1]), i).unwrap();
            assert!((m.k_ext - (a.k_ext + f * (b.k_ext - a.k_ext))).abs() < 1e-9 * a.k_ext);
            assert!((m.k_sca - (a.k_sca + f * (b.k_sca - a.k_sca))).abs() < 1e-9 * a.k_ext);
            let gk = a.g * a.k_sca + f * (b.g * b.k_sca - a.g * a.k_sca);
            assert!((m.g - gk / m.k_sca).abs() < 1e-12, "{name}");
        }
        // Inside the published range nothing changed: suso has no 750 nm
        // row in libRadtran's table and keeps interpolating across it.
        let suso = Component::builtin("suso").unwrap().unwrap();
        let published = parse(data::OPAC_COMPONENTS, "suso");
        assert_eq!(suso.optics(750.0, 1), published.optics(750.0, 1));
    }
}
