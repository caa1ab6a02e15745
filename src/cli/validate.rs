//! `superhelix validate SCENE`: every problem of a scene, on stderr, or its size and the
//! output it would write.

use super::common::{end_phase, phase, read_scene, scene_dir, RunChoices};
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use superhelix_studies::Error;

/// Arguments of `validate`: the scene and the options of `run` that change what it runs
/// or writes, checked as `run` checks them.
#[derive(Args)]
pub struct ValidateArgs {
    /// Scene file (TOML).
    scene: PathBuf,
    /// As `run`'s: --format, --allow-large-output, --tolerance, --part.
    #[command(flatten)]
    choices: RunChoices,
}

/// Run `validate`.
pub fn run(args: ValidateArgs) -> Result<ExitCode, Error> {
    let path = &args.scene;
    let text = read_scene(path)?;
    let options = args.choices.run_options()?;
    let checking = phase("reading the scene and building its simulation");
    let checked = superhelix_studies::check_scene_reporting(&text, scene_dir(path));
    end_phase(checking);
    match checked {
        Ok((mut setup, grooms)) => {
            // run's options, refused as run refuses them
            superhelix_studies::apply_tolerance(&mut setup, args.choices.tolerance)?;
            args.choices.take_part(&mut setup)?;
            if args.choices.tolerance.is_some() || args.choices.part.is_some() {
                superhelix_studies::check_setup(&setup)?;
            }
            report_valid(&setup, &grooms, &options)
        }
        Err(problems) => {
            for p in &problems {
                eprintln!("{p}");
            }
            eprintln!("{}: {} problem(s)", path.display(), problems.len());
            Ok(ExitCode::FAILURE)
        }
    }
}

/// The counts, what the grooms report (fit errors, root spacing, sag-free change) and the
/// output plan of a valid scene; refused when the plan is too large.
fn report_valid(
    setup: &superhelix_studies::SimulationSetup,
    grooms: &[superhelix_studies::runtime::groom::GroomReport],
    options: &superhelix_studies::RunOptions,
) -> Result<ExitCode, Error> {
    let strands = setup.strands.len();
    let steps = superhelix_studies::runtime::scene::step_count(setup);
    let plural = if strands == 1 { "" } else { "s" };
    println!("ok: {strands} strand{plural}, {steps} steps");
    for groom in grooms {
        println!("{groom}");
    }
    println!("{}", engine_line(setup));
    if let Some(note) = superhelix_studies::part::hair_hair_note(setup) {
        println!("{note}");
    }
    let (engine, _) = superhelix_studies::runtime::engine_for(setup);
    let usd = options
        .formats
        .or(setup.output.formats)
        .unwrap_or(superhelix_studies::Formats::DEFAULT)
        .usda;
    println!(
        "{}",
        superhelix_studies::runtime::memory_plan::estimate_with(setup, engine, usd)
    );
    let plan = superhelix_studies::plan_output(setup, Path::new("out"), options);
    println!("{plan}");
    if let Some(note) = &plan.note {
        println!("{note}");
    }
    plan.check_limit()?;
    Ok(ExitCode::SUCCESS)
}

/// The engine `run` will step the scene with, what it keeps per strand, and (under
/// `engine = "auto"`) why the runtime engine when it is that.
fn engine_line(setup: &superhelix_studies::SimulationSetup) -> String {
    use superhelix_studies::runtime::config::Engine;
    let (engine, reason) = superhelix_studies::runtime::engine_for(setup);
    match engine {
        Engine::Embedded => {
            // (N, whether the root is free): a free root's group keeps 3N + 3 coordinates
            let mut sizes: Vec<(usize, bool)> = setup
                .strands
                .iter()
                .map(|s| {
                    (
                        s.strand.geometry.elements(),
                        s.strand.ends.root
                            == superhelix_studies::runtime::model::ends::RootEnd::Free,
                    )
                })
                .collect();
            sizes.sort_unstable();
            sizes.dedup();
            let kept: Vec<String> = sizes
                .iter()
                .filter_map(|&(n, free)| {
                    use superhelix_studies::runtime::solver::embedded::{
                        floating_group_for, group_for,
                    };
                    let group = if free {
                        floating_group_for(n)
                    } else {
                        group_for(n)
                    };
                    group.map(|g| {
                        format!(
                            "{} B per strand at N = {n}{}",
                            g.strand_bytes(),
                            if free { " with a free root" } else { "" }
                        )
                    })
                })
                .collect();
            format!(
                "engine: embedded (the fixed-N step; {}, and one workspace per thread)",
                kept.join(", ")
            )
        }
        _ => match reason {
            Some(why) => format!(
                "engine: runtime (dense 3N x 3N matrices and factorisations per strand), not \
                 the embedded engine: {why}"
            ),
            None => {
                "engine: runtime (dense 3N x 3N matrices and factorisations per strand)".to_string()
            }
        },
    }
}
