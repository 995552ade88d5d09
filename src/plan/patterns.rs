//! The patterns a tool path is made from, placed relative to the aligned reference's principal
//! axes and projected onto the scanned surface (see [`super::project`]).
//!
//! - **ring** (the seed's, Figure 11): a band across the object, perpendicular to its
//!   longitudinal axis, at a station along it. Guide rays lie in the plane perpendicular to the
//!   axis and point at the axis, so the path is the scanned surface's cross-section. By default
//!   it spans the arc the camera saw (the scanned arc around the camera-facing direction, less
//!   an edge margin); `arc_deg` asks for a given arc, centred on the camera-facing direction. A
//!   band of `width_m` is covered by parallel passes at most `spacing_m` apart, boustrophedon,
//!   joined by U-turns on the surface (radius half the pass spacing).
//! - **raster**: boustrophedon coverage of a `width_m × height_m` region of the surface, seen
//!   from the camera: rays parallel to the line of sight through the object's centre; rows run
//!   along (or across) the object's axis. Lengths are measured on the surface: rows are placed at
//!   most `spacing_m` apart along a transect through the region's centre, each row covers
//!   `width_m` of arc length about that transect, and rows are joined by U-turns.
//! - **line** (soil sampling, the seed's first case): a straight path on the seabed beside the
//!   object, parallel to its axis (turned by `heading_deg`), at immersion depth `depth_m` below the
//!   surface; rays along the seabed plane's normal onto the triangulated seabed when there is one
//!   (the plane where it has holes), or onto the plane itself. Without an object (a sediment
//!   patch) it is centred where the optical axis meets the seabed and runs along the image's x.
//! - **polyline**: points read from a CSV file (`x_m,y_m,z_m[,force_n]`) in the reference model's
//!   frame (or the scan's or the world's), corners rounded (`corner_radius_m`), densified, and
//!   cast onto the scan along the reference surface's normal.
//!
//! A band that extends beyond the scanned surface (its end would lie on the reference or
//! nowhere) is an error unless `projection.clip` trims it to the scan. Frame: the scan frame `S`;
//! metres, degrees in the configuration.

use super::project::{
    Facing, Guide, Line, PathPoint, ProjectionConfig, Projector, SmoothSurface, bounded_count, bridge_holes,
    project_all,
};
use super::{ObjectAxes, ObjectInput, PlanInput, perpendicular};
use crate::config::{non_negative, positive, require, shown, shown_to};
use crate::error::{Error, Result};
use crate::frames::Pose;
use crate::mesh::TriangleMesh;
use nalgebra::{Point3, Rotation3, Unit, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// Clearance added around the object's bounding volume for the origins of guide rays, metres.
const RAY_CLEARANCE: f64 = 0.05;

/// Which pattern to plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PatternKind {
    /// A band across the object, perpendicular to its longitudinal axis.
    Ring,
    /// Boustrophedon coverage of a surface region.
    Raster,
    /// A straight path along the seabed at an immersion depth (soil sampling).
    Line,
    /// A polyline read from a CSV file.
    Polyline,
}

impl PatternKind {
    /// The pattern's name.
    pub fn as_str(self) -> &'static str {
        match self {
            PatternKind::Ring => "ring",
            PatternKind::Raster => "raster",
            PatternKind::Line => "line",
            PatternKind::Polyline => "polyline",
        }
    }
}

/// The ring pattern.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RingConfig {
    /// Position of the band's centre along the longitudinal axis, from the object's centre,
    /// metres.
    pub station_m: f64,
    /// The arc to clean, degrees, centred on the camera-facing direction; 0: the whole arc the
    /// camera saw, less `edge_margin_m` at each end.
    pub arc_deg: f64,
    /// Distance kept from the edges of the scanned arc when `arc_deg` is 0, metres.
    pub edge_margin_m: f64,
    /// Width of the band along the axis, metres; 0 for a single pass.
    pub width_m: f64,
    /// Largest distance between passes across the band, metres.
    pub spacing_m: f64,
    /// Desired normal force, N.
    pub force_n: f64,
}

impl Default for RingConfig {
    fn default() -> Self {
        RingConfig {
            station_m: 0.0,
            arc_deg: 0.0,
            edge_margin_m: 0.01,
            width_m: 0.0,
            spacing_m: 0.01,
            force_n: 60.0,
        }
    }
}

/// Which way raster rows run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RowDirection {
    /// Rows parallel to the object's longitudinal axis.
    Along,
    /// Rows across the axis.
    Across,
}

/// The raster pattern.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RasterConfig {
    /// Length of each row along the surface, metres.
    pub width_m: f64,
    /// Extent of the region across the rows, along the surface, metres.
    pub height_m: f64,
    /// Largest distance between rows, metres.
    pub spacing_m: f64,
    /// Which way the rows run.
    pub rows: RowDirection,
    /// Shift of the region's centre from the object's centre, along and across the rows, in the
    /// plane perpendicular to the line of sight, metres.
    pub offset_m: [f64; 2],
    /// Desired normal force, N.
    pub force_n: f64,
}

impl Default for RasterConfig {
    fn default() -> Self {
        RasterConfig {
            width_m: 0.15,
            height_m: 0.10,
            spacing_m: 0.01,
            rows: RowDirection::Along,
            offset_m: [0.0, 0.0],
            force_n: 60.0,
        }
    }
}

/// The soil-sampling line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LineConfig {
    /// Length of the line, metres.
    pub length_m: f64,
    /// Immersion depth of the sampler below the seabed surface, metres.
    pub depth_m: f64,
    /// Heading of the line in the seabed plane, from the object's axis, degrees.
    pub heading_deg: f64,
    /// Gap between the object's footprint and the line (on the camera's side), metres.
    pub clearance_m: f64,
    /// Further shift of the line's centre, along the line and sideways, metres.
    pub offset_m: [f64; 2],
    /// Desired force along the tool axis, N (0: the sampler is position-controlled).
    pub force_n: f64,
}

impl Default for LineConfig {
    fn default() -> Self {
        LineConfig {
            length_m: 0.3,
            depth_m: 0.02,
            heading_deg: 0.0,
            clearance_m: 0.1,
            offset_m: [0.0, 0.0],
            force_n: 0.0,
        }
    }
}

/// The frame polyline points are given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PolylineFrame {
    /// The reference model's frame (mapped by `t_scan_reference`).
    Reference,
    /// The scan (camera) frame `S`.
    Scan,
    /// The world frame `W`.
    World,
}

/// A polyline read from a CSV file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PolylineConfig {
    /// The CSV file: a header `x_m,y_m,z_m` or `x_m,y_m,z_m,force_n`, then one point per line;
    /// `#` comments.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    /// The frame of the points.
    pub frame: PolylineFrame,
    /// How far outside the reference surface the guide rays start, metres (must exceed the
    /// fouling's thickness and the alignment error).
    pub standoff_m: f64,
    /// Desired normal force where the file has no `force_n` column, N.
    pub force_n: f64,
    /// Corners of the polyline are rounded over about this radius (cut at most 40 % into the
    /// adjacent segments), so the tool never turns on the spot, metres.
    pub corner_radius_m: f64,
}

impl Default for PolylineConfig {
    fn default() -> Self {
        PolylineConfig {
            file: None,
            frame: PolylineFrame::Reference,
            standoff_m: 0.05,
            force_n: 60.0,
            corner_radius_m: 0.005,
        }
    }
}

/// Checks the pattern settings.
///
/// # Errors
/// [`Error::Input`] naming the first bad field.
pub fn validate(
    ring: &RingConfig,
    raster: &RasterConfig,
    line: &LineConfig,
    poly: &PolylineConfig,
) -> Result<()> {
    for (what, v) in [
        ("ring.edge_margin_m", ring.edge_margin_m),
        ("ring.width_m", ring.width_m),
        ("ring.force_n", ring.force_n),
        ("line.depth_m", line.depth_m),
        ("line.clearance_m", line.clearance_m),
        ("line.force_n", line.force_n),
        ("raster.force_n", raster.force_n),
        ("polyline.force_n", poly.force_n),
        ("polyline.corner_radius_m", poly.corner_radius_m),
    ] {
        non_negative(what, v)?;
    }
    for (what, v) in [
        ("ring.spacing_m", ring.spacing_m),
        ("raster.width_m", raster.width_m),
        ("raster.height_m", raster.height_m),
        ("raster.spacing_m", raster.spacing_m),
        ("line.length_m", line.length_m),
        ("polyline.standoff_m", poly.standoff_m),
    ] {
        positive(what, v)?;
    }
    let at = |key: &str, step: f64| format!("at a {key} of {} m ", shown(step));
    bounded_count(
        "ring.width_m",
        ring.width_m,
        ring.spacing_m,
        &at("spacing_m", ring.spacing_m),
    )?;
    bounded_count(
        "raster.height_m",
        raster.height_m,
        raster.spacing_m,
        &at("spacing_m", raster.spacing_m),
    )?;
    if !(ring.arc_deg.is_finite() && (0.0..=360.0).contains(&ring.arc_deg)) {
        return Err(Error::input(
            "ring.arc_deg",
            format!("must be between 0 and 360, got {}", ring.arc_deg),
        ));
    }
    let [rx, ry] = raster.offset_m;
    let [lx, ly] = line.offset_m;
    for (what, v) in [
        ("ring.station_m", ring.station_m),
        ("line.heading_deg", line.heading_deg),
        ("raster.offset_m[1]", rx),
        ("raster.offset_m[2]", ry),
        ("line.offset_m[1]", lx),
        ("line.offset_m[2]", ly),
    ] {
        require(v.is_finite(), what, "must be a finite number")?;
    }
    Ok(())
}

/// What a pattern produced: the projected path before timing, and facts for the summary.
#[derive(Debug, Clone, Default)]
pub struct PatternPath {
    /// The projected path in order (scan frame).
    pub points: Vec<PathPoint>,
    /// Passes of a ring band or rows of a raster (1 for a line or polyline).
    pub rows: usize,
    /// Distance between passes or rows, metres (0 for one).
    pub row_spacing_m: f64,
    /// The ring's arc about its axis, degrees.
    pub arc_deg: Option<f64>,
    /// True if `projection.clip` trimmed the pattern to the scanned surface.
    pub clipped: bool,
}

/// Everything a pattern builder needs.
pub struct Context<'a> {
    /// The planner's input.
    pub input: &'a PlanInput<'a>,
    /// Projection settings.
    pub projection: &'a ProjectionConfig,
    /// The object's surfaces prepared for queries, when there is an object.
    pub object: Option<ObjectContext<'a>>,
    /// World pose of the scan frame.
    pub t_world_scan: Pose,
}

/// The object's surfaces prepared for the patterns.
pub struct ObjectContext<'a> {
    /// The object as given.
    pub input: &'a ObjectInput<'a>,
    /// Projection onto the scan with fallback to the reference.
    pub projector: Projector<'a>,
    /// The aligned reference, prepared for queries.
    pub reference: &'a SmoothSurface,
}

impl Context<'_> {
    /// The object, which `pattern` needs.
    ///
    /// # Errors
    /// [`Error::Input`] when the input has no object.
    fn object(&self, pattern: &str) -> Result<&ObjectContext<'_>> {
        self.object.as_ref().ok_or_else(|| {
            Error::input(
                "pattern",
                format!(
                    "the {pattern} pattern needs the object: its scanned surface and the aligned reference"
                ),
            )
        })
    }
}

/// Number of passes covering `width` with at most `spacing` between them, and their spacing.
fn passes(width: f64, spacing: f64) -> (usize, f64) {
    if width <= 0.0 {
        return (1, 0.0);
    }
    let n = (width / spacing - 1e-9).ceil().max(1.0) as usize + 1;
    (n, width / (n - 1) as f64)
}

/// Why a line's scanned range falls short of the wanted range, side by side.
fn why(line: &Line, want: (f64, f64), have: (f64, f64)) -> String {
    let mut out = Vec::new();
    if want.0 < have.0 {
        out.push(format!("at the start {}", line.stops.0.describe()));
    }
    if want.1 > have.1 {
        out.push(format!("at the end {}", line.stops.1.describe()));
    }
    out.join(", ")
}

fn band_error(what: String) -> Error {
    Error::failed(
        "plan",
        format!("band wider than the surface: {what}; narrow the pattern or set projection.clip = true"),
    )
}

fn miss_error(what: &str) -> Error {
    Error::failed(
        "plan",
        format!("the {what} misses the object: no surface under its centre"),
    )
}

/// Clamps `want` to the scanned range `have`, or fails with `what` when it does not fit and
/// clipping is off. Returns the range and whether it was clipped.
fn fit(
    want: (f64, f64),
    have: (f64, f64),
    clip: bool,
    what: impl FnOnce() -> String,
) -> Result<((f64, f64), bool)> {
    let tol = 1e-9;
    if want.0 >= have.0 - tol && want.1 <= have.1 + tol {
        return Ok(((want.0.max(have.0), want.1.min(have.1)), false));
    }
    let cut = (want.0.max(have.0), want.1.min(have.1));
    if clip && cut.1 > cut.0 {
        Ok((cut, true))
    } else {
        Err(band_error(what()))
    }
}

/// One pass of a boustrophedon: a projected line, the part of it to cover (parameter range,
/// increasing) and its coordinate across the passes (metres).
struct Pass {
    line: Line,
    range: (f64, f64),
    cross: f64,
}

/// Joins passes into one path, alternating their direction. Consecutive passes are linked by a
/// U-turn of radius `ρ`, half their distance: a cubic Bézier in the pattern's coordinates
/// (`τ · metric`, `cross`) from the end of one pass to the start of the next, with control
/// points `4/3 ρ` beyond them (a near-semicircle, radius of curvature ≥ 1.1 ρ). The passes are
/// shortened by `ρ` at each turn so that the turn's apex reaches the end of the range, and the
/// turns are projected like the passes. `guide(τ, cross)` gives the guide ray.
fn boustrophedon(
    projector: &Projector,
    passes: &[Pass],
    metric: f64,
    guide: &dyn Fn(f64, f64) -> Guide,
    force: f64,
) -> Result<Vec<PathPoint>> {
    let rho: Vec<f64> = passes
        .windows(2)
        .map(|w| (w[1].cross - w[0].cross).abs() / 2.0)
        .collect();
    let mut path: Vec<PathPoint> = Vec::new();
    let mut previous_end: Option<(f64, f64, f64)> = None;
    for (j, pass) in passes.iter().enumerate() {
        let forward = j % 2 == 0;
        let trim_in = if j > 0 { rho[j - 1] / metric } else { 0.0 };
        let trim_out = rho.get(j).map_or(0.0, |r| r / metric);
        let (lo, hi) = if forward {
            (pass.range.0 + trim_in, pass.range.1 - trim_out)
        } else {
            (pass.range.0 + trim_out, pass.range.1 - trim_in)
        };
        if hi <= lo {
            return Err(Error::failed(
                "plan",
                format!(
                    "pass {j} of the pattern is shorter than the distance between passes; lengthen it or bring the passes closer"
                ),
            ));
        }
        let line = &pass.line;
        let mut pts = line.between(line.arc_at_tau(lo), line.arc_at_tau(hi));
        if !forward {
            pts.reverse();
        }
        let (start, end) = if forward { (lo, hi) } else { (hi, lo) };
        if let Some((t0, c0, r)) = previous_end {
            // Beyond the previous pass's end, in its direction of motion.
            let dir = if forward { -1.0 } else { 1.0 };
            let lambda = 4.0 / 3.0 * r;
            let (x0, x3) = (t0 * metric, start * metric);
            let (x1, x2) = (x0 + dir * lambda, x3 + dir * lambda);
            let c1 = pass.cross;
            let n = ((1.6 * std::f64::consts::PI * r / projector.config.step_m).ceil() as usize).max(2);
            let guides = (1..n).map(|i| {
                let u = i as f64 / n as f64;
                let v = 1.0 - u;
                let x = v * v * v * x0 + 3.0 * v * v * u * x1 + 3.0 * v * u * u * x2 + u * u * u * x3;
                let c = c0 + (c1 - c0) * (3.0 * u * u - 2.0 * u * u * u);
                (x / metric, guide(x / metric, c))
            });
            path.extend(project_all(projector, guides, force, "turn between passes")?);
        }
        path.extend(pts);
        previous_end = rho.get(j).map(|&r| (end, pass.cross, r));
    }
    Ok(path)
}

/// The ring pattern.
///
/// # Errors
/// [`Error::Failed`] if the ring misses the object, the scanned arc is too short, or the band is
/// wider than the surface (unless clipped).
pub fn ring(ctx: &Context, cfg: &RingConfig) -> Result<PatternPath> {
    let obj = ctx.object("ring")?;
    let pj = &obj.projector;
    let ax: &ObjectAxes = &obj.input.axes;
    let a = ax.axis;
    let r_out = ax.radius + RAY_CLEARANCE;
    let (n, spacing) = passes(cfg.width_m, cfg.spacing_m);
    let stations: Vec<f64> = (0..n)
        .map(|j| cfg.station_m - cfg.width_m / 2.0 + j as f64 * spacing)
        .collect();
    let centre0 = ax.centre + a * cfg.station_m;
    let e1 = perpendicular(&a, &(ctx.input.viewpoint - centre0));
    let e2 = a.cross(&e1);
    let guide = |s: f64, th: f64| {
        let u = e1 * th.cos() + e2 * th.sin();
        Guide {
            origin: ax.centre + a * s + u * r_out,
            dir: -u,
            reach: r_out,
        }
    };
    let metric = ax.radius.max(pj.config.step_m);
    let half = cfg.arc_deg.to_radians() / 2.0;
    let clip = pj.config.clip;
    let mut lines = Vec::with_capacity(n);
    let mut range = (-PI, PI);
    let mut clipped = false;
    for &s in &stations {
        let family = |th: f64| guide(s, th);
        let Some(centre) = pj.cast(&family(0.0), 0.0, cfg.force_n) else {
            return Err(
                if n > 1 && pj.cast(&guide(cfg.station_m, 0.0), 0.0, 0.0).is_some() {
                    band_error(format!("the ring's pass at station {s:.3} m is off the object"))
                } else {
                    miss_error("ring")
                },
            );
        };
        let (lo, hi) = if half > 0.0 { (-half, half) } else { (-PI, PI) };
        let line = Line::from_walks(
            pj.walk(&family, centre, lo, metric, None),
            pj.walk(&family, centre, hi, metric, None),
        );
        let seen = (line.at(line.scanned.0).tau, line.at(line.scanned.1).tau);
        let (want_lo, want_hi) = if half > 0.0 {
            (-half, half)
        } else {
            let (a0, a1) = (
                line.scanned.0 + cfg.edge_margin_m,
                line.scanned.1 - cfg.edge_margin_m,
            );
            if a1 <= a0 {
                return Err(Error::failed(
                    "plan",
                    format!(
                        "the scanned arc at station {s:.3} m is {:.1} mm long, less than twice ring.edge_margin_m",
                        (line.scanned.1 - line.scanned.0) * 1e3
                    ),
                ));
            }
            (line.at(a0).tau, line.at(a1).tau)
        };
        let ((lo, hi), c) = fit((want_lo, want_hi), seen, clip, || {
            format!(
                "the ring's arc of {:.1}° exceeds the arc scanned at station {s:.3} m ({:.1}° to {:.1}° about the camera-facing direction; {})",
                cfg.arc_deg,
                seen.0.to_degrees(),
                seen.1.to_degrees(),
                why(&line, (-half, half), (seen.0, seen.1))
            )
        })?;
        clipped |= c;
        range = (range.0.max(lo), range.1.min(hi));
        lines.push(line);
    }
    if range.1 <= range.0 {
        return Err(band_error(
            "the passes of the ring band share no scanned arc".to_string(),
        ));
    }
    let passes: Vec<Pass> = lines
        .into_iter()
        .zip(&stations)
        .map(|(line, &s)| Pass {
            line,
            range,
            cross: s,
        })
        .collect();
    let mut path = boustrophedon(pj, &passes, metric, &|th, s| guide(s, th), cfg.force_n)?;
    bridge_holes(&mut path, obj.reference);
    Ok(PatternPath {
        points: path,
        rows: n,
        row_spacing_m: spacing,
        arc_deg: Some((range.1 - range.0).to_degrees()),
        clipped,
    })
}

/// The raster pattern.
///
/// # Errors
/// [`Error::Failed`] if the region's centre misses the object or the region is larger than the
/// scanned surface (unless clipped).
pub fn raster(ctx: &Context, cfg: &RasterConfig) -> Result<PatternPath> {
    let obj = ctx.object("raster")?;
    let pj = &obj.projector;
    let ax = &obj.input.axes;
    let d = (ax.centre - ctx.input.viewpoint)
        .try_normalize(1e-9)
        .ok_or_else(|| {
            Error::failed(
                "plan",
                "the camera is at the object's centre; no line of sight for the raster",
            )
        })?;
    let along = perpendicular(&d, &ax.axis);
    let across = d.cross(&along);
    let (eu, ev) = match cfg.rows {
        RowDirection::Along => (along, across),
        RowDirection::Across => (across, along),
    };
    let r_out = (ax.radius.powi(2) + ax.half_length.powi(2)).sqrt() + RAY_CLEARANCE;
    let c = ax.centre + eu * cfg.offset_m[0] + ev * cfg.offset_m[1];
    let guide = |u: f64, v: f64| Guide {
        origin: c + eu * u + ev * v - d * r_out,
        dir: d,
        reach: 2.0 * r_out,
    };
    let clip = pj.config.clip;
    let f = cfg.force_n;
    let walk_line = |family: &dyn Fn(f64) -> Guide, centre: PathPoint, target: f64| {
        Line::from_walks(
            pj.walk(family, centre, centre.tau - r_out, 1.0, Some(target)),
            pj.walk(family, centre, centre.tau + r_out, 1.0, Some(target)),
        )
    };
    // The transect across the rows through the region's centre.
    let tv = |v: f64| guide(0.0, v);
    let centre = pj.cast(&tv(0.0), 0.0, f).ok_or_else(|| miss_error("raster"))?;
    let transect = walk_line(&tv, centre, cfg.height_m / 2.0);
    let ((s_lo, s_hi), mut clipped) = fit(
        (-cfg.height_m / 2.0, cfg.height_m / 2.0),
        transect.scanned,
        clip,
        || {
            format!(
                "the raster's height of {} m exceeds the scanned surface ({:.3} m to {:.3} m about its centre; {})",
                shown_to(cfg.height_m, 3),
                transect.scanned.0,
                transect.scanned.1,
                why(
                    &transect,
                    (-cfg.height_m / 2.0, cfg.height_m / 2.0),
                    transect.scanned
                )
            )
        },
    )?;
    let (n, spacing) = passes(s_hi - s_lo, cfg.spacing_m);
    let n = if s_hi - s_lo <= 0.0 { 1 } else { n };
    // Rows are independent once the transect has placed them: walk them in parallel.
    let rows: Vec<(Pass, bool)> = (0..n)
        .into_par_iter()
        .map(|j| {
            let v = transect.at(s_lo + j as f64 * spacing).tau;
            let tu = |u: f64| guide(u, v);
            let centre = pj.cast(&tu(0.0), 0.0, f).ok_or_else(|| miss_error("raster row"))?;
            let row = walk_line(&tu, centre, cfg.width_m / 2.0);
            let ((a, b), cl) = fit((-cfg.width_m / 2.0, cfg.width_m / 2.0), row.scanned, clip, || {
                format!(
                    "row {j} of the raster ({} m long) exceeds the scanned surface ({:.3} m to {:.3} m about its centre; {})",
                    shown_to(cfg.width_m, 3),
                    row.scanned.0,
                    row.scanned.1,
                    why(&row, (-cfg.width_m / 2.0, cfg.width_m / 2.0), row.scanned)
                )
            })?;
            let range = (row.at(a).tau, row.at(b).tau);
            Ok((Pass { line: row, range, cross: v }, cl))
        })
        .collect::<Vec<Result<_>>>()
        .into_iter()
        .collect::<Result<_>>()?; // the first failing row, whatever the threads did
    clipped |= rows.iter().any(|r| r.1);
    let passes: Vec<Pass> = rows.into_iter().map(|r| r.0).collect();
    let mut path = boustrophedon(pj, &passes, 1.0, &|u, v| guide(u, v), f)?;
    bridge_holes(&mut path, obj.reference);
    Ok(PatternPath {
        points: path,
        rows: n,
        row_spacing_m: if n > 1 { spacing } else { 0.0 },
        arc_deg: None,
        clipped,
    })
}

/// Drops leading and trailing fallback points (a line beyond the scanned surface), or fails.
fn trim_to_scan(points: Vec<PathPoint>, clip: bool, what: &str) -> Result<(Vec<PathPoint>, bool)> {
    let first = points.iter().position(|p| !p.fallback);
    let last = points.iter().rposition(|p| !p.fallback);
    let (Some(first), Some(last)) = (first, last) else {
        return Err(Error::failed(
            "plan",
            format!("the {what} misses the scanned surface"),
        ));
    };
    if first == 0 && last == points.len() - 1 {
        return Ok((points, false));
    }
    if !clip || last <= first {
        return Err(band_error(format!(
            "the {what} extends beyond the scanned surface"
        )));
    }
    Ok((points[first..=last].to_vec(), true))
}

/// Fails if the path crosses a hole in the scan longer than `max_hole` metres.
fn check_holes(points: &[PathPoint], max_hole: f64, what: &str) -> Result<()> {
    let mut run = 0.0;
    for w in points.windows(2) {
        if w[1].fallback {
            run += (w[1].point - w[0].point).norm();
            if run > max_hole {
                return Err(Error::failed(
                    "plan",
                    format!(
                        "the {what} crosses a hole in the scan longer than projection.max_hole_m ({max_hole} m) near ({:.3}, {:.3}, {:.3}) m",
                        w[1].point.x, w[1].point.y, w[1].point.z
                    ),
                ));
            }
        } else {
            run = 0.0;
        }
    }
    Ok(())
}

/// The soil-sampling line.
///
/// # Errors
/// [`Error::Failed`] without a seabed plane, if the line crosses the object, or runs beyond the
/// scanned seabed (unless clipped).
pub fn line(ctx: &Context, cfg: &LineConfig) -> Result<PatternPath> {
    let input = ctx.input;
    let plane = input
        .seabed_plane
        .ok_or_else(|| Error::failed("plan", "the line pattern needs the seabed plane"))?;
    let raw_n = Vector3::new(plane[0], plane[1], plane[2]);
    let norm = raw_n.norm();
    if !(norm.is_finite() && norm > 0.0 && plane[3].is_finite()) {
        return Err(Error::input(
            "seabed plane",
            "the plane's normal is zero or not finite",
        ));
    }
    let (n, dist) = (raw_n / norm, plane[3] / norm);
    let height = |p: &Point3<f64>| n.dot(&p.coords) + dist;
    let turn = Rotation3::from_axis_angle(&Unit::new_unchecked(n), cfg.heading_deg.to_radians());
    let (c0, heading, lateral, half_width, top) = match &ctx.object {
        // Beside the object's footprint, parallel to its axis, on the camera's side.
        Some(obj) => {
            let ax = &obj.input.axes;
            let c0 = ax.centre - n * height(&ax.centre);
            let heading = turn * perpendicular(&n, &ax.axis);
            let mut lateral = n.cross(&heading);
            if (input.viewpoint - c0).dot(&lateral) < 0.0 {
                lateral = -lateral;
            }
            let verts = &obj.input.reference.vertices;
            let half_width = verts
                .iter()
                .map(|v| (v - c0).dot(&lateral).abs())
                .fold(0.0, f64::max);
            let top = verts.iter().map(height).fold(0.0, f64::max);
            (c0, heading, lateral, half_width + cfg.clearance_m, top)
        }
        // Where the optical axis (z of the scan frame) meets the seabed, along the image's x.
        None => {
            let along = n.dot(&Vector3::z());
            let t = -height(&input.viewpoint) / along;
            if !(t.is_finite() && t > 0.0) {
                return Err(Error::failed(
                    "plan",
                    "the camera's optical axis does not meet the seabed plane; no place for the line",
                ));
            }
            let heading = turn * perpendicular(&n, &Vector3::x());
            (
                input.viewpoint + Vector3::z() * t,
                heading,
                n.cross(&heading),
                0.0,
                0.0,
            )
        }
    };
    let top = top + RAY_CLEARANCE;
    let c = c0 + lateral * (half_width + cfg.offset_m[1]) + heading * cfg.offset_m[0];
    let reach = 2.0 * top + 2.0 * RAY_CLEARANCE;
    let guide = |t: f64| Guide {
        origin: c + heading * t + n * top,
        dir: -n,
        reach,
    };
    // The seabed plane as a square mesh around the line, wound so its normal is `n`.
    let r = cfg.length_m + 1.0;
    let e2 = n.cross(&heading);
    let corners =
        [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].map(|(x, y)| c + (heading * x + e2 * y) * r);
    let plane_mesh = TriangleMesh {
        vertices: corners.to_vec(),
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    };
    let config = ctx.projection;
    let plane_surface = SmoothSurface::new(&plane_mesh, Facing::Winding, config.smoothing_radius_m)?;
    let seabed = match input.seabed_surface {
        Some(m) if !m.triangles.is_empty() => Some(SmoothSurface::new(
            m,
            Facing::Toward(input.viewpoint),
            config.smoothing_radius_m,
        )?),
        _ => None,
    };
    let projector = match &seabed {
        Some(s) => Projector {
            primary: s,
            fallback: Some(&plane_surface),
            config,
        },
        None => Projector {
            primary: &plane_surface,
            fallback: None,
            config,
        },
    };
    // (The count is bounded by `PlanConfig::validate`.)
    let steps = (cfg.length_m / config.step_m).ceil().max(1.0) as usize;
    let taus: Vec<f64> = (0..=steps)
        .map(|i| -cfg.length_m / 2.0 + cfg.length_m * i as f64 / steps as f64)
        .collect();
    let mut points = project_all(
        &projector,
        taus.iter().map(|&t| (t, guide(t))),
        cfg.force_n,
        "line",
    )?;
    for p in points.iter().filter(|_| ctx.object.is_some()) {
        let g = guide(p.tau);
        let to_seabed = (p.point - g.origin).norm();
        let hits = |s: &SmoothSurface| s.cast(&g.origin, &g.dir, to_seabed).is_some();
        if ctx
            .object
            .as_ref()
            .is_some_and(|o| hits(o.projector.primary) || hits(o.reference))
        {
            return Err(Error::failed(
                "plan",
                format!(
                    "the line crosses the object near ({:.3}, {:.3}, {:.3}) m; move it with line.clearance_m, line.offset_m or line.heading_deg",
                    p.point.x, p.point.y, p.point.z
                ),
            ));
        }
    }
    let mut clipped = false;
    if seabed.is_some() {
        check_holes(&points, config.max_hole_m, "line")?;
        bridge_holes(&mut points, &plane_surface);
        (points, clipped) = trim_to_scan(points, config.clip, "line")?;
    }
    for p in &mut points {
        p.point -= p.normal * cfg.depth_m;
    }
    Ok(PatternPath {
        points,
        rows: 1,
        row_spacing_m: 0.0,
        arc_deg: None,
        clipped,
    })
}

/// Reads a polyline CSV file: header `x_m,y_m,z_m` or `x_m,y_m,z_m,force_n`, `#` comments.
///
/// # Errors
/// [`Error::Input`] naming the file, line and column of the first problem, or fewer than two
/// points.
pub fn read_polyline(path: &Path) -> Result<Vec<(Point3<f64>, Option<f64>)>> {
    let text = crate::config::read_text(path, "a path CSV file")?;
    let origin = path.display();
    let mut columns = None;
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let Some(ncol) = columns else {
            columns = match fields.as_slice() {
                ["x_m", "y_m", "z_m"] => Some(3),
                ["x_m", "y_m", "z_m", "force_n"] => Some(4),
                _ => {
                    return Err(Error::input(
                        format!("{origin} line {}", i + 1),
                        "expected the header x_m,y_m,z_m or x_m,y_m,z_m,force_n",
                    ));
                }
            };
            continue;
        };
        if fields.len() != ncol {
            return Err(Error::input(
                format!("{origin} line {}", i + 1),
                format!("expected {ncol} columns, found {}", fields.len()),
            ));
        }
        let mut v = [0.0; 4];
        for (c, f) in fields.iter().enumerate() {
            let at = || format!("{origin} line {} column {}", i + 1, c + 1);
            v[c] = f
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| Error::input(at(), format!("'{f}' is not a finite number")))?;
            crate::config::within_max(v[c], at)?;
        }
        if ncol == 4 && v[3] < 0.0 {
            return Err(Error::input(
                format!("{origin} line {} column 4", i + 1),
                "force_n is negative",
            ));
        }
        let point = Point3::new(v[0], v[1], v[2]);
        if out.last().is_some_and(|(last, _)| *last == point) {
            return Err(Error::input(
                format!("{origin} line {}", i + 1),
                "repeats the previous point (a segment of no length, with no direction)",
            ));
        }
        out.push((point, (ncol == 4).then_some(v[3])));
    }
    if out.len() < 2 {
        return Err(Error::input(origin, "a polyline needs at least two points"));
    }
    Ok(out)
}

/// A polyline densified to `step` with its corners rounded: each interior vertex is replaced by
/// a quadratic Bézier from `t` before it to `t` after it along the adjacent segments. For a turn
/// of `φ` its tightest radius of curvature (at the apex) is `t cos(φ/2) / tan(φ/2)`, so
/// `t = radius · sin(φ/2) / cos²(φ/2)` gives `radius`; `t` is capped at 40 % of the adjacent
/// segments. Forces are interpolated along the segments and held over a corner.
fn rounded_polyline(points: &[(Point3<f64>, f64)], radius: f64, step: f64) -> Vec<(Point3<f64>, f64)> {
    let mut pts: Vec<(Point3<f64>, f64)> = Vec::with_capacity(points.len());
    for &(p, f) in points {
        if pts.last().is_none_or(|(q, _)| (p - q).norm() > 1e-9) {
            pts.push((p, f));
        }
    }
    let n = pts.len();
    let cut: Vec<f64> = (0..n)
        .map(|i| {
            if i == 0 || i + 1 == n {
                return 0.0;
            }
            let (a, b, c) = (pts[i - 1].0, pts[i].0, pts[i + 1].0);
            let phi = (b - a).angle(&(c - b));
            if phi < 1e-6 {
                return 0.0;
            }
            let limit = 0.4 * (b - a).norm().min((c - b).norm());
            let half = phi / 2.0;
            (radius * half.sin() / half.cos().powi(2)).min(limit)
        })
        .collect();
    let mut out: Vec<(Point3<f64>, f64)> = pts.first().copied().into_iter().collect();
    for i in 0..n.saturating_sub(1) {
        let ((a, fa), (b, fb)) = (pts[i], pts[i + 1]);
        let len = (b - a).norm();
        let d = (b - a) / len;
        let (s0, s1) = (cut[i], len - cut[i + 1]);
        let m = ((s1 - s0) / step).ceil().max(1.0) as usize;
        for k in 1..=m {
            let s = s0 + (s1 - s0) * k as f64 / m as f64;
            out.push((a + d * s, fa + (fb - fa) * s / len));
        }
        if cut[i + 1] > 0.0 {
            let c = pts[i + 2].0;
            let (p, q) = (b - d * cut[i + 1], b + (c - b).normalize() * cut[i + 1]);
            let m = ((2.0 * cut[i + 1] / step).ceil() as usize).max(2);
            for k in 1..=m {
                let u = k as f64 / m as f64;
                let v = 1.0 - u;
                out.push((
                    Point3::from(p.coords * (v * v) + b.coords * (2.0 * u * v) + q.coords * (u * u)),
                    fb,
                ));
            }
        }
    }
    out
}

/// The polyline pattern.
///
/// # Errors
/// [`Error::Input`] for a missing or malformed file; [`Error::Failed`] if the path leaves the
/// object or runs beyond the scanned surface (unless clipped).
pub fn polyline(ctx: &Context, cfg: &PolylineConfig) -> Result<PatternPath> {
    let file = cfg.file.as_deref().ok_or_else(|| {
        Error::input(
            "plan.polyline.file",
            "the polyline pattern needs a CSV file (uvms plan --pattern FILE.csv)",
        )
    })?;
    let raw = read_polyline(file)?;
    let obj = ctx.object("polyline")?;
    let pj = &obj.projector;
    let to_scan = match cfg.frame {
        PolylineFrame::Reference => obj.input.t_scan_reference,
        PolylineFrame::Scan => Pose::identity(),
        PolylineFrame::World => ctx.t_world_scan.inverse(),
    };
    let pts: Vec<(Point3<f64>, f64)> = raw
        .iter()
        .map(|(p, f)| (to_scan * p, f.unwrap_or(cfg.force_n)))
        .collect();
    let step = pj.config.step_m;
    let total: f64 = pts.windows(2).map(|w| (w[1].0 - w[0].0).norm()).sum();
    bounded_count(&file.display().to_string(), total, step, "")?;
    let mut guides = Vec::new();
    let mut tau = 0.0;
    let mut previous: Option<Point3<f64>> = None;
    for (p, f) in rounded_polyline(&pts, cfg.corner_radius_m, step) {
        if let Some(q) = previous {
            tau += (p - q).norm();
        }
        previous = Some(p);
        // The ray starts `standoff` outside the reference along its smoothed normal. Both are
        // taken at `p` itself (the normal and the distance vary continuously along the path; the
        // closest point jumps across the edges of a faceted model).
        let q = obj.reference.project(&p);
        let (normal, _) = obj.reference.local_plane(&p, &q.normal);
        let back = cfg.standoff_m + q.distance;
        guides.push((
            tau,
            f,
            Guide {
                origin: p + normal * back,
                dir: -normal,
                reach: 2.0 * back,
            },
        ));
    }
    let mut points = project_all(pj, guides.iter().map(|(t, _, g)| (*t, *g)), 0.0, "polyline")?;
    for (p, (_, f, _)) in points.iter_mut().zip(&guides) {
        p.force = *f;
    }
    let config = pj.config;
    check_holes(&points, config.max_hole_m, "polyline")?;
    bridge_holes(&mut points, obj.reference);
    let (points, clipped) = trim_to_scan(points, config.clip, "polyline")?;
    Ok(PatternPath {
        points,
        rows: 1,
        row_spacing_m: 0.0,
        arc_deg: None,
        clipped,
    })
}
