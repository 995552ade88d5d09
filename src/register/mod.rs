//! Registration of the reference model to the scanned object: a global initial guess that the
//! object's symmetries cannot fool ([`init`]), hidden-point removal from the camera's viewpoint
//! ([`hidden_points`]), then point-to-plane ICP ([`icp`]).
//!
//! Convention (as small_gicp's `T_target_source`): the reference model is the ICP source, the
//! scanned object the target, and the result `t_scan_reference` maps reference coordinates into
//! the scan frame `S` (the camera where `[view] camera_m` puts it, the origin by default).
//! Units: metres, degrees in reports.

pub mod hidden_points;
pub mod hull;
pub mod icp;
pub mod init;

use crate::cloud::PointCloud;
use crate::cloud::normals::{NormalConfig, estimate_normals};
use crate::cloud::pca::{PrincipalAxes, mean_covariance_of, median, principal_axes, sorted_eigen};
use crate::error::{Error, Result};
use crate::frames::Pose;
use crate::mesh::TriangleMesh;
use crate::spatial::KdIndex;
use crate::surface::Surface;
use hidden_points::{HiddenPointConfig, visible_points};
use icp::{IcpConfig, IcpOutcome, Surfel, evaluate, icp_point_to_plane};
use init::{InitConfig, InitOutcome, initial_guess};
use nalgebra::{Point3, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The reference model prepared for registration (its own frame).
pub struct ReferenceModel {
    /// Surface points, metres.
    pub points: Vec<Point3<f64>>,
    /// Unit normals of `points` (sign arbitrary for a cloud).
    pub normals: Vec<Vector3<f64>>,
    /// Index over `points`.
    pub index: KdIndex,
    /// Principal axes and spans (1–99 % quantiles) of `points`.
    pub shape: PrincipalAxes,
    /// The model's mesh when it came as one.
    pub mesh: Option<TriangleMesh>,
    /// Median distance between neighbouring model points, metres.
    pub spacing_m: f64,
}

impl ReferenceModel {
    /// From a triangle mesh: `samples` points spread uniformly over its surface (seeded).
    ///
    /// # Errors
    /// [`Error::Input`] naming `register.mesh_samples` when `samples` is out of its bounds
    /// ([`MIN_MESH_SAMPLES`], [`MAX_MESH_SAMPLES`]), or naming `what` if the mesh has no area.
    pub fn from_mesh(mesh: TriangleMesh, samples: usize, seed: u64, what: &str) -> Result<Self> {
        check_mesh_samples(samples)?;
        let (points, normals) = mesh.sample_surface(samples, seed);
        if points.is_empty() {
            return Err(Error::input(what, "the reference mesh has no surface area"));
        }
        Self::build(points, normals, Some(mesh), what)
    }

    /// From a point cloud (its normals by PCA, or the file's when present).
    ///
    /// # Errors
    /// [`Error::Input`] (naming `what`) with fewer than 10 points.
    pub fn from_cloud(cloud: PointCloud, normal_cfg: &NormalConfig, what: &str) -> Result<Self> {
        if cloud.len() < 10 {
            return Err(Error::input(
                what,
                format!("the reference has only {} points", cloud.len()),
            ));
        }
        let normals = match cloud.normals {
            Some(n) if n.len() == cloud.points.len() => n,
            _ => {
                let centre =
                    crate::cloud::pca::mean_covariance(&cloud.points).map_or(Point3::origin(), |m| m.0);
                estimate_normals(&cloud.points, normal_cfg, &centre).map_err(|e| Error::input(what, e))?
            }
        };
        Self::build(cloud.points, normals, None, what)
    }

    /// The model's points, normals and index, for ICP.
    pub fn surfel(&self) -> Surfel<'_> {
        Surfel {
            points: &self.points,
            normals: &self.normals,
            index: &self.index,
        }
    }

    /// The model's points at `indices` (model frame).
    pub fn points_at(&self, indices: &[usize]) -> Vec<Point3<f64>> {
        indices.iter().map(|&i| self.points[i]).collect()
    }

    fn build(
        points: Vec<Point3<f64>>,
        normals: Vec<Vector3<f64>>,
        mesh: Option<TriangleMesh>,
        what: &str,
    ) -> Result<Self> {
        crate::cloud::object_size(what, &points)?;
        let index = KdIndex::new(&points).map_err(|e| Error::input(what, e))?;
        let shape = principal_axes(&points, 0.01).ok_or_else(|| Error::input(what, "no points"))?;
        let spacing_m = crate::triangulate::median_spacing(&points, &index);
        Ok(ReferenceModel {
            points,
            normals,
            index,
            shape,
            mesh,
            spacing_m,
        })
    }
}

/// The scanned object's normals for ICP.
#[derive(Debug, Clone, Copy)]
pub enum ScanNormals<'a> {
    /// Given, one per scan point.
    Given(&'a [Vector3<f64>]),
    /// Estimated with this configuration ([`estimate_normals`], oriented towards the camera)
    /// while the global initial guess and the first hidden-point removal run: neither needs them,
    /// and the hidden-point removal is serial, so the two cores share the work.
    Estimate(&'a NormalConfig),
}

/// Where ICP starts.
#[derive(Debug, Clone, PartialEq)]
pub enum InitMode {
    /// The global search of [`init`].
    Auto,
    /// A given `t_scan_reference` (identity, or a user's prior pose).
    Given(Pose),
}

/// Configuration of the registration stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RegisterConfig {
    /// Points sampled on a reference mesh ([`MIN_MESH_SAMPLES`] to [`MAX_MESH_SAMPLES`]).
    pub mesh_samples: usize,
    /// Seed of the mesh sampling.
    pub seed: u64,
    /// Global initial guess (`--init auto`).
    pub init: InitConfig,
    /// Hidden-point removal before ICP.
    pub hidden_points: HiddenPointConfig,
    /// ICP.
    pub icp: IcpConfig,
    /// Symmetric ICP: also pair every scan point with the nearest point of the whole model
    /// (model normal), so that the model's closed geometry holds it where the scan ends.
    pub symmetric: bool,
    /// At most this many ICP runs, each after culling the hidden points again from the last
    /// estimate; a run is skipped when the last moved the camera (in the model's frame) too
    /// little to move the silhouette by half the model's point spacing (1 to
    /// [`MAX_VISIBILITY_ROUNDS`]).
    pub visibility_rounds: usize,
    /// Distance for the reported fitness and inlier RMSE, metres; 0 uses ICP's last gate.
    pub evaluation_distance_m: f64,
    /// Fail when the scan fitness (the fraction of the scanned object within the evaluation
    /// distance of the aligned model's surface, [`Registration::scan_fitness`]) is below this
    /// (a fraction in [0, 1]).
    pub min_fitness: f64,
    /// Fail when ICP's last gate is wider than `icp.min_gate_m` and than `icp.gate_sigmas` ×
    /// this × the scan's own noise ([`scan_noise`]): the residuals then spread this many times
    /// more than the scan's noise, a wrong alignment or a reference that does not fit the object
    /// (0: no such check).
    pub max_noise_ratio: f64,
}

impl Default for RegisterConfig {
    fn default() -> Self {
        RegisterConfig {
            mesh_samples: 20_000,
            seed: 1,
            init: InitConfig::default(),
            hidden_points: HiddenPointConfig::default(),
            icp: IcpConfig::default(),
            symmetric: true,
            visibility_rounds: 2,
            evaluation_distance_m: 0.0,
            min_fitness: 0.3,
            max_noise_ratio: 3.0,
        }
    }
}

/// Fewest points sampled on a reference mesh.
pub const MIN_MESH_SAMPLES: usize = 100;

/// Most points sampled on a reference mesh: 100 times the default, a point every 1.3 mm on
/// the seed's 0.35 m bottle (2.3 m²). Every visibility round culls them (a convex hull) and
/// ICP pairs the scan with them.
pub const MAX_MESH_SAMPLES: usize = 2_000_000;

/// Most ICP runs with the hidden points culled again: 50 times the default (the runs stop
/// once the silhouette no longer moves, usually after two).
pub const MAX_VISIBILITY_ROUNDS: usize = 100;

/// `Ok` if `samples` is within [`MIN_MESH_SAMPLES`] and [`MAX_MESH_SAMPLES`].
fn check_mesh_samples(samples: usize) -> Result<()> {
    crate::config::count_between(
        "register.mesh_samples",
        samples,
        MIN_MESH_SAMPLES,
        MAX_MESH_SAMPLES,
    )
}

impl RegisterConfig {
    /// Checks every value, the global search's, the hidden-point removal's and ICP's included.
    ///
    /// # Errors
    /// [`Error::Input`] naming the field (`register.…`).
    pub fn validate(&self) -> Result<()> {
        use crate::config::{count_between, require};
        check_mesh_samples(self.mesh_samples)?;
        self.init.validate()?;
        self.hidden_points.validate()?;
        self.icp.validate("register.icp")?;
        count_between(
            "register.visibility_rounds",
            self.visibility_rounds,
            1,
            MAX_VISIBILITY_ROUNDS,
        )?;
        crate::config::non_negative("register.evaluation_distance_m", self.evaluation_distance_m)?;
        crate::config::non_negative("register.max_noise_ratio", self.max_noise_ratio)?;
        require(
            (0.0..=1.0).contains(&self.min_fitness),
            "register.min_fitness",
            format!(
                "must be a fraction in [0, 1], got {}",
                crate::config::shown(self.min_fitness)
            ),
        )
    }
}

/// The registration's result.
#[derive(Debug, Clone, PartialEq)]
pub struct Registration {
    /// Maps reference-model coordinates into the scan frame.
    pub t_scan_reference: Pose,
    /// Where ICP started.
    pub initial: Pose,
    /// The global search's outcome (`--init auto`).
    pub init: Option<InitOutcome>,
    /// Indices into the model's points (and normals) of those visible from the camera at the
    /// final pose.
    pub visible: Vec<usize>,
    /// Fraction of the visible reference points with a scan point within the evaluation distance
    /// (Open3D's `fitness`, the reference being the source).
    pub fitness: f64,
    /// Fraction of the scanned object's points within the evaluation distance of the aligned
    /// model's surface (for a point cloud, of the plane of its nearest point): how much of the
    /// scan the model explains.
    pub scan_fitness: f64,
    /// RMS distance of those pairs, metres.
    pub inlier_rmse_m: f64,
    /// The evaluation distance, metres.
    pub evaluation_distance_m: f64,
    /// The scan's own noise ([`scan_noise`]), metres.
    pub scan_noise_m: f64,
    /// ICP iterations over all rounds.
    pub iterations: usize,
    /// The last ICP round converged.
    pub converged: bool,
    /// The last ICP round's outcome.
    pub icp: IcpOutcome,
    /// The scanned object's unit normals ICP used (given or estimated), one per scan point.
    pub scan_normals: Vec<Vector3<f64>>,
    /// Wall time of the sub-stages (`init`, `hidden_points`, `icp` per round).
    pub timings: crate::perception::Timings,
}

/// The fraction of the scanned object `scan` within `dist` of the surface of the model placed by
/// `t_scan_reference`: a mesh's own; for a point cloud, the plane of the nearest point (along its
/// normal), that point no farther than `dist` and three times the cloud's spacing (its points'
/// median distance to their nearest; randomly strewn, one point in 500 is farther from all of
/// them). Counted point to point against a mesh's samples or a cloud's points instead, a point
/// between them reads as far as half their spacing, and a correct alignment's fraction depends
/// on their density (a 1 m box read 0.35 at the default `mesh_samples` and 0.98 at ten times as
/// many; against a cloud of 15,000 of its points, 0.27, below `min_fitness`).
fn scan_fitness(
    model: &ReferenceModel,
    scan: &[Point3<f64>],
    t_scan_reference: &Pose,
    dist: f64,
) -> Result<f64> {
    if scan.is_empty() {
        return Ok(0.0);
    }
    let to_model = t_scan_reference.inverse();
    let surface = model.mesh.as_ref().map(Surface::new).transpose()?;
    let reach = dist + 3.0 * model.spacing_m;
    let within = scan
        .par_iter()
        .filter(|p| {
            let q = to_model * *p;
            match &surface {
                Some(s) => s.distance_within(&q, dist).is_some(),
                None => model.index.nearest_within(&q, reach).is_some_and(|nb| {
                    (q - model.points[nb.index]).dot(&model.normals[nb.index]).abs() <= dist
                }),
            }
        })
        .count();
    Ok(within as f64 / scan.len() as f64)
}

/// Registers `model` onto the scanned object `scan` (scan frame; its normals unit, oriented or
/// not, given or estimated here; `scan_index` over `scan`), seen from `camera` (scan frame): the
/// hidden-point removal keeps the model's points visible from there.
///
/// # Errors
/// [`Error::Input`] for a bad configuration; [`Error::Failed`] (stage `icp`) when ICP finds too
/// few pairs, does not converge, ends below `min_fitness`, or with its residuals spread far
/// beyond the scan's noise (`max_noise_ratio`) — the message says what it reached.
pub fn register(
    model: &ReferenceModel,
    scan: &[Point3<f64>],
    scan_normals: ScanNormals<'_>,
    scan_index: &KdIndex,
    camera: &Point3<f64>,
    init: &InitMode,
    cfg: &RegisterConfig,
) -> Result<Registration> {
    cfg.validate()?;
    // The initial pose and the model's points visible from it, alongside the scan's normals.
    let start = || -> Result<_> {
        let mut timings = crate::perception::Timings::default();
        let (initial, init_outcome) = match init {
            InitMode::Given(p) => (*p, None),
            InitMode::Auto => {
                let shape = principal_axes(scan, 0.01).ok_or_else(|| Error::failed("init", "empty scan"))?;
                let o = timings.time("init", || initial_guess(model, scan, &shape, &cfg.init))?;
                (o.t_scan_reference, Some(o))
            }
        };
        let visible = timings.time("hidden_points", || {
            visible_indices(model, &initial, camera, &cfg.hidden_points)
        });
        Ok((initial, init_outcome, visible, timings))
    };
    let normals = || {
        let mut timings = crate::perception::Timings::default();
        let n = timings.time("normals", || match scan_normals {
            ScanNormals::Given(n) => Ok(n.to_vec()),
            ScanNormals::Estimate(config) => estimate_normals(scan, config, camera),
        });
        (n, timings)
    };
    let (started, (normals, normals_time)) = rayon::join(start, normals);
    let (initial, init_outcome, first_visible, mut timings) = started?;
    let scan_normals = normals?;
    timings.0.extend(normals_time.0);
    if scan_normals.len() != scan.len() {
        return Err(Error::input(
            "register",
            format!("{} normals for {} scan points", scan_normals.len(), scan.len()),
        ));
    }
    let mut first_visible = Some(first_visible);
    let size = model.shape.spans.max();
    let mut gate = if cfg.icp.initial_gate_m > 0.0 {
        cfg.icp.initial_gate_m
    } else {
        0.25 * size
    };
    if let Some(o) = &init_outcome {
        // The global search already brought the model within a few τ of the scan.
        gate = gate.min(4.0 * o.score_m).max(cfg.icp.min_gate_m);
    }
    let mut pose = initial;
    let mut iterations = 0;
    let mut visible = Vec::new();
    let mut last = None;
    let mut culled_from: Option<Pose> = None;
    for _ in 0..cfg.visibility_rounds {
        if culled_from.is_some_and(|p| !silhouette_moved(model, camera, &p, &pose)) {
            break;
        }
        culled_from = Some(pose);
        visible = match first_visible.take() {
            Some(v) => v,
            None => timings.time("hidden_points", || {
                visible_indices(model, &pose, camera, &cfg.hidden_points)
            }),
        };
        let source = model.points_at(&visible);
        let target = Surfel {
            points: scan,
            normals: &scan_normals,
            index: scan_index,
        };
        let reverse = cfg.symmetric.then(|| model.surfel());
        let o = timings.time("icp", || {
            icp_point_to_plane(&source, target, reverse, &pose, gate, &cfg.icp)
        })?;
        iterations += o.iterations;
        pose = o.t_target_source;
        gate = (2.0 * o.gate_m).min(gate);
        last = Some(o);
    }
    let Some(icp) = last else {
        return Err(Error::failed("icp", "no round ran"));
    };
    if culled_from.is_some_and(|p| silhouette_moved(model, camera, &p, &pose)) {
        visible = timings.time("hidden_points", || {
            visible_indices(model, &pose, camera, &cfg.hidden_points)
        });
    }
    let dist = if cfg.evaluation_distance_m > 0.0 {
        cfg.evaluation_distance_m
    } else {
        icp.gate_m
    };
    let (fitness, inlier_rmse_m) = evaluate(&model.points_at(&visible), scan_index, &pose, dist);
    let scan_fitness = scan_fitness(model, scan, &pose, dist)?;
    let reached = format!(
        "fitness {fitness:.3} (scan {scan_fitness:.3}) at {dist:.4} m, inlier RMSE {inlier_rmse_m:.5} m, \
         {iterations} iterations, last step {:.2e}° / {:.2e} m",
        icp.last_step.0.to_degrees(),
        icp.last_step.1
    );
    if !icp.converged {
        return Err(Error::failed(
            "icp",
            format!(
                "did not converge: {reached}: still moving after [register.icp] max_iterations = {} a round; a direction the scan barely constrains, such as a body of revolution's turn about its axis, drifts with the noise: a [register.icp] degenerate_ratio larger than {} holds it, more max_iterations let it settle",
                cfg.icp.max_iterations, cfg.icp.degenerate_ratio
            ),
        ));
    }
    if scan_fitness < cfg.min_fitness {
        return Err(Error::failed(
            "icp",
            format!(
                "scan fitness {} below min_fitness {}: {reached}",
                crate::config::shown_significant(scan_fitness, 6),
                crate::config::shown(cfg.min_fitness)
            ),
        ));
    }
    // ICP's gate follows the residuals' spread down to the noise: a gate left wide is an
    // alignment that explains the scan only as far as that gate (a bunny 126° off converged
    // with a scan fitness of 0.95 at a 39 mm gate, against 0.06 mm of the scan's noise).
    let scan_noise_m = scan_noise(scan, scan_index);
    let noise_gate = cfg.icp.gate_sigmas * cfg.max_noise_ratio * scan_noise_m;
    if cfg.max_noise_ratio > 0.0 && icp.gate_m > noise_gate.max(cfg.icp.min_gate_m) {
        let spread = if scan_noise_m > 0.0 {
            format!("{:.0} times", icp.gate_m / (cfg.icp.gate_sigmas * scan_noise_m))
        } else {
            "beyond".into()
        };
        return Err(Error::failed(
            "icp",
            format!(
                "its residuals spread {spread} the scan's own noise, {:.3} mm (its last gate {:.2} mm; register.max_noise_ratio {}): a wrong alignment, or a reference that does not fit the object: {reached}",
                scan_noise_m * 1e3,
                icp.gate_m * 1e3,
                crate::config::shown(cfg.max_noise_ratio)
            ),
        ));
    }
    Ok(Registration {
        t_scan_reference: pose,
        initial,
        init: init_outcome,
        visible,
        fitness,
        scan_fitness,
        inlier_rmse_m,
        evaluation_distance_m: dist,
        scan_noise_m,
        iterations,
        converged: true,
        icp,
        scan_normals,
        timings,
    })
}

/// Points of the scan [`scan_noise`] looks at, at most (evenly spread over the cloud's order).
const NOISE_SAMPLES: usize = 2000;

/// The scan's own noise: the median, over up to [`NOISE_SAMPLES`] of its points, of the RMS
/// distance of a point's 20 nearest (itself included) to their least-squares plane (the square
/// root of their covariance's least eigenvalue), metres; an upper bound of the noise along the
/// normal, which a surface's curvature over the neighbourhood raises. 0 for fewer than 3 points.
pub fn scan_noise(scan: &[Point3<f64>], index: &KdIndex) -> f64 {
    if scan.len() < 3 {
        return 0.0;
    }
    let step = scan.len().div_ceil(NOISE_SAMPLES);
    let mut rms: Vec<f64> = scan
        .par_iter()
        .step_by(step)
        .filter_map(|p| {
            let near = index.knn(p, 20);
            let (_, cov) = mean_covariance_of(scan, near.iter().map(|n| n.index))?;
            Some(sorted_eigen(&cov).0.min().max(0.0).sqrt())
        })
        .collect();
    median(&mut rms).unwrap_or(0.0)
}

/// Whether moving the model from `from` to `to` moves the camera (scan frame), seen from the
/// model, enough to shift its silhouette by half the model's point spacing: the silhouette of an
/// object of the model's size moves by about its size times the change of the viewing direction.
fn silhouette_moved(model: &ReferenceModel, camera: &Point3<f64>, from: &Pose, to: &Pose) -> bool {
    let (a, b) = (from.inverse() * camera, to.inverse() * camera);
    let range = (a - model.shape.centroid).norm().max(1e-9);
    model.shape.spans.max() * (b - a).norm() / range > 0.5 * model.spacing_m
}

/// Indices (increasing) of the model's points visible from `camera` (scan frame) when the model
/// sits at `pose`; all of them with the hidden-point removal off.
pub fn visible_indices(
    model: &ReferenceModel,
    pose: &Pose,
    camera: &Point3<f64>,
    cfg: &HiddenPointConfig,
) -> Vec<usize> {
    if !cfg.enabled {
        return (0..model.points.len()).collect();
    }
    visible_points(&model.points, &(pose.inverse() * camera), cfg.radius_factor)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use nalgebra::Isometry3;
    use rand::{RngExt, SeedableRng};
    use std::f64::consts::TAU;

    /// A plane scanned on a 2 mm grid with Gaussian noise of σ = 0.5 mm along its normal: the
    /// RMS distance of 20 points to their fitted plane is σ √(χ²₁₇ / 20), whose median is
    /// 0.904 σ; the noise-free plane has none.
    #[test]
    fn scan_noise_is_the_noise_along_the_normal() {
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(7);
        let sigma = 5e-4;
        let mut gauss = || {
            let (u, v): (f64, f64) = (rng.random(), rng.random());
            (-2.0 * (1.0 - u).ln()).sqrt() * (TAU * v).cos()
        };
        let normal = Vector3::new(1.0, 2.0, 2.0) / 3.0;
        let (a, b) = (
            Vector3::new(2.0, -1.0, 0.0) / 5f64.sqrt(),
            normal.cross(&Vector3::new(2.0, -1.0, 0.0)).normalize(),
        );
        let grid = |noise: &mut dyn FnMut() -> f64| -> Vec<Point3<f64>> {
            (0..10_000)
                .map(|i| {
                    let (x, y) = ((i % 100) as f64 * 0.002, (i / 100) as f64 * 0.002);
                    Point3::from(a * x + b * y + normal * (sigma * noise()))
                })
                .collect()
        };
        let noisy = grid(&mut gauss);
        let noise = scan_noise(&noisy, &KdIndex::new(&noisy).unwrap());
        assert!((noise / sigma - 0.904).abs() < 0.05, "{noise}");
        let flat = grid(&mut || 0.0);
        assert!(scan_noise(&flat, &KdIndex::new(&flat).unwrap()) < 1e-9);
    }

    /// Points and outward normals on a bottle lying along x: body radius 0.05 m from x = −0.12 to
    /// 0.1, a neck of radius 0.015 m to x = 0.16, flat ends.
    pub(crate) fn bottle(n: usize, seed: u64) -> (Vec<Point3<f64>>, Vec<Vector3<f64>>) {
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(seed);
        let parts = [(0.05, -0.12, 0.1), (0.015, 0.1, 0.16)];
        let (mut pts, mut nrm) = (Vec::new(), Vec::new());
        while pts.len() < n {
            let k = rng.random_range(0..4);
            let a = rng.random::<f64>() * TAU;
            match k {
                0 | 1 => {
                    let (r, x0, x1) = parts[k];
                    if k == 1 && rng.random::<f64>() > 0.3 {
                        continue; // the neck has less area
                    }
                    let x = rng.random_range(x0..x1);
                    pts.push(Point3::new(x, r * a.cos(), r * a.sin()));
                    nrm.push(Vector3::new(0.0, a.cos(), a.sin()));
                }
                2 => {
                    let r = 0.05 * rng.random::<f64>().sqrt();
                    pts.push(Point3::new(-0.12, r * a.cos(), r * a.sin()));
                    nrm.push(-Vector3::x());
                }
                _ => {
                    let r = 0.015 + (0.05 - 0.015) * rng.random::<f64>();
                    pts.push(Point3::new(0.1, r * a.cos(), r * a.sin()));
                    nrm.push(Vector3::x());
                }
            }
        }
        (pts, nrm)
    }

    /// A single-view scan of the bottle at `truth`: the points whose normal faces the camera,
    /// with Gaussian noise `sigma` along the view ray.
    pub(crate) fn scan_of(truth: &Pose, sigma: f64, seed: u64) -> Vec<Point3<f64>> {
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(seed);
        let (pts, nrm) = bottle(30_000, seed + 100);
        pts.iter()
            .zip(&nrm)
            .filter_map(|(p, n)| {
                let (p, n) = (truth * p, truth * n);
                let ray = p.coords.normalize();
                (n.dot(&ray) < -0.05).then(|| {
                    let g = (-2.0 * rng.random::<f64>().max(1e-300).ln()).sqrt()
                        * (TAU * rng.random::<f64>()).cos();
                    p + ray * (sigma * g)
                })
            })
            .collect()
    }

    #[test]
    fn registers_a_half_seen_bottle_from_any_orientation() {
        let (mp, mn) = bottle(20_000, 1);
        let model = ReferenceModel::build(mp, mn, None, "model").unwrap();
        for (k, (axis, angle)) in [
            (Vector3::new(0.0, 0.0, 1.0), 2.5),
            (Vector3::new(1.0, 1.0, 0.0), 1.2),
            (Vector3::new(0.3, -1.0, 0.5), -2.8),
        ]
        .into_iter()
        .enumerate()
        {
            let truth = Isometry3::new(Vector3::new(0.05, -0.03, 1.0), axis.normalize() * angle);
            let scan = scan_of(&truth, 0.0005, 10 + k as u64);
            let idx = KdIndex::new(&scan).unwrap();
            let normals = estimate_normals(&scan, &NormalConfig::default(), &Point3::origin()).unwrap();
            let r = register(
                &model,
                &scan,
                ScanNormals::Given(&normals),
                &idx,
                &Point3::origin(),
                &InitMode::Auto,
                &RegisterConfig::default(),
            )
            .unwrap();
            // The bottle is a body of revolution: its turn about its axis is not observable.
            let axis_deg = (r.t_scan_reference * Vector3::x())
                .angle(&(truth * Vector3::x()))
                .to_degrees();
            let m = (r.t_scan_reference.translation.vector - truth.translation.vector).norm();
            assert!(
                axis_deg < 0.3 && m < 0.0015,
                "case {k}: axis {axis_deg}° {m} m, {r:?}"
            );
            assert!(r.converged && r.fitness > 0.7, "{r:?}");
            if k == 0 {
                // Estimated alongside the initial guess, the same normals and the same result.
                let estimated = ScanNormals::Estimate(&NormalConfig::default());
                let e = register(
                    &model,
                    &scan,
                    estimated,
                    &idx,
                    &Point3::origin(),
                    &InitMode::Auto,
                    &RegisterConfig::default(),
                )
                .unwrap();
                assert_eq!(e.scan_normals, normals);
                assert_eq!(e.t_scan_reference, r.t_scan_reference);
            }
        }
    }

    /// The hidden-point removal sees the model from `camera`, not from the scan frame's origin:
    /// a bottle 1 m in front of the origin, seen from a camera 1 m beside it (at right angles to
    /// the origin's view), keeps the side that faces that camera (its outward normals towards
    /// it), and of the side that faces the origin only the quarter turn the two share.
    #[test]
    fn the_model_is_culled_from_the_camera_not_the_origin() {
        let (points, normals) = bottle(6000, 5);
        let model = ReferenceModel::build(points, normals, None, "model").unwrap();
        let pose = Isometry3::new(Vector3::new(0.0, 0.0, 1.0), Vector3::zeros());
        let facing = |visible: &[usize], camera: &Point3<f64>| {
            let toward = visible
                .iter()
                .filter(|&&i| model.normals[i].dot(&(pose.inverse() * camera - model.points[i])) > 0.0)
                .count();
            toward as f64 / visible.len() as f64
        };
        let beside = Point3::new(0.0, 1.0, 1.0);
        let cfg = HiddenPointConfig::default();
        let from_beside = visible_indices(&model, &pose, &beside, &cfg);
        let from_origin = visible_indices(&model, &pose, &Point3::origin(), &cfg);
        // The culling keeps a few points just past the silhouette (0.93 face their camera).
        assert!(facing(&from_beside, &beside) > 0.9);
        assert!(facing(&from_origin, &Point3::origin()) > 0.9);
        // Seen at right angles, a body of revolution shows half its seen side to both cameras.
        assert!(facing(&from_beside, &Point3::origin()) < 0.6);
        assert!(facing(&from_origin, &beside) < 0.6);
    }

    #[test]
    fn scan_fitness_is_against_the_mesh_s_surface_whatever_its_samples() {
        let cube = crate::surface::tests::cube();
        let truth = Isometry3::new(Vector3::new(0.2, -0.1, 2.0), Vector3::new(0.3, -0.5, 0.2));
        let (on, _) = cube.sample_surface(6000, 7);
        let scan: Vec<_> = on.iter().map(|p| truth * p).collect();
        let (dist, slid) = (0.002, Isometry3::translation(0.03, 0.0, 0.0));
        for samples in [MIN_MESH_SAMPLES, 20_000] {
            let model = ReferenceModel::from_mesh(cube.clone(), samples, 1, "model").unwrap();
            assert_eq!(scan_fitness(&model, &scan, &truth, dist).unwrap(), 1.0);
            // Slid 30 mm along x, the four faces along x still explain their points, the two
            // across it none: two thirds of the area.
            let f = scan_fitness(&model, &scan, &(truth * slid), dist).unwrap();
            assert!((f - 2.0 / 3.0).abs() < 0.02, "{samples} samples: {f}");
        }
        // A cloud of 2,000 of the cube's points, 25 mm apart, ten times the distance: its
        // points' planes explain the scan but near the edges, where the nearest point may lie on
        // the next face.
        let (points, normals) = cube.sample_surface(2000, 1);
        let cloud = ReferenceModel::build(points, normals, None, "model").unwrap();
        let f = scan_fitness(&cloud, &scan, &truth, dist).unwrap();
        assert!(f > 0.9, "{f}");
        let f = scan_fitness(&cloud, &scan, &(truth * slid), dist).unwrap();
        assert!((f - 2.0 / 3.0).abs() < 0.06, "{f}");
    }

    #[test]
    fn bad_registration_values_are_input_errors() {
        use crate::perception::assert_bad_input;
        let with = |f: &dyn Fn(&mut RegisterConfig)| {
            let mut c = RegisterConfig::default();
            f(&mut c);
            c.validate()
        };
        // NaN disabled the fitness guard (`scan_fitness < NaN` is false).
        assert_bad_input(with(&|c| c.min_fitness = f64::NAN), "register.min_fitness");
        assert_bad_input(with(&|c| c.min_fitness = 1.5), "register.min_fitness");
        assert_bad_input(
            with(&|c| c.evaluation_distance_m = f64::NAN),
            "register.evaluation_distance_m",
        );
        assert_bad_input(with(&|c| c.mesh_samples = usize::MAX), "register.mesh_samples");
        assert_bad_input(
            with(&|c| c.visibility_rounds = usize::MAX),
            "register.visibility_rounds",
        );
        assert_bad_input(
            with(&|c| c.hidden_points.radius_factor = 0.0),
            "register.hidden_points.radius_factor",
        );
        assert_bad_input(
            with(&|c| c.init.score_fraction = 1e300),
            "register.init.score_fraction",
        );
        RegisterConfig::default().validate().unwrap();
    }

    #[test]
    fn a_huge_sample_count_is_an_input_error_not_a_capacity_overflow() {
        let mesh = TriangleMesh {
            vertices: vec![
                Point3::origin(),
                Point3::new(0.1, 0.0, 0.0),
                Point3::new(0.0, 0.1, 0.0),
                Point3::new(0.0, 0.0, 0.1),
            ],
            triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        };
        for n in [usize::MAX, 1_000_000_000, 0] {
            crate::perception::assert_bad_input(
                ReferenceModel::from_mesh(mesh.clone(), n, 1, "model.ply").map(|_| ()),
                "register.mesh_samples",
            );
        }
        let m = ReferenceModel::from_mesh(mesh.clone(), 1000, 1, "model.ply").unwrap();
        assert_eq!(m.points.len(), 1000);
        // The same shape in micrometres or kilometres is bad input naming the file (the one a
        // kilometre across was "no cluster fits", the other "converged").
        for scale in [1e-6, 1e4] {
            let scaled = TriangleMesh {
                vertices: mesh.vertices.iter().map(|v| v * scale).collect(),
                triangles: mesh.triangles.clone(),
            };
            let Err(e) = ReferenceModel::from_mesh(scaled, 1000, 1, "model.ply") else {
                panic!("a model {scale} times the size was accepted");
            };
            assert_eq!(e.exit_code(), 2);
            assert!(e.to_string().contains("model.ply: the model is"), "{e}");
        }
    }
}
