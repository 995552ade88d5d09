//! The perception pipeline: a scan to the object's cluster ([`segment`]), and on to the aligned
//! reference model, the triangulated scan surface and the alignment's accuracy ([`check`]).
//!
//! Stages, in order, each configured by its own table of [`PerceptionConfig`] and timed:
//! `clean` (range gate, voxel down-sampling, statistical outlier removal) → `seabed` (RANSAC plane,
//! [`crate::segment::seabed`]) → `cluster` (Euclidean clusters of what stands on it) → `select`
//! (the cluster that matches the reference's size and shape) → `register` (global initial guess
//! and hidden-point removal, alongside the object's normals; ICP) → `surface` (2.5-D Delaunay of
//! the object; no triangle across a pixel that saw another point of the cleaned scan) →
//! `accuracy` (the seed's \[59\] test trajectories; pose errors and ADD-S with ground truth).
//!
//! Frames: everything is in the scan frame `S` (camera at `view.camera_m`, the origin for a
//! stereo scan) except the reference model, which is in its own frame; `t_scan_reference` maps the
//! model into the scan. Units: metres, seconds.

use crate::accuracy::{
    AccuracyConfig, Deviation, FreeSpace, TruthErrors, free_space, trajectory_accuracy, truth_errors,
};
use crate::cloud::PointCloud;
use crate::cloud::filter::{
    OutlierConfig, RangeCropConfig, VoxelConfig, crop_range, remove_statistical_outliers, voxel_downsample,
};
use crate::cloud::normals::NormalConfig;
use crate::cloud::pca::{PrincipalAxes, principal_axes};
use crate::config::{non_negative, require};
use crate::error::{Error, Result};
use crate::frames::Pose;
use crate::mesh::TriangleMesh;
use crate::register::{InitMode, ReferenceModel, RegisterConfig, Registration, ScanNormals, register};
use crate::segment::cluster::{Cluster, ClusterConfig, Clustering, euclidean_clusters};
use crate::segment::seabed::{SeabedConfig, SeabedFit, find_seabed, object_side};
use crate::segment::select::{SelectConfig, Selection, select_cluster, span_score, spans_text};
use crate::spatial::KdIndex;
use crate::surface::Surface;
use crate::triangulate::{SurfaceConfig, median_spacing, triangulate_view};
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::time::Instant;

/// Cleaning of the raw scan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CleanConfig {
    /// Closest kept range from the camera, metres (≥ 0).
    pub min_range_m: f64,
    /// Farthest kept range from the camera, metres: above `min_range_m`, or 0 for no limit.
    pub max_range_m: f64,
    /// Voxel edge for down-sampling, metres (≥ 0); 0 keeps every point.
    pub voxel_m: f64,
    /// Remove statistical outliers (flying pixels, speckle).
    pub remove_outliers: bool,
    /// Statistical outlier removal.
    pub outliers: OutlierConfig,
}

impl Default for CleanConfig {
    fn default() -> Self {
        CleanConfig {
            min_range_m: 0.0,
            max_range_m: 0.0,
            voxel_m: 0.0,
            remove_outliers: true,
            outliers: OutlierConfig::default(),
        }
    }
}

/// Where the camera is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ViewConfig {
    /// The camera's centre in the scan frame, metres (the origin for a stereo scan in `S`;
    /// within ±[`MAX_COORDINATE_M`]).
    pub camera_m: [f64; 3],
}

impl Default for ViewConfig {
    fn default() -> Self {
        ViewConfig { camera_m: [0.0; 3] }
    }
}

impl ViewConfig {
    /// The camera's centre.
    pub fn camera(&self) -> Point3<f64> {
        Point3::from(self.camera_m)
    }

    /// Checks `camera_m`: three finite coordinates within ±[`MAX_COORDINATE_M`] (squared
    /// distances from farther away overflow).
    ///
    /// # Errors
    /// [`Error::Input`] naming `view.camera_m`.
    pub fn validate(&self) -> Result<()> {
        check_camera(&self.camera())
    }
}

/// Largest coordinate of the camera's centre, metres: 1000 km, far beyond any scene, and far
/// below where squared distances overflow.
pub const MAX_COORDINATE_M: f64 = 1e6;

/// `Ok` if `camera` is finite and within ±[`MAX_COORDINATE_M`] on every axis, else an input error
/// naming `view.camera_m`.
fn check_camera(camera: &Point3<f64>) -> Result<()> {
    require(
        camera.iter().all(|c| c.abs() <= MAX_COORDINATE_M),
        "view.camera_m",
        format!(
            "must be three finite coordinates within ±{MAX_COORDINATE_M} m, got [{}, {}, {}]",
            crate::config::shown(camera.x),
            crate::config::shown(camera.y),
            crate::config::shown(camera.z)
        ),
    )
}

impl CleanConfig {
    /// Checks every value.
    ///
    /// # Errors
    /// [`Error::Input`] naming the field (`clean.…`).
    pub fn validate(&self) -> Result<()> {
        non_negative("clean.min_range_m", self.min_range_m)?;
        non_negative("clean.max_range_m", self.max_range_m)?;
        require(
            self.max_range_m == 0.0 || self.max_range_m > self.min_range_m,
            "clean.max_range_m",
            format!(
                "must exceed clean.min_range_m ({}) or be 0 for no limit, got {}",
                crate::config::shown(self.min_range_m),
                crate::config::shown(self.max_range_m)
            ),
        )?;
        non_negative("clean.voxel_m", self.voxel_m)?;
        self.outliers.validate("clean.outliers")
    }
}

/// Configuration of every perception stage (the `[perception]` tables of a pipeline file, or a
/// `--config` file of `uvms segment` / `uvms check`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PerceptionConfig {
    /// The camera.
    pub view: ViewConfig,
    /// Cleaning of the raw scan.
    pub clean: CleanConfig,
    /// Seabed removal.
    pub seabed: SeabedConfig,
    /// Euclidean clustering.
    pub cluster: ClusterConfig,
    /// Choice of the object's cluster.
    pub select: SelectConfig,
    /// Normals of the scanned object.
    pub normals: NormalConfig,
    /// Registration of the reference model.
    pub register: RegisterConfig,
    /// Triangulation of the scanned object.
    pub surface: SurfaceConfig,
    /// The \[59\] accuracy estimate.
    pub accuracy: AccuracyConfig,
}

impl PerceptionConfig {
    /// Checks every stage's values, so that a bad value of a late stage is reported before the
    /// first stage runs.
    ///
    /// # Errors
    /// [`Error::Input`] naming the first bad field (`seabed.threshold_m`, `register.icp.…`).
    pub fn validate(&self) -> Result<()> {
        self.view.validate()?;
        self.clean.validate()?;
        self.seabed.validate()?;
        self.cluster.validate()?;
        self.select.validate()?;
        self.normals.validate()?;
        self.register.validate()?;
        self.surface.validate()?;
        self.accuracy.validate()?;
        crate::config::within_range(self, "")
    }
}

/// Wall time of one stage.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StageTime {
    /// Stage name.
    pub stage: String,
    /// Wall time, seconds.
    pub seconds: f64,
}

/// Per-stage wall times, in the order the stages ran.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Timings(pub Vec<StageTime>);

impl Timings {
    /// Runs `f` and records its wall time under `stage`.
    pub fn time<T>(&mut self, stage: &str, f: impl FnOnce() -> T) -> T {
        let t0 = Instant::now();
        let out = f();
        self.0.push(StageTime {
            stage: stage.to_string(),
            seconds: t0.elapsed().as_secs_f64(),
        });
        out
    }

    /// Total wall time, seconds.
    pub fn total(&self) -> f64 {
        self.0.iter().map(|s| s.seconds).sum()
    }
}

/// Point counts through the cleaning stage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CleanReport {
    /// Points in the scan.
    pub input: usize,
    /// After the range gate.
    pub after_range: usize,
    /// After voxel down-sampling.
    pub after_voxel: usize,
    /// After outlier removal.
    pub after_outliers: usize,
}

/// The scan cleaned and cut into seabed, clusters and the object.
#[derive(Debug, Clone)]
pub struct Segmentation {
    /// The cleaned scan; every index below refers to it.
    pub cloud: PointCloud,
    /// Point counts through cleaning.
    pub cleaning: CleanReport,
    /// The seabed (when the stage ran).
    pub seabed: Option<SeabedFit>,
    /// Points on the object side of the seabed (all points without the seabed stage).
    pub object_side: Vec<usize>,
    /// The clusters' link, metres (`cluster.tolerance_m` or longer for a sparse scan; `None`
    /// with clustering off).
    pub link_m: Option<f64>,
    /// Clusters (largest first); one cluster of the whole object side when clustering is off.
    pub clusters: Vec<Cluster>,
    /// The object's cluster.
    pub selection: Selection,
    /// Wall time per stage.
    pub timings: Timings,
}

impl Segmentation {
    /// The object's cluster.
    pub fn object(&self) -> &Cluster {
        &self.clusters[self.selection.index]
    }

    /// The object's points (scan frame), with their colours when the scan has them.
    pub fn object_cloud(&self) -> PointCloud {
        self.cloud.select(&self.object().indices)
    }
}

/// The cleaning stage.
///
/// # Errors
/// [`Error::Input`] for a bad configuration; [`Error::Failed`] (stage `clean`) when no point
/// survives.
pub fn clean(
    scan: &PointCloud,
    cfg: &CleanConfig,
    camera: &Point3<f64>,
) -> Result<(PointCloud, CleanReport)> {
    cfg.validate()?;
    check_camera(camera)?;
    let input = scan.len();
    let mut cloud: Cow<'_, PointCloud> = if cfg.min_range_m > 0.0 || cfg.max_range_m > 0.0 {
        let gate = RangeCropConfig {
            viewpoint: camera.coords.into(),
            min_m: cfg.min_range_m,
            max_m: if cfg.max_range_m > 0.0 {
                cfg.max_range_m
            } else {
                f64::INFINITY
            },
        };
        Cow::Owned(crop_range(scan, &gate)?.cloud)
    } else {
        Cow::Borrowed(scan)
    };
    let after_range = cloud.len();
    if cfg.voxel_m > 0.0 && !cloud.is_empty() {
        cloud = Cow::Owned(voxel_downsample(&cloud, &VoxelConfig { voxel_m: cfg.voxel_m })?.cloud);
    }
    let after_voxel = cloud.len();
    if cfg.remove_outliers && cloud.len() > cfg.outliers.neighbours {
        cloud = Cow::Owned(remove_statistical_outliers(&cloud, &cfg.outliers)?.cloud);
    }
    let cloud = cloud.into_owned();
    if cloud.is_empty() {
        return Err(Error::failed(
            "clean",
            format!("no point of the {input} left after cleaning"),
        ));
    }
    let report = CleanReport {
        input,
        after_range,
        after_voxel,
        after_outliers: cloud.len(),
    };
    Ok((cloud, report))
}

/// Cleans the scan, removes the seabed (near the prior `up` when given), clusters what stands on
/// it and chooses the object's cluster: the one matching `reference_spans` (the reference model's
/// principal spans, decreasing) or, without a reference, the largest.
///
/// # Errors
/// [`Error::Input`] for a bad configuration; [`Error::Failed`] when no plane, no cluster or no
/// cluster fitting the reference is found.
pub fn segment(
    scan: &PointCloud,
    up: Option<&Vector3<f64>>,
    reference_spans: Option<&Vector3<f64>>,
    cfg: &PerceptionConfig,
) -> Result<Segmentation> {
    cfg.validate()?;
    let mut timings = Timings::default();
    let camera = cfg.view.camera();
    let (cloud, cleaning) = timings.time("clean", || clean(scan, &cfg.clean, &camera))?;
    let (seabed, object_side) = if cfg.seabed.enabled {
        let fit = timings.time("seabed", || find_seabed(&cloud.points, up, &cfg.seabed))?;
        let side = object_side(&cloud.points, &fit, &cfg.seabed);
        (Some(fit), side)
    } else {
        ((None), (0..cloud.len()).collect())
    };
    if object_side.is_empty() {
        return Err(Error::failed(
            "cluster",
            "no point on the object side of the seabed",
        ));
    }
    let side_points: Vec<Point3<f64>> = object_side.iter().map(|&i| cloud.points[i]).collect();
    let mut link_m = None;
    let clusters = timings.time("cluster", || -> Result<Vec<Cluster>> {
        if cfg.cluster.enabled {
            let spacing = KdIndex::new(&side_points).map_or(0.0, |ix| median_spacing(&side_points, &ix));
            // Points farther apart than the reference is long are the scan's units, not its
            // density (the bottle's scan in millimetres: 4.8 "m" apart, against its 0.71 m).
            if let Some(r) = reference_spans
                && spacing > r.max()
            {
                return Err(Error::failed(
                    "cluster",
                    format!(
                        "the points above the seabed lie {} m from their nearest (median), farther than the reference's {} m is long: the scan in millimetres? (PLY coordinates must be metres)",
                        crate::config::shown_significant(spacing, 2),
                        crate::config::shown_significant(r.max(), 2)
                    ),
                ));
            }
            let linked = ClusterConfig {
                tolerance_m: cfg.cluster.link_m(spacing),
                ..cfg.cluster.clone()
            };
            link_m = Some(linked.tolerance_m);
            let found = euclidean_clusters(&side_points, &linked)?;
            if found.clusters.is_empty() {
                return Err(no_cluster(&side_points, &found, &linked, spacing));
            }
            // Back to indices into the cleaned cloud.
            Ok(found
                .clusters
                .into_iter()
                .map(|c| Cluster {
                    indices: c.indices.iter().map(|&i| object_side[i]).collect(),
                    shape: c.shape,
                })
                .collect())
        } else {
            let shape = principal_axes(&side_points, cfg.cluster.span_quantile)
                .ok_or_else(|| Error::failed("cluster", "no points"))?;
            Ok(vec![Cluster {
                indices: object_side.clone(),
                shape,
            }])
        }
    })?;
    let selection = timings.time("select", || {
        select_cluster(&clusters, reference_spans, &cfg.select)
    })?;
    Ok(Segmentation {
        cloud,
        cleaning,
        seabed,
        object_side,
        link_m,
        clusters,
        selection,
        timings,
    })
}

/// How `check` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckOptions {
    /// Prior on the seabed normal in the scan frame.
    pub up: Option<Vector3<f64>>,
    /// Where ICP starts.
    pub init: InitMode,
    /// The scan is the object already: skip the seabed, clustering and selection.
    pub whole_scan: bool,
    /// The true `t_scan_reference`, when known.
    pub truth: Option<Pose>,
}

impl Default for CheckOptions {
    fn default() -> Self {
        CheckOptions {
            up: None,
            init: InitMode::Auto,
            whole_scan: false,
            truth: None,
        }
    }
}

/// Everything `check` found: the public results the planning stage uses.
#[derive(Debug, Clone)]
pub struct CheckResult {
    /// The segmentation (`None` with `whole_scan`).
    pub segmentation: Option<Segmentation>,
    /// The scanned object's points with their normals (scan frame).
    pub object: PointCloud,
    /// The scanned object's principal axes and spans (scan frame).
    pub object_shape: PrincipalAxes,
    /// The registration: `t_scan_reference`, fitness, inlier RMSE, iterations, convergence.
    pub registration: Registration,
    /// The reference model's principal axes placed in the scan frame (its longitudinal axis is
    /// column 0 of `axes`).
    pub reference_axes: PrincipalAxes,
    /// The triangulated scan surface of the object (scan frame, normals towards the camera).
    pub scan_surface: TriangleMesh,
    /// The aligned reference surface (scan frame): the model's mesh moved by `t_scan_reference`,
    /// or for a point-cloud model the triangulation of its visible points.
    pub reference_surface: TriangleMesh,
    /// The seed's \[59\] estimate: test trajectories on both surfaces.
    pub accuracy: Deviation,
    /// How much of the aligned model lies where the camera saw past it.
    pub free_space: FreeSpace,
    /// Errors against the ground truth, when given.
    pub truth: Option<TruthErrors>,
    /// Wall time per stage (segmentation's stages included).
    pub timings: Timings,
}

/// The failure of a clustering that found no cluster, with what it found: the points above the
/// seabed in clusters too small (a scan sparser than the link's length) or too large.
fn no_cluster(points: &[Point3<f64>], found: &Clustering, cfg: &ClusterConfig, spacing: f64) -> Error {
    if points.len() < cfg.min_points {
        return Error::failed(
            "cluster",
            format!(
                "no cluster above the seabed: only {} points lie on its object side, fewer than perception.cluster.min_points = {}: a bare seabed, or an object lower than the seabed's threshold",
                points.len(),
                cfg.min_points
            ),
        );
    }
    Error::failed(
        "cluster",
        format!(
            "no cluster above the seabed: of its {} points, {} lie in clusters of fewer than perception.cluster.min_points = {} and {} clusters exceed max_points = {}, linked within {} m (perception.cluster.tolerance_m, or spacing_factor times the spacing), while a point's nearest lies {} m from it (median): a scan sparser than the link, such as one from a far camera, needs a longer link",
            points.len(),
            found.small_points,
            cfg.min_points,
            found.large_clusters,
            cfg.max_points,
            cfg.tolerance_m,
            crate::config::shown_significant(spacing, 2)
        ),
    )
}

/// Segments the scan (unless `whole_scan`), registers `model` onto the object, triangulates the
/// object's surface and estimates the alignment's accuracy.
///
/// # Errors
/// [`Error::Input`] for a bad configuration; [`Error::Failed`] naming the stage that failed (no
/// plane, no fitting cluster, ICP not converged — with what it reached).
pub fn check(
    scan: &PointCloud,
    model: &ReferenceModel,
    opts: &CheckOptions,
    cfg: &PerceptionConfig,
) -> Result<CheckResult> {
    cfg.validate()?;
    let camera = cfg.view.camera();
    let (segmentation, object_points, mut timings) = if opts.whole_scan {
        let mut t = Timings::default();
        let (cloud, _) = t.time("clean", || clean(scan, &cfg.clean, &camera))?;
        // The scan is the object: its size must fit the reference's as a cluster's must.
        if let Some(shape) = principal_axes(&cloud.points, cfg.cluster.span_quantile)
            && span_score(&shape.spans, &model.shape.spans, &cfg.select).is_none()
        {
            // A thousand times the reference's size is the scan's units, not its object.
            let ratio = shape.spans.max() / model.shape.spans.max();
            let why = if (300.0..3000.0).contains(&ratio) {
                "the scan in millimetres? (PLY coordinates must be metres)"
            } else {
                "not the reference's object?"
            };
            return Err(Error::failed(
                "select",
                format!(
                    "--whole-scan: the scan's {} m does not fit the reference's {} m within a factor {} (select.max_span_ratio): {why}",
                    spans_text(&shape.spans),
                    spans_text(&model.shape.spans),
                    cfg.select.max_span_ratio
                ),
            ));
        }
        (None, cloud, t)
    } else {
        let seg = segment(scan, opts.up.as_ref(), Some(&model.shape.spans), cfg)?;
        let obj = seg.object_cloud();
        let t = seg.timings.clone();
        (Some(seg), obj, t)
    };
    let mut object = object_points;
    let index = KdIndex::new(&object.points)?;
    let object_shape = principal_axes(&object.points, 0.01)
        .ok_or_else(|| Error::failed("register", "the object has no points"))?;
    // The object's normals are estimated inside the registration, alongside its global initial
    // guess (its timings hold both).
    let normals = ScanNormals::Estimate(&cfg.normals);
    let registration = timings.time("register", || {
        register(
            model,
            &object.points,
            normals,
            &index,
            &camera,
            &opts.init,
            &cfg.register,
        )
    })?;
    object.normals = Some(registration.scan_normals.clone());
    let pose = registration.t_scan_reference;
    let scan_surface = timings.time("surface", || {
        // The rest of the cleaned scan: no triangle of the object spans a pixel that saw
        // something else.
        let others = segmentation.as_ref().map_or_else(Vec::new, |seg| {
            let mut on_object = vec![false; seg.cloud.len()];
            seg.object().indices.iter().for_each(|&i| on_object[i] = true);
            seg.cloud
                .points
                .iter()
                .zip(&on_object)
                .filter(|&(_, &o)| !o)
                .map(|(p, _)| *p)
                .collect()
        });
        triangulate_view(&object.points, &others, &camera, &cfg.surface)
    })?;
    // The aligned model's points the camera sees.
    let seen: Vec<Point3<f64>> = registration
        .visible
        .iter()
        .map(|&i| pose * model.points[i])
        .collect();
    let reference_surface = timings.time("reference_surface", || match &model.mesh {
        Some(m) => Ok(m.transformed(&pose)),
        None => triangulate_view(&seen, &[], &camera, &cfg.surface),
    })?;
    let free_space = timings.time("free_space", || {
        let scanned = segmentation.as_ref().map_or(&object.points, |s| &s.cloud.points);
        let normals: Vec<Vector3<f64>> = registration
            .visible
            .iter()
            .map(|&i| pose * model.normals[i])
            .collect();
        let mut ranges: Vec<f64> = object.points.iter().map(|p| (p - camera).norm()).collect();
        let range = crate::cloud::pca::median(&mut ranges).unwrap_or(1.0);
        let spacing_rad = median_spacing(&object.points, &index) / range;
        free_space(
            scanned,
            &seen,
            &normals,
            &camera,
            spacing_rad,
            10.0 * registration.scan_noise_m,
        )
    });
    if free_space.fraction() > cfg.accuracy.max_free_space {
        return Err(Error::failed(
            "accuracy",
            format!(
                "{:.1} % of the aligned reference's {} points seen face-on lie in front of all the camera saw around them, by up to {:.0} mm (accuracy.max_free_space {}): the camera saw past where the reference is put: a wrong alignment (a face on the back of a wall, slid along the object, turned end for end), a reference larger than the object, or [view] camera_m not where the scan was taken from",
                100.0 * free_space.fraction(),
                free_space.judged,
                1e3 * free_space.max_m,
                crate::config::shown(cfg.accuracy.max_free_space)
            ),
        ));
    }
    let accuracy = timings.time("accuracy", || -> Result<Deviation> {
        let scan_s = Surface::new(&scan_surface)?;
        let ref_s = Surface::new(&reference_surface)?;
        trajectory_accuracy(&object.points, &camera, &scan_s, &ref_s, &cfg.accuracy)
    })?;
    let truth = match &opts.truth {
        Some(t) => Some(truth_errors(&model.points, model.mesh.as_ref(), &pose, t)?),
        None => None,
    };
    let reference_axes = PrincipalAxes {
        centroid: pose * model.shape.centroid,
        axes: pose.rotation.to_rotation_matrix().matrix() * model.shape.axes,
        variances: model.shape.variances,
        spans: model.shape.spans,
    };
    Ok(CheckResult {
        segmentation,
        object,
        object_shape,
        registration,
        reference_axes,
        scan_surface,
        reference_surface,
        accuracy,
        free_space,
        truth,
        timings,
    })
}

/// Asserts that `r` is a bad-input error (exit code 2) on one line naming `field`.
#[cfg(test)]
#[track_caller]
pub(crate) fn assert_bad_input<T: std::fmt::Debug>(r: Result<T>, field: &str) {
    let e = r.expect_err(field);
    let msg = e.to_string();
    assert_eq!(e.exit_code(), 2, "{msg}");
    assert!(
        msg.starts_with(&format!("{field}: ")),
        "{msg} does not name {field}"
    );
    assert!(!msg.contains('\n'), "{msg}");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::from_toml_str;

    /// A plate scanned 12 mm apart, sparser than the 10 mm link: every point alone and no
    /// cluster with the link fixed (`spacing_factor = 0`), one cluster of every point with the
    /// link at twice the spacing.
    #[test]
    fn the_cluster_link_follows_a_sparse_scan() {
        let plate: Vec<Point3<f64>> = (0..30 * 20)
            .map(|i| Point3::new((i % 30) as f64 * 0.012, (i / 30) as f64 * 0.012, 1.0))
            .collect();
        let scan = PointCloud {
            points: plate,
            ..PointCloud::default()
        };
        let mut cfg = PerceptionConfig::default();
        cfg.seabed.enabled = false;
        cfg.clean.remove_outliers = false;
        let seg = segment(&scan, None, None, &cfg).unwrap();
        assert_eq!(seg.object().indices.len(), 600);
        assert!((seg.link_m.unwrap() - 0.024).abs() < 1e-9, "{:?}", seg.link_m);
        cfg.cluster.spacing_factor = 0.0;
        let e = segment(&scan, None, None, &cfg).unwrap_err().to_string();
        assert!(e.contains("linked within 0.01 m"), "{e}");
        // The plate as a seabed with one point before it: a bare seabed, not a sparse scan.
        let mut bare = scan.clone();
        bare.points.push(Point3::new(0.1, 0.1, 0.9));
        cfg.seabed.enabled = true;
        let e = segment(&bare, None, None, &cfg).unwrap_err().to_string();
        assert!(e.contains("only 1 points lie on its object side"), "{e}");
    }

    /// The values the review found accepted, or failing late with the wrong exit code.
    #[test]
    fn every_bad_value_is_named_before_work_starts() {
        for (text, field) in [
            ("[view]\ncamera_m = [nan, 0.0, 0.0]", "view.camera_m"),
            ("[view]\ncamera_m = [-1e300, 0.0, 0.0]", "view.camera_m"),
            ("[clean]\nmin_range_m = nan", "clean.min_range_m"),
            ("[clean]\nmin_range_m = -1.0", "clean.min_range_m"),
            ("[clean]\nmax_range_m = nan", "clean.max_range_m"),
            (
                "[clean]\nmin_range_m = 2.0\nmax_range_m = 1.0",
                "clean.max_range_m",
            ),
            ("[clean]\nvoxel_m = nan", "clean.voxel_m"),
            (
                "[clean.outliers]\nneighbours = 18446744073709551615",
                "clean.outliers.neighbours",
            ),
            (
                "[seabed]\nobject_min_height_m = nan",
                "seabed.object_min_height_m",
            ),
            (
                "[seabed]\nobject_max_height_m = nan",
                "seabed.object_max_height_m",
            ),
            ("[seabed]\nmax_threshold_m = inf", "seabed.max_threshold_m"),
            (
                "[seabed]\nmax_iterations = 18446744073709551615",
                "seabed.max_iterations",
            ),
            ("[cluster]\nspan_quantile = nan", "cluster.span_quantile"),
            ("[cluster]\nspacing_factor = -1.0", "cluster.spacing_factor"),
            ("[cluster]\nspacing_factor = 1e3", "cluster.spacing_factor"),
            ("[cluster]\nspan_quantile = 1e300", "cluster.span_quantile"),
            ("[select]\ndepth_weight = nan", "select.depth_weight"),
            ("[select]\ndepth_weight = inf", "select.depth_weight"),
            ("[normals]\nradius_m = nan", "normals.radius_m"),
            ("[normals]\nneighbours = 1000000000", "normals.neighbours"),
            ("[register]\nmin_fitness = nan", "register.min_fitness"),
            (
                "[register]\nevaluation_distance_m = nan",
                "register.evaluation_distance_m",
            ),
            (
                "[register]\nmesh_samples = 18446744073709551615",
                "register.mesh_samples",
            ),
            ("[register]\nmesh_samples = 1000000000", "register.mesh_samples"),
            (
                "[register.init]\ngate_fraction = 0.004",
                "register.init.gate_fraction",
            ),
            (
                "[register.init]\nscore_fraction = inf",
                "register.init.score_fraction",
            ),
            (
                "[register.init]\nrotation_steps = 18446744073709551615",
                "register.init.rotation_steps",
            ),
            ("[register.init]\nrefine = 1000000000", "register.init.refine"),
            (
                "[register.hidden_points]\nradius_factor = nan",
                "register.hidden_points.radius_factor",
            ),
            (
                "[register.icp]\ntranslation_tolerance_m = 0.0",
                "register.icp.translation_tolerance_m",
            ),
            (
                "[surface]\nmax_view_angle_deg = inf",
                "surface.max_view_angle_deg",
            ),
            (
                "[surface]\nsmoothing_neighbours = 18446744073709551615",
                "surface.smoothing_neighbours",
            ),
            ("[accuracy]\nlines = 18446744073709551615", "accuracy.lines"),
            ("[accuracy]\nmax_free_space = 1.5", "accuracy.max_free_space"),
            ("[accuracy]\nmax_free_space = nan", "accuracy.max_free_space"),
            (
                "[accuracy]\nsamples_per_line = 1000000000",
                "accuracy.samples_per_line",
            ),
        ] {
            let cfg: PerceptionConfig = from_toml_str(text, "c.toml").unwrap();
            assert_bad_input(cfg.validate(), field);
        }
        PerceptionConfig::default().validate().unwrap();
    }

    /// A flat patch with a box on it, seen from 1 m.
    fn scan() -> PointCloud {
        let mut pts: Vec<Point3<f64>> = (0..4900)
            .map(|i| {
                Point3::new(
                    -0.35 + 0.01 * (i % 70) as f64,
                    -0.35 + 0.01 * (i / 70) as f64,
                    1.0,
                )
            })
            .collect();
        pts.extend((0..400).map(|i| Point3::new(0.005 * (i % 20) as f64, 0.005 * (i / 20) as f64, 0.95)));
        PointCloud::from_points(pts)
    }

    #[test]
    fn stages_reject_bad_values_with_exit_2_not_a_failed_run() {
        let scan = scan();
        // A NaN camera left no point "in front of the camera" (exit 1) in the surface stage.
        let mut cfg = PerceptionConfig::default();
        cfg.view.camera_m = [f64::NAN, 0.0, 0.0];
        assert_bad_input(segment(&scan, None, None, &cfg), "view.camera_m");
        assert_bad_input(
            clean(&scan, &cfg.clean, &Point3::new(f64::NAN, 0.0, 0.0)),
            "view.camera_m",
        );
        // A NaN span quantile made every span 0 and failed the selection (exit 1).
        let mut cfg = PerceptionConfig::default();
        cfg.cluster.span_quantile = f64::NAN;
        assert_bad_input(
            segment(&scan, None, Some(&Vector3::new(0.1, 0.1, 0.05)), &cfg),
            "cluster.span_quantile",
        );
        let mut cfg = PerceptionConfig::default();
        cfg.clean.voxel_m = f64::NAN;
        assert_bad_input(clean(&scan, &cfg.clean, &Point3::origin()), "clean.voxel_m");
    }
}
