//! A point of a strand's centreline at arc length s, its Jacobian J(s) = ∂y(s)/∂q and,
//! contracted with a vector c, its Hessian c · ∂²y(s)/∂q∂q: what a contact sample, a
//! held end or a point load acts through (the runtime's kernels and, for contacts, the
//! fixed-N step). From the chain of rigid element ends up to the element holding s and
//! that element's local functions at s ([`MomentSource::point`]); no allocation.

use crate::element::ElementPoint;
use crate::float::Float;
use crate::moments::{end_derivatives_from, EndDerivatives};
use crate::pose::{darboux, Pose};
use crate::strand_terms::MomentSource;
use nalgebra::{Matrix3, Vector3};

/// The element holding arc length `s` of a strand of element lengths `lengths`, and
/// s's abscissa in it (clamped to the element; beyond the tip, the last element's).
pub fn locate<T: Float>(lengths: &[T], s: T) -> (usize, T) {
    let mut start = T::zero();
    let n = lengths.len();
    for (q, &l) in lengths.iter().enumerate() {
        if s <= start + l || q + 1 == n {
            return (q, (s - start).max(T::zero()).min(l));
        }
        start += l;
    }
    (0, T::zero())
}

/// What [`strand_point`] may keep between calls: the q its scratch ends were computed
/// for (`q`, 3N long, on the caller's storage) and how many elements of the chain they
/// hold (`valid`). Points asked in a row at the same q (a strand's contact samples and
/// partners, in arc-length order, at every solve) then chain each element once, not once
/// per point.
pub struct PointChain<'a, T: Float = f64> {
    /// The q the chain was computed for (NaN at first: no q).
    pub q: &'a mut [T],
    /// Elements of the chain computed for `q`.
    pub valid: &'a mut usize,
}

/// Where [`strand_point`] hands the entries of a Hessian: `add(k, l, value)`.
pub type HessianSink = fn(usize, usize, f64);

/// What [`strand_point`] takes for `hessian` when no Hessian is asked.
pub const NO_HESSIAN: Option<(Vector3<f64>, &mut HessianSink)> = None;

/// y(s) and J(s) (into `jac`, 3N columns), and `c · ∂²y/∂q²` handed entry by entry to
/// `add(k, l, value)` when `hessian` is (c, add) (each off-diagonal pair (k, l), (l, k)
/// handed twice, once each way), for a strand rooted at `root` with element lengths
/// `lengths` at q, from the element points of `source`. `ends` (N + 1 long) and
/// `end_derivs` (N long) are scratch and hold q's values up to the element holding s
/// afterwards; with `chain`, the elements it records for this q are not chained again
/// (the scratch must then be left alone between calls).
#[allow(clippy::too_many_arguments)]
pub fn strand_point<T: Float, S: MomentSource<T> + ?Sized, F: FnMut(usize, usize, T)>(
    source: &S,
    root: &Pose<T>,
    lengths: &[T],
    ends: &mut [Pose<T>],
    end_derivs: &mut [EndDerivatives<T>],
    chain: Option<PointChain<'_, T>>,
    q: &[T],
    s: T,
    jac: &mut [Vector3<T>],
    hessian: Option<(Vector3<T>, &mut F)>,
) -> Vector3<T> {
    strand_point_pose(
        source, root, lengths, ends, end_derivs, chain, q, s, jac, hessian,
    )
    .position
}

/// [`strand_point`] with the material frame at s: the pose (y(s), F(s)).
#[allow(clippy::too_many_arguments)]
pub fn strand_point_pose<T: Float, S: MomentSource<T> + ?Sized, F: FnMut(usize, usize, T)>(
    source: &S,
    root: &Pose<T>,
    lengths: &[T],
    ends: &mut [Pose<T>],
    end_derivs: &mut [EndDerivatives<T>],
    chain: Option<PointChain<'_, T>>,
    q: &[T],
    s: T,
    jac: &mut [Vector3<T>],
    hessian: Option<(Vector3<T>, &mut F)>,
) -> Pose<T> {
    let (e, u) = locate(lengths, s);
    // ends and end derivatives of the elements up to e (those the chain holds for this q
    // are kept)
    let first = match chain {
        Some(c) => {
            let first = if *c.q == *q {
                (*c.valid).min(e)
            } else {
                c.q.copy_from_slice(q);
                *c.valid = 0;
                0
            };
            *c.valid = (*c.valid).max(e);
            first
        }
        None => 0,
    };
    ends[0] = *root;
    let mut pt = ElementPoint::default();
    for p in first..e {
        let d = darboux(q, p);
        source.point(&d, lengths[p], &mut pt);
        let start = ends[p];
        ends[p + 1] = Pose {
            position: start.position + start.frame * pt.p,
            frame: start.frame * pt.frame,
        };
        end_derivs[p] = end_derivatives_from(&start.frame, &pt);
    }
    source.point(&darboux(q, e), u, &mut pt);
    let f: Matrix3<T> = ends[e].frame;
    let y = ends[e].position + f * pt.p;
    for col in jac.iter_mut() {
        *col = Vector3::zeros();
    }
    for qe in 0..e {
        let ed = &end_derivs[qe];
        let rho = y - ends[qe + 1].position;
        for i in 0..3 {
            jac[3 * qe + i] = ed.dp[i] + ed.dtheta[i].cross(&rho);
        }
    }
    for i in 0..3 {
        jac[3 * e + i] = f * pt.dp[i];
    }
    if let Some((c, add)) = hessian {
        // k upstream of l (different elements): c·(dθ_k × J_l)
        for l in 3..3 * (e + 1) {
            for k in 0..3 * (l / 3) {
                let val = c.cross(&end_derivs[k / 3].dtheta[k % 3]).dot(&jac[l]);
                add(k, l, val);
                add(l, k, val);
            }
        }
        // pairs within an element upstream of e
        for qe in 0..e {
            let ed = &end_derivs[qe];
            let rho = y - ends[qe + 1].position;
            for i in 0..3 {
                for j in 0..3 {
                    let d2 = ed.d2p[i][j]
                        + ed.dw[i][j].cross(&rho)
                        + ed.dtheta[i].cross(&ed.dtheta[j].cross(&rho));
                    add(3 * qe + i, 3 * qe + j, c.dot(&d2));
                }
            }
        }
        // pairs within element e
        let cf = f.transpose() * c;
        for i in 0..3 {
            for j in 0..3 {
                add(3 * e + i, 3 * e + j, cf.dot(&pt.d2p[i][j]));
            }
        }
    }
    Pose {
        position: y,
        frame: f * pt.frame,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::moments::ElementMoments;
    use std::vec;
    use std::vec::Vec;

    /// The element points by jets; the moments by quadrature (not read here).
    pub(crate) struct Jets;
    impl MomentSource for Jets {
        fn moments(&self, d: &Vector3<f64>, l: f64, rotary: &[f64; 3], out: &mut ElementMoments) {
            *out = ElementMoments::by_quadrature(d, l, rotary, 8);
        }
        fn describe(&self) -> &'static str {
            "jets"
        }
        fn is_generated(&self) -> bool {
            false
        }
    }

    /// J(s) against central differences of y(s) in each coordinate, and the Hessian
    /// contracted with c against central differences of c · J(s) (1e-6 in q), at points
    /// in the first, a middle and the last element of a 4-element strand, with and
    /// without a chain kept between the calls; the chained calls give the same bits.
    #[test]
    fn the_jacobian_and_the_hessian_are_the_derivatives_of_the_point() {
        let lengths = [0.03, 0.05, 0.04, 0.02];
        let n = lengths.len();
        let dofs = 3 * n;
        let root = Pose {
            position: Vector3::new(0.01, -0.02, 0.05),
            frame: nalgebra::Rotation3::from_euler_angles(0.2, -0.4, 0.9).into_inner(),
        };
        let q: Vec<f64> = (0..dofs)
            .map(|i| [3.0, 25.0, -8.0, 0.5][i % 4] + 0.1 * i as f64)
            .collect();
        let c = Vector3::new(0.3, -1.2, 0.7);
        let mut ends = vec![Pose::default(); n + 1];
        let mut derivs = vec![EndDerivatives::default(); n];
        let (mut chain_q, mut valid) = (vec![f64::NAN; dofs], 0usize);
        let point = |q: &[f64], s: f64, jac: &mut [Vector3<f64>]| {
            let mut e = vec![Pose::default(); n + 1];
            let mut d = vec![EndDerivatives::default(); n];
            strand_point(
                &Jets, &root, &lengths, &mut e, &mut d, None, q, s, jac, NO_HESSIAN,
            )
        };
        for s in [0.01, 0.06, 0.135] {
            let mut jac = vec![Vector3::zeros(); dofs];
            let mut h = vec![0.0; dofs * dofs];
            let mut add = |k: usize, l: usize, v: f64| h[k + l * dofs] += v;
            let y = strand_point(
                &Jets,
                &root,
                &lengths,
                &mut ends,
                &mut derivs,
                Some(PointChain {
                    q: &mut chain_q,
                    valid: &mut valid,
                }),
                &q,
                s,
                &mut jac,
                Some((c, &mut add)),
            );
            let mut plain = vec![Vector3::zeros(); dofs];
            assert_eq!(point(&q, s, &mut plain), y, "s = {s}: chained and fresh");
            assert_eq!(plain, jac);
            let step = 1e-6;
            let jscale = jac.iter().fold(0.0f64, |m, j| m.max(j.norm()));
            let hscale = h.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            for k in 0..dofs {
                let (mut up, mut down) = (q.clone(), q.clone());
                up[k] += step;
                down[k] -= step;
                let (mut ju, mut jd) = (vec![Vector3::zeros(); dofs], vec![Vector3::zeros(); dofs]);
                let dy = (point(&up, s, &mut ju) - point(&down, s, &mut jd)) / (2.0 * step);
                assert!(
                    (dy - jac[k]).norm() <= 1e-7 * jscale,
                    "s = {s}, J column {k}"
                );
                for l in 0..dofs {
                    let numeric = (c.dot(&ju[l]) - c.dot(&jd[l])) / (2.0 * step);
                    assert!(
                        (numeric - h[k + l * dofs]).abs() <= 1e-6 * hscale,
                        "s = {s}, H({k}, {l}): {numeric} against {}",
                        h[k + l * dofs]
                    );
                }
            }
        }
    }
}
