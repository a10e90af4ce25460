//! The density from which sun-aware connections draw one point along a
//! whole flight (`spectral`).
//!
//! It follows up to two channels (one for a single wavelength), the
//! less extinct first, drawn from with shares 1 − s and s
//! ([`MOST_EXTINCT_SHARE`]). Each followed channel's density is a
//! defensive mixture:
//! - with share α, q_sun ∝ c̄·e^(−τ)·e^(−τ̃_sun);
//! - with share 1 − α, q_flight ∝ c̄·e^(−τ).
//!
//! Here τ is the channel's optical depth along the flight and τ̃_sun its
//! approximate depth toward the sun (`sun_depth`). Both are piecewise
//! exponential over pieces of the flight: runs of up to a given number of
//! layer segments (one: exact per segment) and [`PIECE_DEPTH`] optical
//! depth of the last followed channel, a piece longer than 40 km halved
//! (up to three times) where the sun's depth at its middle is below the
//! mean of its ends' by more than 0.3. Inside a piece, both exponents are
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
use crate::transport::sun_depth::{BLOCKED_DEPTH, SunDepth};

/// The most optical depth of the last followed channel in one piece of
/// more than one segment.
pub const PIECE_DEPTH: f64 = 0.3;

/// Pieces longer than this (km) are halved where the sun's depth at
/// their middle is below the mean of its values at their ends by more
/// than [`SPLIT_DEVIATION`] in a followed channel: along a flight of 100
/// km or more (a tangent segment low in the atmosphere) under a grazing
/// sun the depth is far from linear, and a piece that follows it
/// linearly draws too few points where it dips, which makes heavy tails
/// (where it bulges, the piece only draws more points than it needs).
/// Measured on 2026-11-27 (docs/design-sun.md, "Sun connections along shared
/// paths"): twilight paths about 5 % dearer, the largest variance per
/// path at 620-740 nm about a third.
const SPLIT_LENGTH_KM: f64 = 40.0;

/// See [`SPLIT_LENGTH_KM`].
const SPLIT_DEVIATION: f64 = 0.3;

/// The most times a piece is halved ([`SPLIT_LENGTH_KM`]).
const MAX_HALVINGS: u32 = 3;

/// The most channels a density follows.
pub const MAX_FOLLOWED: usize = 2;

/// The share of the draws from the second followed channel, the more
/// extinct one (channels are followed least extinct first), where both
/// can be drawn from; the first gets the rest. Of a spectral group's
/// bands the most extinct is the noisiest in most of the sky model grid's
/// tasks (320-360 nm in every task of `bench --grid`), and a point drawn
/// for the less extinct channel serves it little (320-360 nm single
/// scattering seen from 15 km, sun 1° down: a variance per path of 0.33
/// in its group at equal shares, 0.11 alone). Measured on 2026-11-28
/// (docs/design-sun.md, "Sun connections along shared paths"): the grid's twelve
/// sun-aware tasks need 1-3 % fewer paths than with equal shares
/// (geometric mean at three seeds), the one from 15 km at −4.2° and
/// 131.8 km 14-17 % more (its least extinct band limits it); 0.85 raised
/// the least extinct channel's noise too far. A small gain: a fixed
/// share cannot know which band will limit a task.
pub const MOST_EXTINCT_SHARE: f64 = 0.7;

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
    /// The layer of its last segment (its end lies on a level of it; for
    /// the sun's depth there, before pieces are halved).
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

/// The change over a piece of the exponent of its sun-following part
/// (e^(−τ)·e^(−τ̃_sun)·c) and of its flight part (e^(−τ)·c), in that order.
#[inline]
fn changes(t: &Terms) -> [f64; 2] {
    [t.tau + t.sun1 - t.sun0 - t.gc, t.tau - t.gc]
}

/// A drawn point: its distance along the flight, the segment holding it,
/// and the density it was drawn with, per unit length.
#[derive(Debug, Clone, Copy)]
pub struct Point {
    pub t: f64,
    pub segment: usize,
    pub pdf: f64,
    /// The piece it was drawn in (a hint for [`FlightDensity::sun_pdf_of`]
    /// on a density with the same pieces).
    pub piece: usize,
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
    /// Buffers for [`FlightDensity::halve_bends`].
    spare_pieces: Vec<Piece>,
    spare_terms: Vec<Terms>,
    /// The pieces that bend: index, segment of the middle, depths there.
    bends: Vec<(usize, (usize, [f64; MAX_FOLLOWED]))>,
    /// Per piece and followed channel (`[piece·followed + k]`), where
    /// [`FlightDensity::keep_normalisers`] made them: 1 − e^(−Δ) of the
    /// sun-following and the flight part, Δ their exponent's change over
    /// the piece (what a draw and its density need); empty otherwise.
    normalisers: Vec<[f64; 2]>,
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
        self.normalisers.clear();
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
        // Long pieces halved where the sun's depth bends.
        if self.pieces.iter().any(|p| p.t1 - p.t0 > SPLIT_LENGTH_KM) {
            self.halve_bends(ray, segments, depth, sun);
        }
        let np = self.pieces.len();
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

    /// Halves every piece longer than [`SPLIT_LENGTH_KM`] where the sun's
    /// depth at its middle is below the mean of its ends' by more than
    /// [`SPLIT_DEVIATION`] in a followed channel, and each half the same
    /// way, at most [`MAX_HALVINGS`] deep. A half has half the piece's
    /// optical depth (exact in one segment, where σ is constant) and the
    /// mean of its part of the piece's exponential c.
    fn halve_bends(&mut self, ray: &Ray, segments: &[Segment], depth: &SunDepth, sun: DVec3) {
        let nk = self.followed;
        let ctx = (ray, segments, depth, sun);
        let terms_of = |terms: &[Terms], j: usize| {
            let mut t = [Terms::default(); MAX_FOLLOWED];
            t[..nk].copy_from_slice(&terms[j * nk..(j + 1) * nk]);
            t
        };
        // The long pieces' middles first, the flight kept as it is unless
        // one of them bends.
        self.bends.clear();
        for (j, piece) in self.pieces.iter().enumerate() {
            if piece.t1 - piece.t0 > SPLIT_LENGTH_KM
                && let Some(bend) = bend(nk, piece, &terms_of(&self.terms, j), ctx)
            {
                self.bends.push((j, bend));
            }
        }
        if self.bends.is_empty() {
            return;
        }
        let mut pieces = std::mem::take(&mut self.spare_pieces);
        let mut terms = std::mem::take(&mut self.spare_terms);
        pieces.clear();
        terms.clear();
        let mut out = (&mut pieces, &mut terms);
        let mut bends = self.bends.iter().peekable();
        for (j, &piece) in self.pieces.iter().enumerate() {
            let t = terms_of(&self.terms, j);
            match bends.next_if(|b| b.0 == j) {
                Some(&(_, bend)) => split(&mut out, nk, piece, t, bend, ctx, 1),
                None => keep(&mut out, nk, piece, &t),
            }
        }
        self.spare_pieces = std::mem::replace(&mut self.pieces, pieces);
        self.spare_terms = std::mem::replace(&mut self.terms, terms);
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

    /// Followed channel `k`'s approximate sunlit integral,
    /// ∫ c̄·e^(−τ)·e^(−τ̃_sun) dt over the flight; 0 where it cannot be
    /// drawn from.
    pub fn sun_integral_of(&self, k: usize) -> f64 {
        if k < self.followed && self.totals[k].2 {
            self.totals[k].0 * (-self.shifts[k]).exp()
        } else {
            0.0
        }
    }

    /// The density, per unit length at distance `t` along the flight, of
    /// followed channel `k`'s sun-following part alone (what
    /// [`FlightDensity::sample`] would draw from with that channel alone
    /// and share 1): over the flight it integrates to 1 where the channel
    /// can be drawn from, and it is 0 where it cannot or off the flight.
    /// `hint`: the piece to try first (a drawn [`Point::piece`] of a
    /// density with the same pieces; any other value searches).
    pub fn sun_pdf_of(&self, k: usize, t: f64, hint: usize) -> f64 {
        if k >= self.followed || !self.totals[k].2 {
            return 0.0;
        }
        let nk = self.followed;
        // The drawn point's piece where the pieces are the same, else the
        // one holding t.
        let j = match self.pieces.get(hint) {
            Some(p) if p.t0 <= t && t <= p.t1 => hint,
            _ => self.pieces.partition_point(|p| p.t1 < t),
        };
        let Some(p) = self.pieces.get(j) else {
            return 0.0;
        };
        let len = p.t1 - p.t0;
        if t < p.t0 || len <= 0.0 {
            return 0.0;
        }
        let tk = &self.terms[j * nk + k];
        let u = (t - p.t0) / len;
        let de = changes(tk)[0];
        let inside = if de.abs() < 1e-9 {
            1.0
        } else {
            de * (-de * u).exp() / self.one_minus_exp(j, k, 0, de)
        };
        tk.sun_integral / self.totals[k].0 * inside / len
    }

    /// Keeps 1 − e^(−Δ) of every piece's parts for the draws and densities
    /// to come (until the next build): for a density drawn from again and
    /// again (the view's own flight), where they would cost three `expm1`
    /// a draw; the same numbers either way.
    pub fn keep_normalisers(&mut self) {
        self.normalisers.clear();
        self.normalisers
            .extend(self.terms.iter().map(|t| changes(t).map(|de| -(-de).exp_m1())));
    }

    /// 1 − e^(−`de`) for piece `j`, followed channel `k` and part `part`
    /// (0 the sun-following, 1 the flight's; `de` its exponent's change
    /// over the piece): kept ([`FlightDensity::keep_normalisers`]) or
    /// computed.
    #[inline]
    fn one_minus_exp(&self, j: usize, k: usize, part: usize, de: f64) -> f64 {
        match self.normalisers.get(j * self.followed + k) {
            Some(n) => n[part],
            None => -(-de).exp_m1(),
        }
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
        // The followed channel's share of the draws.
        let share = |k: usize| match (usable.len(), k) {
            (1, _) => 1.0,
            (_, 0) => 1.0 - MOST_EXTINCT_SHARE,
            _ => MOST_EXTINCT_SHARE,
        };
        let k = match usable {
            [only] => {
                sampler.next_f64();
                *only
            }
            _ => usize::from(sampler.next_f64() < MOST_EXTINCT_SHARE),
        };
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
        let part = usize::from(!from_sun);
        let de = changes(&self.terms[j * nk + k])[part];
        let v = sampler.next_f64();
        let u = if de.abs() < 1e-9 {
            v
        } else {
            -(-v * self.one_minus_exp(j, k, part, de)).ln_1p() / de
        };
        let p = self.pieces[j];
        let len = p.t1 - p.t0;
        let t = p.t0 + u * len;
        let segment = (p.first..p.end).find(|&i| t <= segments[i].t1).unwrap_or(p.end - 1);
        // The density of this draw, per unit length: for each followed
        // channel and part, the chance of the piece (its integral over
        // the total) times the density of u inside it.
        let inside = |k: usize, part: usize, de: f64| {
            if de.abs() < 1e-9 {
                1.0
            } else {
                de * (-de * u).exp() / self.one_minus_exp(j, k, part, de)
            }
        };
        let mut pdf = 0.0;
        for &k in usable {
            let t = &self.terms[j * nk + k];
            let [de_sun, de_flight] = changes(t);
            let (sun_total, flight_total, _) = self.totals[k];
            pdf += share(k)
                * (alpha * t.sun_integral / sun_total * inside(k, 0, de_sun)
                    + (1.0 - alpha) * t.flight_integral / flight_total * inside(k, 1, de_flight));
        }
        pdf /= len;
        (pdf > 0.0 && pdf.is_finite()).then_some(Point {
            t,
            segment,
            pdf,
            piece: j,
        })
    }
}

/// Where a followed channel's sun depth at the middle of `piece` is below
/// the mean of its ends' by more than [`SPLIT_DEVIATION`]: the segment
/// holding the middle and every channel's depth there.
fn bend(
    nk: usize,
    piece: &Piece,
    terms: &[Terms; MAX_FOLLOWED],
    (ray, segments, depth, sun): Context,
) -> Option<(usize, [f64; MAX_FOLLOWED])> {
    // The depth can only dip that far below the mean where the mean is
    // above SPLIT_DEVIATION; and not between two points at the blocked
    // depth: the planet's shadow is convex, and elsewhere that depth
    // leaves nothing to draw.
    let dips = |t: &Terms| {
        let mean = 0.5 * (t.sun0 + t.sun1);
        mean > SPLIT_DEVIATION && t.sun0.min(t.sun1) < BLOCKED_DEPTH
    };
    if !terms[..nk].iter().any(dips) {
        return None;
    }
    let tm = 0.5 * (piece.t0 + piece.t1);
    let s = (piece.first..piece.end)
        .find(|&i| tm <= segments[i].t1)
        .unwrap_or(piece.end - 1);
    let mut v = [0.0f64; MAX_FOLLOWED + 1];
    depth.at_in_layer_into(ray.origin + tm * ray.dir, sun, segments[s].layer, &mut v[..=nk]);
    let mut mid = [0.0f64; MAX_FOLLOWED];
    let mut off = 0.0f64;
    for k in 0..nk {
        mid[k] = SunDepth::profile_depth(&v[..=nk], k);
        off = off.max(0.5 * (terms[k].sun0 + terms[k].sun1) - mid[k]);
    }
    (off > SPLIT_DEVIATION).then_some((s, mid))
}

/// What halving needs of the flight: its ray and segments, the sun's
/// depth table and direction.
type Context<'a> = (&'a Ray, &'a [Segment], &'a SunDepth, DVec3);

/// Adds to `out` the halves of `piece` (its `terms`) at its middle, in
/// segment `s` with the sun's depths `mid` there, each halved again
/// where it bends (`halvings` so far).
fn split(
    out: &mut (&mut Vec<Piece>, &mut Vec<Terms>),
    nk: usize,
    piece: Piece,
    terms: [Terms; MAX_FOLLOWED],
    (s, mid): (usize, [f64; MAX_FOLLOWED]),
    ctx: Context,
    halvings: u32,
) {
    let segments = ctx.1;
    let tm = 0.5 * (piece.t0 + piece.t1);
    let (mut a, mut b) = (terms, terms);
    for k in 0..nk {
        let t = terms[k];
        let tau = 0.5 * t.tau;
        // c ∝ e^(gc·u) over u in [0, 1] with mean c: the halves' means.
        let (c_a, c_b) = if t.gc.abs() < 1e-9 {
            (t.c, t.c)
        } else {
            let h = 0.5 * t.gc;
            let c_a = t.c * t.gc / t.gc.exp_m1() * h.exp_m1() / h;
            (c_a, c_a * h.exp())
        };
        a[k] = Terms {
            tau,
            sun1: mid[k],
            c: c_a,
            gc: 0.5 * t.gc,
            ..t
        };
        b[k] = Terms {
            tau0: t.tau0 + tau,
            tau,
            sun0: mid[k],
            c: c_b,
            gc: 0.5 * t.gc,
            ..t
        };
    }
    // The second half starts in the segment after s when tm is s's end.
    let second = if tm >= segments[s].t1 { s + 1 } else { s };
    let halves = [
        (
            Piece {
                end: s + 1,
                t1: tm,
                ..piece
            },
            a,
        ),
        (
            Piece {
                first: second,
                t0: tm,
                ..piece
            },
            b,
        ),
    ];
    for (half, t) in halves {
        let next = (halvings < MAX_HALVINGS && half.t1 - half.t0 > SPLIT_LENGTH_KM)
            .then(|| bend(nk, &half, &t, ctx))
            .flatten();
        match next {
            Some(bend) => split(out, nk, half, t, bend, ctx, halvings + 1),
            None => keep(out, nk, half, &t),
        }
    }
}

/// Adds `piece` with its `terms` to `out` as it is.
fn keep(out: &mut (&mut Vec<Piece>, &mut Vec<Terms>), nk: usize, piece: Piece, terms: &[Terms; MAX_FOLLOWED]) {
    out.0.push(piece);
    out.1.extend_from_slice(&terms[..nk]);
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
        let (levels, sigma, ray, segments) = eight_layer_flight();
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
            let mut density = FlightDensity::default();
            assert!(density.build(&ray, &segments, 1, 4, one_channel(&sigma, &c), &depth, sun));
            assert!(density.terms.iter().any(|t| t.gc < -2.0), "c falls inside a piece");
            // Šidák over both flights' 16 segments at 1e-4.
            assert_draws_carry_their_density(&density, &segments, 16);
        }
    }

    /// The same with two followed channels, the second twenty times as
    /// extinct (its density far nearer the flight's start), drawn from
    /// with their shares ([`MOST_EXTINCT_SHARE`]): a pdf that took equal
    /// shares fails it (segment 0: the mean of 1/pdf 1.202 ± 0.004
    /// against its length 1.155).
    #[test]
    fn two_followed_channels_draw_with_their_shares() {
        let (levels, sigma, ray, segments) = eight_layer_flight();
        let extinct: Vec<f64> = sigma.iter().map(|s| 20.0 * s).collect();
        let c = [0.1; 8];
        let sun = DVec3::new(-0.6, 0.0, 0.8);
        let depth = SunDepth::of_profiles(
            &levels,
            &[sigma.clone(), extinct.clone()],
            &Geometry::PlaneParallel,
            sun,
            false,
        );
        let optics = |_: usize, s: &Segment| {
            let len = s.t1 - s.t0;
            [
                (sigma[s.layer] * len, c[s.layer]),
                (extinct[s.layer] * len, 2.0 * c[s.layer]),
            ]
        };
        let mut density = FlightDensity::default();
        assert!(density.build(&ray, &segments, 2, 4, optics, &depth, sun));
        assert!(density.totals.iter().all(|t| t.2), "both channels can be drawn from");
        assert_draws_carry_their_density(&density, &segments, 8);
    }

    /// One followed channel's optics per segment: σ per layer over the
    /// segment's length, and c per layer.
    fn one_channel<'a>(sigma: &'a [f64], c: &'a [f64]) -> impl FnMut(usize, &Segment) -> SegmentOptics + 'a {
        move |_, s| {
            let mut o = [(0.0, 0.0); MAX_FOLLOWED];
            o[0] = (sigma[s.layer] * (s.t1 - s.t0), c[s.layer]);
            o
        }
    }

    /// Eight 1 km layers (their levels) whose σ falls by e every 1.2 km,
    /// and a slant flight up through them from the ground, 30° from the
    /// vertical, with its segments.
    fn eight_layer_flight() -> (Vec<f64>, Vec<f64>, Ray, Vec<Segment>) {
        let levels: Vec<f64> = (0..=8).map(|i| i as f64).collect();
        let sigma: Vec<f64> = (0..8).map(|i| 0.4 * (-(i as f64 + 0.5) / 1.2).exp()).collect();
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
        (levels, sigma, ray, segments)
    }

    /// Over 400,000 draws from `density`, 1/pdf summed over the draws in
    /// each of the flight's `segments` estimates its length: checked
    /// two-sided at 1e-4 over `family` such checks (Šidák).
    fn assert_draws_carry_their_density(density: &FlightDensity, segments: &[Segment], family: usize) {
        let n = 400_000;
        let mut sums = vec![(0.0f64, 0.0f64); segments.len()];
        let mut sampler = Sampler::new(&[7]);
        for _ in 0..n {
            let p = density
                .sample(segments, SUN_SHARE_IN_TEST, &mut sampler)
                .expect("a point");
            assert!(segments[p.segment].t0 <= p.t && p.t <= segments[p.segment].t1);
            let w = 1.0 / p.pdf;
            sums[p.segment].0 += w;
            sums[p.segment].1 += w * w;
        }
        let z = crate::compat::significance::sidak_threshold(family, 1e-4);
        for (s, (sum, sum_sq)) in segments.iter().zip(sums) {
            let mean = sum / n as f64;
            let se = ((sum_sq / n as f64 - mean * mean) / (n as f64 - 1.0)).sqrt();
            let len = s.t1 - s.t0;
            assert!(
                (mean - len).abs() < z * se,
                "segment {}: {mean} ± {se} against {len}",
                s.layer
            );
        }
    }

    /// A flight that starts level at 3 km toward a sun 1.5° below the
    /// horizontal there, on a planet of 6371 km, through air whose σ has
    /// scale heights of 8 and 1.5 km: it crosses its first layer (3-4 km)
    /// in 113 km, along which the sun rises by a degree from grazing the
    /// lowest air, so the sun's depth is far from linear along that one
    /// segment. The pieces there are halved, the density's largest
    /// weight relative to the exact sunlit single scattering (over the
    /// table's own depths) comes down, and drawn points still carry the
    /// density they were drawn from.
    #[test]
    fn pieces_are_halved_where_the_suns_depth_bends() {
        let radius = 6371.0;
        let levels: Vec<f64> = (0..=30).map(f64::from).collect();
        let sigma: Vec<f64> = (0..30)
            .map(|i| {
                let z = f64::from(i) + 0.5;
                0.01 * (-z / 8.0).exp() + 0.1 * (-z / 1.5).exp()
            })
            .collect();
        let c: Vec<f64> = sigma.iter().map(|s| 0.8 * s).collect();
        let e = (-1.5f64).to_radians();
        let sun = DVec3::new(e.cos(), 0.0, e.sin());
        let geometry = Geometry::Spherical { radius_km: radius };
        let depth = SunDepth::of_profiles(&levels, std::slice::from_ref(&sigma), &geometry, sun, false);
        let r0 = radius + 3.0;
        let ray = Ray {
            origin: DVec3::new(0.0, 0.0, r0),
            dir: DVec3::X,
            layer: 3,
        };
        // Where the level ray crosses the levels above it.
        let t_at = |z: f64| ((radius + z).powi(2) - r0 * r0).sqrt();
        let segments: Vec<Segment> = (3..30)
            .map(|i| Segment {
                t0: t_at(i as f64),
                t1: t_at(i as f64 + 1.0),
                layer: i,
            })
            .collect();
        let mut density = FlightDensity::default();
        assert!(density.build(&ray, &segments, 1, 1, one_channel(&sigma, &c), &depth, sun));
        assert!(density.pieces.len() > segments.len(), "no piece was halved");
        // The sunlit single scattering along the flight at 2,000 points per
        // segment, f = c·e^(−τ)·e^(−τ̃_sun) over the table's own depths, its
        // integral by the midpoint rule, and the sun-following part's
        // density at each point: the halved density's, and that of one
        // piece per segment (its integral c·len·e^(−a)·(1 − e^(−b))/b, a
        // the exponent at its start and b its change over it, the sun's
        // depth read at its ends).
        let inside = |de: f64, u: f64| de * (-de * u).exp() / -(-de).exp_m1();
        let steps = 2000;
        let (mut points, mut per_segment, mut tau) = (Vec::new(), Vec::new(), 0.0);
        for (i, s) in segments.iter().enumerate() {
            let len = s.t1 - s.t0;
            let k = sigma[s.layer];
            let sun0 = depth.at_in_layer(ray.origin + s.t0 * ray.dir, sun, s.layer);
            let sun1 = depth.at_end_in_layer(ray.origin + s.t1 * ray.dir, sun, s.layer);
            let (a, b) = (tau + sun0, k * len + sun1 - sun0);
            per_segment.push((c[s.layer] * len * (-a).exp() * -(-b).exp_m1() / b, b));
            for j in 0..steps {
                let u = (j as f64 + 0.5) / steps as f64;
                let t = s.t0 + u * len;
                let f = c[s.layer]
                    * (-(tau + k * u * len + depth.at_in_layer(ray.origin + t * ray.dir, sun, s.layer))).exp();
                points.push((i, u, t, f * len / steps as f64));
            }
            tau += k * len;
        }
        let quadrature: f64 = points.iter().map(|p| p.3).sum();
        let per_segment_total: f64 = per_segment.iter().map(|p| p.0).sum();
        // The largest of f/∫f over the density, at the grid's points: 1
        // where the density is exact, and what bounds a connection's weight.
        let (mut worst_halved, mut worst_per_segment) = (0.0f64, 0.0f64);
        for &(i, u, t, f_step) in &points {
            let f = f_step * steps as f64 / (segments[i].t1 - segments[i].t0) / quadrature;
            let j = density
                .pieces
                .iter()
                .position(|p| p.t0 <= t && t <= p.t1)
                .expect("a piece");
            let (p, tk) = (density.pieces[j], density.terms[j]);
            let de = tk.tau + tk.sun1 - tk.sun0 - tk.gc;
            let q = tk.sun_integral / density.totals[0].0 * inside(de, (t - p.t0) / (p.t1 - p.t0)) / (p.t1 - p.t0);
            worst_halved = worst_halved.max(f / q);
            let (integral, b) = per_segment[i];
            let q = integral / per_segment_total * inside(b, u) / (segments[i].t1 - segments[i].t0);
            worst_per_segment = worst_per_segment.max(f / q);
        }
        // One piece per segment: 15.6 (the sun's depth along the first
        // segment runs 17.7, 10.1, 8.0, 5.4, 3.7 at t = 0, 40, 56, 80, 113
        // km); halved: 3.9 (its last halves are under 40 km, so they are
        // not halved again).
        assert!(worst_per_segment > 10.0, "the flight hardly bends: {worst_per_segment}");
        assert!(
            worst_halved < 5.0,
            "{worst_halved}, one piece per segment {worst_per_segment}"
        );
        assert_draws_carry_their_density(&density, &segments, segments.len());
    }

    const SUN_SHARE_IN_TEST: f64 = 0.8;

    /// A piece of four 15 km segments halved at its middle (the end of
    /// its second segment): each half has half its optical depth, the
    /// sun's depth at the middle, and the means of c = A·e^(−2u) over
    /// u in [0, 1/2] and [1/2, 1] where the piece's mean is 0.5, with
    /// half its slope.
    #[test]
    fn a_halved_piece_keeps_its_depths_and_its_exponential_c() {
        let segments: Vec<Segment> = (0..4)
            .map(|i| Segment {
                t0: 15.0 * i as f64,
                t1: 15.0 * (i + 1) as f64,
                layer: i,
            })
            .collect();
        let levels = [0.0, 1.0, 2.0, 3.0, 4.0];
        let sun = DVec3::Z;
        let depth = SunDepth::of_profiles(&levels, &[vec![0.1; 4]], &Geometry::PlaneParallel, sun, false);
        let ray = Ray {
            origin: DVec3::ZERO,
            dir: DVec3::X,
            layer: 0,
        };
        let piece = Piece {
            first: 0,
            end: 4,
            t0: 0.0,
            t1: 60.0,
            end_layer: 3,
        };
        let terms = Terms {
            tau0: 0.1,
            tau: 0.2,
            sun0: 1.0,
            sun1: 2.0,
            c: 0.5,
            gc: -2.0,
            ..Terms::default()
        };
        let (mut pieces, mut halves) = (Vec::new(), Vec::new());
        let mut out = (&mut pieces, &mut halves);
        let ctx = (&ray, segments.as_slice(), &depth, sun);
        split(
            &mut out,
            1,
            piece,
            [terms, Terms::default()],
            (1, [1.2, 0.0]),
            ctx,
            MAX_HALVINGS,
        );
        assert_eq!(pieces.len(), 2);
        assert_eq!(
            (pieces[0].first, pieces[0].end, pieces[0].t0, pieces[0].t1),
            (0, 2, 0.0, 30.0)
        );
        assert_eq!(
            (pieces[1].first, pieces[1].end, pieces[1].t0, pieces[1].t1),
            (2, 4, 30.0, 60.0)
        );
        let a = 0.5 * 2.0 / (1.0 - (-2.0f64).exp());
        let expected = [
            (0.1, 1.0, 1.2, a * (1.0 - (-1.0f64).exp())),
            (0.2, 1.2, 2.0, a * ((-1.0f64).exp() - (-2.0f64).exp())),
        ];
        for (h, (tau0, sun0, sun1, c)) in halves.iter().zip(expected) {
            assert!((h.tau0 - tau0).abs() < 1e-12 && (h.tau - 0.1).abs() < 1e-12);
            assert_eq!((h.sun0, h.sun1, h.gc), (sun0, sun1, -1.0));
            assert!((h.c - c).abs() < 1e-12, "{} against {c}", h.c);
        }
    }

    /// The eight-layer flight with two followed channels, the second
    /// twenty times as extinct, c falling with height (far from flat in a
    /// piece of four), under a sun at (−0.6, 0, 0.8).
    struct TwoChannels {
        levels: Vec<f64>,
        sigma: Vec<f64>,
        extinct: Vec<f64>,
        ray: Ray,
        segments: Vec<Segment>,
        c: Vec<f64>,
        sun: DVec3,
        depth: SunDepth,
    }

    impl TwoChannels {
        fn new() -> TwoChannels {
            let (levels, sigma, ray, segments) = eight_layer_flight();
            let extinct: Vec<f64> = sigma.iter().map(|s| 20.0 * s).collect();
            let c: Vec<f64> = (0..8).map(|i| 0.3 * (-(i as f64 + 0.5) / 1.2).exp()).collect();
            let sun = DVec3::new(-0.6, 0.0, 0.8);
            let profiles = [sigma.clone(), extinct.clone()];
            let depth = SunDepth::of_profiles(&levels, &profiles, &Geometry::PlaneParallel, sun, false);
            TwoChannels {
                levels,
                sigma,
                extinct,
                ray,
                segments,
                c,
                sun,
                depth,
            }
        }

        /// Its density in pieces of four into `density`.
        fn build(&self, density: &mut FlightDensity) -> bool {
            let optics = |_: usize, s: &Segment| {
                let len = s.t1 - s.t0;
                [
                    (self.sigma[s.layer] * len, self.c[s.layer]),
                    (self.extinct[s.layer] * len, self.c[s.layer]),
                ]
            };
            density.build(&self.ray, &self.segments, 2, 4, optics, &self.depth, self.sun)
        }
    }

    /// A channel's sun part alone ([`FlightDensity::sun_pdf_of`]) is a
    /// density: over the eight-layer flight with two followed channels and
    /// pieces of four (c far from flat inside them) it integrates to 1
    /// (Simpson's rule on 4000 steps per piece), it is 0 off the flight,
    /// and with one channel and share 1 it is the density `sample` draws
    /// with; [`FlightDensity::sun_integral_of`] is `sunlit_integral`'s
    /// term.
    #[test]
    fn a_channels_sun_part_alone_is_a_density() {
        let flight = TwoChannels::new();
        let mut density = FlightDensity::default();
        assert!(flight.build(&mut density));
        let TwoChannels {
            levels,
            sigma,
            ray,
            segments,
            c,
            sun,
            ..
        } = flight;
        for k in 0..2 {
            let mut total = 0.0;
            for (j, p) in density.pieces.iter().enumerate() {
                let steps = 4000;
                let h = (p.t1 - p.t0) / steps as f64;
                // Each piece's own ends (a piece's start is its
                // predecessor's end, where the density jumps), found by
                // the hint and by the search alike.
                let f = |i: usize| {
                    let t = (p.t0 + i as f64 * h).clamp(p.t0 + 1e-9 * h, p.t1 - 1e-9 * h);
                    let q = density.sun_pdf_of(k, t, j);
                    assert_eq!(q, density.sun_pdf_of(k, t, usize::MAX));
                    assert_eq!(q, density.sun_pdf_of(k, t, (j + 1) % density.pieces.len()));
                    q
                };
                let mut sum = f(0) + f(steps);
                for i in 1..steps {
                    sum += if i % 2 == 1 { 4.0 } else { 2.0 } * f(i);
                }
                total += sum * h / 3.0;
            }
            assert!((total - 1.0).abs() < 1e-9, "channel {k}: {total}");
            assert_eq!(density.sun_pdf_of(k, segments[7].t1 + 0.1, 0), 0.0);
            assert_eq!(density.sun_pdf_of(k, -0.1, 0), 0.0);
        }
        assert_eq!(density.sun_pdf_of(2, 1.0, 0), 0.0);
        // One channel: the draws' own density.
        let depth = SunDepth::of_profiles(
            &levels,
            std::slice::from_ref(&sigma),
            &Geometry::PlaneParallel,
            sun,
            false,
        );
        assert!(density.build(&ray, &segments, 1, 4, one_channel(&sigma, &c), &depth, sun));
        let mut sampler = Sampler::new(&[3]);
        for _ in 0..1000 {
            let p = density.sample(&segments, 1.0, &mut sampler).expect("a point");
            let q = density.sun_pdf_of(0, p.t, p.piece);
            assert!((q / p.pdf - 1.0).abs() < 1e-12, "{q} against {}", p.pdf);
        }
        assert!((density.sun_integral_of(0) / density.sunlit_integral() - 1.0).abs() < 1e-15);
        assert_eq!(density.sun_integral_of(1), 0.0);
    }

    /// Kept normalisers ([`FlightDensity::keep_normalisers`]) change no
    /// number: the same draws, densities and sun parts bit for bit, over
    /// two followed channels and both parts; a new build drops them.
    #[test]
    fn kept_normalisers_give_the_same_draws_bit_for_bit() {
        let flight = TwoChannels::new();
        let segments = &flight.segments;
        let mut density = FlightDensity::default();
        assert!(flight.build(&mut density));
        let draws = |density: &FlightDensity| {
            let mut sampler = Sampler::new(&[5]);
            (0..2000)
                .map(|_| {
                    let p = density.sample(segments, 0.8, &mut sampler).expect("a point");
                    let sun_parts = [0, 1].map(|k| density.sun_pdf_of(k, p.t, p.piece).to_bits());
                    (p.t.to_bits(), p.pdf.to_bits(), p.segment, p.piece, sun_parts)
                })
                .collect::<Vec<_>>()
        };
        let computed = draws(&density);
        density.keep_normalisers();
        assert_eq!(density.normalisers.len(), density.terms.len());
        assert_eq!(draws(&density), computed);
        assert!(flight.build(&mut density));
        assert!(density.normalisers.is_empty());
    }

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
        let usable = density.build(&ray, &segments, 1, 1, one_channel(&sigma, &c), &depth, sun);
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
