//! `superhelix render FRAMES --out DIR`: the preview pictures re-rendered from written frames.

use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;
use superhelix_studies::render::{render, RenderRequest};
use superhelix_studies::Error;

/// Arguments of `render`.
#[derive(Args)]
pub struct RenderArgs {
    /// frames.npy, frames.json, or the run's output directory.
    frames: PathBuf,
    /// Output directory.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Picture width, pixels (64..=8192).
    #[arg(long, default_value_t = 1200)]
    width: u32,
    /// Picture height, pixels (64..=8192).
    #[arg(long, default_value_t = 600)]
    height: u32,
    /// Panels from left to right, a comma list of front, side, top.
    #[arg(long, default_value = "front,side")]
    views: String,
    /// Frame shown in preview.png (default: the last one).
    #[arg(long, value_name = "K")]
    frame: Option<usize>,
    /// Write preview.gif (the default).
    #[arg(long, overrides_with = "no_gif")]
    gif: bool,
    /// Do not write preview.gif.
    #[arg(long, overrides_with = "gif")]
    no_gif: bool,
    /// The scene the frames were simulated from: draw its bodies (placed by its head
    /// motion at each frame's time) and its [render] strands.
    #[arg(long, value_name = "SCENE")]
    scene: Option<PathBuf>,
}

/// Run `render`.
pub fn run(args: RenderArgs) -> Result<ExitCode, Error> {
    let files = render(&RenderRequest {
        frames: args.frames,
        out: args.out,
        width: args.width,
        height: args.height,
        views: args.views,
        frame: args.frame,
        gif: args.gif || !args.no_gif,
        scene: args.scene,
    })?;
    for f in &files {
        println!("wrote {}", f.display());
    }
    Ok(ExitCode::SUCCESS)
}
