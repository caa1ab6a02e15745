//! `superhelix coulomb-scaling`: the cost of the multipole method against the number of
//! particles (hair-like sets, 10⁴ … 4·10⁶), and the direct sum's rate in pair
//! interactions per second, as a table and a log–log plot.

use crate::study_plot::{log_log_svg, Marker, Series, Style};
use crate::{Error, Result};
use plotters::prelude::{RGBColor, SeriesLabelPosition};
use std::fmt::Write as _;
use std::time::Instant;
use superhelix_fmm::samples::curly_fibres;
use superhelix_fmm::{direct_sum, Fmm, FmmOptions, FmmStats, Softening};

/// One size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScalingPoint {
    /// Particles.
    pub particles: usize,
    /// Seconds of one evaluation (potential and field).
    pub seconds: f64,
    /// The tree and its passes.
    pub stats: FmmStats,
}

/// What `coulomb-scaling` measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Scaling {
    /// Requested accuracy.
    pub eps: f64,
    /// Options it gave.
    pub options: FmmOptions,
    /// Worker threads.
    pub threads: usize,
    /// Each size.
    pub points: Vec<ScalingPoint>,
    /// Direct sum: particles, seconds, pair interactions per second per thread.
    pub direct: (usize, f64, f64),
}

/// Measure sizes `sizes` (particles; hair-like sets of fibres of 100) at `eps` on the
/// current rayon pool, and the direct sum on `direct_particles`.
pub fn measure(sizes: &[usize], eps: f64, direct_particles: usize) -> Result<Scaling> {
    let options =
        FmmOptions::for_accuracy(eps).map_err(|e| Error::invalid("--eps", e.to_string()))?;
    let mut fmm = Fmm::new(options).map_err(|e| Error::invalid("--eps", e.to_string()))?;
    let mut points = Vec::new();
    for &n in sizes {
        let (p, q) = curly_fibres(n.div_ceil(100), 100, 1);
        let start = Instant::now();
        let (_, stats) = fmm
            .evaluate(&p, &q)
            .map_err(|e| Error::invalid("particles", e.to_string()))?;
        points.push(ScalingPoint {
            particles: p.len(),
            seconds: start.elapsed().as_secs_f64(),
            stats,
        });
    }
    let (p, q) = curly_fibres(direct_particles.div_ceil(100), 100, 2);
    let start = Instant::now();
    let _ = direct_sum(&p, &q, Softening::NONE);
    let seconds = start.elapsed().as_secs_f64();
    let threads = rayon::current_num_threads();
    let rate = (p.len() as f64).powi(2) / seconds / threads as f64;
    Ok(Scaling {
        eps,
        options,
        threads,
        points,
        direct: (p.len(), seconds, rate),
    })
}

/// The table, as Markdown.
pub fn render(s: &Scaling) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "eps = {:e} (p = {}, θ = {}, leaves of {}), {} thread(s); hair-like particles (curly fibres of 100)\n",
        s.eps, s.options.order, s.options.theta, s.options.leaf_size, s.threads
    );
    let _ = writeln!(
        t,
        "| particles | seconds | µs per particle | boxes | M2L | direct pairs |"
    );
    let _ = writeln!(t, "|---|---|---|---|---|---|");
    for p in &s.points {
        let _ = writeln!(
            t,
            "| {} | {:.3} | {:.2} | {} | {} | {:.3e} |",
            p.particles,
            p.seconds,
            p.seconds / p.particles as f64 * 1e6,
            p.stats.nodes,
            p.stats.m2l,
            p.stats.p2p_interactions as f64
        );
    }
    let _ = writeln!(
        t,
        "\nDirect sum of {} particles: {:.3} s, {:.3e} pair interactions per second per thread.",
        s.direct.0, s.direct.1, s.direct.2
    );
    t
}

/// The log–log plot of seconds against particles, with the linear slope through the first point.
pub fn plot(s: &Scaling) -> Result<String> {
    let series = vec![Series {
        name: format!("multipole method, eps = {:e}", s.eps),
        style: Style {
            colour: RGBColor(31, 119, 180),
            marker: Marker::Circle,
        },
        points: s
            .points
            .iter()
            .map(|p| (p.particles as f64, p.seconds))
            .collect(),
        line: true,
    }];
    let linear = s.points.first().map(|f| {
        s.points
            .iter()
            .map(|p| {
                (
                    p.particles as f64,
                    f.seconds * p.particles as f64 / f.particles as f64,
                )
            })
            .collect()
    });
    log_log_svg(
        &format!("Cost against particles ({} thread(s))", s.threads),
        "particles",
        "seconds per evaluation",
        &series,
        linear.map(|l| ("linear", l)),
        SeriesLabelPosition::UpperLeft,
    )
}
