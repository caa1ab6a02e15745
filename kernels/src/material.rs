//! What the dynamics needs of a fibre's material and cross-section (paper section 4.2,
//! appendix B): mass per length, the three stiffnesses and the rotary inertia, by the
//! textbook formulas for an elliptic section; and the natural curvature and twist of a
//! measured helix.

use crate::math::{powi, sqrt};

/// Mass per length, stiffnesses and rotary inertia of a cross-section.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SectionTerms {
    /// ρS, kg/m.
    pub mass_per_length: f64,
    /// (GJ, EI1, EI2) in N·m²: torsion, bending about n1 (the κ1 direction), bending
    /// about n2. The stiffness matrix is `K = diag(l_Q · stiffness[i])` (eq. 5c).
    pub stiffness: [f64; 3],
    /// Rotary inertia per unit length about (n0, n1, n2), kg·m: ρ(I1 + I2), ρI1, ρI2.
    pub rotary_inertia: [f64; 3],
}

/// The terms of an elliptic section of mean radius `radius` (m) and ellipticity
/// `ellipticity` = r_max / r_min ≥ 1 (semi-axes a = r√e along n1, b = r/√e along n2,
/// keeping the area πr²), Young's modulus `youngs_modulus` (Pa), Poisson ratio `poisson`
/// and density `density` (kg/m³): `EI1 = E π a b³/4`, `EI2 = E π a³ b/4`,
/// `GJ = G π a³ b³/(a² + b²)`, `G = E / (2(1+ν))`, `ρS = ρ π a b`.
pub fn section_terms(
    radius: f64,
    ellipticity: f64,
    youngs_modulus: f64,
    poisson: f64,
    density: f64,
) -> SectionTerms {
    let s = sqrt(ellipticity);
    let (a, b) = (radius * s, radius / s);
    let pi = core::f64::consts::PI;
    let e = youngs_modulus;
    let g = e / (2.0 * (1.0 + poisson));
    let i1 = pi * a * powi(b, 3) / 4.0;
    let i2 = pi * powi(a, 3) * b / 4.0;
    let rho = density;
    SectionTerms {
        mass_per_length: rho * pi * a * b,
        stiffness: [
            g * pi * powi(a, 3) * powi(b, 3) / (a * a + b * b),
            e * i1,
            e * i2,
        ],
        rotary_inertia: [rho * (i1 + i2), rho * i1, rho * i2],
    }
}

/// Natural (τ, κ1, κ2) of a helix of radius `radius` and step (rise per turn) `step`,
/// both in metres: the exact helix `κ = R/(R² + c²)`, `τ = c/(R² + c²)`, `c = step/(2π)`
/// when `exact`, else the paper's small-pitch form (section 4.2) `κ = 1/R`,
/// `τ = step/(2πR²)`. A zero radius gives a straight strand (0, 0, 0).
pub fn helix_curvature(radius: f64, step: f64, exact: bool) -> [f64; 3] {
    if radius <= 0.0 {
        return [0.0, 0.0, 0.0];
    }
    let c = step / (2.0 * core::f64::consts::PI);
    if exact {
        let den = radius * radius + c * c;
        [c / den, radius / den, 0.0]
    } else {
        [c / (radius * radius), 1.0 / radius, 0.0]
    }
}
