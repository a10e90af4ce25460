//! Cells of a (γ, α) table that its own sky has no direction for, taken
//! from the tables of the neighbouring sun elevations (the supplement's
//! "dilation": the valid area is widened by just what the interpolation
//! between fitted elevations reads).
//!
//! The runtime interpolates reconstructed values linearly in the sun's
//! elevation at fixed (γ, α). The valid parallelogram moves with the sun,
//! so a query between the nodes η₀ < η < η₁ reads cells of the η₀ table
//! that only the η₁ sky has (and the other way round). A harmonic fill of
//! those cells knows nothing of the sky there; the neighbour's data does.
//! With T the table being completed and N a neighbour, the borrowed value
//! is N + d, where d is T − N on the cells both have, continued
//! harmonically into the cells only N has: d joins T's own data without a
//! seam, and the interpolation at η reads N + (1 − t)·d there, which tends
//! to the neighbour's own sky as η tends to it. Where both neighbours
//! have a cell the two values are averaged.

use super::AngleTable;
use super::laplace;

/// Fills, in `table`, the cells it has no data for but a neighbour has,
/// and returns which cells now hold data (its own or borrowed). The
/// neighbours are raw tables (their `valid` flags mark their own data) on
/// the same nodes as `table`; cells that no table has are left as they are.
///
/// # Panics
///
/// If a neighbour's size differs from `table`'s: a programming error.
pub fn borrow_from_neighbours(table: &mut AngleTable, neighbours: &[&AngleTable]) -> Vec<bool> {
    let cells = table.values.len();
    let mut sum = vec![0.0; cells];
    let mut count = vec![0u8; cells];
    for nb in neighbours {
        assert_eq!(
            nb.values.len(),
            cells,
            "borrow_from_neighbours: tables of different sizes"
        );
        let both: Vec<bool> = (0..cells).map(|k| table.valid[k] && nb.valid[k]).collect();
        let gains = (0..cells).any(|k| nb.valid[k] && !table.valid[k]);
        if !gains || !both.iter().any(|&b| b) {
            continue;
        }
        let mut diff: Vec<f64> = (0..cells)
            .map(|k| if both[k] { table.values[k] - nb.values[k] } else { 0.0 })
            .collect();
        laplace::fill(&mut diff, &both, table.n, table.n, false);
        for k in 0..cells {
            if nb.valid[k] && !table.valid[k] {
                sum[k] += nb.values[k] + diff[k];
                count[k] += 1;
            }
        }
    }
    let mut has = table.valid.clone();
    for k in 0..cells {
        if count[k] > 0 {
            table.values[k] = sum[k] / f64::from(count[k]);
            has[k] = true;
        }
    }
    has
}

#[cfg(test)]
mod tests {
    use super::super::SphereImage;
    use super::super::reproject::to_angle_table;
    use super::*;

    /// The raw table of a sky whose pixels hold f(direction) for a sun at
    /// `elevation_deg`, seen from the ground.
    fn raw(f: impl Fn(glam::DVec3) -> f64, elevation_deg: f64, n: usize) -> AngleTable {
        let mut img = SphereImage::zeros(256, 128);
        for j in 0..img.height {
            for i in 0..img.width {
                img.values[j * img.width + i] = f(img.direction(i, j));
            }
        }
        to_angle_table(&img, elevation_deg.to_radians(), 0.0, n)
    }

    #[test]
    fn a_sky_that_depends_on_the_table_angles_alone_is_borrowed_exactly() {
        // F = 1 + γ/π + 2·(α/π)²: the same function of (γ, α) at every sun
        // elevation, so the cells one sky lacks are known from the other.
        // The 30° table borrows the cells only the 40° sky has; there the
        // difference of the two tables is 0 on the shared cells (up to
        // sampling), and the borrowed value is F.
        let n = 91;
        let f_of =
            |gamma: f64, alpha: f64| 1.0 + gamma / std::f64::consts::PI + 2.0 * (alpha / std::f64::consts::PI).powi(2);
        let sky = |e: f64| {
            move |v: glam::DVec3| {
                let s = glam::DVec3::new(e.to_radians().cos(), 0.0, e.to_radians().sin());
                let gamma = v.dot(s).clamp(-1.0, 1.0).acos();
                let alpha = v.z.clamp(-1.0, 1.0).acos();
                1.0 + gamma / std::f64::consts::PI + 2.0 * (alpha / std::f64::consts::PI).powi(2)
            }
        };
        let mut low = raw(sky(30.0), 30.0, n);
        let high = raw(sky(40.0), 40.0, n);
        let own = low.valid.clone();
        let has = borrow_from_neighbours(&mut low, &[&high]);
        let mut borrowed = 0;
        for k in 0..n * n {
            assert_eq!(has[k], own[k] || high.valid[k]);
            if has[k] && !own[k] {
                borrowed += 1;
                // Up to the images' own sampling error at that cell (largest
                // at the poles, where the bilinear lookup clamps).
                let (gamma, alpha) = (low.angle(k % n), low.angle(k / n));
                let sampling = (high.values[k] - f_of(gamma, alpha)).abs();
                assert!(
                    (low.values[k] - f_of(gamma, alpha)).abs() < 0.005 + sampling,
                    "γ {gamma}, α {alpha}: {} vs {} (sampling error {sampling})",
                    low.values[k],
                    f_of(gamma, alpha)
                );
            }
        }
        assert!(borrowed > 100, "only {borrowed} cells borrowed");
    }

    #[test]
    fn a_constant_offset_between_the_skies_is_kept_in_the_borrowed_cells() {
        // The neighbour is the same sky plus 0.5: the borrowed cells must
        // carry the table's own level (N + d with d = −0.5), not the
        // neighbour's, so that the table stays continuous.
        let n = 61;
        let f = |v: glam::DVec3| 2.0 + v.z;
        let mut low = raw(f, 10.0, n);
        let high = raw(move |v| f(v) + 0.5, 25.0, n);
        let own = low.valid.clone();
        borrow_from_neighbours(&mut low, &[&high]);
        for (k, (&had, &theirs)) in own.iter().zip(&high.valid).enumerate() {
            if theirs && !had {
                let alpha = low.angle(k / n);
                assert!(
                    (low.values[k] - (2.0 + alpha.cos())).abs() < 0.02,
                    "α {alpha}: {}",
                    low.values[k]
                );
            }
        }
    }

    #[test]
    fn without_neighbours_or_new_cells_nothing_changes() {
        let n = 31;
        let mut t = raw(|v| v.x, 20.0, n);
        let before = t.clone();
        assert_eq!(borrow_from_neighbours(&mut t, &[]), before.valid);
        assert_eq!(t, before);
        let same = before.clone();
        assert_eq!(borrow_from_neighbours(&mut t, &[&same]), before.valid);
        assert_eq!(t, before);
    }
}
