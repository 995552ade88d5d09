//! Point-to-plane ICP (Chen & Medioni 1992) with a robust kernel, a shrinking correspondence gate
//! and convergence on the pose change.
//!
//! Each iteration pairs every source point `p` (moved by the current estimate) with its nearest
//! target point `q` (normal `n`) when they are at most the gate apart, and solves the linearised
//! least-squares problem `min Σ w(r)·r²`, `r = (R p + t − q)·n`, for a small rotation (about the
//! paired points' centroid, for conditioning) and translation (6×6 normal equations solved by SVD,
//! so that directions the geometry does not constrain stay put). The weights `w` come from an
//! M-estimator (Tukey, Huber or Cauchy) scaled by the robust spread of the residuals
//! (1.4826 × MAD), iteratively reweighted. The gate starts at `initial_gate_m` and shrinks to
//! `gate_sigmas` × that spread (never below `min_gate_m`, never growing), as in KISS-ICP's
//! adaptive threshold. Iteration stops when the step's rotation and translation are both below
//! their tolerances while the gate has settled.
//!
//! Correspondence search and the accumulation of the normal equations run in parallel over
//! fixed-size chunks whose partial sums are added in chunk order, so the result does not depend on
//! the number of threads. Units: metres, radians.

use crate::cloud::pca::median;
use crate::error::{Error, Result};
use crate::frames::Pose;
use crate::spatial::KdIndex;
use nalgebra::{Matrix6, Point3, Translation3, UnitQuaternion, Vector3, Vector6};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The robust kernel applied to point-to-plane residuals.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Kernel {
    /// Plain least squares.
    None,
    /// Huber, `k = 1.345 σ`.
    Huber,
    /// Cauchy, `k = 2.385 σ`.
    Cauchy,
    /// Tukey's biweight, `k = 4.685 σ` (residuals beyond `k` get no weight).
    Tukey,
}

impl Kernel {
    /// The IRLS weight of residual `r` for the robust scale `sigma`.
    pub fn weight(self, r: f64, sigma: f64) -> f64 {
        let a = r.abs();
        match self {
            Kernel::None => 1.0,
            Kernel::Huber => {
                let k = 1.345 * sigma;
                if a <= k { 1.0 } else { k / a }
            }
            Kernel::Cauchy => {
                let k = 2.385 * sigma;
                1.0 / (1.0 + (a / k).powi(2))
            }
            Kernel::Tukey => {
                let k = 4.685 * sigma;
                if a >= k {
                    0.0
                } else {
                    (1.0 - (a / k).powi(2)).powi(2)
                }
            }
        }
    }
}

/// Configuration of ICP.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IcpConfig {
    /// Most iterations.
    pub max_iterations: usize,
    /// Correspondence gate at the start, metres; 0 takes a quarter of the reference's largest
    /// span.
    pub initial_gate_m: f64,
    /// Smallest gate, metres.
    pub min_gate_m: f64,
    /// The gate shrinks to this many robust standard deviations of the residuals.
    pub gate_sigmas: f64,
    /// Robust kernel.
    pub kernel: Kernel,
    /// Floor of the kernel's scale, metres (sensor noise below this is not resolved).
    pub min_sigma_m: f64,
    /// Convergence: largest rotation step, radians.
    pub rotation_tolerance_rad: f64,
    /// Convergence: largest translation step, metres.
    pub translation_tolerance_m: f64,
    /// Fewest correspondences for a step.
    pub min_correspondences: usize,
    /// Use at most this many source points (evenly strided); 0 uses all.
    pub max_source_points: usize,
}

impl Default for IcpConfig {
    fn default() -> Self {
        IcpConfig {
            max_iterations: 60,
            initial_gate_m: 0.0,
            min_gate_m: 0.002,
            gate_sigmas: 4.0,
            kernel: Kernel::Tukey,
            min_sigma_m: 0.0001,
            rotation_tolerance_rad: 1e-5,
            translation_tolerance_m: 1e-6,
            min_correspondences: 30,
            max_source_points: 20_000,
        }
    }
}

impl IcpConfig {
    /// Checks the values a user can get wrong.
    ///
    /// # Errors
    /// [`Error::Input`] naming the field (under `prefix`, e.g. `icp`).
    pub fn validate(&self, prefix: &str) -> Result<()> {
        let bad = |f: &str, why: &str| Err(Error::input(format!("{prefix}.{f}"), why));
        let pos = |x: f64| x > 0.0 && x.is_finite();
        if self.max_iterations == 0 {
            return bad("max_iterations", "must be ≥ 1");
        }
        if !(self.initial_gate_m >= 0.0 && self.initial_gate_m.is_finite()) {
            return bad(
                "initial_gate_m",
                "must be ≥ 0 (0 = a quarter of the reference's size)",
            );
        }
        if !pos(self.min_gate_m) {
            return bad("min_gate_m", "must be > 0");
        }
        if !pos(self.gate_sigmas) {
            return bad("gate_sigmas", "must be > 0");
        }
        if !pos(self.min_sigma_m) {
            return bad("min_sigma_m", "must be > 0");
        }
        if !pos(self.rotation_tolerance_rad) || !pos(self.translation_tolerance_m) {
            return bad("rotation_tolerance_rad", "tolerances must be > 0");
        }
        if self.min_correspondences < 6 {
            return bad("min_correspondences", "must be ≥ 6");
        }
        Ok(())
    }
}

/// What ICP reached.
#[derive(Debug, Clone, PartialEq)]
pub struct IcpOutcome {
    /// The estimate: maps source coordinates into target coordinates.
    pub t_target_source: Pose,
    /// Iterations run.
    pub iterations: usize,
    /// True if the pose change fell below the tolerances.
    pub converged: bool,
    /// Correspondences in the last iteration.
    pub correspondences: usize,
    /// Fraction of the (used) source points paired in the last iteration.
    pub fitness: f64,
    /// RMS point-to-point distance of the last pairs, metres.
    pub inlier_rmse_m: f64,
    /// RMS point-to-plane residual of the last pairs, metres.
    pub plane_rmse_m: f64,
    /// The last gate, metres.
    pub gate_m: f64,
    /// Rotation (radians) and translation (metres) of the last step.
    pub last_step: (f64, f64),
}

/// Points per chunk of the parallel reductions.
const CHUNK: usize = 512;

/// One pair: source index, nearest target index, point-to-point distance, plane residual.
#[derive(Clone, Copy)]
struct Pair {
    source: usize,
    target: usize,
    distance: f64,
    residual: f64,
}

/// Registers `source` onto `target` (with unit `target_normals` and `target_index` built on
/// `target`) starting from `init`. `gate0` is the initial gate in metres (callers resolve the
/// config's 0 to a size-based value).
///
/// # Errors
/// [`Error::Failed`] (stage `icp`) when fewer than `min_correspondences` pairs are found.
pub fn icp_point_to_plane(
    source: &[Point3<f64>],
    target: &[Point3<f64>],
    target_normals: &[Vector3<f64>],
    target_index: &KdIndex,
    init: &Pose,
    gate0: f64,
    cfg: &IcpConfig,
) -> Result<IcpOutcome> {
    let stride = if cfg.max_source_points > 0 && source.len() > cfg.max_source_points {
        source.len().div_ceil(cfg.max_source_points)
    } else {
        1
    };
    let src: Vec<Point3<f64>> = source.iter().step_by(stride).copied().collect();
    let mut pose = *init;
    let mut gate = gate0.max(cfg.min_gate_m);
    let mut moved: Vec<Point3<f64>> = vec![Point3::origin(); src.len()];
    let mut out = IcpOutcome {
        t_target_source: pose,
        iterations: 0,
        converged: false,
        correspondences: 0,
        fitness: 0.0,
        inlier_rmse_m: 0.0,
        plane_rmse_m: 0.0,
        gate_m: gate,
        last_step: (f64::INFINITY, f64::INFINITY),
    };
    for it in 1..=cfg.max_iterations {
        moved.par_iter_mut().zip(&src).for_each(|(m, p)| *m = pose * p);
        let pairs = pairs_within(&moved, target, target_normals, target_index, gate);
        if pairs.len() < cfg.min_correspondences {
            return Err(Error::failed(
                "icp",
                format!(
                    "only {} correspondences within the {:.4} m gate at iteration {it} (need {}); \
                     the initial guess is too far off",
                    pairs.len(),
                    gate,
                    cfg.min_correspondences
                ),
            ));
        }
        let mut abs: Vec<f64> = pairs.iter().map(|p| p.residual.abs()).collect();
        let sigma = (1.4826 * median(&mut abs).unwrap_or(0.0)).max(cfg.min_sigma_m);
        // Weighted normal equations about the paired points' centroid.
        let centre = pairs
            .iter()
            .fold(Vector3::zeros(), |a, p| a + moved[p.source].coords)
            / pairs.len() as f64;
        let (h, b) = pairs
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut h = Matrix6::zeros();
                let mut b = Vector6::zeros();
                for p in chunk {
                    let w = cfg.kernel.weight(p.residual, sigma);
                    if w <= 0.0 {
                        continue;
                    }
                    let n = target_normals[p.target];
                    let x = moved[p.source].coords - centre;
                    let c = x.cross(&n);
                    let j = Vector6::new(c.x, c.y, c.z, n.x, n.y, n.z);
                    h += w * j * j.transpose();
                    b += w * p.residual * j;
                }
                (h, b)
            })
            .collect::<Vec<_>>()
            .into_iter()
            .fold((Matrix6::zeros(), Vector6::zeros()), |(ha, ba), (h, b)| {
                (ha + h, ba + b)
            });
        let step = solve(&h, &(-b));
        let omega = Vector3::new(step[0], step[1], step[2]);
        let dt = Vector3::new(step[3], step[4], step[5]);
        let rot = UnitQuaternion::from_scaled_axis(omega);
        // x' = R (x − c) + c + dt
        let delta = Pose::from_parts(Translation3::from(centre - rot * centre + dt), rot);
        pose = delta * pose;
        let rms = |f: &dyn Fn(&Pair) -> f64| {
            (pairs.iter().map(|p| f(p).powi(2)).sum::<f64>() / pairs.len() as f64).sqrt()
        };
        let new_gate = (cfg.gate_sigmas * sigma).clamp(cfg.min_gate_m, gate);
        let settled = new_gate >= 0.99 * gate;
        out = IcpOutcome {
            t_target_source: pose,
            iterations: it,
            converged: false,
            correspondences: pairs.len(),
            fitness: pairs.len() as f64 / src.len() as f64,
            inlier_rmse_m: rms(&|p| p.distance),
            plane_rmse_m: rms(&|p| p.residual),
            gate_m: gate,
            last_step: (omega.norm(), dt.norm()),
        };
        gate = new_gate;
        if settled && omega.norm() < cfg.rotation_tolerance_rad && dt.norm() < cfg.translation_tolerance_m {
            out.converged = true;
            break;
        }
    }
    Ok(out)
}

/// Nearest-target pairs within `gate` of the (moved) source points, in source order.
fn pairs_within(
    moved: &[Point3<f64>],
    target: &[Point3<f64>],
    normals: &[Vector3<f64>],
    index: &KdIndex,
    gate: f64,
) -> Vec<Pair> {
    moved
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            let mut v = Vec::with_capacity(chunk.len());
            for (k, p) in chunk.iter().enumerate() {
                if let Some(nb) = index.nearest(p)
                    && nb.distance <= gate
                {
                    v.push(Pair {
                        source: c * CHUNK + k,
                        target: nb.index,
                        distance: nb.distance,
                        residual: (p - target[nb.index]).dot(&normals[nb.index]),
                    });
                }
            }
            v
        })
        .flatten()
        .collect()
}

/// Solves the 6×6 symmetric system by SVD, zeroing directions whose singular value is below
/// 1e-9 of the largest (unconstrained directions do not move).
fn solve(h: &Matrix6<f64>, rhs: &Vector6<f64>) -> Vector6<f64> {
    let svd = h.svd(true, true);
    let max = svd.singular_values.max();
    if !(max > 0.0) || !max.is_finite() {
        return Vector6::zeros();
    }
    svd.solve(rhs, 1e-9 * max).unwrap_or_else(|_| Vector6::zeros())
}

/// Fitness and inlier RMSE of `source` moved by `pose` against `target` (Open3D's
/// `evaluate_registration`): the fraction of source points whose nearest target point is within
/// `distance` metres, and the RMS distance of those, metres.
pub fn evaluate(source: &[Point3<f64>], target_index: &KdIndex, pose: &Pose, distance: f64) -> (f64, f64) {
    if source.is_empty() {
        return (0.0, 0.0);
    }
    let (count, sum) = source
        .par_chunks(CHUNK)
        .map(|chunk| {
            chunk.iter().fold((0usize, 0.0), |(c, s), p| {
                match target_index.nearest(&(pose * p)) {
                    Some(nb) if nb.distance <= distance => (c + 1, s + nb.distance * nb.distance),
                    _ => (c, s),
                }
            })
        })
        .collect::<Vec<_>>()
        .into_iter()
        .fold((0, 0.0), |(c, s), (c2, s2)| (c + c2, s + s2));
    let rmse = if count > 0 {
        (sum / count as f64).sqrt()
    } else {
        0.0
    };
    (count as f64 / source.len() as f64, rmse)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloud::normals::{NormalConfig, estimate_normals};
    use nalgebra::Isometry3;
    use rand::{RngExt, SeedableRng};

    /// A wavy surface patch (well-constrained in all six directions) 1 m in front of the camera.
    fn patch(n: usize, seed: u64) -> Vec<Point3<f64>> {
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                let (x, y): (f64, f64) = (rng.random_range(-0.15..0.15), rng.random_range(-0.1..0.1));
                let z = 1.0 + 0.03 * (x / 0.05).sin() * (y / 0.04).cos() + 0.5 * x * x;
                Point3::new(x, y, z)
            })
            .collect()
    }

    #[test]
    fn recovers_a_known_motion() {
        let target = patch(20_000, 1);
        let idx = KdIndex::new(&target).unwrap();
        let normals = estimate_normals(&target, &idx, &NormalConfig::default(), &Point3::origin());
        // Source: an independent sampling of the same surface, moved by the inverse of `truth`.
        let truth = Isometry3::new(Vector3::new(0.01, -0.008, 0.005), Vector3::new(0.05, -0.03, 0.04));
        let source: Vec<Point3<f64>> = patch(8000, 2).iter().map(|p| truth.inverse() * p).collect();
        let out = icp_point_to_plane(
            &source,
            &target,
            &normals,
            &idx,
            &Pose::identity(),
            0.05,
            &IcpConfig::default(),
        )
        .unwrap();
        assert!(out.converged, "{out:?}");
        let (deg, m) = crate::frames::pose_error(&out.t_target_source, &truth);
        assert!(deg < 0.05 && m < 2e-4, "{deg}° {m} m");
        assert!(out.fitness > 0.95);
        let (fit, rmse) = evaluate(&source, &idx, &out.t_target_source, 0.005);
        assert!(fit > 0.99 && rmse < 0.002, "{fit} {rmse}");
    }

    #[test]
    fn too_far_off_is_a_failed_run() {
        let target = patch(2000, 3);
        let idx = KdIndex::new(&target).unwrap();
        let normals = vec![Vector3::z(); target.len()];
        let far = Isometry3::translation(5.0, 0.0, 0.0);
        let err = icp_point_to_plane(
            &target,
            &target,
            &normals,
            &idx,
            &far,
            0.05,
            &IcpConfig::default(),
        )
        .unwrap_err();
        assert_eq!(err.exit_code(), 1);
        assert!(err.to_string().starts_with("icp:"), "{err}");
    }

    #[test]
    fn kernels_downweight_outliers() {
        for k in [Kernel::Huber, Kernel::Cauchy, Kernel::Tukey] {
            assert_eq!(k.weight(0.0, 1.0), 1.0);
            assert!(k.weight(10.0, 1.0) < 0.2, "{k:?}");
        }
        assert_eq!(Kernel::Tukey.weight(5.0, 1.0), 0.0);
        assert_eq!(Kernel::None.weight(100.0, 1.0), 1.0);
    }
}
