//! A dataset file's bytes, written field by field.

use super::encode::*;
use super::tables::*;

/// The file's bytes, field by field.
#[derive(Default)]
pub(super) struct Writer(pub(super) Vec<u8>);

impl Writer {
    pub(super) fn count(&mut self, n: usize) {
        self.0.extend_from_slice(&(n as i32).to_le_bytes());
    }

    pub(super) fn f64(&mut self, x: f64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }

    pub(super) fn list(&mut self, values: &[f64]) {
        self.count(values.len());
        values.iter().for_each(|&x| self.f64(x));
    }

    pub(super) fn half(&mut self, x: f64) {
        self.0.extend_from_slice(&nearest_half(x).to_le_bytes());
    }

    pub(super) fn f32s(&mut self, values: impl IntoIterator<Item = f32>) {
        values
            .into_iter()
            .for_each(|x| self.0.extend_from_slice(&x.to_le_bytes()));
    }

    pub(super) fn axes(&mut self, a: &Axes) {
        for values in [&a.visibilities_km, &a.albedos, &a.altitudes_m, &a.elevations_deg] {
            self.list(values);
        }
        self.count(a.channels);
        self.f64(a.channel_start_nm);
        self.f64(a.channel_width_nm);
    }

    pub(super) fn radiance(&mut self, r: &Radiance) {
        self.count(r.rank);
        for breaks in [&r.sun_breaks, &r.zenith_breaks, &r.emph_breaks] {
            self.list(breaks);
        }
        let n_sun = r.sun_breaks.len();
        for (config, c) in r.coefs.chunks_exact(r.config_len().max(1)).enumerate() {
            let (components, emph) = c.split_at(r.rank * r.component_len());
            for (k, comp) in components.chunks_exact(r.component_len().max(1)).enumerate() {
                let scale = r.zenith_scales.get(config * r.rank + k).copied().unwrap_or(1.0);
                comp[..n_sun].iter().for_each(|&x| self.half(x as f64));
                self.f64(scale);
                comp[n_sun..].iter().for_each(|&z| self.half(z as f64 * scale));
            }
            emph.iter().for_each(|&x| self.half(x as f64));
        }
    }

    pub(super) fn transmittance(&mut self, t: &Transmittance) {
        for n in [t.d_dim, t.a_dim, t.visibilities_km.len(), t.altitudes_m.len(), t.rank] {
            self.count(n);
        }
        self.f32s(t.altitudes_m.iter().map(|&x| x as f32));
        self.f32s(t.visibilities_km.iter().map(|&x| x as f32));
        self.f32s(t.u.iter().copied());
        self.f32s(t.v.iter().copied());
    }

    pub(super) fn polarisation(&mut self, p: &Polarisation) {
        self.count(p.rank);
        self.list(&p.sun_breaks);
        self.list(&p.zenith_breaks);
        self.f32s(p.coefs.iter().copied());
    }
}
