//! `superhelix render FRAMES --out DIR [--scene SCENE]`: the preview pictures re-rendered
//! from frames a run wrote, with other camera settings (and, with the scene, its bodies
//! and render strands).

use std::path::{Path, PathBuf};
use superhelix_runtime::output::frames::FrameStore;
use superhelix_runtime::output::json::{JsonFrameStore, PARTIAL_SUFFIX};
use superhelix_runtime::output::npy::{NpyFrameStore, NPY_FILE};
use superhelix_runtime::output::plan::Formats;
use superhelix_runtime::output::preview::{PreviewOptions, View};
use superhelix_runtime::output::products::write_products;
use superhelix_runtime::output::scenery::Scenery;
use superhelix_runtime::{parse_scene_at, Error, Result};

/// What `render` is asked to do.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderRequest {
    /// `frames.npy`, `frames.json` or the directory holding one of them.
    pub frames: PathBuf,
    /// Output directory.
    pub out: PathBuf,
    /// Picture width, pixels.
    pub width: u32,
    /// Picture height, pixels.
    pub height: u32,
    /// Comma list of views: front, side, top.
    pub views: String,
    /// Frame of `preview.png` (default: the last one).
    pub frame: Option<usize>,
    /// Also write `preview.gif`.
    pub gif: bool,
    /// The scene the frames were simulated from: its bodies are drawn under the strands,
    /// placed by its head motion at each frame's time, and its `[render]` strands with
    /// them (`None`: the strands alone).
    pub scene: Option<PathBuf>,
}

/// Name of the JSON frames file a run writes.
const JSON_FILE: &str = "frames.json";

/// Open the frames at `path`: a `.npy` file, a `.json` file (or the
/// `frames.json.partial` a killed run leaves: its complete frames), or a directory
/// holding `frames.npy` (preferred), `frames.json` or `frames.json.partial`.
pub fn open_frames(path: &Path) -> Result<Box<dyn FrameStore>> {
    let partial = format!("{JSON_FILE}{PARTIAL_SUFFIX}");
    let file = if path.is_dir() {
        if path.join(NPY_FILE).is_file() {
            path.join(NPY_FILE)
        } else if path.join(JSON_FILE).is_file() {
            path.join(JSON_FILE)
        } else if path.join(&partial).is_file() {
            path.join(&partial)
        } else {
            return Err(Error::invalid(
                "FRAMES",
                format!(
                    "{} holds neither {NPY_FILE} nor {JSON_FILE}",
                    path.display()
                ),
            ));
        }
    } else if path.is_file() {
        path.to_path_buf()
    } else {
        return Err(Error::invalid(
            "FRAMES",
            format!(
                "{} does not exist: give a frames.npy, a frames.json or their directory",
                path.display()
            ),
        ));
    };
    let name = file.file_name().and_then(|n| n.to_str()).unwrap_or("");
    let extension = if name.ends_with(&format!(".json{PARTIAL_SUFFIX}")) {
        Some("json")
    } else {
        file.extension().and_then(|e| e.to_str())
    };
    match extension {
        Some("npy") => Ok(Box::new(NpyFrameStore::open(&file)?)),
        Some("json") => Ok(Box::new(JsonFrameStore::open(&file)?)),
        _ => Err(Error::invalid(
            "FRAMES",
            format!("{}: expected a .npy or .json frames file", file.display()),
        )),
    }
}

/// The camera settings of `request`; errors name the option (`--width`, `--views`, ...).
pub fn preview_options(request: &RenderRequest) -> Result<PreviewOptions> {
    let views = View::parse_list(&request.views).map_err(|m| Error::invalid("--views", m))?;
    let options = PreviewOptions {
        width: request.width,
        height: request.height,
        views,
        frame: request.frame,
        ..PreviewOptions::default()
    };
    options.check("--")?;
    Ok(options)
}

/// Render `preview.png` (frame `--frame`, default the last), `preview_first.png` and, with
/// `gif`, `preview.gif` into `out`. Returns the files written.
pub fn render(request: &RenderRequest) -> Result<Vec<PathBuf>> {
    let options = preview_options(request)?;
    let mut store = open_frames(&request.frames)?;
    let count = store.frame_count();
    if count == 0 {
        return Err(Error::invalid(
            "FRAMES",
            format!("{} holds no frame", request.frames.display()),
        ));
    }
    if let Some(k) = request.frame.filter(|&k| k >= count) {
        return Err(Error::invalid(
            "--frame",
            format!(
                "{k} is out of range: {} holds frames 0..={}",
                request.frames.display(),
                count - 1
            ),
        ));
    }
    let formats = Formats {
        json: false,
        npy: false,
        usda: false,
        png: true,
        gif: request.gif,
        obj: false,
    };
    // frames alone carry no scene: the bodies and render strands come from --scene
    let scenery = match &request.scene {
        None => Scenery::default(),
        Some(path) => {
            let text = crate::runtime::input::read_text_bounded(
                path,
                crate::runtime::input::TEXT_FILE_LIMIT,
                "scene file",
            )
            .map_err(|e| Error::invalid("--scene", e))?;
            let dir = path.parent().unwrap_or(Path::new("."));
            let setup = parse_scene_at(&text, dir)?;
            let strands = store.layout().strands.len();
            if setup.strands.len() != strands {
                return Err(Error::invalid(
                    "--scene",
                    format!(
                        "{} has {} strands, the frames {strands}: not the scene they were simulated from",
                        path.display(),
                        setup.strands.len()
                    ),
                ));
            }
            Scenery::from_setup(&setup)?
        }
    };
    write_products(store.as_mut(), &formats, &request.out, &options, &scenery)
}
