//! Writing results: CSV tables for the `directions` sensor and the fluxes,
//! always through a temporary file renamed into place, so a crash never
//! leaves a file that looks complete.

use std::io::Write;
use std::path::Path;

use crate::error::{Error, Result};
use crate::render::{Direction, Fluxes, Tally};

/// Header of the radiance CSV of a `directions` sensor.
pub const RADIANCE_CSV_HEADER: &str =
    "wavelength_nm,albedo,view_zenith_deg,azimuth_deg,I,Q,U,V,I_se,Q_se,U_se,V_se,samples";
/// Header of the flux CSV.
pub const FLUX_CSV_HEADER: &str =
    "wavelength_nm,albedo,altitude_km,e_dir,e_down,e_up,e_down_se,e_up_se,samples";

/// The radiance of one direction at one wavelength and albedo.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadianceRow {
    pub wavelength_nm: f64,
    pub albedo: f64,
    pub direction: Direction,
    pub tally: Tally,
}

/// The fluxes at one wavelength and albedo.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FluxRow {
    pub wavelength_nm: f64,
    pub albedo: f64,
    pub altitude_km: f64,
    pub fluxes: Fluxes,
}

/// The radiance CSV text.
pub fn radiance_csv(rows: &[RadianceRow]) -> String {
    let mut s = String::from(RADIANCE_CSV_HEADER);
    s.push('\n');
    for r in rows {
        let (m, se) = (r.tally.mean(), r.tally.standard_error());
        s.push_str(&format!(
            "{},{},{},{},{:.9e},{:.9e},{:.9e},{:.9e},{:.4e},{:.4e},{:.4e},{:.4e},{}\n",
            r.wavelength_nm,
            r.albedo,
            r.direction.view_zenith_deg,
            r.direction.azimuth_deg,
            m[0],
            m[1],
            m[2],
            m[3],
            se[0],
            se[1],
            se[2],
            se[3],
            r.tally.samples
        ));
    }
    s
}

/// The flux CSV text.
pub fn flux_csv(rows: &[FluxRow]) -> String {
    let mut s = String::from(FLUX_CSV_HEADER);
    s.push('\n');
    for r in rows {
        let f = &r.fluxes;
        s.push_str(&format!(
            "{},{},{},{:.9e},{:.9e},{:.9e},{:.4e},{:.4e},{}\n",
            r.wavelength_nm,
            r.albedo,
            r.altitude_km,
            f.e_dir,
            f.e_down,
            f.e_up,
            f.e_down_se,
            f.e_up_se,
            f.samples
        ));
    }
    s
}

/// Writes `contents` to `path` atomically: a temporary file in the same
/// directory, flushed and synced, then renamed over `path`.
pub fn write_atomic(path: &Path, contents: &[u8]) -> Result<()> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(io)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp.{}", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(contents)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sub").join("a.csv");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(p.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
    }
}
