//! Trajectory planning on the scanned surface (`uvms plan`).
//!
//! After the seed (Konoplin et al. 2024, section 4 and Figure 11): the desired tool path is
//! projected onto the triangulated surface of the *scanned* object — not the reference model,
//! since the real object is silted, fouled and deformed — and the tool is held perpendicular to
//! that surface at every point, pressing with a desired force along `k = z_G`.
//!
//! Stages, each in its own module:
//! 1. [`patterns`]: a ring, raster, line or polyline placed relative to the aligned reference's
//!    principal axes ([`ObjectAxes`]) and the camera's viewpoint;
//! 2. [`project`]: ray casting onto the scan, falling back to the aligned reference mesh in the
//!    scan's holes (flagged, and moved to the scan's level at the hole's borders), with smoothed
//!    normals and positions;
//! 3. [`timing::resample`]: a uniform straight-line spacing at the tool speed;
//! 4. [`tool_frame`]: `z_G = -n` (normals smoothed again along the path), `x_G` = path tangent,
//!    optional service angle;
//! 5. [`timing::schedule`]: the orientation-rate limit, approach, dwell and retreat;
//! 6. the frame change from the scan frame `S` to the world `W`
//!    (`t_world_scan = t_world_vehicle · t_vehicle_camera`, [`ScanFrames`]).
//!
//! [`plan`] runs them in order. Its input ([`PlanInput`]) is in the scan frame `S`; its output
//! ([`Plan::trajectory`]) is in `W`. SI units throughout (m, s, N; degrees only in the
//! configuration).

pub mod fixtures;
pub mod patterns;
pub mod project;
pub mod timing;
pub mod tool_frame;

use crate::error::{Error, Result};
use crate::frames::{Pose, ScanFrames, pose_to_rows};
use crate::mesh::TriangleMesh;
use crate::trajectory::{Phase, Trajectory};
use nalgebra::{Point3, SymmetricEigen, Vector3};
use patterns::{
    Context, LineConfig, ObjectContext, PatternKind, PatternPath, PolylineConfig, RasterConfig, RingConfig,
};
use project::{Facing, ProjectionConfig, Projector, SmoothSurface};
use serde::{Deserialize, Serialize};
use timing::TimingConfig;
use tool_frame::ToolConfig;

/// A unit vector perpendicular to the unit vector `a`, as close to `hint` as possible (any
/// perpendicular when `hint` is parallel to `a`).
pub fn perpendicular(a: &Vector3<f64>, hint: &Vector3<f64>) -> Vector3<f64> {
    (hint - a * a.dot(hint)).try_normalize(1e-9).unwrap_or_else(|| {
        let seed = if a.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        (seed - a * a.dot(&seed)).normalize()
    })
}

/// The planner's configuration (`[plan]` of a pipeline file, or `uvms plan --config`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlanConfig {
    /// The pattern to plan.
    pub pattern: PatternKind,
    /// The ring pattern's settings.
    pub ring: RingConfig,
    /// The raster pattern's settings.
    pub raster: RasterConfig,
    /// The soil-sampling line's settings.
    pub line: LineConfig,
    /// The polyline pattern's settings.
    pub polyline: PolylineConfig,
    /// Projection onto the scanned surface.
    pub projection: ProjectionConfig,
    /// Tool orientation.
    pub tool: ToolConfig,
    /// Speeds and segments.
    pub timing: TimingConfig,
    /// Where the scan was taken from (camera mounting, vehicle pose).
    pub frames: ScanFrames,
}

impl Default for PlanConfig {
    fn default() -> Self {
        PlanConfig {
            pattern: PatternKind::Ring,
            ring: RingConfig::default(),
            raster: RasterConfig::default(),
            line: LineConfig::default(),
            polyline: PolylineConfig::default(),
            projection: ProjectionConfig::default(),
            tool: ToolConfig::default(),
            timing: TimingConfig::default(),
            frames: ScanFrames::default(),
        }
    }
}

impl PlanConfig {
    /// Checks every value.
    ///
    /// # Errors
    /// [`Error::Input`] naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        patterns::validate(&self.ring, &self.raster, &self.line, &self.polyline)?;
        self.projection.validate()?;
        project::bounded_count(
            "line.length_m",
            self.line.length_m,
            self.projection.step_m,
            &format!(
                "at a projection.step_m of {} m ",
                crate::config::shown(self.projection.step_m)
            ),
        )?;
        self.tool.validate()?;
        self.timing.validate()?;
        self.frames.validate()?;
        crate::config::within_range(self, "")
    }
}

/// The object's centre, longitudinal axis and extent: the frame patterns are placed in.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ObjectAxes {
    /// Area-weighted centroid of the surface, metres.
    pub centre: Point3<f64>,
    /// Unit longitudinal axis (the principal direction of largest spread).
    pub axis: Vector3<f64>,
    /// Largest distance of the surface from the centre along the axis, metres.
    pub half_length: f64,
    /// Largest distance of the surface from the axis line, metres.
    pub radius: f64,
}

impl ObjectAxes {
    /// Principal axes of a mesh's surface: the centroid and the eigenvector of the largest
    /// eigenvalue of the area-weighted second moment (exact per triangle:
    /// `A/12 (Σ vᵢvᵢᵀ + s sᵀ)` with `s = Σ vᵢ`). The axis's sign is chosen to point along the
    /// mesh's first vertex-to-last-vertex direction (deterministic for a given mesh).
    ///
    /// # Errors
    /// [`Error::Failed`] for a mesh without area.
    pub fn from_mesh(mesh: &TriangleMesh) -> Result<ObjectAxes> {
        let n = mesh.vertices.len();
        if mesh.triangles.iter().flatten().any(|&i| i as usize >= n) {
            return Err(Error::input("mesh", "a triangle index is out of range"));
        }
        let Some((centre, cov)) = mesh.surface_moments() else {
            return Err(Error::failed("plan", "the reference mesh has no surface area"));
        };
        let eig = SymmetricEigen::new(cov);
        let imax = eig.eigenvalues.imax();
        let mut axis: Vector3<f64> = eig.eigenvectors.column(imax).into_owned();
        if let (Some(p), Some(q)) = (mesh.vertices.first(), mesh.vertices.last())
            && axis.dot(&(q - p)) < 0.0
        {
            axis = -axis;
        }
        Ok(Self::with_axis(mesh, centre, axis))
    }

    /// The extent of a mesh about a given centre and axis (normalised here; any principal-axes
    /// estimate, e.g. the registration's `reference_axes`).
    pub fn with_axis(mesh: &TriangleMesh, centre: Point3<f64>, axis: Vector3<f64>) -> ObjectAxes {
        let axis = axis.try_normalize(1e-12).unwrap_or(Vector3::x());
        let (mut half_length, mut radius) = (0.0f64, 0.0f64);
        for v in &mesh.vertices {
            let d = v - centre;
            let along = d.dot(&axis);
            half_length = half_length.max(along.abs());
            radius = radius.max((d - axis * along).norm());
        }
        ObjectAxes {
            centre,
            axis,
            half_length,
            radius,
        }
    }
}

/// The object the ring, raster and polyline patterns are planned on; scan frame `S`, metres.
#[derive(Debug, Clone, Copy)]
pub struct ObjectInput<'a> {
    /// The triangulated surface of the scanned object.
    pub scan_surface: &'a TriangleMesh,
    /// The reference mesh aligned to the scan (already mapped by `t_scan_reference`).
    pub reference: &'a TriangleMesh,
    /// The alignment: maps reference-model coordinates into the scan frame.
    pub t_scan_reference: Pose,
    /// The aligned reference's centre, longitudinal axis and extent.
    pub axes: ObjectAxes,
}

/// What the planner works on; everything in the scan frame `S`, metres.
#[derive(Debug, Clone, Copy)]
pub struct PlanInput<'a> {
    /// The object; only the line pattern can do without (a sediment patch to sample).
    pub object: Option<ObjectInput<'a>>,
    /// The camera centre (the origin for a scan in the camera frame, whose z axis is the
    /// optical axis).
    pub viewpoint: Point3<f64>,
    /// The seabed plane `[a, b, c, d]` (unit normal towards the camera, `ax + by + cz + d = 0`);
    /// needed by the line pattern.
    pub seabed_plane: Option<[f64; 4]>,
    /// The triangulated seabed around the object, if any (for the line pattern).
    pub seabed_surface: Option<&'a TriangleMesh>,
}

/// The planner's diagnostics, part of `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlanReport {
    /// The pattern planned.
    pub pattern: String,
    /// Number of trajectory samples (all phases).
    pub points: usize,
    /// Number of samples in contact.
    pub contact_points: usize,
    /// Length of the path in contact, m.
    pub length_m: f64,
    /// Duration of the whole trajectory, s.
    pub duration_s: f64,
    /// Tool speed in contact, m/s.
    pub speed_m_s: f64,
    /// Distance between contact samples along the path, m.
    pub spacing_m: f64,
    /// Contact samples on the aligned reference (holes in the scan).
    pub fallback_points: usize,
    /// Passes of a ring band or rows of a raster.
    pub rows: usize,
    /// Distance between passes or rows, m.
    pub row_spacing_m: f64,
    /// The ring's arc about the object's axis, degrees.
    pub arc_deg: Option<f64>,
    /// True if the pattern was trimmed to the scanned surface.
    pub clipped: bool,
    /// Fastest turn of the tool frame between samples, deg/s.
    pub max_rate_deg_s: f64,
    /// Contact steps slowed by the orientation-rate limit.
    pub rate_limited_steps: usize,
    /// Durations of the approach, dwell, contact and retreat, s.
    pub phase_durations_s: [f64; 4],
    /// Largest desired force, N.
    pub force_max_n: f64,
    /// The frame of the trajectory.
    pub frame: &'static str,
    /// `t_world_scan` used, 4×4 row-major.
    pub t_world_scan: [[f64; 4]; 4],
    /// The object's principal axes in the scan frame (none without an object).
    pub object_axes: Option<ObjectAxes>,
}

/// A planned trajectory and its diagnostics.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The trajectory in the world frame `W`.
    pub trajectory: Trajectory,
    /// Diagnostics.
    pub report: PlanReport,
}

/// Plans a trajectory: pattern, projection, resampling, tool frames, timing, world frame.
///
/// # Errors
/// [`Error::Input`] for a bad configuration, a malformed mesh or polyline file;
/// [`Error::Failed`] if the scan holds no object surface, the pattern misses the object, or is
/// wider than the scanned surface (unless clipped).
pub fn plan(input: &PlanInput, config: &PlanConfig) -> Result<Plan> {
    config.validate()?;
    let radius = config.projection.smoothing_radius_m;
    let surfaces = match &input.object {
        Some(obj) => {
            if obj.scan_surface.triangles.is_empty() {
                return Err(Error::failed(
                    "plan",
                    "the scan holds no object surface (no triangles)",
                ));
            }
            let (scan, reference) = rayon::join(
                || SmoothSurface::new(obj.scan_surface, Facing::Toward(input.viewpoint), radius),
                || SmoothSurface::new(obj.reference, Facing::Winding, radius),
            );
            Some((obj, scan?, reference?))
        }
        None => None,
    };
    let t_world_scan = config.frames.t_world_scan();
    let ctx = Context {
        input,
        projection: &config.projection,
        object: surfaces.as_ref().map(|(obj, scan, reference)| ObjectContext {
            input: obj,
            projector: Projector {
                primary: scan,
                fallback: Some(reference),
                config: &config.projection,
            },
            reference,
        }),
        t_world_scan,
    };
    let path: PatternPath = match config.pattern {
        PatternKind::Ring => patterns::ring(&ctx, &config.ring)?,
        PatternKind::Raster => patterns::raster(&ctx, &config.raster)?,
        PatternKind::Line => patterns::line(&ctx, &config.line)?,
        PatternKind::Polyline => patterns::polyline(&ctx, &config.polyline)?,
    };
    // A pattern clipped to the scanned surface is as short as the scan made it: a scan too
    // small for the pattern, not a bad timing.
    let (samples, spacing) =
        timing::resample(&path.points, config.timing.spacing()).map_err(|e| match e {
            Error::Input { reason, .. } if path.clipped => Error::failed(
                "plan",
                format!(
                    "{reason} (the pattern was clipped to the scanned surface, which is too small for it)"
                ),
            ),
            other => other,
        })?;
    let points: Vec<Point3<f64>> = samples.iter().map(|p| p.point).collect();
    let window = (radius / spacing).round().max(1.0) as usize;
    let normals = tool_frame::smooth_along(&samples.iter().map(|p| p.normal).collect::<Vec<_>>(), window);
    let orientations = tool_frame::tool_frames(
        &points,
        &normals,
        window,
        config.tool.service_angle_deg.to_radians(),
        config.tool.x_axis,
    );
    let max_rate = config.tool.max_rate_deg_s.to_radians();
    let (mut timed, stats) = timing::schedule(&samples, &orientations, spacing, &config.timing, max_rate);
    for s in &mut timed {
        s.position = t_world_scan * s.position;
        s.orientation = t_world_scan.rotation * s.orientation;
        s.k = t_world_scan.rotation * s.k;
    }
    let trajectory = Trajectory {
        samples: timed,
        notes: vec![
            format!("pattern: {}", config.pattern.as_str()),
            Trajectory::t_world_scan_note(&t_world_scan),
        ],
    };
    let contact: Vec<_> = trajectory.phase(Phase::Contact).collect();
    let max_rate_deg_s = contact
        .windows(2)
        .map(|w| w[0].orientation.angle_to(&w[1].orientation) / (w[1].t - w[0].t))
        .fold(0.0, f64::max)
        .to_degrees();
    let report = PlanReport {
        pattern: config.pattern.as_str().to_string(),
        points: trajectory.samples.len(),
        contact_points: contact.len(),
        length_m: trajectory.contact_length(),
        duration_s: trajectory.duration(),
        speed_m_s: config.timing.speed_m_s,
        spacing_m: spacing,
        fallback_points: contact.iter().filter(|s| s.fallback).count(),
        rows: path.rows,
        row_spacing_m: path.row_spacing_m,
        arc_deg: path.arc_deg,
        clipped: path.clipped,
        max_rate_deg_s,
        rate_limited_steps: stats.rate_limited_steps,
        phase_durations_s: [stats.approach_s, stats.dwell_s, stats.contact_s, stats.retreat_s],
        force_max_n: contact.iter().map(|s| s.force).fold(0.0, f64::max),
        frame: "W",
        t_world_scan: pose_to_rows(&t_world_scan),
        object_axes: input.object.map(|o| o.axes),
    };
    Ok(Plan { trajectory, report })
}
