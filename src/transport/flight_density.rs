//! The density from which sun-aware connections draw one point along a
//! whole flight (`spectral`).
//!
//! It follows up to two channels (one for a single wavelength). Each
//! followed channel's density is a defensive mixture:
//! - with share α, q_sun ∝ c̄·e^(−τ)·e^(−τ̃_sun);
//! - with share 1 − α, q_flight ∝ c̄·e^(−τ).
//!
//! Here τ is the channel's optical depth along the flight and τ̃_sun its
//! approximate depth toward the sun (`sun_depth`). Both are piecewise
//! exponential over pieces of the flight: runs of up to a given number of
//! layer segments (one: exact per segment) and [`PIECE_DEPTH`] optical
//! depth of the last followed channel. Inside a piece, both exponents are
//! linear in the distance from their exact values at its ends, and so is
//! ln c (c = σ_s·P11 at the sun's centre), through the values of the
//! piece's first and last segments at their middles: σ_s falls about
//! exponentially with altitude, the aerosol's within a kilometre or two,
//! so over a piece of four layers it can fall tenfold. (With c flat at the
//! piece's mean, as until 2026-11-27, single scattering at 740 nm seen at
//! the zenith from the ground under a sun 10° up had a variance per path
//! 4.7 times this one's.) A piece is chosen with the integral of its
//! density with c flat at its length-weighted mean c̄.
//!
//! The point's pdf is that of the draw itself: a channel, a part, a piece
//! by that integral, then the exact exponential inside it. Whatever the
//! pieces' accuracy, a contribution divided by it is unbiased wherever
//! σ_s > 0. The q_flight share bounds every weight by about 1/(1 − α)
//! times that of sampling the flight's own density.

use glam::DVec3;

use crate::geometry::ray::{Ray, Segment};
use crate::sampling::sampler::Sampler;
use crate::transport::sun_depth::SunDepth;

/// The most optical depth of the last followed channel in one piece of
/// more than one segment.
pub const PIECE_DEPTH: f64 = 0.3;

/// The most channels a density follows.
pub const MAX_FOLLOWED: usize = 2;

/// One segment's optics for each followed channel: its optical depth and
/// its σ_s·P11 at the sun's centre.
pub type SegmentOptics = [(f64, f64); MAX_FOLLOWED];

/// A run of a flight's segments that is one exponential piece.
#[derive(Debug, Default, Clone, Copy)]
struct Piece {
    /// Its segments, `first..end`, and its span along the flight.
    first: usize,
    end: usize,
    t0: f64,
    t1: f64,
    /// The layer of its last segment (its end lies on a level of it).
    end_layer: usize,
}

/// One piece for one followed channel.
#[derive(Debug, Default, Clone, Copy)]
struct Terms {
    /// Optical depth along the flight at the piece's start, and over it.
    tau0: f64,
    tau: f64,
    /// Approximate depth toward the sun at the piece's ends.
    sun0: f64,
    sun1: f64,
    /// Mean σ_s·P11 at the sun's centre (the piece's share), and the
    /// change of its logarithm over the piece (the density's shape inside
    /// it).
    c: f64,
    gc: f64,
    /// ∫ of the unnormalised sun-following and flight densities.
    sun_integral: f64,
    flight_integral: f64,
}

/// A drawn point: its distance along the flight, the segment holding it,
/// and the density it was drawn with, per unit length.
#[derive(Debug, Clone, Copy)]
pub struct Point {
    pub t: f64,
    pub segment: usize,
    pub pdf: f64,
}

/// The density along one flight; its buffers are reused from flight to
/// flight.
#[derive(Debug, Default, Clone)]
pub struct FlightDensity {
    pieces: Vec<Piece>,
    terms: Vec<Terms>,
    /// Per followed channel: the totals of both parts, and whether it can
    /// be drawn from.
    totals: [(f64, f64, bool); MAX_FOLLOWED],
    /// Per followed channel: the exponent the sun-following integrals are
    /// shifted by (their true values are theirs × e^(−shift)).
    shifts: [f64; MAX_FOLLOWED],
    followed: usize,
}

impl FlightDensity {
    /// Builds the density of the flight along `ray` over its `segments`
    /// for `followed` channels, in pieces of at most `piece_segments`
    /// segments. `optics(i, segment)` is called once per segment, in
    /// order. `depth` holds one profile per followed channel. Returns
    /// whether any channel can be drawn from.
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        &mut self,
        ray: &Ray,
        segments: &[Segment],
        followed: usize,
        piece_segments: usize,
        mut optics: impl FnMut(usize, &Segment) -> SegmentOptics,
        depth: &SunDepth,
        sun: DVec3,
    ) -> bool {
        debug_assert!((1..=MAX_FOLLOWED).contains(&followed) && depth.profiles() == followed);
        self.followed = followed;
        self.pieces.clear();
        self.terms.clear();
        let nk = followed;
        let Some(first) = segments.first() else {
            return false;
        };
        // Pass 1: the pieces, with their optics.
        let mut piece = Piece {
            first: 0,
            t0: first.t0,
            ..Piece::default()
        };
        // Per followed channel: Σ c·length and Σ τ of the open piece, and
        // τ along the flight at its start.
        let mut acc = [(0.0f64, 0.0f64); MAX_FOLLOWED];
        // Per followed channel: c and the middle of the piece's first and
        // last segments.
        let mut ends = [[(0.0f64, 0.0f64); 2]; MAX_FOLLOWED];
        let mut tau0 = [0.0f64; MAX_FOLLOWED];
        let last = nk - 1;
        for (i, seg) in segments.iter().enumerate() {
            let len = seg.t1 - seg.t0;
            let o = optics(i, seg);
            if i > piece.first && (i - piece.first >= piece_segments || acc[last].1 + o[last].0 > PIECE_DEPTH) {
                self.close(piece, i, segments[i - 1], &acc, &ends, &mut tau0);
                piece = Piece {
                    first: i,
                    t0: seg.t0,
                    ..Piece::default()
                };
                acc = [(0.0, 0.0); MAX_FOLLOWED];
            }
            let middle = 0.5 * (seg.t0 + seg.t1);
            for k in 0..nk {
                acc[k].0 += o[k].1 * len;
                acc[k].1 += o[k].0;
                if i == piece.first {
                    ends[k][0] = (o[k].1, middle);
                }
                ends[k][1] = (o[k].1, middle);
            }
        }
        self.close(
            piece,
            segments.len(),
            segments[segments.len() - 1],
            &acc,
            &ends,
            &mut tau0,
        );
        // Pass 2: depths toward the sun at the pieces' ends.
        let mut v = [0.0f64; MAX_FOLLOWED + 1];
        depth.at_in_layer_into(ray.origin + first.t0 * ray.dir, sun, first.layer, &mut v[..=nk]);
        for k in 0..nk {
            self.terms[k].sun0 = SunDepth::profile_depth(&v[..=nk], k);
        }
        let np = self.pieces.len();
        for j in 0..np {
            let p = self.pieces[j];
            depth.at_end_in_layer_into(ray.origin + p.t1 * ray.dir, sun, p.end_layer, &mut v[..=nk]);
            for k in 0..nk {
                let sun1 = SunDepth::profile_depth(&v[..=nk], k);
                self.terms[j * nk + k].sun1 = sun1;
                if j + 1 < np {
                    self.terms[(j + 1) * nk + k].sun0 = sun1;
                }
            }
        }
        // Pass 3: the integrals, one exponential per piece boundary (both
        // exponents are continuous along the flight), the sun's shifted by
        // its smallest exponent.
        let integral = |c: f64, len: f64, w0: f64, w1: f64, de: f64| {
            c * len
                * if de.abs() < 1e-7 {
                    0.5 * (w0 + w1)
                } else {
                    (w0 - w1) / de
                }
        };
        let mut any = false;
        for k in 0..nk {
            let at = |j: usize| self.terms[j * nk + k];
            let e_min = (0..np)
                .map(|j| {
                    let t = at(j);
                    (t.tau0 + t.sun0).min(t.tau0 + t.tau + t.sun1)
                })
                .fold(f64::INFINITY, f64::min);
            let (mut sun_total, mut flight_total) = (0.0, 0.0);
            let mut w_sun = (-(at(0).tau0 + at(0).sun0 - e_min)).exp();
            let mut w_flight = (-at(0).tau0).exp();
            for j in 0..np {
                let len = self.pieces[j].t1 - self.pieces[j].t0;
                let t = &mut self.terms[j * nk + k];
                let w_sun1 = (-(t.tau0 + t.tau + t.sun1 - e_min)).exp();
                let w_flight1 = (-(t.tau0 + t.tau)).exp();
                t.sun_integral = integral(t.c, len, w_sun, w_sun1, t.tau + t.sun1 - t.sun0);
                t.flight_integral = integral(t.c, len, w_flight, w_flight1, t.tau);
                (w_sun, w_flight) = (w_sun1, w_flight1);
                sun_total += t.sun_integral;
                flight_total += t.flight_integral;
            }
            let usable = sun_total > 0.0 && flight_total > 0.0 && sun_total.is_finite() && flight_total.is_finite();
            self.totals[k] = (sun_total, flight_total, usable);
            self.shifts[k] = e_min;
            any |= usable;
        }
        any
    }

    /// Closes `piece` before segment `end` (`last` its last segment) with
    /// its sums `acc`, and moves `tau0` on past it.
    fn close(
        &mut self,
        mut piece: Piece,
        end: usize,
        last: Segment,
        acc: &[(f64, f64); MAX_FOLLOWED],
        ends: &[[(f64, f64); 2]; MAX_FOLLOWED],
        tau0: &mut [f64; MAX_FOLLOWED],
    ) {
        piece.end = end;
        piece.t1 = last.t1;
        piece.end_layer = last.layer;
        let len = piece.t1 - piece.t0;
        for k in 0..self.followed {
            let mean = if len > 0.0 { acc[k].0 / len } else { 0.0 };
            // The slope of ln c between the first and last segments'
            // middles, over the whole piece: σ_s falls about exponentially
            // with altitude, so a piece of several layers (the aerosol's
            // within a few kilometres) is far from its mean at its ends.
            let [(c_first, m_first), (c_last, m_last)] = ends[k];
            let gc = if c_first > 0.0 && c_last > 0.0 && m_last - m_first > 0.25 * len {
                ((c_last / c_first).ln() * len / (m_last - m_first)).clamp(-MAX_LOG_CHANGE, MAX_LOG_CHANGE)
            } else {
                0.0
            };
            self.terms.push(Terms {
                tau0: tau0[k],
                tau: acc[k].1,
                c: mean,
                gc,
                ..Terms::default()
            });
            tau0[k] += acc[k].1;
        }
        self.pieces.push(piece);
    }

    /// The mean over the followed channels of the approximate sunlit
    /// single scattering along the flight, ∫ c̄·e^(−τ)·e^(−τ̃_sun) dt
    /// (0 for a channel that cannot be drawn from): what the flight would
    /// bring a vertex at its start, to the densities' accuracy.
    pub fn sunlit_integral(&self) -> f64 {
        let nk = self.followed.max(1);
        (0..self.followed)
            .filter(|&k| self.totals[k].2)
            .map(|k| self.totals[k].0 * (-self.shifts[k]).exp())
            .sum::<f64>()
            / nk as f64
    }

    /// Draws a point along the flight of `segments` (those of `build`),
    /// with share `alpha` of the sun-following part; `None` when no
    /// channel can be drawn from or the density vanishes there.
    pub fn sample(&self, segments: &[Segment], alpha: f64, sampler: &mut Sampler) -> Option<Point> {
        let nk = self.followed;
        let mut usable = [0usize; MAX_FOLLOWED];
        let mut n_usable = 0;
        for k in (0..nk).filter(|&k| self.totals[k].2) {
            usable[n_usable] = k;
            n_usable += 1;
        }
        let usable = &usable[..n_usable];
        if usable.is_empty() {
            return None;
        }
        let np = self.pieces.len();
        let k = usable[((sampler.next_f64() * usable.len() as f64) as usize).min(usable.len() - 1)];
        let from_sun = alpha == 1.0 || sampler.next_f64() < alpha;
        let weight_of = |t: &Terms| if from_sun { t.sun_integral } else { t.flight_integral };
        let mut target = sampler.next_f64() * if from_sun { self.totals[k].0 } else { self.totals[k].1 };
        let j = (0..np)
            .find(|&j| {
                let w = weight_of(&self.terms[j * nk + k]);
                target -= w;
                target < 0.0 && w > 0.0
            })
            .unwrap_or_else(|| {
                (0..np)
                    .rev()
                    .find(|&j| weight_of(&self.terms[j * nk + k]) > 0.0)
                    .unwrap_or(0)
            });
        let tk = self.terms[j * nk + k];
        let de = (if from_sun { tk.tau + tk.sun1 - tk.sun0 } else { tk.tau }) - tk.gc;
        let v = sampler.next_f64();
        let u = if de.abs() < 1e-9 {
            v
        } else {
            -(-v * (-(-de).exp_m1())).ln_1p() / de
        };
        let p = self.pieces[j];
        let len = p.t1 - p.t0;
        let t = p.t0 + u * len;
        let segment = (p.first..p.end).find(|&i| t <= segments[i].t1).unwrap_or(p.end - 1);
        // The density of this draw, per unit length: for each followed
        // channel and part, the chance of the piece (its integral over
        // the total) times the density of u inside it.
        let inside = |de: f64| {
            if de.abs() < 1e-9 {
                1.0
            } else {
                de * (-de * u).exp() / -(-de).exp_m1()
            }
        };
        let mut pdf = 0.0;
        for &k in usable {
            let t = &self.terms[j * nk + k];
            let (sun_total, flight_total, _) = self.totals[k];
            pdf += alpha * t.sun_integral / sun_total * inside(t.tau + t.sun1 - t.sun0 - t.gc)
                + (1.0 - alpha) * t.flight_integral / flight_total * inside(t.tau - t.gc);
        }
        pdf /= usable.len() as f64 * len;
        (pdf > 0.0 && pdf.is_finite()).then_some(Point { t, segment, pdf })
    }
}

/// The most change of ln(σ_s·P11) over one piece the density follows.
const MAX_LOG_CHANGE: f64 = 10.0;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::shell::Geometry;

    /// The density of a drawn point is the density it was drawn from:
    /// over many draws, 1/pdf summed over the draws in a segment estimates
    /// that segment's length. Eight 1 km layers whose σ and c fall by e
    /// every 1.2 km, pieces of four segments (c then far from flat inside
    /// a piece), a slant flight up toward the sun and one away from it.
    #[test]
    fn drawn_points_carry_the_density_they_were_drawn_from() {
        let levels: Vec<f64> = (0..=8).map(|i| i as f64).collect();
        let sigma: Vec<f64> = (0..8).map(|i| 0.4 * (-(i as f64 + 0.5) / 1.2).exp()).collect();
        let c: Vec<f64> = (0..8).map(|i| 0.3 * (-(i as f64 + 0.5) / 1.2).exp()).collect();
        for sun_x in [0.6f64, -0.6] {
            let sun = DVec3::new(sun_x, 0.0, (1.0 - sun_x * sun_x).sqrt());
            let depth = SunDepth::of_profiles(
                &levels,
                std::slice::from_ref(&sigma),
                &Geometry::PlaneParallel,
                sun,
                false,
            );
            let dir = DVec3::new(0.5, 0.0, 0.75f64.sqrt());
            let ray = Ray {
                origin: DVec3::ZERO,
                dir,
                layer: 0,
            };
            let segments: Vec<Segment> = (0..8)
                .map(|i| Segment {
                    t0: i as f64 / dir.z,
                    t1: (i + 1) as f64 / dir.z,
                    layer: i,
                })
                .collect();
            let mut density = FlightDensity::default();
            let optics = |_: usize, s: &Segment| {
                let mut o = [(0.0, 0.0); MAX_FOLLOWED];
                o[0] = (sigma[s.layer] * (s.t1 - s.t0), c[s.layer]);
                o
            };
            assert!(density.build(&ray, &segments, 1, 4, optics, &depth, sun));
            assert!(density.terms.iter().any(|t| t.gc < -2.0), "c falls inside a piece");
            let n = 400_000;
            let mut sums = vec![(0.0f64, 0.0f64); segments.len()];
            let mut sampler = Sampler::new(&[7]);
            for _ in 0..n {
                let p = density
                    .sample(&segments, SUN_SHARE_IN_TEST, &mut sampler)
                    .expect("a point");
                assert!(segments[p.segment].t0 <= p.t && p.t <= segments[p.segment].t1);
                let w = 1.0 / p.pdf;
                sums[p.segment].0 += w;
                sums[p.segment].1 += w * w;
            }
            for (s, (sum, sum_sq)) in segments.iter().zip(sums) {
                let mean = sum / n as f64;
                let se = ((sum_sq / n as f64 - mean * mean) / (n as f64 - 1.0)).sqrt();
                let len = s.t1 - s.t0;
                // 4.52 standard errors: two-sided, Šidák over 16 values at 1e-4.
                assert!(
                    (mean - len).abs() < 4.52 * se,
                    "segment {}: {mean} ± {se} against {len}",
                    s.layer
                );
            }
        }
    }

    const SUN_SHARE_IN_TEST: f64 = 0.8;

    #[test]
    fn the_sunlit_integral_is_the_closed_form_in_exponential_layers() {
        // Plane-parallel layers 0–5 km (σ 0.1/km) and 5–10 km (σ 0.02/km),
        // sun at μ0 = 0.5, c = σ_s·P11 = 0.7 and 0.3; a vertical flight
        // from 1 km to the top (a piece ends on a level, as flights do),
        // one piece per segment. Along it both exponents
        // are linear in each layer, so the pieces are exact and
        // ∫ c·e^(−τ(t))·e^(−τ_sun(t)) dt has a closed form per layer:
        // c·e^(−a)·(1 − e^(−b·L))/b, a the exponent at the layer's start
        // and b its slope.
        let levels = [0.0, 5.0, 10.0];
        let sigma = [0.1, 0.02];
        let c = [0.7, 0.3];
        let mu0: f64 = 0.5;
        let sun = DVec3::new((1.0 - mu0 * mu0).sqrt(), 0.0, mu0);
        let depth = SunDepth::of_profiles(&levels, &[sigma.to_vec()], &Geometry::PlaneParallel, sun, false);
        let ray = Ray {
            origin: DVec3::new(0.0, 0.0, 1.0),
            dir: DVec3::Z,
            layer: 0,
        };
        let segments = [
            Segment {
                t0: 0.0,
                t1: 4.0,
                layer: 0,
            },
            Segment {
                t0: 4.0,
                t1: 9.0,
                layer: 1,
            },
        ];
        let mut density = FlightDensity::default();
        let usable = density.build(
            &ray,
            &segments,
            1,
            1,
            |_, s| {
                let mut o = [(0.0, 0.0); MAX_FOLLOWED];
                o[0] = (sigma[s.layer] * (s.t1 - s.t0), c[s.layer]);
                o
            },
            &depth,
            sun,
        );
        assert!(usable);
        // τ_sun at altitude z: the column above over μ0.
        let above = |z: f64| {
            if z < 5.0 {
                sigma[0] * (5.0 - z) + sigma[1] * 5.0
            } else {
                sigma[1] * (10.0 - z)
            }
        };
        let mut expected = 0.0;
        let mut tau = 0.0;
        for s in &segments {
            let (z0, len, k) = (1.0 + s.t0, s.t1 - s.t0, sigma[s.layer]);
            let a = tau + above(z0) / mu0;
            let b = k - k / mu0;
            expected += c[s.layer] * (-a).exp() * (1.0 - (-b * len).exp()) / b;
            tau += k * len;
        }
        let got = density.sunlit_integral();
        assert!((got / expected - 1.0).abs() < 1e-12, "{got} against {expected}");
    }
}
