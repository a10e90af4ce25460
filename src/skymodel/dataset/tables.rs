//! What a dataset holds: its axes and tables as the runtime holds them
//! after reading ([`Dataset`]), and the fitted `f64` values a dataset is
//! encoded from ([`DatasetFit`]).

/// The configuration axes: one fitted configuration per (visibility,
/// albedo, altitude, elevation, channel), visibility outermost.
#[derive(Debug, Clone, PartialEq)]
pub struct Axes {
    pub visibilities_km: Vec<f64>,
    pub albedos: Vec<f64>,
    pub altitudes_m: Vec<f64>,
    pub elevations_deg: Vec<f64>,
    /// `channels` channels `channel_width_nm` wide from `channel_start_nm`.
    pub channels: usize,
    pub channel_start_nm: f64,
    pub channel_width_nm: f64,
}

impl Axes {
    /// The number of configurations.
    pub fn configurations(&self) -> usize {
        let [v, a, h, e] = [
            &self.visibilities_km,
            &self.albedos,
            &self.altitudes_m,
            &self.elevations_deg,
        ]
        .map(Vec::len);
        v * a * h * e * self.channels
    }

    /// The index of a configuration in file (and memory) order, from its
    /// indices [visibility, albedo, altitude, elevation, channel].
    pub fn configuration(&self, [v, a, h, e, c]: [usize; 5]) -> usize {
        (((v * self.albedos.len() + a) * self.altitudes_m.len() + h) * self.elevations_deg.len() + e) * self.channels
            + c
    }

    /// "configuration 5 (visibility 0, albedo 1, altitude 0, elevation 1,
    /// channel 0)", for errors.
    pub fn describe(&self, configuration: usize) -> String {
        let sizes = [&self.albedos, &self.altitudes_m, &self.elevations_deg].map(Vec::len);
        let c = configuration % self.channels.max(1);
        let mut rest = configuration / self.channels.max(1);
        let mut index = [0; 3];
        for k in (0..3).rev() {
            index[k] = rest % sizes[k].max(1);
            rest /= sizes[k].max(1);
        }
        let [a, h, e] = index;
        format!(
            "configuration {configuration} (visibility {rest}, albedo {a}, altitude {h}, elevation {e}, channel {c})"
        )
    }

    /// The end of the last channel (nm).
    pub fn channel_end_nm(&self) -> f64 {
        self.channel_start_nm + self.channels as f64 * self.channel_width_nm
    }
}

/// The sky-radiance tables. Per configuration, as the runtime lays them
/// out in memory: `rank` × (values at the sun breaks, then at the zenith
/// breaks), then values at the emphasis breaks.
#[derive(Debug, Clone, PartialEq)]
pub struct Radiance {
    pub rank: usize,
    /// Breaks (rad) of γ, of α and of θ′.
    pub sun_breaks: Vec<f64>,
    pub zenith_breaks: Vec<f64>,
    pub emph_breaks: Vec<f64>,
    /// The file's zenithScale per configuration and rank component, kept so
    /// that the file is written again bit for bit.
    pub zenith_scales: Vec<f64>,
    pub coefs: Vec<f32>,
}

impl Radiance {
    /// Values per rank component: sun then zenith.
    pub fn component_len(&self) -> usize {
        self.sun_breaks.len() + self.zenith_breaks.len()
    }

    /// Values per configuration.
    pub fn config_len(&self) -> usize {
        self.rank * self.component_len() + self.emph_breaks.len()
    }
}

/// The transmittance tables: √T at node (distance d, altitude a) for
/// observer altitude `alt`, visibility `vis` and a channel is
/// `Σ_r U[alt][d][a][r] · V[vis][alt][channel][r]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Transmittance<T = f32> {
    pub d_dim: usize,
    pub a_dim: usize,
    /// Observer altitudes (m) and visibilities (km), `f32` in the file.
    pub altitudes_m: Vec<f64>,
    pub visibilities_km: Vec<f64>,
    pub rank: usize,
    pub u: Vec<T>,
    pub v: Vec<T>,
}

/// The polarisation tables: per configuration `rank` × (values at the sun
/// breaks, then at the zenith breaks).
#[derive(Debug, Clone, PartialEq)]
pub struct Polarisation {
    pub rank: usize,
    pub sun_breaks: Vec<f64>,
    pub zenith_breaks: Vec<f64>,
    pub coefs: Vec<f32>,
}

impl Polarisation {
    /// Values per rank component: sun then zenith.
    pub fn component_len(&self) -> usize {
        self.sun_breaks.len() + self.zenith_breaks.len()
    }

    /// Values per configuration.
    pub fn config_len(&self) -> usize {
        self.rank * self.component_len()
    }
}

/// A dataset as the runtime holds it after reading.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    pub axes: Axes,
    pub radiance: Radiance,
    pub transmittance: Transmittance,
    pub polarisation: Option<Polarisation>,
}

/// A fitted dataset in double precision, for [`Dataset::encode`].
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetFit {
    pub axes: Axes,
    pub radiance: RadianceFit,
    pub transmittance: TransmittanceFit,
    pub polarisation: Option<PolarisationFit>,
}

/// Fitted radiance: the breaks and one entry per configuration, in file
/// order ([`Axes::configuration`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RadianceFit {
    pub sun_breaks: Vec<f64>,
    pub zenith_breaks: Vec<f64>,
    pub emph_breaks: Vec<f64>,
    pub configs: Vec<RadianceConfigFit>,
}

/// One configuration's rank components and emphasis values.
#[derive(Debug, Clone, PartialEq)]
pub struct RadianceConfigFit {
    pub components: Vec<ComponentFit>,
    pub emph: Vec<f64>,
}

/// One rank component: values at the sun breaks and at the zenith breaks.
#[derive(Debug, Clone, PartialEq)]
pub struct ComponentFit {
    pub sun: Vec<f64>,
    pub zenith: Vec<f64>,
}

/// A fitted transmittance part, laid out as the file's.
pub type TransmittanceFit = Transmittance<f64>;

/// Fitted polarisation: the breaks and, per configuration, its rank
/// components.
#[derive(Debug, Clone, PartialEq)]
pub struct PolarisationFit {
    pub sun_breaks: Vec<f64>,
    pub zenith_breaks: Vec<f64>,
    pub configs: Vec<Vec<ComponentFit>>,
}
