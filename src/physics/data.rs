//! The data tables atmosim carries, embedded at compile time so the binary
//! runs anywhere, and the one parser for their format.
//!
//! Format: UTF-8 text; lines starting with `#` are comments (provenance, and
//! `key: value` lines such as `t0_K: 273.15` or `components: inso waso`);
//! every other non-blank line is a row of whitespace-separated numbers.
//! The files are written by `scripts/derive_data.py` from the public source
//! data; each says where its numbers come from.

use crate::error::{Error, Result};

/// A parsed data table: its comment lines and its numeric rows.
#[derive(Debug, Clone)]
pub struct Table {
    /// Name used in error messages (file name or built-in name).
    pub name: String,
    /// Comment lines without the leading `#` and surrounding blanks.
    pub comments: Vec<String>,
    /// Numeric rows, each with the same number of columns.
    pub rows: Vec<Vec<f64>>,
}

impl Table {
    /// Parses `text`, requiring exactly `columns` numbers per row (or, with
    /// `columns == 0`, the same count in every row).
    pub fn parse(name: &str, text: &str, columns: usize) -> Result<Table> {
        let mut comments = Vec::new();
        let mut rows: Vec<Vec<f64>> = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let s = line.trim();
            if s.is_empty() {
                continue;
            }
            if let Some(c) = s.strip_prefix('#') {
                comments.push(c.trim().to_string());
                continue;
            }
            let row = s
                .split_whitespace()
                .map(|w| {
                    w.parse::<f64>()
                        .map_err(|_| Error::data(name, format!("line {}: `{w}` is not a number", i + 1)))
                })
                .collect::<Result<Vec<f64>>>()?;
            let expected = if columns > 0 {
                columns
            } else {
                rows.first().map_or(row.len(), Vec::len)
            };
            if row.len() != expected {
                return Err(Error::data(
                    name,
                    format!("line {}: {} columns, expected {expected}", i + 1, row.len()),
                ));
            }
            if let Some(bad) = row.iter().find(|v| !v.is_finite()) {
                return Err(Error::data(name, format!("line {}: non-finite value {bad}", i + 1)));
            }
            rows.push(row);
        }
        if rows.is_empty() {
            return Err(Error::data(name, "no data rows"));
        }
        Ok(Table {
            name: name.to_string(),
            comments,
            rows,
        })
    }

    /// The value of a `key: value` comment line, if present.
    pub fn header(&self, key: &str) -> Option<&str> {
        self.comments.iter().find_map(|c| {
            let (k, v) = c.split_once(':')?;
            (k.trim() == key).then(|| v.trim())
        })
    }

    /// Column `j` of every row.
    pub fn column(&self, j: usize) -> Vec<f64> {
        self.rows.iter().map(|r| r[j]).collect()
    }

    /// Checks that column `j` strictly increases.
    pub fn require_ascending(&self, j: usize, what: &str) -> Result<()> {
        for w in self.rows.windows(2) {
            if w[1][j] <= w[0][j] {
                return Err(Error::data(
                    &self.name,
                    format!("{what} must increase strictly ({} then {})", w[0][j], w[1][j]),
                ));
            }
        }
        Ok(())
    }
}

macro_rules! embedded {
    ($($name:literal => $path:literal),* $(,)?) => {
        &[$(($name, include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/", $path)))),*]
    };
}

/// The six AFGL gas profiles (Anderson et al. 1986).
pub static AFGL_PROFILES: &[(&str, &str)] = embedded! {
    "us_standard" => "atmospheres/afgl/us_standard.txt",
    "midlatitude_summer" => "atmospheres/afgl/midlatitude_summer.txt",
    "midlatitude_winter" => "atmospheres/afgl/midlatitude_winter.txt",
    "subarctic_summer" => "atmospheres/afgl/subarctic_summer.txt",
    "subarctic_winter" => "atmospheres/afgl/subarctic_winter.txt",
    "tropical" => "atmospheres/afgl/tropical.txt",
};

/// The ten OPAC mixtures as mass-density profiles (Hess et al. 1998).
pub static OPAC_MIXTURES: &[(&str, &str)] = embedded! {
    "antarctic" => "atmospheres/opac/mixtures/antarctic.txt",
    "continental_average" => "atmospheres/opac/mixtures/continental_average.txt",
    "continental_clean" => "atmospheres/opac/mixtures/continental_clean.txt",
    "continental_polluted" => "atmospheres/opac/mixtures/continental_polluted.txt",
    "desert" => "atmospheres/opac/mixtures/desert.txt",
    "desert_spheroids" => "atmospheres/opac/mixtures/desert_spheroids.txt",
    "maritime_clean" => "atmospheres/opac/mixtures/maritime_clean.txt",
    "maritime_polluted" => "atmospheres/opac/mixtures/maritime_polluted.txt",
    "maritime_tropical" => "atmospheres/opac/mixtures/maritime_tropical.txt",
    "urban" => "atmospheres/opac/mixtures/urban.txt",
};

/// OPAC component optical properties available (Mie, per unit mass).
pub static OPAC_COMPONENTS: &[(&str, &str)] = embedded! {
    "inso" => "atmospheres/opac/components/inso.txt",
    "waso" => "atmospheres/opac/components/waso.txt",
    "soot" => "atmospheres/opac/components/soot.txt",
    "suso" => "atmospheres/opac/components/suso.txt",
};

/// OPAC component optics computed by atmosim's Mie solver (`atmosim
/// opac-tables`), all ten components; same format as `OPAC_COMPONENTS`,
/// which keeps libRadtran's published tables of the four it has.
pub static OPAC_MIE_OPTICS: &[(&str, &str)] = embedded! {
    "inso" => "atmospheres/opac/mie/inso_optics.txt",
    "waso" => "atmospheres/opac/mie/waso_optics.txt",
    "soot" => "atmospheres/opac/mie/soot_optics.txt",
    "ssam" => "atmospheres/opac/mie/ssam_optics.txt",
    "sscm" => "atmospheres/opac/mie/sscm_optics.txt",
    "minm" => "atmospheres/opac/mie/minm_optics.txt",
    "miam" => "atmospheres/opac/mie/miam_optics.txt",
    "micm" => "atmospheres/opac/mie/micm_optics.txt",
    "mitr" => "atmospheres/opac/mie/mitr_optics.txt",
    "suso" => "atmospheres/opac/mie/suso_optics.txt",
};

/// OPAC phase matrices by component and humidity (`mie::tables` format),
/// named by `mie::tables::phase_table_name` (e.g. `waso_rh50`), written by
/// `atmosim opac-tables`.
pub static OPAC_PHASE: &[(&str, &str)] = embedded! {
    "inso_rh0" => "atmospheres/opac/mie/inso_rh0_phase.txt",
    "waso_rh0" => "atmospheres/opac/mie/waso_rh0_phase.txt",
    "waso_rh50" => "atmospheres/opac/mie/waso_rh50_phase.txt",
    "waso_rh70" => "atmospheres/opac/mie/waso_rh70_phase.txt",
    "waso_rh80" => "atmospheres/opac/mie/waso_rh80_phase.txt",
    "waso_rh90" => "atmospheres/opac/mie/waso_rh90_phase.txt",
    "waso_rh95" => "atmospheres/opac/mie/waso_rh95_phase.txt",
    "waso_rh98" => "atmospheres/opac/mie/waso_rh98_phase.txt",
    "waso_rh99" => "atmospheres/opac/mie/waso_rh99_phase.txt",
    "soot_rh0" => "atmospheres/opac/mie/soot_rh0_phase.txt",
    "ssam_rh0" => "atmospheres/opac/mie/ssam_rh0_phase.txt",
    "ssam_rh50" => "atmospheres/opac/mie/ssam_rh50_phase.txt",
    "ssam_rh70" => "atmospheres/opac/mie/ssam_rh70_phase.txt",
    "ssam_rh80" => "atmospheres/opac/mie/ssam_rh80_phase.txt",
    "ssam_rh90" => "atmospheres/opac/mie/ssam_rh90_phase.txt",
    "ssam_rh95" => "atmospheres/opac/mie/ssam_rh95_phase.txt",
    "ssam_rh98" => "atmospheres/opac/mie/ssam_rh98_phase.txt",
    "ssam_rh99" => "atmospheres/opac/mie/ssam_rh99_phase.txt",
    "sscm_rh0" => "atmospheres/opac/mie/sscm_rh0_phase.txt",
    "sscm_rh50" => "atmospheres/opac/mie/sscm_rh50_phase.txt",
    "sscm_rh70" => "atmospheres/opac/mie/sscm_rh70_phase.txt",
    "sscm_rh80" => "atmospheres/opac/mie/sscm_rh80_phase.txt",
    "sscm_rh90" => "atmospheres/opac/mie/sscm_rh90_phase.txt",
    "sscm_rh95" => "atmospheres/opac/mie/sscm_rh95_phase.txt",
    "sscm_rh98" => "atmospheres/opac/mie/sscm_rh98_phase.txt",
    "sscm_rh99" => "atmospheres/opac/mie/sscm_rh99_phase.txt",
    "minm_rh0" => "atmospheres/opac/mie/minm_rh0_phase.txt",
    "miam_rh0" => "atmospheres/opac/mie/miam_rh0_phase.txt",
    "micm_rh0" => "atmospheres/opac/mie/micm_rh0_phase.txt",
    "mitr_rh0" => "atmospheres/opac/mie/mitr_rh0_phase.txt",
    "suso_rh0" => "atmospheres/opac/mie/suso_rh0_phase.txt",
    "suso_rh50" => "atmospheres/opac/mie/suso_rh50_phase.txt",
    "suso_rh70" => "atmospheres/opac/mie/suso_rh70_phase.txt",
    "suso_rh80" => "atmospheres/opac/mie/suso_rh80_phase.txt",
    "suso_rh90" => "atmospheres/opac/mie/suso_rh90_phase.txt",
    "suso_rh95" => "atmospheres/opac/mie/suso_rh95_phase.txt",
    "suso_rh98" => "atmospheres/opac/mie/suso_rh98_phase.txt",
    "suso_rh99" => "atmospheres/opac/mie/suso_rh99_phase.txt",
};

/// OPAC refractive indices of all ten components, every tabulated humidity
/// in one file per component (Hess et al. 1998); input of the Mie solver.
pub static OPAC_REFRACTIVE: &[(&str, &str)] = embedded! {
    "inso" => "atmospheres/opac/refractive/inso.txt",
    "waso" => "atmospheres/opac/refractive/waso.txt",
    "soot" => "atmospheres/opac/refractive/soot.txt",
    "ssam" => "atmospheres/opac/refractive/ssam.txt",
    "sscm" => "atmospheres/opac/refractive/sscm.txt",
    "minm" => "atmospheres/opac/refractive/minm.txt",
    "miam" => "atmospheres/opac/refractive/miam.txt",
    "micm" => "atmospheres/opac/refractive/micm.txt",
    "mitr" => "atmospheres/opac/refractive/mitr.txt",
    "suso" => "atmospheres/opac/refractive/suso.txt",
};

/// OPAC log-normal size distributions of all components and humidities.
pub static OPAC_SIZE_DISTRIBUTIONS: &str = include_str!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/atmospheres/opac/size_distributions.txt"
));

/// Ozone cross-section tables.
pub static OZONE_CROSS_SECTIONS: &[(&str, &str)] = embedded! {
    "bogumil" => "spectra/ozone_bogumil.txt",
    "molina" => "spectra/ozone_molina.txt",
};

/// NO₂ absorption cross section (Bogumil et al., IUP Bremen), 280–760 nm,
/// in the ozone tables' format.
pub static NO2_CROSS_SECTION: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/spectra/no2_bogumil.txt"));

/// O₂–O₂ collision-induced absorption (Greenblatt et al. 1990), cm⁵.
pub static O4_CROSS_SECTION: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/spectra/o4_greenblatt.txt"));

/// The k-distributions of H₂O, CO₂, O₂, CH₄ and N₂O per 40 nm band,
/// 280–2480 nm (`physics::kdistribution`).
pub static GAS_KDISTRIBUTIONS: &str =
    include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/spectra/gas_kdistributions.txt"));

/// The CIE 1931 2° colour-matching functions, 380–780 nm every 5 nm (the
/// colour of previews, `io::srgb`).
pub static CIE_1931_2DEG: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/spectra/cie1931_2deg_5nm.txt"));

/// Kurucz (1992) extraterrestrial solar irradiance, 1 nm, W m⁻² nm⁻¹.
pub static SOLAR_KURUCZ: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/spectra/solar_kurucz_1nm.txt"));

/// Looks up a built-in table by name.
pub fn builtin(set: &'static [(&'static str, &'static str)], name: &str) -> Option<&'static str> {
    set.iter().find(|(n, _)| *n == name).map(|(_, text)| *text)
}

/// The names of a built-in set, for error messages.
pub fn names(set: &[(&str, &str)]) -> String {
    set.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
}

/// The 1-based line numbers of a table text's data rows, in the order of
/// [`Table::rows`], for errors that name the line of a row.
pub fn row_lines(text: &str) -> impl Iterator<Item = usize> + '_ {
    text.lines().enumerate().filter_map(|(i, l)| {
        let s = l.trim();
        (!s.is_empty() && !s.starts_with('#')).then_some(i + 1)
    })
}

/// Linear interpolation in a table with ascending abscissae `x`; `None`
/// outside `[x[0], x[n-1]]`.
pub fn interp_linear(x: &[f64], y: &[f64], at: f64) -> Option<f64> {
    let (lo, frac) = bracket(x, at)?;
    Some(if frac == 0.0 {
        y[lo]
    } else {
        y[lo] + (y[lo + 1] - y[lo]) * frac
    })
}

/// The interval of an ascending table that holds `at`: the index of its
/// lower node and the fraction of the way to the next node. `None` outside.
///
/// The lower node is the last one at or below `at` (the last but one at
/// the table's end). It is found from a guess at `at`'s place on a
/// straight line from the first node to the last, walked a few nodes to
/// the right one: on the evenly spaced spectral tables read once per path
/// and channel (ozone's 8,360 rows at 0.1 nm) that is one or two steps
/// instead of a binary search's thirteen; a table far from even falls
/// back to the binary search, with the same result.
pub fn bracket(x: &[f64], at: f64) -> Option<(usize, f64)> {
    let n = x.len();
    if n == 0 || !(at >= x[0] && at <= x[n - 1]) {
        return None;
    }
    if n == 1 {
        return Some((0, 0.0));
    }
    let lo = lower_node(x, at);
    let hi = lo + 1;
    Some((lo, ((at - x[lo]) / (x[hi] - x[lo])).min(1.0)))
}

/// Nodes a guess may be walked before the binary search takes over.
const BRACKET_WALK: usize = 4;

/// The last node of `x` (ascending, at least 2 nodes, `x[0] ≤ at ≤
/// x[n−1]`) at or below `at`, at most n − 2.
#[inline]
fn lower_node(x: &[f64], at: f64) -> usize {
    let last = x.len() - 2;
    let span = x[last + 1] - x[0];
    let guess = if span > 0.0 {
        (((at - x[0]) / span) * (last + 1) as f64) as usize
    } else {
        0
    };
    let mut lo = guess.min(last);
    for _ in 0..BRACKET_WALK {
        if lo > 0 && x[lo] > at {
            lo -= 1;
        } else if lo < last && x[lo + 1] <= at {
            lo += 1;
        } else {
            return lo;
        }
    }
    x.partition_point(|&v| v <= at).clamp(1, last + 1) - 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_comments_headers_and_rows() {
        let t = Table::parse("t", "# a: 1.5\n# free text\n1 2\n\n3 4\n", 2).unwrap();
        assert_eq!(t.header("a"), Some("1.5"));
        assert_eq!(t.rows, vec![vec![1.0, 2.0], vec![3.0, 4.0]]);
    }

    #[test]
    fn rejects_ragged_and_non_numeric_rows() {
        assert!(Table::parse("t", "1 2\n3\n", 0).is_err());
        let e = Table::parse("t", "1 x\n", 2).unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("`x`"), "{e}");
    }

    /// The bracket by binary search alone, as it was found before the
    /// guess: the reference the guessed one must equal.
    fn bracket_by_search(x: &[f64], at: f64) -> Option<(usize, f64)> {
        let n = x.len();
        if n == 0 || !(at >= x[0] && at <= x[n - 1]) {
            return None;
        }
        if n == 1 {
            return Some((0, 0.0));
        }
        let hi = x.partition_point(|&v| v <= at).clamp(1, n - 1);
        let lo = hi - 1;
        Some((lo, ((at - x[lo]) / (x[hi] - x[lo])).min(1.0)))
    }

    use proptest::prelude::Just;

    proptest::proptest! {
        #[test]
        fn the_guessed_bracket_is_the_binary_searchs(
            steps in proptest::collection::vec(proptest::prop_oneof![
                Just(0.0),
                0.001f64..0.002,
                0.1f64..1.0,
                1.0f64..1000.0,
            ], 1..60),
            start in -100.0f64..100.0,
            at in proptest::prop_oneof![0.0f64..1.0, Just(0.0), Just(1.0)],
            outside in -0.5f64..1.5,
        ) {
            // Ascending nodes, uneven, with repeats; points inside (on
            // nodes included) and outside.
            let mut x = vec![start];
            for s in &steps {
                x.push(x.last().unwrap() + s);
            }
            let (a, b) = (x[0], *x.last().unwrap());
            for p in [a + at * (b - a), a + outside * (b - a)] {
                proptest::prop_assert_eq!(bracket(&x, p), bracket_by_search(&x, p));
            }
            for &node in &x {
                proptest::prop_assert_eq!(bracket(&x, node), bracket_by_search(&x, node));
            }
        }
    }

    #[test]
    fn the_guess_finds_the_ozone_tables_rows() {
        // The built-in ozone table, evenly spaced: every node and midpoint.
        let text = builtin(OZONE_CROSS_SECTIONS, "bogumil").unwrap();
        let t = Table::parse("bogumil", text, 4).unwrap();
        let x: Vec<f64> = t.rows.iter().map(|r| r[0]).collect();
        for k in 0..x.len() {
            assert_eq!(bracket(&x, x[k]), bracket_by_search(&x, x[k]));
            if k + 1 < x.len() {
                let mid = 0.5 * (x[k] + x[k + 1]);
                assert_eq!(bracket(&x, mid), bracket_by_search(&x, mid));
            }
        }
    }

    #[test]
    fn interpolation_hits_nodes_and_midpoints() {
        let x = [1.0, 2.0, 4.0];
        let y = [10.0, 20.0, 0.0];
        assert_eq!(interp_linear(&x, &y, 2.0), Some(20.0));
        assert_eq!(interp_linear(&x, &y, 4.0), Some(0.0));
        assert_eq!(interp_linear(&x, &y, 3.0), Some(10.0));
        assert_eq!(interp_linear(&x, &y, 0.5), None);
    }

    #[test]
    fn every_builtin_table_parses() {
        for set in [
            AFGL_PROFILES,
            OPAC_MIXTURES,
            OPAC_COMPONENTS,
            OPAC_REFRACTIVE,
            OZONE_CROSS_SECTIONS,
        ] {
            for (name, text) in set {
                Table::parse(name, text, 0).unwrap();
            }
        }
        Table::parse("kurucz", SOLAR_KURUCZ, 2).unwrap();
        Table::parse("size_distributions", OPAC_SIZE_DISTRIBUTIONS, 7).unwrap();
    }
}
