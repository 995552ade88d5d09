//! Point-to-plane ICP (Chen & Medioni 1992) with a robust kernel, a shrinking correspondence gate
//! and convergence on the pose change.
//!
//! Each iteration pairs every source point `p` (moved by the current estimate) with its nearest
//! target point `q` (normal `n`) when they are at most the gate apart, and solves the linearised
//! least-squares problem `min Σ w(r)·r²`, `r = (R p + t − q)·n`, for a small rotation (about the
//! paired points' centroid, for conditioning) and translation: 6×6 normal equations with the
//! rotation scaled by the pairs' radius, solved in their eigenbasis without the directions the
//! geometry does not constrain (Zhang, Kaess & Singh 2016), which therefore stay put. The weights `w` come from an
//! M-estimator (Tukey, Huber or Cauchy) scaled by the robust spread of the residuals
//! (1.4826 × MAD), iteratively reweighted. The gate starts at `initial_gate_m` and shrinks to
//! `gate_sigmas` × that spread (never below `min_gate_m`, never growing), as in KISS-ICP's
//! adaptive threshold. Iteration stops, once the gate has settled, when the step's rotation and
//! translation are both below their tolerances or when the step changes the residuals by less than
//! `motion_tolerance` of their spread.
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
    /// Most iterations (1 to [`MAX_ITERATIONS`]).
    pub max_iterations: usize,
    /// Correspondence gate at the start, metres; 0 takes a quarter of the reference's largest
    /// span.
    pub initial_gate_m: f64,
    /// Smallest gate, metres.
    pub min_gate_m: f64,
    /// The gate shrinks to this many robust standard deviations of the residuals...
    pub gate_sigmas: f64,
    /// ... by at most this factor per iteration.
    pub gate_shrink: f64,
    /// Robust kernel.
    pub kernel: Kernel,
    /// Floor of the kernel's scale, metres (sensor noise below this is not resolved).
    pub min_sigma_m: f64,
    /// Convergence: largest rotation step, radians.
    pub rotation_tolerance_rad: f64,
    /// Convergence: largest translation step, metres.
    pub translation_tolerance_m: f64,
    /// Convergence: the step changes the residuals by less than this fraction of their robust
    /// spread (RMS).
    pub motion_tolerance: f64,
    /// Directions of the (scaled) normal equations with an eigenvalue below this fraction of the
    /// largest are treated as unconstrained and not updated.
    pub degenerate_ratio: f64,
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
            gate_shrink: 0.7,
            kernel: Kernel::Tukey,
            min_sigma_m: 0.0001,
            rotation_tolerance_rad: 1e-5,
            translation_tolerance_m: 1e-6,
            motion_tolerance: 1e-2,
            degenerate_ratio: 1e-2,
            min_correspondences: 30,
            max_source_points: 20_000,
        }
    }
}

/// Most ICP iterations: 150 times the default; ICP on the bottle converges in 10 to 40.
pub const MAX_ITERATIONS: usize = 10_000;

impl IcpConfig {
    /// Checks the values a user can get wrong.
    ///
    /// # Errors
    /// [`Error::Input`] naming the field (under `prefix`, e.g. `register.icp`).
    pub fn validate(&self, prefix: &str) -> Result<()> {
        let bad = |f: &str, why: &str, v: f64| {
            Err(Error::input(
                format!("{prefix}.{f}"),
                format!("{why}, got {}", crate::config::shown(v)),
            ))
        };
        crate::config::count_between(
            format!("{prefix}.max_iterations"),
            self.max_iterations,
            1,
            MAX_ITERATIONS,
        )?;
        if !(self.initial_gate_m >= 0.0 && self.initial_gate_m.is_finite()) {
            return bad(
                "initial_gate_m",
                "must be a finite number ≥ 0 (0 = a quarter of the reference's size)",
                self.initial_gate_m,
            );
        }
        for (f, v) in [
            ("min_gate_m", self.min_gate_m),
            ("gate_sigmas", self.gate_sigmas),
            ("min_sigma_m", self.min_sigma_m),
            ("motion_tolerance", self.motion_tolerance),
            ("rotation_tolerance_rad", self.rotation_tolerance_rad),
            ("translation_tolerance_m", self.translation_tolerance_m),
        ] {
            crate::config::positive(format!("{prefix}.{f}"), v)?;
        }
        if !(self.gate_shrink > 0.0 && self.gate_shrink <= 1.0) {
            return bad("gate_shrink", "must be in (0, 1]", self.gate_shrink);
        }
        if !(self.degenerate_ratio >= 0.0 && self.degenerate_ratio < 1.0) {
            return bad("degenerate_ratio", "must be in [0, 1)", self.degenerate_ratio);
        }
        crate::config::require(
            self.min_correspondences >= 6,
            format!("{prefix}.min_correspondences"),
            format!("must be ≥ 6 (six unknowns), got {}", self.min_correspondences),
        )?;
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
    /// The gate the next iteration would use, metres: a run resumed from `t_target_source` with
    /// this gate continues exactly where this one stopped.
    pub next_gate_m: f64,
    /// Rotation (radians) and translation (metres) of the last step.
    pub last_step: (f64, f64),
}

/// Points per chunk of the parallel reductions.
const CHUNK: usize = 128;

/// One pair, in the target frame: the moved source-side point `x`, the unit normal `n` the
/// residual is measured along, the point-to-point distance and the plane residual.
#[derive(Clone, Copy)]
struct Pair {
    x: Point3<f64>,
    n: Vector3<f64>,
    distance: f64,
    residual: f64,
}

/// A point set with unit normals and an index over its points.
#[derive(Clone, Copy)]
pub struct Surfel<'a> {
    /// Points, metres.
    pub points: &'a [Point3<f64>],
    /// Unit normals (sign irrelevant), one per point.
    pub normals: &'a [Vector3<f64>],
    /// Index over `points`.
    pub index: &'a KdIndex,
}

/// Registers `source` onto `target` starting from `init`: point-to-plane pairs from each source
/// point to its nearest target point (target normal), and with `reverse` (the source's whole
/// surface, in the source frame) also from each target point to its nearest point of that surface
/// (its normal) — a symmetric cost whose second half lets the model's closed geometry (ends,
/// caps) hold it where the scan ends. `gate0` is the initial gate in metres.
///
/// # Errors
/// [`Error::Failed`] (stage `icp`) when fewer than `min_correspondences` pairs are found.
pub fn icp_point_to_plane(
    source: &[Point3<f64>],
    target: Surfel<'_>,
    reverse: Option<Surfel<'_>>,
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
    let tstride = if cfg.max_source_points > 0 && target.points.len() > cfg.max_source_points {
        target.points.len().div_ceil(cfg.max_source_points)
    } else {
        1
    };
    let tgt: Vec<(Point3<f64>, Vector3<f64>)> = match reverse {
        Some(_) => target
            .points
            .iter()
            .zip(target.normals)
            .step_by(tstride)
            .map(|(p, n)| (*p, *n))
            .collect(),
        None => Vec::new(),
    };
    let mut pose = *init;
    let mut gate = gate0.max(cfg.min_gate_m);
    let mut out = IcpOutcome {
        t_target_source: pose,
        iterations: 0,
        converged: false,
        correspondences: 0,
        fitness: 0.0,
        inlier_rmse_m: 0.0,
        plane_rmse_m: 0.0,
        gate_m: gate,
        next_gate_m: gate,
        last_step: (f64::INFINITY, f64::INFINITY),
    };
    for it in 1..=cfg.max_iterations {
        let forward = forward_pairs(&src, &pose, target, gate);
        let n_forward = forward.len();
        let mut pairs = forward;
        if let Some(model) = reverse {
            pairs.extend(reverse_pairs(&tgt, &pose, model, gate));
        }
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
        let spread = (1.4826 * median(&mut abs).unwrap_or(0.0)).max(cfg.min_sigma_m);
        // While the gate is still wide, so is the kernel: pairs that carry the large offsets (the
        // ends of an elongated object) keep their weight until the estimate has moved.
        let sigma = spread.max(gate / cfg.gate_sigmas);
        // Weighted normal equations about the paired points' centroid.
        let centre = pairs.iter().fold(Vector3::zeros(), |a, p| a + p.x.coords) / pairs.len() as f64;
        let (h, b, r2, weight_sum) = pairs
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut h = Matrix6::zeros();
                let mut b = Vector6::zeros();
                let (mut r2, mut ws) = (0.0, 0.0);
                for p in chunk {
                    let x = p.x.coords - centre;
                    r2 += x.norm_squared();
                    let w = cfg.kernel.weight(p.residual, sigma);
                    if w <= 0.0 {
                        continue;
                    }
                    let c = x.cross(&p.n);
                    let j = Vector6::new(c.x, c.y, c.z, p.n.x, p.n.y, p.n.z);
                    h += w * j * j.transpose();
                    b += w * p.residual * j;
                    ws += w;
                }
                (h, b, r2, ws)
            })
            .collect::<Vec<_>>()
            .into_iter()
            .fold((Matrix6::zeros(), Vector6::zeros(), 0.0, 0.0), |a, c| {
                (a.0 + c.0, a.1 + c.1, a.2 + c.2, a.3 + c.3)
            });
        // Rotation scaled by the pairs' RMS radius, so that all six unknowns are lengths.
        let radius = (r2 / pairs.len() as f64).sqrt().max(1e-9);
        let scale = Vector6::new(1.0 / radius, 1.0 / radius, 1.0 / radius, 1.0, 1.0, 1.0);
        let hs = Matrix6::from_fn(|r, c| h[(r, c)] * scale[r] * scale[c]);
        let step_scaled = solve_constrained(&hs, &(-b.component_mul(&scale)), cfg.degenerate_ratio);
        let step = step_scaled.component_mul(&scale);
        // How much the step changes the residuals, RMS metres (the motion the data can see).
        let observed = (step_scaled.dot(&(hs * step_scaled)) / weight_sum.max(1e-300)).sqrt();
        let omega = Vector3::new(step[0], step[1], step[2]);
        let dt = Vector3::new(step[3], step[4], step[5]);
        let rot = UnitQuaternion::from_scaled_axis(omega);
        // x' = R (x − c) + c + dt
        let delta = Pose::from_parts(Translation3::from(centre - rot * centre + dt), rot);
        pose = delta * pose;
        let fwd = &pairs[..n_forward];
        let rms = |f: &dyn Fn(&Pair) -> f64| {
            (fwd.iter().map(|p| f(p).powi(2)).sum::<f64>() / fwd.len().max(1) as f64).sqrt()
        };
        let new_gate = (cfg.gate_sigmas * spread)
            .max(cfg.gate_shrink * gate)
            .clamp(cfg.min_gate_m, gate);
        let settled = new_gate >= 0.99 * gate;
        out = IcpOutcome {
            t_target_source: pose,
            iterations: it,
            converged: false,
            correspondences: pairs.len(),
            fitness: n_forward as f64 / src.len() as f64,
            inlier_rmse_m: rms(&|p| p.distance),
            plane_rmse_m: rms(&|p| p.residual),
            gate_m: gate,
            next_gate_m: new_gate,
            last_step: (omega.norm(), dt.norm()),
        };
        gate = new_gate;
        let small_pose_step =
            omega.norm() < cfg.rotation_tolerance_rad && dt.norm() < cfg.translation_tolerance_m;
        // Also converged when the step no longer changes the residuals (it only wanders along a
        // direction the data barely constrain, e.g. a fouled bottle's turn about its axis).
        if settled && (small_pose_step || observed < cfg.motion_tolerance * spread) {
            out.converged = true;
            break;
        }
    }
    Ok(out)
}

/// Source points moved by `pose`, each with its nearest target point within `gate` (target
/// normal), in source order.
fn forward_pairs(src: &[Point3<f64>], pose: &Pose, target: Surfel<'_>, gate: f64) -> Vec<Pair> {
    src.par_chunks(CHUNK)
        .map(|chunk| {
            let mut v = Vec::with_capacity(chunk.len());
            for p in chunk {
                let x = pose * p;
                if let Some(nb) = target.index.nearest_within(&x, gate) {
                    let n = target.normals[nb.index];
                    v.push(Pair {
                        x,
                        n,
                        distance: nb.distance,
                        residual: (x - target.points[nb.index]).dot(&n),
                    });
                }
            }
            v
        })
        .flatten()
        .collect()
}

/// Target points (with their normals, target frame), each with its nearest point of the source's
/// surface `model` (source frame) within `gate`; the pair is expressed in the target frame along
/// the model's normal, as if the model point were the moving point.
fn reverse_pairs(
    tgt: &[(Point3<f64>, Vector3<f64>)],
    pose: &Pose,
    model: Surfel<'_>,
    gate: f64,
) -> Vec<Pair> {
    let inv = pose.inverse();
    tgt.par_chunks(CHUNK)
        .map(|chunk| {
            let mut v = Vec::with_capacity(chunk.len());
            for (q, _) in chunk {
                if let Some(nb) = model.index.nearest_within(&(inv * q), gate) {
                    let x = pose * model.points[nb.index];
                    let n = pose * model.normals[nb.index];
                    v.push(Pair {
                        x,
                        n,
                        distance: nb.distance,
                        residual: (x - q).dot(&n),
                    });
                }
            }
            v
        })
        .flatten()
        .collect()
}

/// Solves the scaled 6×6 normal equations in the eigenbasis of `h`, leaving out the directions
/// whose eigenvalue is below `ratio` × the largest: directions the geometry does not constrain
/// (the turn about a body of revolution's axis, sliding along a plane) stay put instead of
/// drifting with the noise (degeneracy-aware update, Zhang, Kaess & Singh, ICRA 2016).
fn solve_constrained(h: &Matrix6<f64>, rhs: &Vector6<f64>, ratio: f64) -> Vector6<f64> {
    let e = h.symmetric_eigen();
    let max = e.eigenvalues.max();
    if !(max > 0.0 && max.is_finite()) {
        return Vector6::zeros();
    }
    let mut x = Vector6::zeros();
    for i in 0..6 {
        let l = e.eigenvalues[i];
        if l > ratio * max {
            let v = e.eigenvectors.column(i);
            x += v * (v.dot(rhs) / l);
        }
    }
    x
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
                match target_index.nearest_within(&(pose * p), distance) {
                    Some(nb) => (c + 1, s + nb.distance * nb.distance),
                    None => (c, s),
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
        let normals = estimate_normals(&target, &NormalConfig::default(), &Point3::origin()).unwrap();
        // Source: an independent sampling of the same surface, moved by the inverse of `truth`.
        let truth = Isometry3::new(Vector3::new(0.01, -0.008, 0.005), Vector3::new(0.05, -0.03, 0.04));
        let source: Vec<Point3<f64>> = patch(8000, 2).iter().map(|p| truth.inverse() * p).collect();
        let tgt = Surfel {
            points: &target,
            normals: &normals,
            index: &idx,
        };
        let out =
            icp_point_to_plane(&source, tgt, None, &Pose::identity(), 0.05, &IcpConfig::default()).unwrap();
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
        let tgt = Surfel {
            points: &target,
            normals: &normals,
            index: &idx,
        };
        let err = icp_point_to_plane(&target, tgt, Some(tgt), &far, 0.05, &IcpConfig::default()).unwrap_err();
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

    #[test]
    fn validate_names_the_field_at_fault() {
        use crate::perception::assert_bad_input;
        // It used to name rotation_tolerance_rad for a bad translation tolerance.
        let cfg = IcpConfig {
            translation_tolerance_m: 0.0,
            ..IcpConfig::default()
        };
        assert_bad_input(
            cfg.validate("register.icp"),
            "register.icp.translation_tolerance_m",
        );
        let cfg = IcpConfig {
            rotation_tolerance_rad: f64::NAN,
            ..IcpConfig::default()
        };
        assert_bad_input(
            cfg.validate("register.icp"),
            "register.icp.rotation_tolerance_rad",
        );
        let cfg = IcpConfig {
            max_iterations: usize::MAX,
            ..IcpConfig::default()
        };
        assert_bad_input(cfg.validate("register.icp"), "register.icp.max_iterations");
        IcpConfig::default().validate("register.icp").unwrap();
    }
}
