//! Steps a 5-element strand with the fixed-N step, in f64 and in f32, without std and
//! without alloc.
#![no_std]

use superhelix_generated::kernels::fixed::{
    self, Effects, FixedParams, FixedStrand, FixedWorkspace, StepCounts, StillHead,
};
use superhelix_generated::kernels::material::section_terms;
use superhelix_generated::ClosedForm;

/// Steps a hanging 20 cm strand once under gravity and returns its first coordinate
/// (NaN when it could not).
#[no_mangle]
pub extern "C" fn superhelix_probe_step() -> f64 {
    let section = section_terms(50e-6, 1.0, 1.5e9, 0.48, 1300.0);
    let frame = [[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]];
    let Ok(params) =
        FixedParams::<5, 15>::new([0.0; 3], frame, [0.04; 5], &section, [10.0; 15], 5e-11, 5e-6)
    else {
        return f64::NAN;
    };
    let mut strand = FixedStrand::<5, 15, 7>::at_rest(params);
    let mut ws = FixedWorkspace::<5, 15, 6>::new();
    let effects = Effects {
        gravity: Some([0.0, 0.0, -9.81].into()),
        head_moves: false,
    };
    let mut counts = StepCounts::default();
    match fixed::step(
        &ClosedForm,
        &mut strand,
        &StillHead,
        &effects,
        0.0,
        1.0 / 30.0,
        &mut ws,
        &mut counts,
    ) {
        Ok(_) => strand.q[0],
        Err(_) => f64::NAN,
    }
}

/// The same strand in f32 (`n5::f32`, the f32 step on the generated f32 closed forms),
/// stepped once: its first coordinate (NaN when it could not).
#[no_mangle]
pub extern "C" fn superhelix_probe_step_f32() -> f32 {
    use superhelix_generated::fixed::n5::f32 as n5;
    let section = section_terms(50e-6, 1.0, 1.5e9, 0.48, 1300.0);
    let frame = [[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]];
    let Ok(params) =
        n5::Params::new([0.0; 3], frame, [0.04; 5], &section, [10.0; 15], 5e-11, 5e-6)
    else {
        return f32::NAN;
    };
    let mut strand = n5::Strand::at_rest(params);
    let mut ws = n5::Workspace::new();
    let effects = Effects {
        gravity: Some([0.0, 0.0, -9.81].into()),
        head_moves: false,
    };
    let mut counts = StepCounts::default();
    match n5::step(
        &mut strand,
        &StillHead,
        &effects,
        0.0,
        1.0 / 30.0,
        &mut ws,
        &mut counts,
    ) {
        Ok(_) => strand.q[0],
        Err(_) => f32::NAN,
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}
