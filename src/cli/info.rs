//! `uvms info FILE.ply`: what a PLY file holds — points, faces, properties, encoding and
//! bounding box. Reads the whole file (faces validated and triangulated), so a malformed file is
//! reported exactly as every other command would report it.

use super::{Ctx, Report};
use crate::config::shown_xyz;
use crate::error::Result;
use crate::io::ply::read_ply;
use serde_json::json;
use std::fmt::Write;
use std::path::PathBuf;

/// Arguments of `uvms info`.
#[derive(Debug, clap::Args)]
pub struct InfoArgs {
    /// The PLY file to describe.
    pub file: PathBuf,
}

/// Describes a PLY file.
///
/// # Errors
/// [`crate::Error::Input`] if the file is missing or malformed.
pub fn run(args: &InfoArgs, _ctx: &Ctx) -> Result<Report> {
    let data = read_ply(&args.file)?;
    let info = &data.info;
    let mut summary = serde_json::to_value(info).unwrap_or_else(|_| json!({}));
    summary["file"] = json!(args.file.display().to_string());
    let mut text = String::new();
    let _ = writeln!(text, "{}", args.file.display());
    let _ = writeln!(text, "  encoding     {}", info.encoding);
    let _ = writeln!(
        text,
        "  points       {} ({} in the header, {} non-finite dropped)",
        info.points, info.vertices_in_header, info.non_finite_dropped
    );
    if info.faces > 0 || info.triangles.is_some_and(|t| t > 0) {
        let _ = writeln!(
            text,
            "  faces        {} ({} triangles, {} dropped with non-finite vertices)",
            info.faces,
            info.triangles.unwrap_or(0),
            info.triangles_dropped
        );
    } else {
        let _ = writeln!(text, "  faces        0");
    }
    let _ = writeln!(
        text,
        "  colours      {}\n  normals      {}",
        if info.has_colors { "yes" } else { "no" },
        if info.has_normals { "yes" } else { "no" }
    );
    for e in &info.elements {
        let _ = writeln!(
            text,
            "  element {} {}: {}",
            e.name,
            e.count,
            e.properties.join(", ")
        );
    }
    match (info.bbox_min, info.bbox_max) {
        (Some(lo), Some(hi)) => {
            // Far coordinates (a stray point at 1e300) in exponent form, not 300 digits.
            let extent = [0, 1, 2].map(|i| hi[i] - lo[i]);
            let _ = writeln!(
                text,
                "  bbox min     {} m\n  bbox max     {} m\n  extent       {} m",
                shown_xyz(&lo, 4),
                shown_xyz(&hi, 4),
                shown_xyz(&extent, 4)
            );
        }
        _ => {
            let _ = writeln!(text, "  bbox         (no points)");
        }
    }
    Ok(Report {
        summary,
        text,
        out: None,
        failure: None,
    })
}
