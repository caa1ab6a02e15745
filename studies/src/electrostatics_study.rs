//! `superhelix electrostatics`: the experiments of Sobottka & Weber 2006 (section 4) on a
//! curly tress, and the multipole order against accuracy and time.
//!
//! Experiment 1: a curly tress (300 fibres of 30 cm over an elliptic cross-section, 25 °C,
//! ρ_P = 330/m, −7.7·10⁻⁴ statC/cm) uncharged; charged at RH 65 %; charged at RH 100 %;
//! charged without gravity; charged in one step against five logarithmic steps; and the
//! charged tress at several N to see which N suffices. Each case is a static scene solved
//! by [`Simulation::solve_charged_static`], with a picture (the run's preview) and
//! figures of its spread. Experiment 2: the field of the charged tress's particles by the
//! multipole method at p = 1 … 14 against the direct sum.

use crate::runtime::output::plan::prepare_out_dir;
use crate::runtime::{Error, FrameSource, Result, Simulation, SimulationSetup};
use crate::study_plot::{log_log_svg, Marker, Series, Style};
use crate::{kernel_factory, parse_scene, plan_output, run_planned, RunOptions};
use plotters::prelude::{RGBColor, SeriesLabelPosition};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;
use superhelix_fmm::{direct_sum, Fmm, FmmOptions, Softening};

/// Relative variation of the fibres' natural curvature in the main cases (per strand and
/// per element; see `curvature_variation`).
pub const VARIATION: f64 = 0.2;

/// The paper's mean field strength on the charged tress, V/m.
pub const PAPER_MEAN_FIELD: f64 = 13e3;

/// Settings of the experiments.
#[derive(Debug, Clone, PartialEq)]
pub struct ExperimentOptions {
    /// Fibres of the tress.
    pub fibres: usize,
    /// Elements per fibre of the main cases.
    pub elements: usize,
    /// The N compared for "which N suffices".
    pub element_counts: Vec<usize>,
    /// Orders of experiment 2.
    pub orders: Vec<usize>,
    /// Requested accuracy of the field in the equilibria.
    pub accuracy: f64,
}

impl Default for ExperimentOptions {
    fn default() -> Self {
        ExperimentOptions {
            fibres: 300,
            elements: 30,
            element_counts: vec![10, 20, 30, 60],
            orders: (1..=14).collect(),
            accuracy: 1e-6,
        }
    }
}

/// One case of experiment 1.
#[derive(Debug, Clone, PartialEq)]
pub struct TressCase {
    /// Short name (folder of its picture).
    pub name: String,
    /// What it is.
    pub description: String,
    /// Mean distance of the fibre tips from the tress axis, m.
    pub tip_spread: f64,
    /// Root-mean-square distance of every centreline point from the axis, m.
    pub rms_spread: f64,
    /// Mean height of the tips below the root plane, m (the sag).
    pub tip_depth: f64,
    /// Volume of the axis-aligned box around every centreline point, m³ (the space the
    /// tress takes).
    pub box_volume: f64,
    /// Mean |E| over the particles, V/m (0 uncharged).
    pub mean_field: f64,
    /// The same mean by the direct sum over every pair, V/m (a reference; `None` without
    /// charges, with a charged scalp, or beyond 20,000 particles).
    pub mean_field_direct: Option<f64>,
    /// Largest force on a particle, N.
    pub max_force: f64,
    /// Outer iterations of the charged solve, per charging step.
    pub iterations: Vec<usize>,
    /// Final residual of the outer iteration (relative generalized force).
    pub residual: f64,
    /// Seconds of the solve.
    pub seconds: f64,
    /// Tip positions (for comparing N).
    pub tips: Vec<[f64; 3]>,
}

/// One order of experiment 2.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrderPoint {
    /// Expansion order p.
    pub order: usize,
    /// Mean angle between the multipole and the direct field, rad.
    pub mean_direction_error: f64,
    /// Largest relative error of |E|.
    pub worst_magnitude_error: f64,
    /// Relative l2 error of the field over all particles.
    pub field_rel_l2: f64,
    /// Seconds (one thread).
    pub seconds: f64,
}

/// Everything the experiments measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Experiments {
    /// The settings.
    pub options: ExperimentOptions,
    /// Experiment 1.
    pub cases: Vec<TressCase>,
    /// "Which N": (N, tip spread, RMS tip distance to the finest N's tips, m).
    pub by_elements: Vec<(usize, f64, f64)>,
    /// Experiment 2.
    pub orders: Vec<OrderPoint>,
    /// Particles of experiment 2 and the direct sum's seconds (one thread).
    pub particles: usize,
    /// Seconds of the direct sum.
    pub direct_seconds: f64,
}

/// The scene text of a tress case.
pub fn tress_scene(
    fibres: usize,
    elements: usize,
    humidity: f64,
    gravity: bool,
    charged: Option<(usize, f64)>,
    variation: f64,
) -> String {
    let mut s = String::from("[simulation]\nmode = \"static\"\n\n[environment]\n");
    let _ = writeln!(s, "relative_humidity = {humidity:?}");
    if !gravity {
        s.push_str("gravity = \"none\"\n");
    }
    if let Some((steps, accuracy)) = charged {
        let _ = write!(
            s,
            "\n[electrostatics]\ncharging_steps = {steps}\naccuracy = {accuracy:e}\n"
        );
    }
    let _ = write!(
        s,
        "\n[output]\nformats = [\"json\", \"usda\", \"png\"]\n\n[[tresses]]\nname = \"tress\"\ncount = {fibres}\n\
         semi_axes = [0.01, 0.005]\ndirection = [0.0, 0.0, -1.0]\nnormal = [1.0, 0.0, 0.0]\nlength = 0.3\n\
         elements = {elements}\npreset = \"curly\"\ncurvature_variation = {variation:?}\nseed = 1\n"
    );
    s
}

/// A simulation already solved, as the output driver sees it (its static solve does
/// nothing more).
struct Solved<'a>(&'a mut Simulation);

impl FrameSource for Solved<'_> {
    fn time(&self) -> f64 {
        self.0.time()
    }
    fn strand_count(&self) -> usize {
        self.0.strand_count()
    }
    fn strand_name(&self, i: usize) -> &str {
        FrameSource::strand_name(&*self.0, i)
    }
    fn strand_group(&self, i: usize) -> &str {
        FrameSource::strand_group(&*self.0, i)
    }
    fn strand_radius(&self, i: usize) -> f64 {
        FrameSource::strand_radius(&*self.0, i)
    }
    fn q(&self, i: usize) -> &[f64] {
        self.0.q(i)
    }
    fn v(&self, i: usize) -> &[f64] {
        self.0.v(i)
    }
    fn centreline_world(&mut self, i: usize, samples_per_element: usize) -> Vec<[f64; 3]> {
        self.0.centreline_world(i, samples_per_element)
    }
    fn step(&mut self) -> Result<()> {
        self.0.step()
    }
    fn solve_static(&mut self) -> Result<()> {
        Ok(())
    }
}

/// Solve a tress scene and measure it; its picture and files go to `dir`.
fn run_case(
    name: &str,
    description: &str,
    scene: &str,
    dir: &Path,
) -> Result<(TressCase, Simulation, SimulationSetup)> {
    let setup = parse_scene(scene)?;
    let mut sim = Simulation::new(setup.clone(), kernel_factory())?;
    let start = Instant::now();
    let (iterations, residual) = if sim.electrostatics().is_some() {
        let r = sim.solve_charged_static()?;
        (
            r.stages.iter().map(|s| s.iterations).collect(),
            r.stages.last().map_or(0.0, |s| s.residual),
        )
    } else {
        sim.solve_static()?;
        (Vec::new(), 0.0)
    };
    let seconds = start.elapsed().as_secs_f64();
    let (mean_field, max_force) = sim
        .electrostatics()
        .map_or((0.0, 0.0), |e| (e.last().mean_field, e.last().max_force));
    let mean_field_direct = sim
        .electrostatics()
        .filter(|e| e.last().particles <= 20_000)
        .and_then(|e| e.direct_mean_field());
    let mut tips = Vec::new();
    let (mut tip_r, mut depth, mut rms, mut count) = (0.0, 0.0, 0.0, 0usize);
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for i in 0..sim.strand_count() {
        let line = sim.centreline_world(i, 4);
        for p in &line {
            rms += p[0] * p[0] + p[1] * p[1];
            count += 1;
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        if let Some(t) = line.last() {
            tip_r += (t[0] * t[0] + t[1] * t[1]).sqrt();
            depth += -t[2];
            tips.push(*t);
        }
    }
    let n = tips.len().max(1) as f64;
    let case = TressCase {
        name: name.into(),
        description: description.into(),
        tip_spread: tip_r / n,
        rms_spread: (rms / count.max(1) as f64).sqrt(),
        tip_depth: depth / n,
        box_volume: (0..3).map(|a| (hi[a] - lo[a]).max(0.0)).product(),
        mean_field,
        mean_field_direct,
        max_force,
        iterations,
        residual,
        seconds,
        tips,
    };
    let out = dir.join(name);
    prepare_out_dir(&out)?;
    std::fs::write(out.join("scene.toml"), scene).map_err(|source| Error::Io {
        path: out.join("scene.toml").display().to_string(),
        source,
    })?;
    let plan = plan_output(&setup, &out, &RunOptions::default());
    let never = AtomicBool::new(false);
    let report = run_planned(&setup, &mut Solved(&mut sim), &plan, &never, |_, _| {})?;
    if let Some(e) = report.products_error {
        return Err(e);
    }
    Ok((case, sim, setup))
}

/// Experiment 2 on the particles of a solved charged simulation.
fn order_study(sim: &Simulation, orders: &[usize]) -> Result<(Vec<OrderPoint>, usize, f64)> {
    let Some(e) = sim.electrostatics() else {
        return Err(Error::invalid(
            "electrostatics",
            "experiment 2 needs the charged tress",
        ));
    };
    let (points, _) = e.particles();
    let charges: Vec<f64> = e
        .tracers()
        .charge
        .iter()
        .map(|q| q * e.charge_scale())
        .collect();
    let softening = Softening {
        radius: e.config().softening,
    };
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| Error::invalid("threads", e.to_string()))?;
    let start = Instant::now();
    let (_, reference) = one.install(|| direct_sum(points, &charges, softening));
    let direct_seconds = start.elapsed().as_secs_f64();
    let mut out = Vec::new();
    for &p in orders {
        let options = FmmOptions {
            order: p,
            theta: 0.5,
            leaf_size: 64,
            softening,
        };
        let mut fmm = Fmm::new(options).map_err(|e| Error::invalid("order", e.to_string()))?;
        let start = Instant::now();
        let (field, _) = one
            .install(|| fmm.evaluate(points, &charges))
            .map_err(|e| Error::invalid("electrostatics", e.to_string()))?;
        let seconds = start.elapsed().as_secs_f64();
        let (mut angle, mut worst, mut num, mut den) = (0.0, 0.0f64, 0.0, 0.0);
        for (a, b) in field.field.iter().zip(&reference) {
            let (na, nb) = (norm(a), norm(b));
            let cos = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (na * nb);
            angle += cos.clamp(-1.0, 1.0).acos();
            worst = worst.max((na - nb).abs() / nb);
            num += (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2);
            den += nb * nb;
        }
        out.push(OrderPoint {
            order: p,
            mean_direction_error: angle / reference.len().max(1) as f64,
            worst_magnitude_error: worst,
            field_rel_l2: (num / den).sqrt(),
            seconds,
        });
    }
    Ok((out, points.len(), direct_seconds))
}

fn norm(v: &[f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Run experiments 1 and 2, writing each case's files into `dir/<case>/`.
pub fn run_experiments(
    options: &ExperimentOptions,
    dir: &Path,
    mut progress: impl FnMut(&str),
) -> Result<Experiments> {
    let (f, n, acc) = (options.fibres, options.elements, options.accuracy);
    let specs: Vec<(&str, &str, String)> = vec![
        (
            "uncharged",
            "uncharged, RH 65 %",
            tress_scene(f, n, 65.0, true, None, VARIATION),
        ),
        (
            "charged_rh65",
            "charged, RH 65 %",
            tress_scene(f, n, 65.0, true, Some((1, acc)), VARIATION),
        ),
        (
            "charged_rh100",
            "charged, RH 100 %",
            tress_scene(f, n, 100.0, true, Some((1, acc)), VARIATION),
        ),
        (
            "charged_no_gravity",
            "charged, RH 65 %, no gravity",
            tress_scene(f, n, 65.0, false, Some((1, acc)), VARIATION),
        ),
        (
            "charged_log5",
            "charged in 5 logarithmic steps, RH 65 %",
            tress_scene(f, n, 65.0, true, Some((5, acc)), VARIATION),
        ),
    ];
    let mut cases = Vec::new();
    let mut orders = Vec::new();
    let (mut particles, mut direct_seconds) = (0, 0.0);
    for (name, description, scene) in specs {
        progress(name);
        let (case, sim, _) = run_case(name, description, &scene, dir)?;
        if name == "charged_rh65" && !options.orders.is_empty() {
            progress("orders");
            (orders, particles, direct_seconds) = order_study(&sim, &options.orders)?;
        }
        cases.push(case);
    }
    let mut by_n: Vec<(usize, TressCase)> = Vec::new();
    for &elements in &options.element_counts {
        let name = format!("charged_rh65_n{elements}");
        progress(&name);
        // Without variation: per-element variation would give each N another natural shape.
        let scene = tress_scene(f, elements, 65.0, true, Some((1, acc)), 0.0);
        let (case, _, _) = run_case(
            &name,
            &format!("charged, RH 65 %, N = {elements}"),
            &scene,
            dir,
        )?;
        by_n.push((elements, case));
    }
    let finest = by_n
        .iter()
        .max_by_key(|(n, _)| *n)
        .map(|(_, c)| c.tips.clone())
        .unwrap_or_default();
    let by_elements = by_n
        .iter()
        .map(|(n, c)| {
            let d: f64 = c
                .tips
                .iter()
                .zip(&finest)
                .map(|(a, b)| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2))
                .sum();
            (*n, c.tip_spread, (d / c.tips.len().max(1) as f64).sqrt())
        })
        .collect();
    Ok(Experiments {
        options: options.clone(),
        cases,
        by_elements,
        orders,
        particles,
        direct_seconds,
    })
}

/// The plot of experiment 2: error against time, one point per order.
pub fn order_plot(e: &Experiments) -> Result<String> {
    let series = vec![
        Series {
            name: "mean direction error (rad)".into(),
            style: Style {
                colour: RGBColor(31, 119, 180),
                marker: Marker::Circle,
            },
            points: e
                .orders
                .iter()
                .map(|o| (o.seconds, o.mean_direction_error.max(1e-16)))
                .collect(),
            line: true,
        },
        Series {
            name: "worst relative |E| error".into(),
            style: Style {
                colour: RGBColor(214, 39, 40),
                marker: Marker::Triangle,
            },
            points: e
                .orders
                .iter()
                .map(|o| (o.seconds, o.worst_magnitude_error.max(1e-16)))
                .collect(),
            line: true,
        },
    ];
    log_log_svg(
        &format!(
            "Multipole order p = {}…{} on the charged tress ({} particles)",
            e.orders.first().map_or(0, |o| o.order),
            e.orders.last().map_or(0, |o| o.order),
            e.particles
        ),
        "seconds (one thread)",
        "error against the direct sum",
        &series,
        None,
        SeriesLabelPosition::UpperRight,
    )
}

/// `report.md` of the experiments.
pub fn render_report(e: &Experiments) -> String {
    let mut s = String::new();
    let o = &e.options;
    let _ = writeln!(s, "# Static electricity on a curly tress\n");
    let _ = writeln!(
        s,
        "{} curly fibres of 30 cm, roots over an ellipse of semi-axes 1 cm × 0.5 cm, hanging down; N = {} \
         unless stated; 25 °C; ρ_P = 330 particles/m; charge −7.7·10⁻⁴ statC/cm = {:.3e} C/m; field accuracy {:e}. \
         Static equilibria (Newton per fibre, Coulomb forces refreshed in an outer iteration).\n",
        o.fibres,
        o.elements,
        crate::runtime::forces::electrostatics::PAPER_CHARGE_PER_LENGTH,
        o.accuracy
    );
    let _ = writeln!(s, "## Experiment 1: the tress\n");
    let _ = writeln!(s, "| case | tip distance from axis (mm) | RMS distance from axis (mm) | tip depth (cm) | box volume (cm³) | mean field (kV/m) | largest force (N) | outer iterations | residual | seconds |");
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
    for c in &e.cases {
        let _ = writeln!(
            s,
            "| {} | {:.2} | {:.2} | {:.2} | {:.1} | {:.2} | {:.2e} | {:?} | {:.1e} | {:.1} |",
            c.description,
            c.tip_spread * 1e3,
            c.rms_spread * 1e3,
            c.tip_depth * 1e2,
            c.box_volume * 1e6,
            c.mean_field / 1e3,
            c.max_force,
            c.iterations,
            c.residual,
            c.seconds
        );
    }
    if let Some(c) = e.cases.iter().find(|c| c.name == "charged_rh65") {
        let _ = writeln!(
            s,
            "\nMean field strength E = F/q over the particles of the charged tress (RH 65 %): **{:.1} kV/m**, against the \
             paper's 13 kV/m (ratio {:.2}).\n",
            c.mean_field / 1e3,
            c.mean_field / PAPER_MEAN_FIELD
        );
    }
    for c in &e.cases {
        let _ = writeln!(
            s,
            "### {}\n\n![{}]({}/preview.png)\n",
            c.description, c.description, c.name
        );
    }
    let _ = writeln!(s, "## Which N suffices\n");
    let _ = writeln!(
        s,
        "| N | tip distance from axis (mm) | RMS distance of the tips from the finest N's (mm) |"
    );
    let _ = writeln!(s, "|---|---|---|");
    for (n, spread, d) in &e.by_elements {
        let _ = writeln!(s, "| {n} | {:.3} | {:.3} |", spread * 1e3, d * 1e3);
    }
    if !e.orders.is_empty() {
        let _ = writeln!(
            s,
            "\n## Experiment 2: multipole order against accuracy and time\n"
        );
        let _ = writeln!(
            s,
            "The field at the {} particles of the charged tress (RH 65 %) by the multipole method (θ = 0.5, leaves of 64) \
             against the direct sum ({:.2} s), one thread each.\n\n![order](orders.svg)\n",
            e.particles, e.direct_seconds
        );
        let _ = writeln!(s, "| p | mean direction error (rad) | worst relative \\|E\\| error | relative l2 error | seconds |");
        let _ = writeln!(s, "|---|---|---|---|---|");
        for p in &e.orders {
            let _ = writeln!(
                s,
                "| {} | {:.2e} | {:.2e} | {:.2e} | {:.3} |",
                p.order, p.mean_direction_error, p.worst_magnitude_error, p.field_rel_l2, p.seconds
            );
        }
    }
    s
}

/// Write `report.md` and `orders.svg` into `dir`.
pub fn write_report(e: &Experiments, dir: &Path) -> Result<Vec<PathBuf>> {
    let io = |p: &Path| {
        let p = p.display().to_string();
        move |source| Error::Io { path: p, source }
    };
    let mut files = Vec::new();
    if !e.orders.is_empty() {
        let svg = dir.join("orders.svg");
        std::fs::write(&svg, order_plot(e)?).map_err(io(&svg))?;
        files.push(svg);
    }
    let md = dir.join("report.md");
    std::fs::write(&md, render_report(e)).map_err(io(&md))?;
    files.push(md);
    Ok(files)
}

/// The scene of experiment 3: `fibres` smooth fibres of 25 cm on the upper half of an
/// ellipsoidal head (radii 7.5 × 9.5 × 11 cm), hair and scalp charged.
pub fn half_scalp_scene(fibres: usize, elements: usize, accuracy: f64) -> String {
    format!(
        "[simulation]\nmode = \"static\"\n\n[environment]\nrelative_humidity = 65.0\n\n\
         [electrostatics]\naccuracy = {accuracy:e}\ntolerance = 1e-5\nscalp_body = \"head\"\nscalp_charge = -3e-10\n\n\
         [output]\nformats = [\"npy\", \"png\"]\nsamples_per_element = 2\n\n\
         [[bodies]]\nname = \"head\"\nshape = \"ellipsoid\"\ncenter = [0.0, 0.0, 0.0]\nradii = [0.075, 0.095, 0.11]\n\n\
         [[scalp_hair]]\nname = \"hair\"\nbody = \"head\"\ncount = {fibres}\naxis = [0.0, 0.0, 1.0]\nmax_angle_deg = 90\n\
         length = 0.25\nelements = {elements}\npreset = \"smooth\"\ncomb = [0.0, 0.0, -1.0]\n"
    )
}

/// What experiment 3 measured.
#[derive(Debug, Clone, PartialEq)]
pub struct HalfScalp {
    /// The case (spread, field, iterations, seconds of the charged solve).
    pub case: TressCase,
    /// Particles.
    pub particles: usize,
    /// Seconds of building the scene and the simulation.
    pub setup_seconds: f64,
}

/// Run experiment 3 into `dir` (its scene, `frames.npy`, the picture, `report.md`).
pub fn run_half_scalp(
    fibres: usize,
    elements: usize,
    accuracy: f64,
    dir: &Path,
) -> Result<HalfScalp> {
    let start = Instant::now();
    let scene = half_scalp_scene(fibres, elements, accuracy);
    let name = "half_scalp";
    let (case, sim, _) = run_case(name, "half scalp, hair and scalp charged", &scene, dir)?;
    let particles = sim.electrostatics().map_or(0, |e| e.tracers().len());
    let total = start.elapsed().as_secs_f64();
    let h = HalfScalp {
        setup_seconds: total - case.seconds,
        case,
        particles,
    };
    let mut s = String::new();
    let c = &h.case;
    let _ = writeln!(s, "# Half scalp, charged\n");
    let _ = writeln!(
        s,
        "{fibres} smooth fibres of 25 cm, N = {elements}, on the upper half of an ellipsoidal head (7.5 × 9.5 × 11 cm), \
         RH 65 %; {} tracer particles (ρ_P = 330/m) charged at −7.7·10⁻⁴ statC/cm; scalp charge −3·10⁻¹⁰ C (eq. 8); \
         field accuracy {accuracy:e}; the outer iteration ends at a relative residual of 1e-5.\n",
        h.particles
    );
    let _ = writeln!(s, "| quantity | value |\n|---|---|");
    let _ = writeln!(
        s,
        "| charged static solve | {:.1} s ({:?} outer iterations, residual {:.1e}) |",
        c.seconds, c.iterations, c.residual
    );
    let _ = writeln!(
        s,
        "| building the scene and the simulation | {:.1} s |",
        h.setup_seconds
    );
    let _ = writeln!(
        s,
        "| mean field over the particles | {:.2} kV/m |",
        c.mean_field / 1e3
    );
    let _ = writeln!(s, "| largest force on a particle | {:.2e} N |", c.max_force);
    let _ = writeln!(
        s,
        "| mean tip depth below the head's centre | {:.2} cm |",
        c.tip_depth * 1e2
    );
    let _ = writeln!(s, "\n![half scalp]({name}/preview.png)");
    let md = dir.join("half_scalp.md");
    std::fs::write(&md, s).map_err(|source| Error::Io {
        path: md.display().to_string(),
        source,
    })?;
    Ok(h)
}
