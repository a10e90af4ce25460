//! Physical constants, each with its source. Nothing else in the crate
//! writes a physical constant as a literal.

/// Boltzmann constant in J K⁻¹ (CODATA 2018, exact by the 2019 SI).
pub const BOLTZMANN_J_PER_K: f64 = 1.380649e-23;

/// Molecular number density of air at 288.15 K and 1013.25 hPa in cm⁻³, the
/// N_s of the Rayleigh cross section (Bodhaine et al. 1999, Eq. 22).
pub const AIR_DENSITY_STP_CM3: f64 = 2.546899e19;

/// CO₂ volume mixing ratio of the Peck & Reeder (1972) refractive index of
/// standard air (300 ppm), the base of Bodhaine et al. 1999, Eq. 19.
pub const PECK_REEDER_CO2_RATIO: f64 = 3.0e-4;

/// Molecules per cm² in one Dobson unit (WMO; 0.01 mm of pure ozone at
/// 273.15 K and 1013.25 hPa, from the Loschmidt constant 2.6867811e19 cm⁻³).
pub const DOBSON_UNIT_CM2: f64 = 2.6867811e16;

/// 0 °C in kelvin.
pub const CELSIUS_ZERO_K: f64 = 273.15;

/// Steam-point temperature (K) and pressure (hPa) of the Goff–Gratch (1946)
/// saturation vapour pressure over liquid water, as adopted by the WMO.
pub const GOFF_GRATCH_STEAM_POINT_K: f64 = 373.16;
/// See [`GOFF_GRATCH_STEAM_POINT_K`].
pub const GOFF_GRATCH_STEAM_PRESSURE_HPA: f64 = 1013.246;

/// Koschmieder's constant ln(1/0.02): the meteorological visibility is
/// 3.912/β for a 2 % contrast threshold (Koschmieder 1924).
pub const KOSCHMIEDER_CONSTANT: f64 = 3.912;

/// Wavelength (nm) at which visibility is defined (WMO, 550 nm).
pub const VISIBILITY_WAVELENGTH_NM: f64 = 550.0;

/// Centimetres per kilometre.
pub const CM_PER_KM: f64 = 1.0e5;

/// Avogadro constant in mol⁻¹ (CODATA 2018, exact by the 2019 SI).
pub const AVOGADRO_PER_MOL: f64 = 6.022_140_76e23;

/// Molar mass of water in g mol⁻¹ (IUPAC 2013 standard atomic weights).
pub const H2O_MOLAR_MASS_G: f64 = 18.015;

/// Density of liquid water in g cm⁻³ that defines precipitable water (the
/// depth of the column's water as liquid; WMO).
pub const LIQUID_WATER_G_PER_CM3: f64 = 1.0;

/// CH₄ and N₂O volume mixing ratios, constant with altitude: the ground
/// values of the AFGL 1986 US standard atmosphere (Anderson et al. 1986;
/// the AFGL files atmosim carries hold no CH₄ or N₂O column).
pub const CH4_MIXING_RATIO: f64 = 1.7e-6;
/// See [`CH4_MIXING_RATIO`].
pub const N2O_MIXING_RATIO: f64 = 0.32e-6;
