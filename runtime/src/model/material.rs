//! Material of a strand from physical parameters (paper section 4.2, appendix B; design
//! page "Material").

use serde::{Deserialize, Serialize};

/// Physical parameters of a hair fibre's cross-section and material, SI units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CrossSection {
    /// Mean radius r, metres.
    pub radius: f64,
    /// Ellipticity e = r_max / r_min (≥ 1).
    pub ellipticity: f64,
    /// Young's modulus E, pascals.
    pub youngs_modulus: f64,
    /// Poisson ratio ν, in (−1, 0.5] (the range of an isotropic elastic material; 0.5 is
    /// incompressible, G = E/3).
    pub poisson: f64,
    /// Density ρ, kg/m³ (1300 for hair).
    pub density: f64,
    /// Factor on the torsion modulus: G = `shear_factor` · E / (2(1 + ν)). 1 makes the
    /// section isotropic in the sense of its Poisson ratio; the humidity model
    /// ([`crate::model::humidity`]) sets it to g(RH)/e(RH) relative to the reference
    /// humidity, since water lowers the torsion modulus of hair much more than Young's
    /// modulus (the effective Poisson ratio is then (1 + ν)/`shear_factor` − 1).
    #[serde(default = "unit_factor")]
    pub shear_factor: f64,
}

fn unit_factor() -> f64 {
    1.0
}

/// What the dynamics needs of the material: mass per length and the three stiffnesses.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// ρS, kg/m.
    pub mass_per_length: f64,
    /// (GJ, EI1, EI2) in N·m²: torsion, bending about n1 (the κ1 direction), bending
    /// about n2. The stiffness matrix is `K = diag(l_Q · stiffness[i])`.
    pub stiffness: [f64; 3],
    /// Rotary inertia per unit length of the cross-section about (n0, n1, n2), kg·m:
    /// ρ(I1 + I2), ρI1, ρI2. See [`crate::model::strand::StrandGeometry::rotary_inertia`].
    pub rotary_inertia: [f64; 3],
}

impl CrossSection {
    /// Semi-axes (a along n1, b along n2): a = r√e, b = r/√e, so the area πr² is kept.
    pub fn semi_axes(&self) -> (f64, f64) {
        let s = self.ellipticity.sqrt();
        (self.radius * s, self.radius / s)
    }

    /// Mass per length and stiffnesses by the textbook formulas of the design page:
    /// `EI1 = E π a b³/4`, `EI2 = E π a³ b/4`, `GJ = G π a³ b³/(a² + b²)`,
    /// `G = s E / (2(1+ν))` with s = `shear_factor`, `ρS = ρ π a b`.
    pub fn material(&self) -> Material {
        let t = superhelix_kernels::material::section_terms(
            self.radius,
            self.ellipticity,
            self.youngs_modulus,
            self.poisson,
            self.density,
        );
        let [torsion, bend1, bend2] = t.stiffness;
        Material {
            mass_per_length: t.mass_per_length,
            stiffness: [torsion * self.shear_factor, bend1, bend2],
            rotary_inertia: t.rotary_inertia,
        }
    }
}

/// How a measured helix (radius, step) becomes natural curvature and twist.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum HelixForm {
    /// The exact helix: κ = R/(R² + c²), τ = c/(R² + c²), c = step/(2π). The rest shape
    /// is the measured helix.
    #[default]
    Exact,
    /// The paper's small-pitch form (section 4.2): κ = 1/R, τ = step/(2πR²).
    Paper,
}

/// Natural (τ, κ1, κ2) of a helix of radius `radius` and step (rise per turn) `step`,
/// both in metres. A zero radius gives a straight strand (0, 0, 0).
pub fn helix_curvature(radius: f64, step: f64, form: HelixForm) -> [f64; 3] {
    superhelix_kernels::material::helix_curvature(radius, step, form == HelixForm::Exact)
}

/// The four hair types of the paper's appendix B.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Preset {
    /// Asian, smooth: r = 50 µm, e = 1, no curl, E = 1 GPa.
    Smooth,
    /// Caucasian 1, wavy: r = 35 µm, e = 1.1, helix 1 cm / 0.5 cm, E = 2 GPa.
    Wavy,
    /// Caucasian 2, curly: r = 50 µm, e = 1.1, helix 0.6 cm / 0.5 cm, E = 1.5 GPa.
    Curly,
    /// African, fuzzy: r = 50 µm, e = 1.2, helix 0.1 cm / 1 cm, E = 0.5 GPa.
    Fuzzy,
}

/// Everything a preset sets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PresetParams {
    /// Cross-section and material, as measured at 65 % relative humidity (the reference
    /// of [`crate::model::humidity`]).
    pub cross_section: CrossSection,
    /// Radius of the natural helix, metres (0 = straight).
    pub helix_radius: f64,
    /// Step of the natural helix, metres.
    pub helix_step: f64,
    /// Internal friction γ, kg·m³/s. Section 4.2 reports γ in [5e-11, 5e-10], with
    /// 1e-10 fitted for a disciplined curly clump (figure 6); more curl, more friction.
    pub internal_friction: f64,
    /// Air drag ν, kg/(m·s): section 4.2 gives 5e-6 for disciplined hair up to 5e-5 for
    /// fuzzy hair.
    pub air_drag: f64,
}

impl Preset {
    /// All presets, in the paper's order.
    pub const ALL: [Preset; 4] = [Preset::Smooth, Preset::Wavy, Preset::Curly, Preset::Fuzzy];

    /// The preset's name as written in scenes.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Smooth => "smooth",
            Preset::Wavy => "wavy",
            Preset::Curly => "curly",
            Preset::Fuzzy => "fuzzy",
        }
    }

    /// Parse a preset name (`smooth`, `wavy`, `curly`, `fuzzy`).
    pub fn from_name(name: &str) -> Option<Preset> {
        Preset::ALL.into_iter().find(|p| p.name() == name)
    }

    /// The appendix-B values, with our documented friction and drag defaults.
    pub fn params(self) -> PresetParams {
        let cs = |radius_um: f64, ellipticity: f64, e_gpa: f64| CrossSection {
            radius: radius_um * 1e-6,
            ellipticity,
            youngs_modulus: e_gpa * 1e9,
            poisson: 0.48,
            density: 1300.0,
            shear_factor: 1.0,
        };
        match self {
            Preset::Smooth => PresetParams {
                cross_section: cs(50.0, 1.0, 1.0),
                helix_radius: 0.0,
                helix_step: 0.0,
                internal_friction: 5e-11,
                air_drag: 5e-6,
            },
            Preset::Wavy => PresetParams {
                cross_section: cs(35.0, 1.1, 2.0),
                helix_radius: 0.01,
                helix_step: 0.005,
                internal_friction: 1e-10,
                air_drag: 1e-5,
            },
            Preset::Curly => PresetParams {
                cross_section: cs(50.0, 1.1, 1.5),
                helix_radius: 0.006,
                helix_step: 0.005,
                internal_friction: 1e-10,
                air_drag: 2e-5,
            },
            Preset::Fuzzy => PresetParams {
                cross_section: cs(50.0, 1.2, 0.5),
                helix_radius: 0.001,
                helix_step: 0.01,
                internal_friction: 5e-10,
                air_drag: 5e-5,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn circular_section_has_equal_bending_and_textbook_torsion() {
        let cs = CrossSection {
            radius: 50e-6,
            ellipticity: 1.0,
            youngs_modulus: 1e9,
            poisson: 0.5,
            density: 1300.0,
            shear_factor: 1.0,
        };
        let m = cs.material();
        let i = std::f64::consts::PI * 50e-6_f64.powi(4) / 4.0;
        assert!((m.stiffness[1] / (1e9 * i) - 1.0).abs() < 1e-14);
        assert!((m.stiffness[2] / m.stiffness[1] - 1.0).abs() < 1e-14);
        // GJ = G * polar moment 2I for a circle; G = E/3 at nu = 0.5.
        assert!((m.stiffness[0] / (1e9 / 3.0 * 2.0 * i) - 1.0).abs() < 1e-14);
        assert!((m.mass_per_length / (1300.0 * std::f64::consts::PI * 2.5e-9) - 1.0).abs() < 1e-14);
    }

    #[test]
    fn exact_helix_differs_from_paper_form_as_the_design_page_says() {
        // Fuzzy: R = 1 mm, step 1 cm: the paper's curvature 1/R is 3.5x the exact one.
        let e = helix_curvature(0.001, 0.01, HelixForm::Exact);
        let p = helix_curvature(0.001, 0.01, HelixForm::Paper);
        let ratio = p[1] / e[1];
        assert!((ratio - 3.533).abs() < 0.01, "ratio {ratio}");
        // Wavy: 0.6 % off.
        let e = helix_curvature(0.01, 0.005, HelixForm::Exact);
        let p = helix_curvature(0.01, 0.005, HelixForm::Paper);
        assert!(((p[1] / e[1] - 1.0) - 0.00633).abs() < 2e-4);
    }
}
