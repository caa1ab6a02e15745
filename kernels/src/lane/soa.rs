//! Structure of arrays: W strands' values of one kind as one value of lanes, lane k
//! strand k's (part 3 of docs/architecture.md's "Strands in lanes"). [`Soa::load`] takes
//! W values into lanes and [`Soa::store`] gives lane k back, exactly: the strands keep
//! their own storage (their arrays, checkpoints, the C ABI), and a step on lanes loads
//! them before and stores them after.
//!
//! Implemented for the scalars, nalgebra's fixed-size vectors and matrices, arrays of
//! anything that is, and the step's small structures ([`Pose`], [`ElementMoments`],
//! [`EndDerivatives`], [`SuffixBody`], [`FrameMotion`]), so that the step's own code
//! over [`crate::float::Arith`] runs on W strands with the same types.

use super::Lanes;
use crate::body_field::BodyField;
use crate::moments::rotary::RotaryElement;
use crate::moments::{ElementMoments, EndDerivatives, FrameMotion, SuffixBody};
use crate::pose::Pose;
use crate::Float;
use nalgebra::{Const, SMatrix};

/// A value that W strands hold one each, and its lanes.
pub trait Soa<const W: usize>: Sized {
    /// The W values in lanes.
    type Lanes;
    /// Lane k holds `values[k]`.
    fn load(values: [&Self; W]) -> Self::Lanes;
    /// Lane `k` (< W) of `lanes`.
    fn store(lanes: &Self::Lanes, k: usize) -> Self;
}

macro_rules! scalar_soa {
    ($($t:ty),*) => {$(
        impl<const W: usize> Soa<W> for $t {
            type Lanes = Lanes<$t, W>;
            #[inline(always)]
            fn load(values: [&Self; W]) -> Lanes<$t, W> {
                Lanes(values.map(|x| *x))
            }
            #[inline(always)]
            fn store(lanes: &Lanes<$t, W>, k: usize) -> $t {
                lanes.0[k]
            }
        }
    )*};
}

scalar_soa!(f64, f32);

impl<T: Float + Soa<W, Lanes = Lanes<T, W>>, const W: usize, const R: usize, const C: usize> Soa<W>
    for SMatrix<T, R, C>
{
    type Lanes = SMatrix<Lanes<T, W>, R, C>;
    #[inline(always)]
    fn load(values: [&Self; W]) -> Self::Lanes {
        SMatrix::<Lanes<T, W>, R, C>::from_fn_generic(Const::<R>, Const::<C>, |r, c| {
            Lanes(values.map(|m| m[(r, c)]))
        })
    }
    #[inline(always)]
    fn store(lanes: &Self::Lanes, k: usize) -> Self {
        lanes.map(|x| x.0[k])
    }
}

impl<X: Soa<W>, const W: usize, const L: usize> Soa<W> for [X; L] {
    type Lanes = [X::Lanes; L];
    #[inline(always)]
    fn load(values: [&Self; W]) -> Self::Lanes {
        core::array::from_fn(|i| X::load(values.map(|v| &v[i])))
    }
    #[inline(always)]
    fn store(lanes: &Self::Lanes, k: usize) -> Self {
        core::array::from_fn(|i| X::store(&lanes[i], k))
    }
}

// a structure whose fields are all Soa: its lanes are the same structure over lanes
macro_rules! struct_soa {
    ($name:ident { $($field:ident),* }) => {
        impl<T: Float + Soa<W, Lanes = Lanes<T, W>>, const W: usize> Soa<W> for $name<T> {
            type Lanes = $name<Lanes<T, W>>;
            #[inline(always)]
            fn load(values: [&Self; W]) -> Self::Lanes {
                $name { $($field: Soa::load(values.map(|v| &v.$field))),* }
            }
            #[inline(always)]
            fn store(lanes: &Self::Lanes, k: usize) -> Self {
                $name { $($field: Soa::store(&lanes.$field, k)),* }
            }
        }
    };
}

struct_soa!(Pose { position, frame });
struct_soa!(BodyField {
    uniform,
    linear,
    velocity
});
struct_soa!(ElementMoments {
    first,
    second,
    dfirst,
    cross,
    gram,
    rot,
    rot_w,
    rot_ww,
    pdp,
    d2first,
    cross2,
    pd2p,
    dpdp,
    dpd2p
});
struct_soa!(EndDerivatives {
    dp,
    dtheta,
    d2p,
    dw
});
struct_soa!(RotaryElement {
    torque,
    b_own,
    lambda,
    lambda_w,
    psi,
    own,
    rot,
    rot_w
});
struct_soa!(SuffixBody {
    mass,
    first,
    second,
    velocity,
    moment_velocity,
    rot
});
struct_soa!(FrameMotion {
    omega,
    alpha,
    velocity,
    acceleration
});

#[cfg(test)]
mod tests {
    use super::*;

    /// Loading W structures and storing each lane gives each back, bit for bit.
    #[test]
    fn load_then_store_is_exact() {
        let mut x = 0.3f64;
        let mut next = move || {
            x = (x * 3.7 + 0.11) % 1.0;
            x - 0.5
        };
        let moments: [ElementMoments; 4] = core::array::from_fn(|_| {
            let mut m = ElementMoments {
                first: nalgebra::Vector3::new(next(), next(), -0.0),
                ..Default::default()
            };
            m.pdp[2][(1, 0)] = next();
            m.dpd2p[1][2][0] = next();
            m.pd2p[0][2][(2, 1)] = f64::NAN;
            m
        });
        let lanes = ElementMoments::load(moments.each_ref());
        for (k, m) in moments.iter().enumerate() {
            let back = <ElementMoments as Soa<4>>::store(&lanes, k);
            assert_eq!(back.first[2].to_bits(), (-0.0f64).to_bits());
            assert_eq!(back.pdp, m.pdp);
            assert_eq!(back.dpd2p, m.dpd2p);
            assert!(back.pd2p[0][2][(2, 1)].is_nan());
            assert_eq!(back.first, m.first);
        }
        assert_eq!(lanes.pdp[2][(1, 0)].0[3], moments[3].pdp[2][(1, 0)]);
    }
}
