//! `uvms segment SCAN.ply [--up X,Y,Z] [--reference MODEL.ply] [--config F] --out DIR`: the
//! seabed and the clusters standing on it, as coloured PLYs in the style of the seed's Figure 10
//! (seabed red, the object green, other clusters in other colours, the rest grey).

use super::{Ctx, Report, config_origin};
use crate::cloud::PointCloud;
use crate::error::{Error, Result};
use crate::io::ply::{read_cloud, read_ply, write_cloud};
use crate::output::OutDir;
use crate::perception::{PerceptionConfig, Segmentation, segment};
use crate::register::ReferenceModel;
use crate::segment::seabed::SeabedFit;
use nalgebra::Vector3;
use serde_json::{Value, json};
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// Arguments of `uvms segment`.
#[derive(Debug, clap::Args)]
pub struct SegmentArgs {
    /// The scan (PLY, scan frame `S`).
    pub scan: PathBuf,
    /// Prior on the seabed normal in the scan frame (opposite to gravity), e.g. `0,-0.7,-0.7`;
    /// may be tens of degrees off.
    #[arg(long, value_parser = parse_vector3, allow_hyphen_values = true)]
    pub up: Option<Vector3<f64>>,
    /// A reference model (PLY mesh or cloud): the object is the cluster matching its size and
    /// shape instead of the largest.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Perception configuration (TOML).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
}

/// Parses `X,Y,Z` into a vector (a command-line value).
///
/// # Errors
/// A message for clap (usage error, exit code 2) when it is not three finite numbers within
/// ±1e9.
pub fn parse_vector3(s: &str) -> std::result::Result<Vector3<f64>, String> {
    super::parse_numbers::<3>(s).map(Vector3::from)
}

/// Reads a reference model: a PLY with faces is a mesh (sampled), one without is a cloud.
///
/// # Errors
/// [`Error::Input`] naming the file if it cannot be read, holds too little, or has faces on a
/// vertex that is not finite.
pub fn load_reference(path: &Path, cfg: &PerceptionConfig) -> Result<ReferenceModel> {
    let data = read_ply(path)?;
    crate::io::ply::refuse_holes(path, &data.info)?;
    let what = path.display().to_string();
    if data.triangles.is_empty() {
        ReferenceModel::from_cloud(data.cloud, &cfg.normals, &what)
    } else {
        let mesh = crate::mesh::TriangleMesh {
            vertices: data.cloud.points,
            triangles: data.triangles,
        };
        ReferenceModel::from_mesh(mesh, cfg.register.mesh_samples, cfg.register.seed, &what)
    }
}

/// Colours of the figure: seabed, object, the rest.
const SEABED: [u8; 3] = [220, 40, 40];
const OBJECT: [u8; 3] = [40, 200, 60];
const REST: [u8; 3] = [150, 150, 150];
const PALETTE: [[u8; 3]; 6] = [
    [40, 90, 230],
    [230, 170, 30],
    [170, 60, 200],
    [30, 200, 200],
    [240, 120, 170],
    [120, 90, 40],
];

/// The scan coloured as the seed's Figure 10, and the clusters alone (each its own colour).
pub fn coloured(seg: &Segmentation) -> (PointCloud, PointCloud) {
    let mut scene = seg.cloud.clone();
    let mut colors = vec![REST; scene.len()];
    if let Some(fit) = &seg.seabed {
        for &i in &fit.inliers {
            colors[i] = SEABED;
        }
    }
    let mut cluster_idx = Vec::new();
    let mut cluster_col = Vec::new();
    for (k, c) in seg.clusters.iter().enumerate() {
        let col = if k == seg.selection.index {
            OBJECT
        } else {
            PALETTE[k % PALETTE.len()]
        };
        for &i in &c.indices {
            colors[i] = col;
            cluster_idx.push(i);
            cluster_col.push(col);
        }
    }
    scene.colors = Some(colors);
    let mut clusters = seg.cloud.select(&cluster_idx);
    clusters.colors = Some(cluster_col);
    clusters.normals = None;
    scene.normals = None;
    (scene, clusters)
}

/// The segment part of a summary.
pub fn segmentation_summary(seg: &Segmentation) -> Value {
    let clusters: Vec<Value> = seg
        .clusters
        .iter()
        .zip(&seg.selection.scores)
        .map(|(c, s)| {
            json!({
                "points": c.indices.len(),
                "centroid": c.shape.centroid.coords.as_slice(),
                "extent": c.shape.spans.as_slice(),
                "axes": [c.shape.axes.column(0).as_slice(), c.shape.axes.column(1).as_slice(), c.shape.axes.column(2).as_slice()],
                "shape_score": s,
            })
        })
        .collect();
    let mut v = json!({
        "scan_points": seg.cleaning.input,
        "cleaning": seg.cleaning,
        "object_side_points": seg.object_side.len(),
        "cluster_link_m": seg.link_m,
        "clusters": clusters,
        "object_cluster": seg.selection.index,
        "object_points": seg.object().indices.len(),
        "object_extent": seg.object().shape.spans.as_slice(),
        "timings_s": seg.timings,
    });
    if let Some(fit) = &seg.seabed {
        v["seabed_plane"] = json!(fit.plane.coefficients());
        v["seabed_inliers"] = json!(fit.inliers.len());
        v["seabed_threshold_m"] = json!(fit.threshold_m);
        v["seabed_inlier_rms_m"] = json!(fit.inlier_rms_m);
        v["seabed_iterations"] = json!(fit.iterations);
        v["seabed_angle_to_up_deg"] = json!(fit.angle_to_up_deg);
    }
    v
}

/// The scan's and the seabed's lines of the report: the points read and left after cleaning,
/// the seabed's plane (`None`: the stage was off).
pub fn scan_text(read: usize, cleaned: usize, seabed: Option<&SeabedFit>, text: &mut String) {
    let _ = writeln!(text, "scan         {read} points, {cleaned} after cleaning");
    match seabed {
        Some(f) => {
            let [a, b, c, d] = f.plane.coefficients();
            let _ = writeln!(
                text,
                "seabed       {a:.4} x + {b:.4} y + {c:.4} z + {d:.4} = 0, {} inliers (threshold {:.4} m, RMS {:.4} m){}",
                f.inliers.len(),
                f.threshold_m,
                f.inlier_rms_m,
                f.angle_to_up_deg
                    .map_or(String::new(), |a| format!(", {a:.1}° from --up"))
            );
        }
        None => {
            let _ = writeln!(text, "seabed       (stage off)");
        }
    }
}

/// Human-readable lines about a segmentation.
pub fn segmentation_text(seg: &Segmentation, text: &mut String) {
    scan_text(seg.cleaning.input, seg.cloud.len(), seg.seabed.as_ref(), text);
    let _ = writeln!(
        text,
        "clusters     {} ({} points above the seabed)",
        seg.clusters.len(),
        seg.object_side.len()
    );
    for (k, c) in seg.clusters.iter().enumerate().take(10) {
        let s = c.shape.spans;
        let _ = writeln!(
            text,
            "  {k:>3}{} {:>8} points  {:.3} × {:.3} × {:.3} m  at [{:.3}, {:.3}, {:.3}]",
            if k == seg.selection.index { " *" } else { "  " },
            c.indices.len(),
            s[0],
            s[1],
            s[2],
            c.shape.centroid.x,
            c.shape.centroid.y,
            c.shape.centroid.z
        );
    }
}

/// Runs `uvms segment`.
///
/// # Errors
/// [`Error::Input`] for bad files or configuration (exit 2); [`Error::Failed`] when no plane or no
/// cluster is found (exit 1).
pub fn run(args: &SegmentArgs, _ctx: &Ctx) -> Result<Report> {
    let cfg: PerceptionConfig = crate::config::load(args.config.as_deref())?;
    cfg.validate()
        .map_err(|e| e.in_table(config_origin(args.config.as_deref()), ""))?;
    let mut inputs: Vec<&Path> = vec![&args.scan];
    if let Some(r) = &args.reference {
        inputs.push(r);
    }
    if let Some(c) = &args.config {
        inputs.push(c);
    }
    let out = OutDir::create(
        &args.out,
        &inputs,
        &["segmented.ply", "clusters.ply", "object.ply", "seabed.ply"],
    )?;
    let (scan, _) = read_cloud(&args.scan)?;
    if scan.is_empty() {
        return Err(Error::input(args.scan.display(), "the scan has no points"));
    }
    let reference = match &args.reference {
        Some(r) => Some(load_reference(r, &cfg)?),
        None => None,
    };
    let seg = segment(
        &scan,
        args.up.as_ref(),
        reference.as_ref().map(|r| &r.shape.spans),
        &cfg,
    )
    .map_err(|e| super::named_in(e, args.config.as_deref(), &super::perception_tables()))?;
    let (scene, clusters) = coloured(&seg);
    out.write_with("segmented.ply", |w| write_cloud(w, &scene))?;
    out.write_with("clusters.ply", |w| write_cloud(w, &clusters))?;
    let mut object = seg.object_cloud();
    object.normals = None;
    out.write_with("object.ply", |w| write_cloud(w, &object))?;
    if let Some(fit) = &seg.seabed {
        let mut seabed = seg.cloud.select(&fit.inliers);
        seabed.colors = Some(vec![SEABED; seabed.len()]);
        seabed.normals = None;
        out.write_with("seabed.ply", |w| write_cloud(w, &seabed))?;
    }
    // The configuration last: a run whose products failed leaves none.
    out.write_toml("config.toml", &cfg)?;
    let mut summary = segmentation_summary(&seg);
    summary["scan"] = json!(args.scan.display().to_string());
    let mut text = String::new();
    segmentation_text(&seg, &mut text);
    let _ = writeln!(
        text,
        "wrote        segmented.ply, clusters.ply, object.ply{} in {}",
        if seg.seabed.is_some() { ", seabed.ply" } else { "" },
        out.path().display()
    );
    Ok(Report {
        summary,
        text,
        out: Some(out),
        failure: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vectors_parse_or_say_why() {
        assert_eq!(parse_vector3("0,-1, 0.5").unwrap(), Vector3::new(0.0, -1.0, 0.5));
        assert!(parse_vector3("0,1").is_err());
        assert!(parse_vector3("a,b,c").is_err());
        assert!(parse_vector3("nan,0,1").is_err());
    }
}
