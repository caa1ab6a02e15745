//! Fibre properties from the relative humidity of the air, along the 25 °C isotherms:
//! Young's modulus, torsion modulus, water content (weight) and diameter, as Sobottka &
//! Weber choose them (*Computing Static Electricity on Human Hair*, 2006, section 3.4 and
//! figure 3, after Robbins' book, their reference Rob02).
//!
//! # The table
//!
//! One row per relative humidity RH (percent) of [`HUMIDITY_POINTS`]; values in between
//! are interpolated linearly. The columns, all at 25 °C:
//!
//! | RH % | [`YOUNGS_MODULUS`] e | [`TORSION_MODULUS`] g | [`WATER_REGAIN`] w | [`DIAMETER_SWELLING`] s |
//! |---|---|---|---|---|
//! | 0 | 1.00 | 1.00 | 0.000 | 0.000 |
//! | 10 | 0.96 | 0.90 | 0.040 | 0.018 |
//! | 20 | 0.92 | 0.80 | 0.060 | 0.026 |
//! | 30 | 0.87 | 0.69 | 0.074 | 0.032 |
//! | 40 | 0.82 | 0.58 | 0.088 | 0.039 |
//! | 50 | 0.77 | 0.47 | 0.103 | 0.045 |
//! | 60 | 0.71 | 0.37 | 0.120 | 0.053 |
//! | 65 | 0.68 | 0.32 | 0.130 | 0.057 |
//! | 70 | 0.65 | 0.27 | 0.140 | 0.061 |
//! | 80 | 0.57 | 0.19 | 0.170 | 0.074 |
//! | 90 | 0.48 | 0.13 | 0.220 | 0.096 |
//! | 100 | 0.37 | 0.08 | 0.320 | 0.140 |
//!
//! - **e**: Young's modulus relative to the dry fibre (0 % RH). Sources: M. Feughelman,
//!   *Mechanical Properties and Structure of Alpha-Keratin Fibres: Wool, Human Hair and
//!   Related Fibres*, UNSW Press, Sydney, 1997 (the chapters on the effect of water on the
//!   Hookean region), and M. Feughelman, "A two-phase structure for keratin fibers",
//!   *Textile Research Journal* 29(3), 223–228, 1959: the modulus of α-keratin fibres falls
//!   by a factor of about 2.7 from dry to wet (here e(100) = 0.37). C. R. Robbins,
//!   *Chemical and Physical Behavior of Human Hair*, 4th ed., Springer, 2002, chapter on
//!   the physical properties of hair (tensile properties at 65 % RH and in water), gives
//!   the same picture for human hair. The dry/wet ratio is the sources'; the points in
//!   between are our smooth curve through the end values, shaped like the published
//!   curves (a steady fall that steepens above about 80 % RH), and are approximate
//!   (think ±0.05).
//! - **g**: torsion (shear) modulus relative to the dry fibre. Sources: Feughelman 1997 and
//!   1959 (as above), J. B. Speakman, "The rigidity of wool and its change with adsorption
//!   of water vapour", *Transactions of the Faraday Society* 25, 92–103, 1929, and for
//!   human hair H. Bogaty, "Torsional properties of hair in relation to permanent waving
//!   and setting", *Journal of the Society of Cosmetic Chemists* 18, 575–589, 1967, as
//!   summarised by Robbins (4th ed., same chapter): the torsional modulus is carried by the
//!   water-absorbing matrix and falls by an order of magnitude or more from dry to wet
//!   (here 1/g(100) = 12.5). As for e, only the dry/wet ratio is from the sources; the
//!   interior points are a smooth curve through it and are approximate (think ±0.05).
//! - **w**: water regain, mass of water per mass of dry hair (kg/kg), between the
//!   absorption and desorption branches. Source: the water-sorption isotherm of human hair
//!   at 25 °C in Robbins (4th ed. 2002 and 5th ed. 2012, chapter on the physical
//!   properties of hair: water content of hair against RH), which goes back to N. H.
//!   Chamberlain and J. B. Speakman (1931): about 0.13 at 65 % RH (quoted values
//!   0.12–0.15) and about 0.32 at 100 % RH (quoted 0.30–0.33). The column holds
//!   approximate values of that sigmoid curve, not digitised from the figure (think
//!   ±0.01).
//! - **s**: relative increase of the fibre's diameter over the dry fibre. Sources: Robbins
//!   (4th ed., same chapter), after Y. Stam, M. Leonard and H. Eyring, "The swelling of
//!   human hair in water and water vapor", *Textile Research Journal* 22, 448–465, 1952:
//!   about 14 % from dry to saturated vapour (14–16 % from dry to soaked in water), and the
//!   swelling follows the water taken up. Our column is s = 0.14 · w / w(100), rounded to
//!   three decimals: only s(100) is a quoted value, the rest is that proportionality.
//!
//! None of these sources was consulted in a copy for this table: the books' chapter,
//! table and page numbers are not given, and the end values above are the sources'
//! figures as they are commonly quoted. The journal papers are the primary measurements
//! the books summarise.
//!
//! # The reference humidity
//!
//! A strand preset's Young's modulus, Poisson ratio, density and radius are taken as
//! measured at [`REFERENCE_HUMIDITY`] = 65 % RH, the standard conditioning humidity of fibre
//! measurements. At another RH, [`HumidityScaling::at`] gives the factors relative to 65 %:
//!
//! - E(RH) = E_preset · e(RH)/e(65)
//! - G(RH) = G_preset · g(RH)/g(65), G_preset = E_preset / (2(1 + ν_preset)); in a
//!   [`CrossSection`] this is `shear_factor` = (g(RH)/g(65)) / (e(RH)/e(65)), so the
//!   effective Poisson ratio changes with RH
//! - mass per length ∝ 1 + w(RH): (1 + w(RH)) / (1 + w(65)) (water adds mass)
//! - radius ∝ 1 + s(RH): (1 + s(RH)) / (1 + s(65)); the ellipticity is kept (the section
//!   swells alike in every direction)
//! - density · area = mass per length: ρ(RH) = ρ_preset · mass factor / radius factor²
//!
//! The second moments of the section follow the radius (I ∝ r⁴), so the bending
//! stiffnesses scale as e · r⁴ and the torsional stiffness as g · r⁴; the rotary inertia
//! ρI scales as mass factor · radius factor². At 65 % every factor is exactly 1. From 0
//! to 10 % RH the swelling outweighs the small fall of E and EI rises by 3 %; above 10 %
//! it falls, and GJ falls over the whole range.

use crate::model::material::CrossSection;

/// The relative humidity, percent, at which presets' values are taken as measured.
pub const REFERENCE_HUMIDITY: f64 = 65.0;

/// Lowest relative humidity of the table, percent.
pub const MIN_HUMIDITY: f64 = 0.0;
/// Highest relative humidity of the table, percent.
pub const MAX_HUMIDITY: f64 = 100.0;

/// The relative humidities of the table's rows, percent, increasing.
pub const HUMIDITY_POINTS: [f64; 12] = [
    0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 65.0, 70.0, 80.0, 90.0, 100.0,
];

/// e: Young's modulus relative to the dry fibre, at [`HUMIDITY_POINTS`] (module docs:
/// sources; interior points approximate).
pub const YOUNGS_MODULUS: [f64; 12] = [
    1.00, 0.96, 0.92, 0.87, 0.82, 0.77, 0.71, 0.68, 0.65, 0.57, 0.48, 0.37,
];

/// g: torsion (shear) modulus relative to the dry fibre, at [`HUMIDITY_POINTS`] (module
/// docs: sources; interior points approximate).
pub const TORSION_MODULUS: [f64; 12] = [
    1.00, 0.90, 0.80, 0.69, 0.58, 0.47, 0.37, 0.32, 0.27, 0.19, 0.13, 0.08,
];

/// w: water regain, kg of water per kg of dry hair, at [`HUMIDITY_POINTS`] (module docs:
/// the 25 °C isotherm, approximate).
pub const WATER_REGAIN: [f64; 12] = [
    0.000, 0.040, 0.060, 0.074, 0.088, 0.103, 0.120, 0.130, 0.140, 0.170, 0.220, 0.320,
];

/// s: relative increase of the diameter over the dry fibre, at [`HUMIDITY_POINTS`] (module
/// docs: 0.14 at 100 % RH, proportional to the regain below).
pub const DIAMETER_SWELLING: [f64; 12] = [
    0.000, 0.018, 0.026, 0.032, 0.039, 0.045, 0.053, 0.057, 0.061, 0.074, 0.096, 0.140,
];

/// Linear interpolation of `column` (values at [`HUMIDITY_POINTS`]) at `rh`; a table
/// point gives its value exactly. `None` outside [0, 100] or for NaN.
pub fn interpolate(column: &[f64; 12], rh: f64) -> Option<f64> {
    if !(MIN_HUMIDITY..=MAX_HUMIDITY).contains(&rh) {
        return None;
    }
    // first point above rh: the segment is [k − 1, k]; at a point, its own value
    let k = HUMIDITY_POINTS.partition_point(|&x| x <= rh);
    if k == HUMIDITY_POINTS.len() {
        return Some(column[k - 1]);
    }
    let (x0, x1) = (HUMIDITY_POINTS[k - 1], HUMIDITY_POINTS[k]);
    let (v0, v1) = (column[k - 1], column[k]);
    Some(v0 + (rh - x0) / (x1 - x0) * (v1 - v0))
}

/// The four table values of a fibre at one relative humidity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FibreState {
    /// e: Young's modulus relative to the dry fibre.
    pub youngs_modulus: f64,
    /// g: torsion modulus relative to the dry fibre.
    pub torsion_modulus: f64,
    /// w: kg of water per kg of dry hair.
    pub water_regain: f64,
    /// s: relative increase of the diameter over the dry fibre.
    pub diameter_swelling: f64,
}

impl FibreState {
    /// The table interpolated at `rh` percent; `None` outside [0, 100] or for NaN.
    pub fn at(rh: f64) -> Option<FibreState> {
        Some(FibreState {
            youngs_modulus: interpolate(&YOUNGS_MODULUS, rh)?,
            torsion_modulus: interpolate(&TORSION_MODULUS, rh)?,
            water_regain: interpolate(&WATER_REGAIN, rh)?,
            diameter_swelling: interpolate(&DIAMETER_SWELLING, rh)?,
        })
    }
}

/// Factors that take a fibre's values at [`REFERENCE_HUMIDITY`] to their values at another
/// relative humidity (module docs: the formulas).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HumidityScaling {
    /// E(RH) / E(65) = e(RH) / e(65).
    pub youngs_modulus: f64,
    /// G(RH) / G(65) = g(RH) / g(65).
    pub torsion_modulus: f64,
    /// Mass per length: (1 + w(RH)) / (1 + w(65)).
    pub mass_per_length: f64,
    /// Radius: (1 + s(RH)) / (1 + s(65)).
    pub radius: f64,
}

impl HumidityScaling {
    /// The factors at `rh` percent; `None` outside [0, 100] or for NaN. Every factor is
    /// exactly 1 at [`REFERENCE_HUMIDITY`].
    pub fn at(rh: f64) -> Option<HumidityScaling> {
        let here = FibreState::at(rh)?;
        let reference = FibreState::at(REFERENCE_HUMIDITY)?;
        Some(HumidityScaling {
            youngs_modulus: here.youngs_modulus / reference.youngs_modulus,
            torsion_modulus: here.torsion_modulus / reference.torsion_modulus,
            mass_per_length: (1.0 + here.water_regain) / (1.0 + reference.water_regain),
            radius: (1.0 + here.diameter_swelling) / (1.0 + reference.diameter_swelling),
        })
    }

    /// Density factor: mass per length over area, `mass_per_length / radius²`.
    pub fn density(&self) -> f64 {
        self.mass_per_length / (self.radius * self.radius)
    }

    /// Factor on `shear_factor` of a section whose G is E / (2(1 + ν)) at 65 %: the
    /// torsion factor over Young's, so that G follows g while E follows e.
    pub fn shear(&self) -> f64 {
        self.torsion_modulus / self.youngs_modulus
    }

    /// `section` (taken as measured at 65 % RH) at this humidity: radius, Young's modulus
    /// and density scaled, the ellipticity and Poisson ratio kept, and the torsion modulus
    /// scaled by its own factor through `shear_factor`.
    pub fn section(&self, section: &CrossSection) -> CrossSection {
        CrossSection {
            radius: section.radius * self.radius,
            ellipticity: section.ellipticity,
            youngs_modulus: section.youngs_modulus * self.youngs_modulus,
            poisson: section.poisson,
            density: section.density * self.density(),
            shear_factor: section.shear_factor * self.shear(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::material::Preset;

    const COLUMNS: [(&str, [f64; 12]); 4] = [
        ("youngs", YOUNGS_MODULUS),
        ("torsion", TORSION_MODULUS),
        ("regain", WATER_REGAIN),
        ("swelling", DIAMETER_SWELLING),
    ];

    fn rel(a: f64, b: f64) -> f64 {
        (a / b - 1.0).abs()
    }

    #[test]
    fn table_points_give_their_own_values() {
        for (name, column) in COLUMNS {
            for (k, &rh) in HUMIDITY_POINTS.iter().enumerate() {
                assert_eq!(interpolate(&column, rh), Some(column[k]), "{name} at {rh}");
            }
        }
        let s = FibreState::at(100.0).unwrap();
        assert_eq!(
            (s.youngs_modulus, s.torsion_modulus, s.water_regain),
            (0.37, 0.08, 0.32)
        );
        assert_eq!(s.diameter_swelling, 0.14);
    }

    #[test]
    fn between_points_the_values_are_linear() {
        // midway between 60 and 65, and a quarter of the way from 80 to 90
        let e = interpolate(&YOUNGS_MODULUS, 62.5).unwrap();
        assert!((e - 0.695).abs() < 1e-15, "{e}");
        let w = interpolate(&WATER_REGAIN, 82.5).unwrap();
        assert!((w - (0.170 + 0.25 * 0.050)).abs() < 1e-15, "{w}");
        let g = interpolate(&TORSION_MODULUS, 5.0).unwrap();
        assert!((g - 0.95).abs() < 1e-15, "{g}");
        // every segment: the midpoint is the mean of its ends
        for (name, column) in COLUMNS {
            for k in 1..HUMIDITY_POINTS.len() {
                let mid = 0.5 * (HUMIDITY_POINTS[k - 1] + HUMIDITY_POINTS[k]);
                let got = interpolate(&column, mid).unwrap();
                let want = 0.5 * (column[k - 1] + column[k]);
                assert!(
                    (got - want).abs() < 1e-15,
                    "{name} at {mid}: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn outside_the_table_there_is_no_value() {
        for rh in [-1e-9, 100.0 + 1e-9, f64::NAN, f64::INFINITY, -5.0] {
            assert_eq!(FibreState::at(rh), None, "{rh}");
            assert_eq!(HumidityScaling::at(rh), None, "{rh}");
        }
        assert!(FibreState::at(0.0).is_some() && FibreState::at(100.0).is_some());
    }

    #[test]
    fn the_reference_humidity_changes_nothing() {
        let f = HumidityScaling::at(REFERENCE_HUMIDITY).unwrap();
        for x in [
            f.youngs_modulus,
            f.torsion_modulus,
            f.mass_per_length,
            f.radius,
            f.density(),
            f.shear(),
        ] {
            assert!((x - 1.0).abs() <= 1e-15, "{f:?}");
        }
        for preset in Preset::ALL {
            let cs = preset.params().cross_section;
            let (a, b) = (cs.material(), f.section(&cs).material());
            assert!(rel(b.mass_per_length, a.mass_per_length) <= 1e-15);
            for i in 0..3 {
                assert!(
                    rel(b.stiffness[i], a.stiffness[i]) <= 1e-15,
                    "{preset:?} {i}"
                );
                assert!(rel(b.rotary_inertia[i], a.rotary_inertia[i]) <= 1e-15);
            }
        }
    }

    #[test]
    fn stiffness_falls_and_mass_and_diameter_grow_with_humidity() {
        for k in 1..HUMIDITY_POINTS.len() {
            assert!(HUMIDITY_POINTS[k] > HUMIDITY_POINTS[k - 1]);
            assert!(YOUNGS_MODULUS[k] < YOUNGS_MODULUS[k - 1], "e at row {k}");
            assert!(TORSION_MODULUS[k] < TORSION_MODULUS[k - 1], "g at row {k}");
            assert!(WATER_REGAIN[k] > WATER_REGAIN[k - 1], "w at row {k}");
            assert!(
                DIAMETER_SWELLING[k] > DIAMETER_SWELLING[k - 1],
                "s at row {k}"
            );
        }
        // finely, through the interpolation, on the scaled section of a preset
        let cs = Preset::Curly.params().cross_section;
        let mut previous: Option<(f64, crate::model::material::Material, f64)> = None;
        for i in 0..=200 {
            let rh = 0.5 * i as f64;
            let f = HumidityScaling::at(rh).unwrap();
            let section = f.section(&cs);
            let m = section.material();
            if let Some((rh0, m0, r0)) = previous {
                assert!(m.mass_per_length > m0.mass_per_length, "{rh0} -> {rh}");
                assert!(section.radius > r0, "{rh0} -> {rh}");
                // torsion softens faster than the section swells
                assert!(m.stiffness[0] < m0.stiffness[0], "{rh0} -> {rh}");
            }
            previous = Some((rh, m, section.radius));
        }
        // the moduli themselves fall (the stiffnesses EI gain r⁴ from the swelling)
        let (dry, wet) = (
            HumidityScaling::at(0.0).unwrap(),
            HumidityScaling::at(100.0).unwrap(),
        );
        assert!(dry.youngs_modulus > 1.0 && wet.youngs_modulus < 1.0);
        assert!(
            wet.torsion_modulus < wet.youngs_modulus,
            "torsion falls more"
        );
        assert!(wet.mass_per_length > 1.0 && dry.mass_per_length < 1.0);
    }

    #[test]
    fn bending_stiffness_peaks_at_ten_percent_and_falls_above() {
        let bending = |rh: f64| {
            let f = HumidityScaling::at(rh).unwrap();
            f.youngs_modulus * f.radius.powi(4)
        };
        let peak = bending(10.0) / bending(0.0);
        assert!((1.025..1.035).contains(&peak), "{peak}");
        for i in 0..=20 {
            let rh = 0.5 * i as f64;
            assert!(bending(rh) <= bending(10.0), "{rh}");
        }
        for i in 0..180 {
            let rh = 10.0 + 0.5 * i as f64;
            assert!(bending(rh + 0.5) < bending(rh), "{rh}");
        }
    }

    #[test]
    fn the_sources_end_values_hold() {
        let (dry, wet) = (FibreState::at(0.0).unwrap(), FibreState::at(100.0).unwrap());
        let e_ratio = dry.youngs_modulus / wet.youngs_modulus;
        assert!((2.5..=3.0).contains(&e_ratio), "E dry/wet {e_ratio}");
        let g_ratio = dry.torsion_modulus / wet.torsion_modulus;
        assert!(g_ratio >= 10.0, "G dry/wet {g_ratio}");
        let at65 = FibreState::at(65.0).unwrap();
        assert!((0.12..=0.15).contains(&at65.water_regain));
        assert!((0.30..=0.33).contains(&wet.water_regain));
        assert!((0.14..=0.16).contains(&wet.diameter_swelling));
    }

    #[test]
    fn mass_per_length_is_density_times_area() {
        let cs = Preset::Wavy.params().cross_section;
        let m65 = cs.material().mass_per_length;
        for rh in [0.0, 33.0, 65.0, 87.5, 100.0] {
            let f = HumidityScaling::at(rh).unwrap();
            let section = f.section(&cs);
            let m = section.material();
            assert!(
                rel(m.mass_per_length, m65 * f.mass_per_length) < 1e-14,
                "{rh}"
            );
            let area = std::f64::consts::PI * section.radius * section.radius;
            assert!(rel(m.mass_per_length, section.density * area) < 1e-14);
            // the second moments follow the radius: EI ∝ e r⁴, GJ ∝ g r⁴
            let (m0, r4) = (cs.material(), f.radius.powi(4));
            assert!(rel(m.stiffness[1], m0.stiffness[1] * f.youngs_modulus * r4) < 1e-14);
            assert!(rel(m.stiffness[2], m0.stiffness[2] * f.youngs_modulus * r4) < 1e-14);
            assert!(rel(m.stiffness[0], m0.stiffness[0] * f.torsion_modulus * r4) < 1e-14);
        }
    }
}
