//! Reading a uvspec input file: its keywords, checked and mapped onto an
//! atmosim job (see the module docs of `uvspec` for the mapping).
//!
//! (Over 600 lines: `parse` is one match over uvspec's keywords, each
//! keyword's checks beside its spelling.)

use std::path::Path;

use crate::error::{Error, Result};
use crate::physics::constants::DOBSON_UNIT_CM2;

/// Keywords that only tune a numerical solver: accepted with a warning.
pub const NUMERICAL_KEYWORDS: &[&str] = &[
    "number_of_streams",
    "disort_intcor",
    "deltam",
    "disort_spherical_albedo",
    "print_disort_info",
    "mc_photons",
    "mc_std",
    "mc_vroom",
    "mc_minphotons",
    "mc_maxscatters",
    "mc_randomseed",
    "polradtran_quad_type",
    "polradtran_max_delta_tau",
    "polradtran_aziorder",
    "polradtran_src_code",
    "sdisort",
    "twostr_only",
];

/// Keywords accepted without effect: they change only how uvspec finds its
/// data or how much it prints.
pub const IGNORED_KEYWORDS: &[&str] = &["quiet", "verbose", "data_files_path"];

/// uvspec's AFGL atmosphere names and atmosim's profiles.
const AFGL_NAMES: &[(&str, &str)] = &[
    ("afglus", "us_standard"),
    ("afglms", "midlatitude_summer"),
    ("afglmw", "midlatitude_winter"),
    ("afglss", "subarctic_summer"),
    ("afglsw", "subarctic_winter"),
    ("afglt", "tropical"),
];

/// The atmosphere profile of the input.
#[derive(Debug, Clone, PartialEq)]
pub enum ProfileChoice {
    /// A built-in AFGL profile (atmosim's name).
    Builtin(String),
    /// A profile file, relative to the input file.
    File(String),
}

/// The radiative-transfer geometry the solver implies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UvspecGeometry {
    PlaneParallel,
    /// `pseudospherical`, `sdisort`, `spsdisort`: spherical direct beam.
    PseudoSpherical,
    /// `mc_spherical`: full spherical geometry.
    Spherical,
}

/// An output altitude: a number (km) or uvspec's `sur`/`boa`/`toa`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Zout {
    Km(f64),
    Surface,
    Top,
}

/// Explicit aerosol layer files (uvspec `aerosol_file tau|ssa|gg`): each
/// a list of (z_km, value), the value belonging to [z, next higher z].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AerosolFiles {
    pub tau: Option<Vec<(f64, f64)>>,
    pub ssa: Option<Vec<(f64, f64)>>,
    pub gg: Option<Vec<(f64, f64)>>,
    /// Line of the first `aerosol_file`, for errors.
    pub line: usize,
}

/// A parsed uvspec input.
#[derive(Debug, Clone, PartialEq)]
pub struct UvspecInput {
    /// The input file's name, for messages.
    pub file: String,
    /// Directory that relative file names in the input start from.
    pub dir: std::path::PathBuf,
    pub profile: ProfileChoice,
    pub albedo: f64,
    pub sza_deg: f64,
    pub phi0_deg: f64,
    pub umu: Vec<f64>,
    pub phi_deg: Vec<f64>,
    pub zout: Vec<Zout>,
    pub wavelength_nm: f64,
    pub radius_km: f64,
    /// An OPAC mixture (atmosim's name).
    pub aerosol_species: Option<String>,
    pub aerosol_visibility_km: Option<f64>,
    pub aerosol_files: Option<AerosolFiles>,
    pub ozone_column_du: Option<f64>,
    /// `bogumil` or `molina` (uvspec's default: Molina).
    pub ozone_model: String,
    /// Radiance per unit E0 (`output_quantity transmittance`); otherwise
    /// absolute, × the Kurucz spectrum in mW m⁻² nm⁻¹.
    pub transmittance: bool,
    pub solver: String,
    pub polarized: bool,
    pub geometry: UvspecGeometry,
    /// `output_user` columns of the flux line (None: uvspec's default).
    pub output_user: Option<Vec<String>>,
    /// Line of each keyword, for errors raised after parsing.
    pub lines: Vec<(String, usize)>,
    /// Warnings for accepted settings that do nothing in atmosim.
    pub warnings: Vec<String>,
}

/// Flux-line columns `output_user` may name (radiance columns are accepted
/// and leave the flux line alone).
pub const FLUX_COLUMNS: &[&str] = &[
    "lambda",
    "wavelength",
    "zout",
    "sza",
    "edir",
    "edn",
    "eup",
    "eglo",
    "enet",
    "esum",
    "uavgdir",
    "uavgdn",
    "uavgup",
    "uavg",
];
const RADIANCE_COLUMNS: &[&str] = &["uu", "u0u", "umu", "phi"];

/// Default flux line of uvspec's 1D solvers.
pub const DEFAULT_FLUX_COLUMNS: &[&str] = &["lambda", "edir", "edn", "eup", "uavgdir", "uavgdn", "uavgup"];

struct Line<'a> {
    file: &'a str,
    number: usize,
    keyword: &'a str,
    args: Vec<&'a str>,
}

impl Line<'_> {
    fn err(&self, message: impl Into<String>) -> Error {
        Error::Uvspec {
            file: self.file.to_string(),
            line: self.number,
            message: message.into(),
        }
    }

    /// Exactly `n` values (`what` names them).
    fn want(&self, n: usize, what: &str) -> Result<()> {
        if self.args.len() < n {
            Err(self.err(format!("`{}`: missing value ({what})", self.keyword)))
        } else if self.args.len() > n {
            Err(self.err(format!(
                "`{}`: too many values ({} given; expected {what})",
                self.keyword,
                self.args.len()
            )))
        } else {
            Ok(())
        }
    }

    fn number(&self, i: usize) -> Result<f64> {
        let w = self
            .args
            .get(i)
            .ok_or_else(|| self.err(format!("`{}`: missing value", self.keyword)))?;
        w.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| self.err(format!("`{}`: `{w}` is not a number", self.keyword)))
    }

    /// One number in [lo, hi].
    fn one_in(&self, what: &str, lo: f64, hi: f64) -> Result<f64> {
        self.want(1, what)?;
        let v = self.number(0)?;
        if v < lo || v > hi {
            return Err(self.err(format!("`{}` = {v}: out of range (valid: {what})", self.keyword)));
        }
        Ok(v)
    }

    /// A non-empty list of numbers.
    fn list(&self, what: &str) -> Result<Vec<f64>> {
        if self.args.is_empty() {
            return Err(self.err(format!("`{}`: missing value ({what})", self.keyword)));
        }
        (0..self.args.len()).map(|i| self.number(i)).collect()
    }
}

/// Reads a file an input names (relative to the input), returning its text.
pub type Resolver<'a> = dyn Fn(&str) -> std::io::Result<String> + 'a;

impl UvspecInput {
    /// Reads and parses a uvspec input file; files it names are read
    /// relative to its directory.
    pub fn from_file(path: &Path) -> Result<UvspecInput> {
        let text = crate::job::input::read_text(path)?;
        let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        let resolve = |name: &str| std::fs::read_to_string(dir.join(name));
        let mut input = Self::parse(&text, &path.display().to_string(), &resolve)?;
        input.dir = dir;
        Ok(input)
    }

    /// Parses uvspec input text; `file` names it in errors and `resolve`
    /// reads the files it names.
    pub fn parse(text: &str, file: &str, resolve: &Resolver) -> Result<UvspecInput> {
        let mut input = UvspecInput {
            file: file.to_string(),
            dir: std::path::PathBuf::from("."),
            profile: ProfileChoice::Builtin(String::new()),
            albedo: 0.0,
            sza_deg: 0.0,
            phi0_deg: 0.0,
            umu: Vec::new(),
            phi_deg: Vec::new(),
            zout: Vec::new(),
            wavelength_nm: f64::NAN,
            radius_km: 6370.0,
            aerosol_species: None,
            aerosol_visibility_km: None,
            aerosol_files: None,
            ozone_column_du: None,
            ozone_model: "molina".to_string(),
            transmittance: false,
            solver: "disort".to_string(),
            polarized: false,
            geometry: UvspecGeometry::PlaneParallel,
            output_user: None,
            lines: Vec::new(),
            warnings: Vec::new(),
        };
        let mut aerosol_default = false;
        let mut nstokes: Option<(u32, usize)> = None;
        let mut mc_polarisation = false;
        let mut pseudospherical = false;
        let mut mc_spherical = false;
        let mut last_line = 0;
        for (i, raw) in text.lines().enumerate() {
            last_line = i + 1;
            let content = raw.split('#').next().unwrap_or("").trim();
            let mut words = content.split_whitespace();
            let Some(keyword) = words.next() else { continue };
            let line = Line {
                file,
                number: i + 1,
                keyword,
                args: words.collect(),
            };
            input.lines.push((keyword.to_string(), line.number));
            match keyword {
                "atmosphere_file" => {
                    line.want(1, "an AFGL name such as afglus, or a file")?;
                    input.profile = profile_choice(line.args[0]);
                }
                "albedo" => input.albedo = line.one_in("0 to 1", 0.0, 1.0)?,
                "sza" => input.sza_deg = line.one_in("0 to 180 degrees", 0.0, 180.0)?,
                "phi0" => input.phi0_deg = line.one_in("-360 to 360 degrees", -360.0, 360.0)?,
                "umu" => {
                    let umu = line.list("cosines of the polar angles, -1 to 1")?;
                    if let Some(bad) = umu.iter().find(|u| u.abs() > 1.0) {
                        return Err(line.err(format!("`umu` = {bad}: out of range (valid: -1 to 1)")));
                    }
                    input.umu = umu;
                }
                "phi" => {
                    let phi = line.list("azimuths in degrees")?;
                    if let Some(bad) = phi.iter().find(|p| p.abs() > 360.0) {
                        return Err(line.err(format!("`phi` = {bad}: out of range (valid: -360 to 360 degrees)")));
                    }
                    input.phi_deg = phi;
                }
                "zout" => {
                    if line.args.is_empty() {
                        return Err(line.err("`zout`: missing value (altitudes in km, or sur, boa, toa)"));
                    }
                    input.zout = line
                        .args
                        .iter()
                        .enumerate()
                        .map(|(k, w)| match w.to_ascii_lowercase().as_str() {
                            "sur" | "boa" => Ok(Zout::Surface),
                            "toa" => Ok(Zout::Top),
                            _ => line.number(k).map(Zout::Km),
                        })
                        .collect::<Result<_>>()?;
                }
                "wavelength" => {
                    let w = line.list("a wavelength in nm")?;
                    if w.len() > 2 {
                        return Err(line.err("`wavelength`: at most two values (λ or λ λ)"));
                    }
                    if w.len() == 2 && w[0] != w[1] {
                        return Err(line.err(format!(
                            "`wavelength` {} {}: atmosim runs one wavelength per input (give one value, or the same twice)",
                            w[0], w[1]
                        )));
                    }
                    if w[0] <= 0.0 {
                        return Err(line.err(format!("`wavelength` = {}: not a positive wavelength in nm", w[0])));
                    }
                    input.wavelength_nm = w[0];
                }
                "earth_radius" => input.radius_km = line.one_in("a positive radius in km", 1.0, 1.0e6)?,
                "aerosol_default" => {
                    line.want(0, "no value")?;
                    aerosol_default = true;
                }
                "aerosol_species_file" => {
                    line.want(1, "an OPAC mixture name, e.g. continental_average")?;
                    input.aerosol_species = Some(opac_name(line.args[0]));
                }
                "aerosol_visibility" => {
                    input.aerosol_visibility_km = Some(line.one_in("a positive visibility in km", 1e-6, 1.0e6)?);
                }
                "aerosol_file" => {
                    line.want(2, "tau|ssa|gg and a file")?;
                    let values = read_layer_file(&line, line.args[1], resolve)?;
                    let files = input.aerosol_files.get_or_insert_with(|| AerosolFiles {
                        line: line.number,
                        ..AerosolFiles::default()
                    });
                    match line.args[0] {
                        "tau" => files.tau = Some(values),
                        "ssa" => files.ssa = Some(values),
                        "gg" => files.gg = Some(values),
                        other => {
                            return Err(line.err(format!(
                                "`aerosol_file {other}`: not supported (valid: tau, ssa, gg; atmosim's aerosol \
                                 phase function is Henyey–Greenstein)"
                            )));
                        }
                    }
                }
                "mol_modify" => {
                    line.want(3, "a species, a column and its unit (DU or CM_2)")?;
                    let column = line.number(1)?;
                    let du = match line.args[2] {
                        "DU" | "du" => column,
                        "CM_2" | "cm_2" => column / DOBSON_UNIT_CM2,
                        u => return Err(line.err(format!("`mol_modify`: unit `{u}` (valid: DU, CM_2)"))),
                    };
                    match line.args[0].to_ascii_uppercase().as_str() {
                        "O3" => {
                            if !(0.0..=2000.0).contains(&du) {
                                return Err(line.err(format!("`mol_modify O3` = {du} DU: out of range (0 to 2000 DU)")));
                            }
                            input.ozone_column_du = Some(du);
                        }
                        species if column == 0.0 => {
                            // atmosim models no absorber but ozone: a zero column is its model exactly.
                            let _ = species;
                        }
                        species => {
                            return Err(line.err(format!(
                                "`mol_modify {species}` = {column}: atmosim models no absorption by {species} \
                                 (only 0 is valid; ozone is the only gas absorber)"
                            )));
                        }
                    }
                }
                "crs_model" => {
                    line.want(2, "a species and a model")?;
                    match (line.args[0].to_ascii_lowercase().as_str(), line.args[1]) {
                        ("rayleigh", "Bodhaine" | "bodhaine") => {}
                        ("o3", "Bogumil" | "bogumil") => input.ozone_model = "bogumil".into(),
                        ("o3", "Molina" | "molina") => input.ozone_model = "molina".into(),
                        (species, model) => {
                            return Err(line.err(format!(
                                "`crs_model {species} {model}`: not available (valid: rayleigh Bodhaine, \
                                 o3 Bogumil, o3 Molina)"
                            )));
                        }
                    }
                }
                "mol_abs_param" => {
                    line.want(1, "crs")?;
                    if line.args[0] != "crs" {
                        return Err(line.err(format!(
                            "`mol_abs_param {}`: atmosim computes absorption from cross sections only (valid: crs)",
                            line.args[0]
                        )));
                    }
                }
                "output_quantity" => {
                    line.want(1, "transmittance")?;
                    if line.args[0] != "transmittance" {
                        return Err(line.err(format!(
                            "`output_quantity {}`: not supported (valid: transmittance; leave it out for absolute \
                             radiance)",
                            line.args[0]
                        )));
                    }
                    input.transmittance = true;
                }
                "rte_solver" => {
                    line.want(1, "a solver name")?;
                    let s = line.args[0];
                    match s {
                        "disort" | "fdisort1" | "fdisort2" | "twostr" | "polradtran" | "mystic" | "montecarlo" => {}
                        "sdisort" | "spsdisort" | "sos" => pseudospherical = true,
                        _ => {
                            return Err(line.err(format!(
                                "`rte_solver {s}`: unknown (valid: disort, fdisort1, fdisort2, sdisort, spsdisort, \
                                 twostr, sos, polradtran, mystic, montecarlo)"
                            )));
                        }
                    }
                    input.solver = s.to_string();
                }
                "pseudospherical" => {
                    line.want(0, "no value")?;
                    pseudospherical = true;
                }
                "mc_spherical" => {
                    if line.args.len() > 1 {
                        return Err(line.err("`mc_spherical`: at most one value (1D)"));
                    }
                    mc_spherical = true;
                }
                "mc_polarisation" | "mc_polarization" => {
                    if line.args.len() > 1 {
                        return Err(line.err(format!("`{keyword}`: at most one value")));
                    }
                    mc_polarisation = true;
                }
                "polradtran" => {
                    if line.args.first() == Some(&"nstokes") {
                        line.want(2, "nstokes 1, 3 or 4")?;
                        let n = line.number(1)?;
                        if ![1.0, 3.0, 4.0].contains(&n) {
                            return Err(line.err(format!("`polradtran nstokes` = {n}: (valid: 1, 3, 4)")));
                        }
                        nstokes = Some((n as u32, line.number));
                    } else if line.args.is_empty() {
                        return Err(line.err("`polradtran`: missing value (e.g. nstokes 3)"));
                    } else {
                        input.warnings.push(format!(
                            "{file}:{}: `polradtran {}` ignored (numerical setting)",
                            line.number, line.args[0]
                        ));
                    }
                }
                "source" => {
                    if line.args.first() != Some(&"solar") {
                        return Err(line.err("`source`: only `source solar` is supported"));
                    }
                    if line.args.len() > 1 && !input.transmittance {
                        input.warnings.push(format!(
                            "{file}:{}: solar file `{}` ignored: absolute radiances use atmosim's Kurucz spectrum",
                            line.number, line.args[1]
                        ));
                    }
                }
                "output_user" => {
                    let cols: Vec<String> = line.args.iter().map(|s| s.to_string()).collect();
                    if cols.is_empty() {
                        return Err(line.err("`output_user`: missing value (column names)"));
                    }
                    if let Some(bad) = cols
                        .iter()
                        .find(|c| !FLUX_COLUMNS.contains(&c.as_str()) && !RADIANCE_COLUMNS.contains(&c.as_str()))
                    {
                        return Err(line.err(format!(
                            "`output_user`: column `{bad}` not available (valid: {}, {})",
                            FLUX_COLUMNS.join(", "),
                            RADIANCE_COLUMNS.join(", ")
                        )));
                    }
                    input.output_user = Some(cols);
                }
                k if NUMERICAL_KEYWORDS.contains(&k) => input.warnings.push(format!(
                    "{file}:{}: `{k}` ignored (a numerical setting of uvspec's solvers; atmosim's accuracy is set by \
                     --samples)",
                    line.number
                )),
                k if IGNORED_KEYWORDS.contains(&k) => {}
                k => return Err(line.err(format!("unknown keyword `{k}`"))),
            }
        }
        let at_end = |message: String| Error::Uvspec {
            file: file.to_string(),
            line: last_line,
            message,
        };
        if input.profile == ProfileChoice::Builtin(String::new()) {
            return Err(at_end("no `atmosphere_file` (e.g. `atmosphere_file afglus`)".into()));
        }
        if input.wavelength_nm.is_nan() {
            return Err(at_end("no `wavelength` (e.g. `wavelength 540`)".into()));
        }
        if input.umu.is_empty() != input.phi_deg.is_empty() {
            return Err(at_end("radiances need both `umu` and `phi`".into()));
        }
        if input.zout.is_empty() {
            input.zout.push(Zout::Surface);
        }
        // Aerosol: an OPAC mixture or explicit layers.
        let line_of = |k: &str| input.line_of(k);
        match (&input.aerosol_species, &input.aerosol_files) {
            (Some(_), Some(f)) => {
                return Err(Error::Uvspec {
                    file: file.to_string(),
                    line: f.line,
                    message: "`aerosol_file` cannot be combined with `aerosol_species_file` in atmosim".into(),
                });
            }
            (None, Some(f)) if f.tau.is_none() || f.ssa.is_none() || f.gg.is_none() => {
                return Err(Error::Uvspec {
                    file: file.to_string(),
                    line: f.line,
                    message: "explicit aerosol needs all of `aerosol_file tau`, `aerosol_file ssa` and \
                              `aerosol_file gg` (uvspec's Shettle defaults are not modelled)"
                        .into(),
                });
            }
            (None, None) if aerosol_default => {
                return Err(Error::Uvspec {
                    file: file.to_string(),
                    line: line_of("aerosol_default"),
                    message: "`aerosol_default` alone (Shettle 1989) is not modelled: add `aerosol_species_file` \
                              (an OPAC mixture) or `aerosol_file tau|ssa|gg`"
                        .into(),
                });
            }
            _ => {}
        }
        if input.aerosol_visibility_km.is_some() && input.aerosol_species.is_none() {
            return Err(Error::Uvspec {
                file: file.to_string(),
                line: line_of("aerosol_visibility"),
                message: "`aerosol_visibility` scales an OPAC mixture: it needs `aerosol_species_file`".into(),
            });
        }
        // Polarisation and geometry from the solver.
        input.polarized = match input.solver.as_str() {
            "polradtran" => nstokes.is_none_or(|(n, _)| n > 1),
            "mystic" | "montecarlo" => mc_polarisation,
            _ => false,
        };
        if let Some((n, line)) = nstokes
            && input.solver != "polradtran"
            && n > 1
        {
            input.warnings.push(format!(
                "{file}:{line}: `polradtran nstokes {n}` ignored: the solver is {}",
                input.solver
            ));
        }
        input.geometry = if mc_spherical {
            UvspecGeometry::Spherical
        } else if pseudospherical {
            UvspecGeometry::PseudoSpherical
        } else {
            UvspecGeometry::PlaneParallel
        };
        Ok(input)
    }

    /// The line of the last occurrence of `keyword` (0 if absent).
    pub fn line_of(&self, keyword: &str) -> usize {
        self.lines
            .iter()
            .rev()
            .find(|(k, _)| k == keyword)
            .map_or(0, |(_, l)| *l)
    }
}

/// `afglus`, `afglus.dat`, `../data/atmmod/afglus.dat` → the built-in
/// profile; anything else is a file.
pub(super) fn profile_choice(arg: &str) -> ProfileChoice {
    let stem = Path::new(arg)
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or(arg)
        .trim_end_matches(".dat");
    match AFGL_NAMES.iter().find(|(n, _)| *n == stem) {
        Some((_, name)) => ProfileChoice::Builtin(name.to_string()),
        None => ProfileChoice::File(arg.to_string()),
    }
}

/// `continental_average`, `.../continental_average.mix` → the mixture name.
pub(super) fn opac_name(arg: &str) -> String {
    let base = Path::new(arg).file_name().and_then(|n| n.to_str()).unwrap_or(arg);
    base.split('.').next().unwrap_or(base).to_string()
}

/// A uvspec layer file: `z value` rows (any order), `#` comments.
fn read_layer_file(line: &Line, name: &str, resolve: &Resolver) -> Result<Vec<(f64, f64)>> {
    let text = resolve(name).map_err(|e| line.err(format!("`{}`: cannot read `{name}`: {e}", line.keyword)))?;
    let table = crate::physics::data::Table::parse(name, &text, 2)
        .map_err(|e| line.err(format!("`{}`: `{name}`: {e}", line.keyword)))?;
    let rows: Vec<(f64, f64)> = table.rows.iter().map(|r| (r[0], r[1])).collect();
    if rows.len() < 2 {
        return Err(line.err(format!("`{}`: `{name}` needs at least two levels", line.keyword)));
    }
    Ok(rows)
}
