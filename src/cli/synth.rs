//! `uvms synth [--scene bottle|sediment] [--seed N] [--config F] --out DIR`: a synthetic stereo
//! scan with its ground truth.
//!
//! Writes under `--out`: `scan.ply` (camera frame, colours), `truth.json`, `scene_mesh.ply` (the
//! true surfaces in the scan frame), `reference.ply` (the reference model in its own frame; bottle
//! scene), `config.toml` (the resolved configuration: running it again gives the same bytes) and
//! `summary.json`.

use super::{Ctx, Report};
use crate::config;
use crate::error::{Error, Result};
use crate::io::ply;
use crate::output::OutDir;
use crate::synth::{SceneKind, SynthConfig, synthesize};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `uvms synth`.
#[derive(Debug, clap::Args)]
pub struct SynthArgs {
    /// The scene (overrides `scene` in the configuration).
    #[arg(long, value_enum)]
    pub scene: Option<SceneKind>,
    /// Seed of every random choice (overrides `seed` in the configuration).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Configuration file (TOML); defaults for every key left out.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `uvms synth`.
///
/// # Errors
/// [`crate::Error::Input`] for a bad configuration (naming the key) or output folder;
/// [`crate::Error::Failed`] if a file cannot be written.
pub fn run(args: &SynthArgs, _ctx: &Ctx) -> Result<Report> {
    let mut cfg: SynthConfig = config::load(args.config.as_deref())?;
    if let Some(scene) = args.scene {
        cfg.scene = scene;
    }
    if let Some(seed) = args.seed {
        cfg.seed = seed;
    }
    // The synthesis names a bad key `config KEY`: here the file is known.
    let in_file = |e: Error| match (e, &args.config) {
        (Error::Input { what, reason }, Some(file)) if what.starts_with("config ") => Error::Input {
            what: format!("{}: {}", file.display(), &what["config ".len()..]),
            reason,
        },
        (e, _) => e,
    };
    cfg.validate().map_err(in_file)?;
    let inputs: Vec<&std::path::Path> = args
        .config
        .iter()
        .chain(&cfg.object.reference)
        .map(|p| p.as_path())
        .collect();
    let out = OutDir::create(
        &args.out,
        &inputs,
        &["scan.ply", "scene_mesh.ply", "reference.ply", "truth.json"],
    )?;
    let started = std::time::Instant::now();
    let s = synthesize(&cfg).map_err(in_file)?;
    let elapsed = started.elapsed().as_secs_f64();

    out.write_with("scan.ply", |w| ply::write_cloud(w, &s.scan))?;
    out.write_with("scene_mesh.ply", |w| ply::write_mesh(w, &s.scene_mesh))?;
    if let Some(reference) = &s.reference {
        out.write_with("reference.ply", |w| ply::write_mesh(w, reference))?;
    }
    out.write_json("truth.json", &s.truth)?;
    out.write_toml("config.toml", &s.config)?;

    let c = &s.counts;
    let mut text = String::new();
    let _ = writeln!(
        text,
        "synth: {} scene, seed {}: {} points from {} pixels in {:.2} s",
        match s.truth.scene {
            SceneKind::Bottle => "bottle",
            SceneKind::Sediment => "sediment",
        },
        s.truth.seed,
        c.points,
        c.pixels,
        elapsed
    );
    let _ = writeln!(
        text,
        "  dropped: {} no return, {} out of range, {} stereo shadow, {} outside the right image, {} grazing, {} textureless",
        c.no_return, c.out_of_range, c.stereo_shadow, c.outside_right_image, c.grazing, c.textureless
    );
    let _ = writeln!(
        text,
        "  artefacts: {} speckle, {} flying pixels",
        c.speckle, c.flying
    );
    let _ = writeln!(
        text,
        "  depth noise at 1 m: {:.2} mm; wrote {}",
        1e3 * s.truth.camera.depth_sigma_at_1m_m,
        out.path().display()
    );
    Ok(Report {
        summary: s.summary(),
        text,
        out: Some(out),
        failure: None,
    })
}
