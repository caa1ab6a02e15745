//! Effects exist only when a scene asks for them (issue #4): the kernel is asked only for
//! the terms the scene's effects make non-zero, and an effect not named costs nothing.

use std::sync::{Arc, Mutex};
use superhelix::bench::{setup, BenchOptions, EffectSet};
use superhelix::runtime::config::{Engine, KernelChoice};
use superhelix::runtime::kernels::kernel::{EvalInput, StrandKernel, StrandTerms};
use superhelix::runtime::model::reconstruction::Pose;
use superhelix::runtime::{KernelFactory, Simulation, StrandGeometry};
use superhelix::runtime::{Matrix3, Vector3};

/// Every `Terms` a kernel was asked for, and whether a field term was non-zero.
#[derive(Default, Debug)]
struct Log {
    stiffness: usize,
    damping: usize,
    calls: usize,
    linear_field: usize,
    point_calls: usize,
}

struct Recording {
    inner: Box<dyn StrandKernel>,
    log: Arc<Mutex<Log>>,
}

impl StrandKernel for Recording {
    fn geometry(&self) -> &StrandGeometry {
        self.inner.geometry()
    }
    fn description(&self) -> String {
        self.inner.description()
    }
    fn is_generated(&self) -> bool {
        self.inner.is_generated()
    }
    fn evaluate(&mut self, input: &EvalInput<'_>, out: &mut StrandTerms) {
        {
            let mut log = self.log.lock().expect("log");
            log.calls += 1;
            log.stiffness += usize::from(input.terms.stiffness);
            log.damping += usize::from(input.terms.damping);
            log.linear_field += usize::from(input.field.linear != Matrix3::zeros());
        }
        self.inner.evaluate(input, out)
    }
    fn point(
        &mut self,
        q: &[f64],
        s: f64,
        jac: &mut [Vector3<f64>],
        hessian: Option<(Vector3<f64>, &mut faer::Mat<f64>)>,
    ) -> Vector3<f64> {
        self.log.lock().expect("log").point_calls += 1;
        self.inner.point(q, s, jac, hessian)
    }
    fn element_ends(&mut self, q: &[f64], ends: &mut [Pose]) {
        self.inner.element_ends(q, ends)
    }
}

struct RecordingFactory {
    log: Arc<Mutex<Log>>,
}

impl KernelFactory for RecordingFactory {
    fn create(&self, geometry: &StrandGeometry) -> Option<Box<dyn StrandKernel>> {
        let inner = superhelix::kernel_factory()?.create(geometry)?;
        Some(Box::new(Recording {
            inner,
            log: self.log.clone(),
        }))
    }
    fn available(&self) -> Vec<usize> {
        superhelix::kernel_factory()
            .map(|f| f.available())
            .unwrap_or_default()
    }
}

fn run(effects: &str) -> Log {
    let log = Arc::new(Mutex::new(Log::default()));
    let options = BenchOptions {
        elements: 5,
        strands: 2,
        steps: 10,
        kernels: KernelChoice::Generated,
        effects: EffectSet::parse(effects).expect("valid effects"),
        // the runtime engine asks the factory's kernels (the embedded engine steps
        // generated fixed-N code of its own)
        engine: Engine::Runtime,
        ..BenchOptions::default()
    };
    let factory = RecordingFactory { log: log.clone() };
    let mut sim = Simulation::new(setup(&options).expect("setup"), Some(&factory)).expect("sim");
    for _ in 0..options.steps {
        sim.step().expect("step");
    }
    drop(sim);
    let mut guard = log.lock().expect("log");
    let taken = std::mem::take(&mut *guard);
    drop(guard);
    taken
}

#[test]
fn the_kernel_computes_only_what_the_effects_need() {
    let none = run("none");
    assert!(none.calls > 0);
    assert_eq!(
        (
            none.stiffness,
            none.damping,
            none.linear_field,
            none.point_calls
        ),
        (0, 0, 0, 0),
        "no effect: no field stiffness, damping, linear field or point loads: {none:?}"
    );
    // internal friction is a diagonal the integrator adds: still nothing from the kernel
    let friction = run("friction");
    assert_eq!(
        (friction.stiffness, friction.damping),
        (0, 0),
        "{friction:?}"
    );
    let gravity = run("gravity");
    assert!(gravity.stiffness > 0 && gravity.damping == 0, "{gravity:?}");
    let drag = run("drag");
    assert!(drag.stiffness == 0 && drag.damping > 0, "{drag:?}");
    let head = run("head");
    assert!(head.linear_field > 0, "{head:?}");
    let loads = run("point-loads");
    assert!(loads.point_calls > 0 && loads.damping == 0, "{loads:?}");
}
