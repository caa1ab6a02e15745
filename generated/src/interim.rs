//! Stand-in until the closed form of the element point is generated.
use superhelix_runtime::element::ElementPoint;
use superhelix_runtime::Vector3;

/// The element's local functions at u (by jets for now).
pub fn element_point_into(d: &Vector3<f64>, u: f64, out: &mut ElementPoint) {
    *out = ElementPoint::by_jets(d, u);
}
