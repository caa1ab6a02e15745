//! The parameters of a fixed-N strand, checked once when it is made.

use crate::float::Float;
use crate::material::SectionTerms;
use crate::storage::ParamsView;
use crate::strand_terms::StrandShape;
use nalgebra::{Matrix3, Vector3};

/// Everything a fixed-N strand's mechanics depends on besides its state, in the step's
/// float type `T` (`f64` unless named).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedParams<const N: usize, const D: usize, T: Float = f64> {
    /// Root position r_0 in head coordinates, metres.
    pub root_position: Vector3<T>,
    /// Root frame F_0 in head coordinates: columns (n0, n1, n2), n0 the tangent.
    pub root_frame: Matrix3<T>,
    /// Element lengths l_Q, metres.
    pub lengths: [T; N],
    /// Natural twist and curvatures q_n, rad/m, in the order of q.
    pub natural: [T; D],
    /// Diagonal of K = diag(l_Q · (GJ, EI1, EI2)) (eq. 5c), N·m.
    pub stiffness: [T; D],
    /// Diagonal of the internal friction γ l_Q (3 per element), kg·m⁴/s.
    pub friction: [T; D],
    /// ρS, kg/m.
    pub mass_per_length: T,
    /// Air drag ν, kg/(m·s).
    pub air_drag: T,
    /// Rotary inertia per unit length (ρ(I1 + I2), ρI1, ρI2), kg·m.
    pub rotary_inertia: [T; 3],
}

/// A parameter outside its allowed range: the field and what it must be.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParamsError {
    /// The field, e.g. `lengths`.
    pub field: &'static str,
    /// What it must be, e.g. `finite and > 0`.
    pub expected: &'static str,
}

impl core::fmt::Display for ParamsError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{}: must be {}", self.field, self.expected)
    }
}

fn positive(x: f64) -> bool {
    x.is_finite() && x > 0.0
}

fn non_negative(x: f64) -> bool {
    x.is_finite() && x >= 0.0
}

impl<const N: usize, const D: usize, T: Float> FixedParams<N, D, T> {
    /// Whether the strand dissipates at first order in the step (internal friction or
    /// air drag): only such a strand's solves take the dissipative split of the field
    /// stiffness ([`crate::field_split`]).
    pub fn dissipative(&self) -> bool {
        self.view().dissipative()
    }

    /// The parameters of a strand rooted at `root_position` with frame `root_frame`
    /// (orthonormal, head coordinates), elements of lengths `lengths`, cross-section
    /// terms `section` ([`crate::material::section_terms`]), natural (τ, κ1, κ2) per
    /// element `natural` (3N, rad/m), internal friction γ (kg·m³/s) and air drag ν
    /// (kg/(m·s)). Refuses a value outside its range, naming it. The inputs are `f64`
    /// in either float type: the products below are formed in `f64` and rounded to `T`
    /// once (in f64, the values as given).
    pub fn new(
        root_position: [f64; 3],
        root_frame: [[f64; 3]; 3],
        lengths: [f64; N],
        section: &SectionTerms,
        natural: [f64; D],
        internal_friction: f64,
        air_drag: f64,
    ) -> Result<Self, ParamsError> {
        if D != 3 * N || N == 0 {
            return Err(ParamsError {
                field: "elements",
                expected: "N ≥ 1 with D = 3N coordinates",
            });
        }
        let mut p = FixedParams {
            root_position: Vector3::zeros(),
            root_frame: Matrix3::zeros(),
            lengths: [T::zero(); N],
            natural: [T::zero(); D],
            stiffness: [T::zero(); D],
            friction: [T::zero(); D],
            mass_per_length: T::zero(),
            air_drag: T::zero(),
            rotary_inertia: [T::zero(); 3],
        };
        let scalars = checked_params(
            &ParamsInput {
                root_position,
                root_frame,
                lengths: &lengths,
                section,
                natural: &natural,
                internal_friction,
                air_drag,
            },
            ParamsOut {
                lengths: &mut p.lengths,
                natural: &mut p.natural,
                stiffness: &mut p.stiffness,
                friction: &mut p.friction,
            },
        )?;
        (
            p.root_position,
            p.root_frame,
            p.mass_per_length,
            p.air_drag,
            p.rotary_inertia,
        ) = scalars;
        Ok(p)
    }

    /// The shape the moment assembly reads.
    pub fn shape(&self) -> StrandShape<'_, T> {
        self.view().shape()
    }

    /// The step's view of these parameters.
    pub fn view(&self) -> ParamsView<'_, T> {
        ParamsView {
            root_position: self.root_position,
            root_frame: self.root_frame,
            lengths: &self.lengths,
            natural: &self.natural,
            stiffness: &self.stiffness,
            friction: &self.friction,
            mass_per_length: self.mass_per_length,
            air_drag: self.air_drag,
            rotary_inertia: self.rotary_inertia,
            loads: &[],
            scale: &[],
        }
    }

    /// The same parameters in the float type `U`, each value rounded to it (what
    /// [`FixedParams::new`] gives in `U` from the same inputs).
    pub fn cast<U: Float>(&self) -> FixedParams<N, D, U> {
        let c = |x: &T| U::of(x.as_f64());
        FixedParams {
            root_position: self.root_position.map(|x| c(&x)),
            root_frame: self.root_frame.map(|x| c(&x)),
            lengths: self.lengths.each_ref().map(c),
            natural: self.natural.each_ref().map(c),
            stiffness: self.stiffness.each_ref().map(c),
            friction: self.friction.each_ref().map(c),
            mass_per_length: c(&self.mass_per_length),
            air_drag: c(&self.air_drag),
            rotary_inertia: self.rotary_inertia.each_ref().map(c),
        }
    }

    /// Total length L, metres.
    pub fn length(&self) -> T {
        self.view().length()
    }
}

/// A strand's parameters as given (see [`FixedParams::new`]): N lengths, 3N natural
/// values.
pub(crate) struct ParamsInput<'a> {
    pub(crate) root_position: [f64; 3],
    pub(crate) root_frame: [[f64; 3]; 3],
    pub(crate) lengths: &'a [f64],
    pub(crate) section: &'a SectionTerms,
    pub(crate) natural: &'a [f64],
    pub(crate) internal_friction: f64,
    pub(crate) air_drag: f64,
}

/// Where [`checked_params`] writes the per-element and per-coordinate parameters (N and
/// 3N long).
pub(crate) struct ParamsOut<'a, T> {
    pub(crate) lengths: &'a mut [T],
    pub(crate) natural: &'a mut [T],
    pub(crate) stiffness: &'a mut [T],
    pub(crate) friction: &'a mut [T],
}

/// The root position and frame, ρS, ν and the rotary inertia in `T`.
pub(crate) type ParamScalars<T> = (Vector3<T>, Matrix3<T>, T, T, [T; 3]);

/// Check `input` and write its parameters in `T` into `out` (the products formed in
/// `f64` and rounded to `T` once), or name the first value outside its range.
pub(crate) fn checked_params<T: Float>(
    input: &ParamsInput<'_>,
    out: ParamsOut<'_, T>,
) -> Result<ParamScalars<T>, ParamsError> {
    let err = |field, expected| Err(ParamsError { field, expected });
    let n = input.lengths.len();
    if n == 0
        || input.natural.len() != 3 * n
        || out.lengths.len() != n
        || [out.natural.len(), out.stiffness.len(), out.friction.len()] != [3 * n; 3]
    {
        return err("elements", "N ≥ 1 with D = 3N coordinates");
    }
    let section = input.section;
    if !input.root_position.iter().all(|x| x.is_finite()) {
        return err("root_position", "finite");
    }
    let frame = Matrix3::from_fn(|r, c| input.root_frame[c][r]);
    let orthonormal = (frame.transpose() * frame - Matrix3::identity()).amax() <= 1e-9
        && frame.determinant() > 0.0;
    if !frame.iter().all(|x| x.is_finite()) || !orthonormal {
        return err(
            "root_frame",
            "a rotation (orthonormal columns n0, n1, n2 within 1e-9, det > 0)",
        );
    }
    if !input.lengths.iter().all(|&l| positive(l) && l <= 100.0) {
        return err("lengths", "finite, > 0 and ≤ 100 m");
    }
    if !positive(section.mass_per_length) {
        return err("mass_per_length", "finite and > 0");
    }
    if !section.stiffness.iter().all(|&k| positive(k)) {
        return err("stiffness", "finite and > 0");
    }
    if !section.rotary_inertia.iter().all(|&i| non_negative(i)) {
        return err("rotary_inertia", "finite and ≥ 0");
    }
    if !input
        .natural
        .iter()
        .all(|&x| x.is_finite() && x.abs() <= 1e6)
    {
        return err("natural", "finite, |x| ≤ 1e6 rad/m");
    }
    if !non_negative(input.internal_friction) {
        return err("internal_friction", "finite and ≥ 0");
    }
    if !non_negative(input.air_drag) {
        return err("air_drag", "finite and ≥ 0");
    }
    for (p, &l) in input.lengths.iter().enumerate() {
        out.lengths[p] = T::of(l);
        for i in 0..3 {
            out.stiffness[3 * p + i] = T::of(l * section.stiffness[i]);
            out.friction[3 * p + i] = T::of(l * input.internal_friction);
        }
    }
    for (o, &x) in out.natural.iter_mut().zip(input.natural) {
        *o = T::of(x);
    }
    let scalars: ParamScalars<T> = (
        Vector3::from(input.root_position).map(T::of),
        frame.map(T::of),
        T::of(section.mass_per_length),
        T::of(input.air_drag),
        section.rotary_inertia.map(T::of),
    );
    // what f64 holds may overflow, or round to zero, in f32
    let finite = |x: &[T]| x.iter().all(|x| x.is_finite());
    let positive = |x: &[T]| x.iter().all(|&x| x.is_finite() && x > T::zero());
    let representable = "representable in the step's float type (finite, and > 0 where > 0)";
    let fields: [(&'static str, bool); 8] = [
        ("root_position", finite(scalars.0.as_slice())),
        ("lengths", positive(out.lengths)),
        ("natural", finite(out.natural)),
        ("stiffness", positive(out.stiffness)),
        ("internal_friction", finite(out.friction)),
        ("mass_per_length", positive(&[scalars.2])),
        ("air_drag", finite(&[scalars.3])),
        ("rotary_inertia", finite(&scalars.4)),
    ];
    if let Some((field, _)) = fields.iter().find(|(_, ok)| !ok) {
        return err(field, representable);
    }
    Ok(scalars)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::section_terms;

    /// Values that f64 holds but f32 does not are refused in f32, naming the field.
    #[test]
    fn f32_parameters_must_be_representable_in_f32() {
        let frame = [[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]];
        let section = section_terms(50e-6, 1.0, 1.5e9, 0.48, 1300.0);
        let make = |section: &SectionTerms, drag: f64| {
            FixedParams::<2, 6, f32>::new([0.0; 3], frame, [0.1; 2], section, [1.0; 6], 0.0, drag)
        };
        assert!(make(&section, 5e-6).is_ok());
        let err = make(&section, 1e300).expect_err("air drag overflows f32");
        assert_eq!(err.field, "air_drag");
        let tiny = SectionTerms {
            mass_per_length: 1e-60,
            ..section
        };
        assert_eq!(
            make(&tiny, 5e-6).expect_err("ρS rounds to 0").field,
            "mass_per_length"
        );
        // the same values are fine in f64
        assert!(
            FixedParams::<2, 6>::new([0.0; 3], frame, [0.1; 2], &tiny, [1.0; 6], 0.0, 1e300)
                .is_ok()
        );
    }
}
