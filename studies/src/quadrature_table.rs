//! `superhelix quadrature-table`: what the Gauss–Legendre order of the generic kernel
//! costs and buys on strongly curled hair (W·l ≫ 1, the fuzzy preset), against the
//! closed-form (generated) kernel, or a 256-point generic kernel standing in for it
//! while this build has no generated kernel for N (README "What quadrature order costs").
//!
//! Errors are measured at the states of a reference simulation (S strands of the bench,
//! gravity, drag, internal friction and a head shaking at 2 Hz by ±30°, T steps of
//! 1/30 s), with each state's own body field: per quantity, `max|generic − reference| /
//! max|reference|` over its entries (as in `compare-kernels`), worst over the states.
//! Time per strand-step is the time of T steps of that simulation with each rule, all
//! strands on one thread, best of [`TableOptions::repeats`] runs, divided by S·T; the
//! time is the thread's on-CPU time where the platform has it (unix), so that other load
//! on a shared machine does not count, else wall time ([`Clock`]).

use crate::bench::{BenchOptions, EffectSet};
use crate::compare::Deviation;
use crate::runtime::config::{KernelChoice, SimulationSetup};
use crate::runtime::forces::effects::{body_field, GlobalEffects};
use crate::runtime::kernels::kernel::{EvalInput, KernelFactory, StrandKernel, StrandTerms, Terms};
use crate::runtime::model::material::Preset;
use crate::runtime::{
    Error, GenericKernel, HeadMotion, QuadratureRule, Result, Simulation, StrandGeometry,
};
use std::fmt::Write as _;
use std::time::Instant;

/// The fixed orders of the table.
pub const ORDERS: [usize; 10] = [2, 4, 6, 8, 12, 16, 24, 32, 48, 64];

/// Points per element of the generic kernel standing in for the closed form.
pub const STAND_IN_ORDER: usize = 256;

/// What `quadrature-table` runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TableOptions {
    /// Elements per strand N.
    pub elements: usize,
    /// Hair type (default fuzzy).
    pub preset: Preset,
    /// Time steps T.
    pub steps: usize,
    /// Strands S.
    pub strands: usize,
    /// Timed runs per rule; the fastest counts.
    pub repeats: usize,
}

impl Default for TableOptions {
    fn default() -> Self {
        TableOptions {
            elements: 5,
            preset: Preset::Fuzzy,
            steps: 30,
            strands: 4,
            repeats: 3,
        }
    }
}

/// One line of the table.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The rule (`12`, `adaptive (8 + ⌈1.5 W·l⌉ = 40..42)`, `closed form …`).
    pub label: String,
    /// Worst relative error of M, of the force, of the stiffness (0 for the reference).
    pub errors: [f64; 3],
    /// µs per strand-step, or why the timed simulation failed.
    pub micros: std::result::Result<f64, String>,
}

/// The measured table.
#[derive(Debug, Clone, PartialEq)]
pub struct QuadratureTable {
    /// The options run.
    pub options: TableOptions,
    /// What the errors and times are relative to.
    pub reference: String,
    /// True when no generated kernel exists for N and the 256-point generic kernel
    /// stands in for it.
    pub stand_in: bool,
    /// Smallest and largest element |d|·l over the states compared.
    pub wl: (f64, f64),
    /// Number of states the errors are taken over.
    pub states: usize,
    /// How times were measured.
    pub clock: Clock,
    /// The rows: fixed orders, adaptive, and last the reference.
    pub rows: Vec<Row>,
}

impl QuadratureTable {
    /// µs per strand-step of the reference (the last row).
    pub fn reference_micros(&self) -> Option<f64> {
        self.rows.last().and_then(|r| r.micros.clone().ok())
    }

    /// Markdown: a header paragraph and the table.
    pub fn render(&self) -> String {
        let o = &self.options;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "Quadrature order of the generic kernel, {} preset, N = {} (element W·l = {:.1}..{:.1} \
             over the states compared), {} strands x {} steps of 1/30 s with gravity, drag, \
             internal friction and head shake (2 Hz, ±30°).",
            o.preset.name(),
            o.elements,
            self.wl.0,
            self.wl.1,
            o.strands,
            o.steps
        );
        let _ = writeln!(s, "Reference: {}.", self.reference);
        let _ = writeln!(
            s,
            "Errors: max|generic - reference| / max|reference| over the entries, worst over the \
             {} states of the reference run. Time: best of {} runs of the {} steps, all \
             strands on one thread, by the {}, / ({} x {}) strand-steps.\n",
            self.states,
            o.repeats,
            o.steps,
            self.clock.describe(),
            o.strands,
            o.steps
        );
        let _ = writeln!(
            s,
            "| order | max rel. error M | max rel. error force | max rel. error stiffness | µs per strand-step | x closed form |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|");
        let reference = self.reference_micros();
        let last = self.rows.len().saturating_sub(1);
        for (i, r) in self.rows.iter().enumerate() {
            let errors = if i == last {
                ["-".to_string(), "-".to_string(), "-".to_string()]
            } else {
                r.errors.map(|e| format!("{e:.1e}"))
            };
            let (time, ratio) = match (&r.micros, reference) {
                (Ok(t), Some(rt)) => (format!("{t:.1}"), format!("{:.2}", t / rt)),
                (Ok(t), None) => (format!("{t:.1}"), "-".to_string()),
                (Err(e), _) => (format!("failed: {e}"), "-".to_string()),
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {time} | {ratio} |",
                r.label, errors[0], errors[1], errors[2]
            );
        }
        s
    }
}

fn check(o: &TableOptions) -> Result<()> {
    let mut problems = Vec::new();
    if !(1..=200).contains(&o.elements) {
        problems.push(crate::FieldError::new("--elements", "must be in 1..=200"));
    }
    if !(1..=100_000).contains(&o.steps) {
        problems.push(crate::FieldError::new("--steps", "must be in 1..=100000"));
    }
    if !(1..=10_000).contains(&o.strands) {
        problems.push(crate::FieldError::new("--strands", "must be in 1..=10000"));
    }
    if !(1..=100).contains(&o.repeats) {
        problems.push(crate::FieldError::new("--repeats", "must be in 1..=100"));
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(Error::Invalid(problems))
    }
}

/// The reference kernels: generated, or the generic stand-in.
#[derive(Clone, Copy)]
enum Reference<'a> {
    Generated(&'a dyn KernelFactory),
    StandIn,
}

impl Reference<'_> {
    fn kernel(self, g: &StrandGeometry) -> Result<Box<dyn StrandKernel>> {
        match self {
            Reference::Generated(f) => f.create(g).ok_or_else(|| {
                Error::Kernel(format!(
                    "the generated kernel factory lists N = {} but made no kernel",
                    g.elements()
                ))
            }),
            Reference::StandIn => Ok(Box::new(GenericKernel::new(
                g.clone(),
                QuadratureRule::Fixed(STAND_IN_ORDER),
            ))),
        }
    }
}

/// One state of one strand and the reference's terms there.
struct State {
    strand: usize,
    q: Vec<f64>,
    v: Vec<f64>,
    field: crate::runtime::kernels::kernel::BodyField,
    reference: StrandTerms,
}

/// How the times of the table are measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Clock {
    /// On-CPU time of the (single) stepping thread.
    ThreadCpu,
    /// Wall time (where the thread's CPU time is not available).
    Wall,
}

impl Clock {
    /// The clock of this platform.
    pub fn current() -> Clock {
        if crate::cpu_time::thread_seconds().is_some() {
            Clock::ThreadCpu
        } else {
            Clock::Wall
        }
    }
    pub(crate) fn describe(self) -> &'static str {
        match self {
            Clock::ThreadCpu => "on-CPU time of the stepping thread (clock_gettime CLOCK_THREAD_CPUTIME_ID, so other load on the machine is not counted)",
            Clock::Wall => "wall time",
        }
    }
}

/// Seconds of the fastest of `repeats` runs of `steps` steps of `setup`, all strands on
/// one thread, by `clock`.
fn time_steps(
    setup: &SimulationSetup,
    factory: Option<&dyn KernelFactory>,
    steps: usize,
    repeats: usize,
    clock: Clock,
) -> std::result::Result<f64, String> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| e.to_string())?;
    let now = move || match clock {
        Clock::ThreadCpu => crate::cpu_time::thread_seconds().unwrap_or(f64::NAN),
        Clock::Wall => START.with(|s| s.elapsed().as_secs_f64()),
    };
    pool.install(|| {
        let mut best = f64::INFINITY;
        for _ in 0..repeats {
            let mut sim = Simulation::new(setup.clone(), factory).map_err(|e| e.to_string())?;
            let start = now();
            for _ in 0..steps {
                sim.step().map_err(|e| e.to_string())?;
            }
            best = best.min(now() - start);
        }
        Ok(best)
    })
}

thread_local! {
    static START: Instant = Instant::now();
}

/// Measure the table. `factory` provides the generated kernels (pass
/// [`crate::kernel_factory()`]); without one for N the 256-point generic kernel stands in.
pub fn quadrature_table(
    o: &TableOptions,
    factory: Option<&dyn KernelFactory>,
) -> Result<QuadratureTable> {
    check(o)?;
    let generated = factory.filter(|f| f.available().contains(&o.elements));
    let reference = match generated {
        Some(f) => Reference::Generated(f),
        None => Reference::StandIn,
    };
    let bench_options = BenchOptions {
        elements: o.elements,
        strands: o.strands,
        steps: o.steps,
        kernels: if generated.is_some() {
            KernelChoice::Generated
        } else {
            KernelChoice::Generic
        },
        effects: EffectSet {
            head: true,
            ..EffectSet::default_bench()
        },
        preset: o.preset,
        quadrature: QuadratureRule::Fixed(STAND_IN_ORDER),
        ..BenchOptions::default()
    };
    let setup = crate::bench::setup(&bench_options)?;

    // The states of the reference run, each with its body field and reference terms.
    let effects = GlobalEffects {
        gravity: setup.environment.gravity,
        head_moves: setup.head != HeadMotion::Still,
    };
    let mut reference_kernels = setup
        .strands
        .iter()
        .map(|s| reference.kernel(&s.strand.geometry))
        .collect::<Result<Vec<_>>>()?;
    let mut sim = Simulation::new(setup.clone(), generated)?;
    let mut states = Vec::new();
    let mut wl = (f64::INFINITY, 0.0f64);
    for step in 0..o.steps {
        let head = setup.head.state(sim.time());
        for (i, kernel) in reference_kernels.iter_mut().enumerate() {
            let strand = sim.strand(i);
            let field = body_field(
                &effects,
                &head,
                strand.material.mass_per_length,
                strand.air_drag,
            );
            let (q, v) = (sim.q(i).to_vec(), sim.v(i).to_vec());
            for (e, l) in strand.geometry.lengths.iter().enumerate() {
                let x = l * (q[3 * e].hypot(q[3 * e + 1]).hypot(q[3 * e + 2]));
                wl = (wl.0.min(x), wl.1.max(x));
            }
            let mut terms = StrandTerms::new(q.len());
            kernel.evaluate(
                &EvalInput {
                    q: &q,
                    v: &v,
                    field,
                    terms: Terms::all(),
                },
                &mut terms,
            );
            states.push(State {
                strand: i,
                q,
                v,
                field,
                reference: terms,
            });
        }
        if step + 1 < o.steps {
            sim.step()?;
        }
    }

    let mut rows = Vec::new();
    let mut rules: Vec<(String, QuadratureRule)> = ORDERS
        .iter()
        .map(|&n| (n.to_string(), QuadratureRule::Fixed(n)))
        .collect();
    let adaptive = QuadratureRule::Adaptive;
    rules.push((
        format!(
            "adaptive (8 + ⌈1.5 W·l⌉ = {}..{})",
            adaptive.order(wl.0),
            adaptive.order(wl.1)
        ),
        adaptive,
    ));
    let strand_steps = (o.strands * o.steps) as f64;
    let clock = Clock::current();
    for (label, rule) in rules {
        let mut kernels: Vec<GenericKernel> = setup
            .strands
            .iter()
            .map(|s| GenericKernel::new(s.strand.geometry.clone(), rule))
            .collect();
        let mut worst = [0.0f64; 3];
        for st in &states {
            let mut terms = StrandTerms::new(st.q.len());
            kernels[st.strand].evaluate(
                &EvalInput {
                    q: &st.q,
                    v: &st.v,
                    field: st.field,
                    terms: Terms::all(),
                },
                &mut terms,
            );
            let mut dev = [Deviation::default(); 3];
            dev[0].mat(&terms.mass, &st.reference.mass);
            dev[1].slices(&terms.force, &st.reference.force);
            dev[2].mat(&terms.stiffness, &st.reference.stiffness);
            for k in 0..3 {
                worst[k] = worst[k].max(dev[k].relative());
            }
        }
        let mut timed = setup.clone();
        timed.config.kernels = KernelChoice::Generic;
        timed.config.quadrature = rule;
        let micros =
            time_steps(&timed, None, o.steps, o.repeats, clock).map(|s| 1e6 * s / strand_steps);
        rows.push(Row {
            label,
            errors: worst,
            micros,
        });
    }
    let micros =
        time_steps(&setup, generated, o.steps, o.repeats, clock).map(|s| 1e6 * s / strand_steps);
    let (label, description) = match generated {
        Some(_) => (
            format!("closed form (generated N = {})", o.elements),
            format!(
                "the generated closed-form kernel for N = {} (`{}`)",
                o.elements,
                reference_kernels[0].description()
            ),
        ),
        None => (
            format!("closed form: stand-in, generic {STAND_IN_ORDER} points"),
            format!(
                "STAND-IN: this build has no generated kernel for N = {}, so the generic kernel \
                 with {STAND_IN_ORDER} Gauss-Legendre points per element plays the closed form \
                 (errors below are against it; the time ratios are to it, not to a closed form)",
                o.elements
            ),
        ),
    };
    rows.push(Row {
        label,
        errors: [0.0; 3],
        micros,
    });
    Ok(QuadratureTable {
        options: *o,
        reference: description,
        stand_in: generated.is_none(),
        wl,
        states: states.len(),
        clock,
        rows,
    })
}
