//! The per-N modules of this build and their dispatch: `visit_size` reaches every size
//! in `fixed::SIZES` (the checked-in ones, and those of `SUPERHELIX_N` when the crate was
//! built with it) with the right const parameters and no other, and a per-N module's
//! step is the const-generic step with those parameters, bit for bit.

use superhelix_generated::fixed::{self, n5};
use superhelix_generated::kernels::fixed::{
    step, Effects, FixedParams, FixedStrand, FixedWorkspace, StepCounts, StillHead,
};
use superhelix_generated::kernels::material::section_terms;
use superhelix_generated::sizes::CHECKED_IN_SIZES;
use superhelix_generated::{visit_size, ClosedForm, SizeVisitor};

/// Reports the const parameters it is visited with.
struct Parameters;

impl SizeVisitor for Parameters {
    type Output = [usize; 4];
    fn visit<const N: usize, const D: usize, const E: usize, const B: usize>(self) -> [usize; 4] {
        [N, D, E, B]
    }
}

#[test]
fn visit_size_reaches_exactly_the_sizes_of_the_build() {
    assert!(
        fixed::SIZES.windows(2).all(|w| w[0] < w[1]),
        "{:?}",
        fixed::SIZES
    );
    assert_eq!(fixed::CHECKED_IN, CHECKED_IN_SIZES);
    assert!(fixed::BUILT.iter().all(|n| !CHECKED_IN_SIZES.contains(n)));
    for n in 0..=210 {
        let expected = fixed::SIZES
            .contains(&n)
            .then_some([n, 3 * n, n + 1, 3 * n / 2]);
        assert_eq!(visit_size(n, Parameters), expected, "N = {n}");
    }
    if let Ok(list) = std::env::var("SUPERHELIX_N") {
        // a test binary run with the variable of its build
        for n in list
            .split(',')
            .filter_map(|s| s.trim().parse::<usize>().ok())
        {
            assert!(
                fixed::SIZES.contains(&n),
                "SUPERHELIX_N={list}: N = {n} missing"
            );
        }
    }
}

#[test]
fn a_per_n_module_is_the_const_generic_step_with_literal_sizes() {
    assert_eq!([n5::N, n5::DOFS, n5::ENDS, n5::BASIS], [5, 15, 6, 7]);
    assert_eq!(
        [
            fixed::n20::N,
            fixed::n20::DOFS,
            fixed::n20::ENDS,
            fixed::n20::BASIS
        ],
        [20, 60, 21, 30]
    );
    let section = section_terms(50e-6, 1.0, 1e9, 0.48, 1300.0);
    let frame = [[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]];
    let natural = core::array::from_fn(|i| [1.0, 15.0, -4.0][i % 3]);
    let params: n5::Params =
        FixedParams::new([0.0; 3], frame, [0.05; 5], &section, natural, 5e-11, 5e-6)
            .expect("valid");
    let mut a = n5::Strand::at_rest(params);
    let mut b = FixedStrand::<5, 15, 7>::at_rest(params);
    let mut wa = Box::new(n5::Workspace::new());
    let mut wb = Box::new(FixedWorkspace::<5, 15, 6>::new());
    let effects = Effects {
        gravity: Some([0.0, 0.0, -9.81].into()),
        head_moves: false,
    };
    let (mut ca, mut cb) = (StepCounts::default(), StepCounts::default());
    for k in 0..10 {
        let t = k as f64 / 30.0;
        let ra = n5::step(
            &mut a,
            &StillHead,
            &effects,
            t,
            1.0 / 30.0,
            &mut wa,
            &mut ca,
        );
        let rb = step(
            &ClosedForm,
            &mut b,
            &StillHead,
            &effects,
            t,
            1.0 / 30.0,
            &mut wb,
            &mut cb,
        );
        assert!(ra.is_ok(), "step {k}: {ra:?}");
        assert_eq!(ra, rb);
        let bits = |x: &[f64]| x.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a.q), bits(&b.q));
        assert_eq!(bits(&a.v), bits(&b.v));
    }
    let mut ends = [Default::default(); n5::ENDS];
    n5::centreline(&a, &mut ends);
    assert!(ends
        .iter()
        .all(|p| p.position.iter().all(|x| x.is_finite())));
}
