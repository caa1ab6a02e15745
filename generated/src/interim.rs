//! Stand-ins until the closed forms of the force moments and of the element point are
//! generated: M-related moments in closed form, the rest by quadrature / jets.
use superhelix_runtime::element::ElementPoint;
use superhelix_runtime::moments::ElementMoments;
use superhelix_runtime::Vector3;

/// All element moments (force-only fields by quadrature for now).
pub fn element_moments_into(d: &Vector3<f64>, l: f64, rotary: &[f64; 3], out: &mut ElementMoments) {
    let q = ElementMoments::by_quadrature(d, l, rotary, 16 + 2 * (d.norm() * l).ceil().min(400.0) as usize);
    let m = crate::mass_moments(d, l, rotary);
    *out = ElementMoments {
        d2first: q.d2first,
        cross2: q.cross2,
        dpdp: q.dpdp,
        dpd2p: q.dpd2p,
        pd2p: q.pd2p,
        ..m
    };
}

/// The element's local functions at u (by jets for now).
pub fn element_point_into(d: &Vector3<f64>, u: f64, out: &mut ElementPoint) {
    *out = ElementPoint::by_jets(d, u);
}
