use std::time::Instant;
use superhelix_runtime::kernel::{BodyField, EvalInput, StrandKernel, StrandTerms, Terms};
use superhelix_runtime::kernel_moments::{MomentKernel, MomentSource};
use superhelix_runtime::moments::ElementMoments;
use superhelix_runtime::{GenericKernel, QuadratureRule, StrandGeometry, Vector3, Matrix3};
struct Fake(ElementMoments);
impl MomentSource for Fake {
    fn moments(&self, _d: &Vector3<f64>, _l: f64, _r: &[f64; 3], out: &mut ElementMoments) { *out = self.0; }
    fn describe(&self) -> String { "fake".into() }
    fn is_generated(&self) -> bool { false }
}
fn main() {
    let n = 5;
    let g = StrandGeometry { root_position: Vector3::zeros(), root_frame: Matrix3::identity(), lengths: vec![0.05; n], mass_per_length: 1e-5, rotary_inertia: [1e-12, 5e-13, 5e-13] };
    let q: Vec<f64> = (0..3*n).map(|i| 0.1 * (i as f64).sin() * 20.0).collect();
    let v: Vec<f64> = (0..3*n).map(|i| (i as f64).cos()).collect();
    let field = BodyField { uniform: Vector3::new(0.0, 0.0, -9.81e-5), linear: Matrix3::zeros(), velocity: -Matrix3::identity() * 2e-5 };
    let m = ElementMoments::by_quadrature(&Vector3::new(1.0, 20.0, 3.0), 0.05, &g.rotary_inertia, 30);
    for (name, terms) in [("all", Terms::all()), ("mass+force", Terms { mass: true, force: true, ..Default::default() })] {
        let mut k = MomentKernel::new(g.clone(), Fake(m));
        let mut out = StrandTerms::new(3 * n);
        let input = EvalInput { q: &q, v: &v, field, terms };
        let t = Instant::now();
        let reps = 20000;
        for _ in 0..reps { k.evaluate(&input, &mut out); }
        println!("moment (fake moments) {name}: {:.2} us", t.elapsed().as_secs_f64() / reps as f64 * 1e6);
        let mut k = GenericKernel::new(g.clone(), QuadratureRule::Adaptive);
        let t = Instant::now();
        let reps = 2000;
        for _ in 0..reps { k.evaluate(&input, &mut out); }
        println!("generic {name}: {:.2} us", t.elapsed().as_secs_f64() / reps as f64 * 1e6);
    }
}
