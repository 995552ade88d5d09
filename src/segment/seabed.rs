//! Seabed removal: a RANSAC plane (Fischler & Bolles 1981) with an adaptive iteration count,
//! an optional prior on the plane's normal, a threshold estimated from the data, and a
//! least-squares refit with inlier recount until the inlier set is stable.
//!
//! 1. **Hypotheses.** Three points drawn (seeded `ChaCha8Rng`) from a fixed random subset of the
//!    cloud span a plane. With a prior `up` (the seabed normal in the scan frame from the vehicle's
//!    attitude; it may be tens of degrees off) a hypothesis whose normal is farther than
//!    `up_tolerance_deg` from `up` is rejected before it is scored, so the result is the
//!    best-supported plane *near* `up`, not the largest plane in view (a wall, the background).
//!    Hypotheses are scored in parallel in fixed batches and the first best wins, so the result
//!    does not depend on the number of threads. The iteration count adapts to the best inlier
//!    ratio `w` found so far: `N = ln(1 − p) / ln(1 − w³)` (Hartley & Zisserman, §4.7).
//! 2. **Threshold.** `threshold_m > 0` is used as given. Otherwise the first pass uses
//!    `initial_threshold_m`, and the threshold becomes `noise_sigmas` × the robust standard
//!    deviation (1.4826 × median absolute deviation) of the residuals of the points near that
//!    plane — noise *and* ripples, so a rippled seabed stays one plane.
//! 3. **Refit.** Least-squares plane (PCA) through the inliers, recount on the whole cloud, repeat
//!    until the inlier set stops changing (or `refit_rounds`).
//!
//! The plane's normal points towards the camera (the origin of the scan frame `S`); residuals are
//! signed distances, positive on the camera's side. Units: metres.

use crate::cloud::pca::{mean_covariance_of, median, sorted_eigen};
use crate::config::{count_between, positive, shown};
use crate::error::{Error, Result};
use nalgebra::{Point3, Vector3};
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// A plane `normal · x + d = 0` with a unit normal.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Plane {
    /// Unit normal.
    pub normal: Vector3<f64>,
    /// Offset, metres: the signed distance of the origin is `d`.
    pub d: f64,
}

impl Plane {
    /// The plane through three points, or `None` when they are (nearly) collinear.
    pub fn through(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> Option<Plane> {
        let n = (b - a).cross(&(c - a));
        let scale = (b - a).norm() * (c - a).norm();
        if n.norm() <= 1e-9 * scale || !n.norm().is_finite() {
            return None;
        }
        let normal = n.normalize();
        Some(Plane {
            normal,
            d: -normal.dot(&a.coords),
        })
    }

    /// Least-squares plane through the points `indices` of `points` (total least squares: the
    /// normal is the direction of least variance). `None` with fewer than three points.
    pub fn fit(points: &[Point3<f64>], indices: &[usize]) -> Option<Plane> {
        if indices.len() < 3 {
            return None;
        }
        let (c, cov) = mean_covariance_of(points, indices.iter().copied())?;
        let (_, axes) = sorted_eigen(&cov);
        let normal: Vector3<f64> = axes.column(2).into_owned().try_normalize(1e-300)?;
        Some(Plane {
            normal,
            d: -normal.dot(&c.coords),
        })
    }

    /// Signed distance of `p`, metres (positive on the side the normal points to).
    pub fn signed_distance(&self, p: &Point3<f64>) -> f64 {
        self.normal.dot(&p.coords) + self.d
    }

    /// The same plane with its normal pointing towards `viewpoint` (unchanged if on the plane).
    pub fn facing(self, viewpoint: &Point3<f64>) -> Plane {
        if self.signed_distance(viewpoint) < 0.0 {
            Plane {
                normal: -self.normal,
                d: -self.d,
            }
        } else {
            self
        }
    }

    /// Coefficients `[a, b, c, d]` of `ax + by + cz + d = 0`.
    pub fn coefficients(&self) -> [f64; 4] {
        [self.normal.x, self.normal.y, self.normal.z, self.d]
    }
}

/// Configuration of the seabed stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SeabedConfig {
    /// Run the stage (off: the whole cloud is kept as "object side").
    pub enabled: bool,
    /// Inlier threshold, metres; 0 estimates it from the data (see the module docs).
    pub threshold_m: f64,
    /// First-pass threshold when `threshold_m` is 0, metres.
    pub initial_threshold_m: f64,
    /// The estimated threshold is this many robust standard deviations of the residuals.
    pub noise_sigmas: f64,
    /// Lower bound of the estimated threshold, metres.
    pub min_threshold_m: f64,
    /// Upper bound of the estimated threshold, metres.
    pub max_threshold_m: f64,
    /// Most RANSAC hypotheses (1 to [`MAX_RANSAC_ITERATIONS`]).
    pub max_iterations: usize,
    /// Probability that at least one all-inlier sample is drawn (sets the adaptive count).
    pub confidence: f64,
    /// With a prior `up`: largest angle between a plane's normal and `up`, degrees.
    pub up_tolerance_deg: f64,
    /// Hypotheses are scored on a random subset of this many points (0: all points).
    pub score_points: usize,
    /// Most least-squares refit rounds (at most [`MAX_REFIT_ROUNDS`]).
    pub refit_rounds: usize,
    /// Fewest inliers a plane needs (below it the stage fails: "no plane").
    pub min_inliers: usize,
    /// Seed of the random sampling.
    pub seed: u64,
    /// Object side: points at least this far above the plane, metres; 0 uses the threshold.
    pub object_min_height_m: f64,
    /// Object side: points at most this far above the plane, metres; 0 means no limit.
    pub object_max_height_m: f64,
    /// Object side: only points whose foot on the plane lies inside the convex hull of the
    /// seabed's inliers (things standing on the seabed, not a background beyond it).
    pub object_on_footprint: bool,
}

impl Default for SeabedConfig {
    fn default() -> Self {
        SeabedConfig {
            enabled: true,
            threshold_m: 0.0,
            initial_threshold_m: 0.01,
            noise_sigmas: 3.0,
            min_threshold_m: 0.002,
            max_threshold_m: 0.05,
            max_iterations: 2000,
            confidence: 0.999_999,
            up_tolerance_deg: 45.0,
            score_points: 20_000,
            refit_rounds: 10,
            min_inliers: 100,
            seed: 1,
            object_min_height_m: 0.0,
            object_max_height_m: 0.0,
            object_on_footprint: true,
        }
    }
}

/// The seabed found in a cloud.
#[derive(Debug, Clone, PartialEq)]
pub struct SeabedFit {
    /// The plane, unit normal towards the camera (the scan frame's origin).
    pub plane: Plane,
    /// Indices of the inlier points, increasing.
    pub inliers: Vec<usize>,
    /// Signed distance of every point of the cloud to the plane, metres (positive on the camera's
    /// side).
    pub residuals: Vec<f64>,
    /// The inlier threshold used, metres.
    pub threshold_m: f64,
    /// RMS distance of the inliers to the plane, metres.
    pub inlier_rms_m: f64,
    /// RANSAC hypotheses drawn (first pass plus, with an estimated threshold, second pass).
    pub iterations: usize,
    /// Least-squares refit rounds until the inlier set was stable.
    pub refit_rounds: usize,
    /// Angle between the plane's normal and the prior `up`, degrees (when one was given).
    pub angle_to_up_deg: Option<f64>,
}

/// Hypotheses scored together (in parallel) before the adaptive count is updated.
const BATCH: usize = 32;

struct Ransac<'a> {
    points: &'a [Point3<f64>],
    subset: Vec<usize>,
    up: Option<(Vector3<f64>, f64)>,
}

impl Ransac<'_> {
    /// The best-supported plane for `threshold`, its subset inlier count and hypotheses drawn.
    fn run(&self, threshold: f64, cfg: &SeabedConfig, rng: &mut ChaCha8Rng) -> (Option<Plane>, usize, usize) {
        let m = self.subset.len();
        let mut best: Option<(Plane, usize)> = None;
        let mut needed = cfg.max_iterations;
        let mut drawn = 0;
        while drawn < needed.min(cfg.max_iterations) {
            let batch: Vec<Option<Plane>> = (0..BATCH)
                .map(|_| {
                    let i = rng.random_range(0..m);
                    let j = rng.random_range(0..m);
                    let k = rng.random_range(0..m);
                    if i == j || j == k || i == k {
                        return None;
                    }
                    let [a, b, c] = [i, j, k].map(|s| &self.points[self.subset[s]]);
                    let plane = Plane::through(a, b, c)?;
                    match self.up {
                        Some((up, cos_tol)) if plane.normal.dot(&up).abs() < cos_tol => None,
                        _ => Some(plane),
                    }
                })
                .collect();
            drawn += BATCH;
            let counts: Vec<usize> = batch
                .par_iter()
                .map(|h| h.map_or(0, |pl| self.count(&pl, threshold)))
                .collect();
            for (h, c) in batch.iter().zip(counts) {
                if let Some(pl) = h
                    && best.is_none_or(|(_, bc)| c > bc)
                {
                    best = Some((*pl, c));
                }
            }
            if let Some((_, c)) = best {
                let w = c as f64 / m as f64;
                let p_good = w.powi(3);
                needed = if p_good >= 1.0 {
                    0
                } else if p_good <= 0.0 {
                    cfg.max_iterations
                } else {
                    ((1.0 - cfg.confidence).ln() / (1.0 - p_good).ln()).ceil() as usize
                };
            }
        }
        (best.map(|b| b.0), best.map_or(0, |b| b.1), drawn)
    }

    fn count(&self, plane: &Plane, threshold: f64) -> usize {
        self.subset
            .iter()
            .filter(|&&i| plane.signed_distance(&self.points[i]).abs() <= threshold)
            .count()
    }
}

/// Finds the seabed plane in `points` (scan frame), optionally near the prior `up` (any length;
/// normalised here).
///
/// # Errors
/// [`Error::Input`] for a bad configuration or a zero/non-finite `up`; [`Error::Failed`]
/// (stage `seabed`) when no plane near `up` has `min_inliers` inliers.
pub fn find_seabed(
    points: &[Point3<f64>],
    up: Option<&Vector3<f64>>,
    cfg: &SeabedConfig,
) -> Result<SeabedFit> {
    cfg.validate()?;
    let up = up.map(unit_up).transpose()?;
    if points.len() < 3 {
        return Err(Error::failed(
            "seabed",
            format!("no plane: the cloud has {} points", points.len()),
        ));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let subset: Vec<usize> = if cfg.score_points == 0 || cfg.score_points >= points.len() {
        (0..points.len()).collect()
    } else {
        let mut s = rand::seq::index::sample(&mut rng, points.len(), cfg.score_points).into_vec();
        s.sort_unstable();
        s
    };
    let cos_tol = cfg.up_tolerance_deg.to_radians().cos();
    let ransac = Ransac {
        points,
        subset,
        up: up.map(|u| (u, cos_tol)),
    };
    let auto = cfg.threshold_m <= 0.0;
    let first = if auto {
        cfg.initial_threshold_m
    } else {
        cfg.threshold_m
    };
    let (plane, _, mut iterations) = ransac.run(first, cfg, &mut rng);
    let no_plane = |why: String| {
        let near = up.map_or(String::new(), |u| {
            format!(
                " within {}° of --up ({:.3},{:.3},{:.3})",
                cfg.up_tolerance_deg, u.x, u.y, u.z
            )
        });
        Error::failed("seabed", format!("no plane{near}: {why}"))
    };
    let mut plane = plane.ok_or_else(|| no_plane(format!("none of {iterations} hypotheses qualified")))?;
    let mut threshold = first;
    if auto {
        // Refit on the first-pass inliers, then take the residual spread near that plane.
        if let Some(p) = Plane::fit(points, &inliers_of(points, &plane, first)) {
            plane = p;
        }
        let mut near: Vec<f64> = points
            .par_iter()
            .map(|p| plane.signed_distance(p))
            .filter(|r| r.abs() <= 2.0 * first)
            .collect();
        let centre = median(&mut near).unwrap_or(0.0);
        let mut dev: Vec<f64> = near.iter().map(|r| (r - centre).abs()).collect();
        let sigma = 1.4826 * median(&mut dev).unwrap_or(0.0);
        threshold = (cfg.noise_sigmas * sigma).clamp(cfg.min_threshold_m, cfg.max_threshold_m);
        let (p2, _, it2) = ransac.run(threshold, cfg, &mut rng);
        iterations += it2;
        // Keep the refined first-pass plane if the second pass found nothing near `up`.
        if let Some(p2) = p2 {
            plane = p2;
        }
    }
    // Least-squares refit and recount until the inlier set is stable.
    let mut inliers = inliers_of(points, &plane, threshold);
    let mut rounds = 0;
    while rounds < cfg.refit_rounds {
        rounds += 1;
        let Some(p) = Plane::fit(points, &inliers) else {
            break;
        };
        let next = inliers_of(points, &p, threshold);
        plane = p;
        if next == inliers {
            break;
        }
        inliers = next;
    }
    plane = plane.facing(&Point3::origin());
    let angle_to_up_deg = up.map(|u| plane.normal.dot(&u).abs().min(1.0).acos().to_degrees());
    if let Some(a) = angle_to_up_deg
        && a > cfg.up_tolerance_deg
    {
        return Err(no_plane(format!(
            "the refitted plane drifted to {a:.1}° from --up"
        )));
    }
    if inliers.len() < cfg.min_inliers.max(3) {
        return Err(no_plane(format!(
            "the best plane has {} inliers (min_inliers = {})",
            inliers.len(),
            cfg.min_inliers
        )));
    }
    let residuals: Vec<f64> = points.par_iter().map(|p| plane.signed_distance(p)).collect();
    let inlier_rms_m =
        (inliers.iter().map(|&i| residuals[i].powi(2)).sum::<f64>() / inliers.len() as f64).sqrt();
    Ok(SeabedFit {
        plane,
        inliers,
        residuals,
        threshold_m: threshold,
        inlier_rms_m,
        iterations,
        refit_rounds: rounds,
        angle_to_up_deg,
    })
}

/// Indices of the points on the object side of the seabed: above the plane (camera side) by more
/// than `object_min_height_m` (or the threshold), at most `object_max_height_m` when set, and with
/// `object_on_footprint` only those whose foot on the plane falls inside the convex hull of the
/// inliers' feet. Increasing order.
pub fn object_side(points: &[Point3<f64>], fit: &SeabedFit, cfg: &SeabedConfig) -> Vec<usize> {
    let lo = if cfg.object_min_height_m > 0.0 {
        cfg.object_min_height_m
    } else {
        fit.threshold_m
    };
    let hi = if cfg.object_max_height_m > 0.0 {
        cfg.object_max_height_m
    } else {
        f64::INFINITY
    };
    let n = fit.plane.normal;
    let (e1, e2) = crate::spatial::perpendicular_basis(&n);
    let foot = |p: &Point3<f64>| [p.coords.dot(&e1), p.coords.dot(&e2)];
    let hull = if cfg.object_on_footprint {
        convex_hull_2d(fit.inliers.iter().map(|&i| foot(&points[i])).collect())
    } else {
        Vec::new()
    };
    (0..points.len())
        .into_par_iter()
        .filter(|&i| {
            let h = fit.residuals[i];
            h > lo && h <= hi && (!cfg.object_on_footprint || inside_convex(&hull, foot(&points[i])))
        })
        .collect()
}

/// Convex hull of 2-D points, counter-clockwise (Andrew's monotone chain), after dropping the
/// points well inside the polygon of the extremes along x, y and the diagonals (Akl–Toussaint):
/// most of a seabed's points, which the chain would otherwise sort.
fn convex_hull_2d(mut p: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    if p.len() > 64 {
        let extreme = |f: fn(&[f64; 2]) -> f64| {
            let by = |a: &&[f64; 2], b: &&[f64; 2]| f(a).total_cmp(&f(b));
            [
                *p.iter().min_by(by).unwrap_or(&p[0]),
                *p.iter().max_by(by).unwrap_or(&p[0]),
            ]
        };
        let poly = monotone_chain(
            [
                extreme(|q| q[0]),
                extreme(|q| q[1]),
                extreme(|q| q[0] + q[1]),
                extreme(|q| q[0] - q[1]),
            ]
            .concat(),
        );
        if poly.len() >= 3 {
            // Inside by more than round-off: the chain decides the points near the polygon's
            // edges (a vertex of the hull may lie on one).
            let scale = p.iter().fold(0.0f64, |m, q| m.max(q[0].abs()).max(q[1].abs()));
            let tol = 1e-9 * scale * scale;
            let edges: Vec<_> = poly.iter().zip(poly.iter().cycle().skip(1)).collect();
            p.retain(|&q| !edges.iter().all(|&(&a, &b)| cross(a, b, q) > tol));
        }
    }
    monotone_chain(p)
}

/// `(a − o) × (b − o)`: positive when `o, a, b` turn counter-clockwise.
fn cross(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Andrew's monotone chain: the hull's vertices, counter-clockwise, from the lowest x (then y).
fn monotone_chain(mut p: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    p.par_sort_unstable_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let mut hull: Vec<[f64; 2]> = Vec::with_capacity(64);
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &[f64; 2]>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in iter {
            while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0 {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    hull
}

/// True if `q` is inside (or on) the counter-clockwise convex polygon `hull` (≥ 3 vertices):
/// the wedge from `hull[0]` holding `q` by binary search, then that wedge's outer edge.
fn inside_convex(hull: &[[f64; 2]], q: [f64; 2]) -> bool {
    let n = hull.len();
    if n < 3 || cross(hull[0], hull[1], q) < 0.0 || cross(hull[0], hull[n - 1], q) > 0.0 {
        return false;
    }
    let (mut lo, mut hi) = (1, n - 1);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if cross(hull[0], hull[mid], q) >= 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    cross(hull[lo], hull[hi], q) >= 0.0
}

fn inliers_of(points: &[Point3<f64>], plane: &Plane, threshold: f64) -> Vec<usize> {
    points
        .par_iter()
        .enumerate()
        .filter(|(_, p)| plane.signed_distance(p).abs() <= threshold)
        .map(|(i, _)| i)
        .collect()
}

/// Most RANSAC hypotheses: 500 times the default. The adaptive count needs about 7000 for a
/// seabed that is a fifth of the cloud at the default confidence; each hypothesis is scored on
/// up to `score_points` points.
pub const MAX_RANSAC_ITERATIONS: usize = 1_000_000;

/// Most least-squares refit rounds: 100 times the default (the inlier set is usually stable
/// after two or three).
pub const MAX_REFIT_ROUNDS: usize = 1000;

impl SeabedConfig {
    /// Checks every value.
    ///
    /// # Errors
    /// [`Error::Input`] naming the field (`seabed.…`).
    pub fn validate(&self) -> Result<()> {
        let bad = |field: &str, why: String| Err(Error::input(format!("seabed.{field}"), why));
        if !(self.threshold_m >= 0.0 && self.threshold_m.is_finite()) {
            return bad(
                "threshold_m",
                format!(
                    "must be a finite number ≥ 0 (0 = estimate from the data), got {}",
                    shown(self.threshold_m)
                ),
            );
        }
        if self.threshold_m == 0.0 {
            positive("seabed.initial_threshold_m", self.initial_threshold_m)?;
        }
        positive("seabed.max_threshold_m", self.max_threshold_m)?;
        if !(self.min_threshold_m > 0.0 && self.min_threshold_m <= self.max_threshold_m) {
            return bad(
                "min_threshold_m",
                format!(
                    "must be > 0 and ≤ seabed.max_threshold_m ({}), got {}",
                    shown(self.max_threshold_m),
                    shown(self.min_threshold_m)
                ),
            );
        }
        positive("seabed.noise_sigmas", self.noise_sigmas)?;
        if !(self.confidence > 0.0 && self.confidence < 1.0) {
            return bad(
                "confidence",
                format!("must be in (0, 1), got {}", shown(self.confidence)),
            );
        }
        if !(self.up_tolerance_deg > 0.0 && self.up_tolerance_deg <= 90.0) {
            return bad(
                "up_tolerance_deg",
                format!("must be in (0, 90] degrees, got {}", shown(self.up_tolerance_deg)),
            );
        }
        count_between(
            "seabed.max_iterations",
            self.max_iterations,
            1,
            MAX_RANSAC_ITERATIONS,
        )?;
        count_between("seabed.refit_rounds", self.refit_rounds, 0, MAX_REFIT_ROUNDS)?;
        if !(self.object_min_height_m >= 0.0 && self.object_min_height_m.is_finite()) {
            return bad(
                "object_min_height_m",
                format!(
                    "must be a finite number ≥ 0 (0 = the inlier threshold), got {}",
                    shown(self.object_min_height_m)
                ),
            );
        }
        if !(self.object_max_height_m == 0.0
            || self.object_max_height_m.is_finite() && self.object_max_height_m > self.object_min_height_m)
        {
            return bad(
                "object_max_height_m",
                format!(
                    "must be 0 (no limit) or a finite number > seabed.object_min_height_m ({}), got {}",
                    shown(self.object_min_height_m),
                    shown(self.object_max_height_m)
                ),
            );
        }
        Ok(())
    }
}

/// `up` as a unit vector: scaled by its largest component first, so that a long vector (whose
/// squared norm overflows) is normalised as well as a short one.
///
/// # Errors
/// [`Error::Input`] naming `--up` for a zero or non-finite vector.
pub fn unit_up(u: &Vector3<f64>) -> Result<Vector3<f64>> {
    let err = || {
        Error::input(
            "--up",
            format!(
                "must be a finite non-zero vector, got ({}, {}, {})",
                u.x, u.y, u.z
            ),
        )
    };
    let scale = u.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    if !(u.iter().all(|c| c.is_finite()) && scale > 0.0) {
        return Err(err());
    }
    (u / scale).try_normalize(0.5).ok_or_else(err)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use std::f64::consts::PI;

    /// A sloped, rippled seabed 1 m below the camera plus a box of points standing on it.
    fn scene(noise: f64, ripple: f64, slope_deg: f64, seed: u64) -> (Vec<Point3<f64>>, Plane, usize) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let s = slope_deg.to_radians();
        // Seabed plane: normal tilted by `slope` about x, facing the camera (-z).
        let n = Vector3::new(0.0, s.sin(), -s.cos());
        let e1 = Vector3::x();
        let e2 = n.cross(&e1);
        let origin = Point3::new(0.0, 0.0, 1.0);
        let mut pts = Vec::new();
        for _ in 0..20_000 {
            let (u, v) = (rng.random_range(-0.6..0.6), rng.random_range(-0.6..0.6));
            let h = ripple * (2.0 * PI * u / 0.15).sin() + noise * gauss(&mut rng);
            pts.push(origin + e1 * u + e2 * v + n * h);
        }
        let n_seabed = pts.len();
        for _ in 0..3000 {
            let (u, v, w) = (
                rng.random_range(-0.1..0.1),
                rng.random_range(-0.05..0.05),
                rng.random_range(0.03..0.1),
            );
            pts.push(origin + e1 * u + e2 * v + n * w);
        }
        let plane = Plane {
            normal: n,
            d: -n.dot(&origin.coords),
        };
        (pts, plane, n_seabed)
    }

    fn gauss(rng: &mut ChaCha8Rng) -> f64 {
        let u1: f64 = rng.random::<f64>().max(1e-300);
        let u2: f64 = rng.random();
        (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
    }

    #[test]
    fn sloped_rippled_seabed_is_one_plane() {
        let (pts, truth, n_seabed) = scene(0.001, 0.004, 20.0, 5);
        let fit = find_seabed(&pts, None, &SeabedConfig::default()).unwrap();
        assert!(
            fit.plane.normal.dot(&truth.normal) > 0.9999,
            "normal {:?}",
            fit.plane.normal
        );
        assert!((fit.plane.d - truth.d).abs() < 1e-3);
        // Facing the camera: the origin is on the positive side.
        assert!(fit.plane.d > 0.0);
        // Ripples of 4 mm amplitude plus 1 mm noise: nearly every seabed point is an inlier and
        // no object point (≥ 30 mm above) is.
        let seabed_in = fit.inliers.iter().filter(|&&i| i < n_seabed).count();
        assert!(seabed_in as f64 > 0.99 * n_seabed as f64, "{seabed_in}");
        assert_eq!(fit.inliers.len(), seabed_in);
        assert!(
            fit.threshold_m > 0.004 && fit.threshold_m < 0.03,
            "{}",
            fit.threshold_m
        );
    }

    #[test]
    fn prior_picks_the_plane_near_up_over_a_bigger_wall() {
        let (mut pts, truth, _) = scene(0.001, 0.0, 0.0, 6);
        // A wall bigger than the seabed, at z = 2 m... vertical, at y = -0.8 m.
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for _ in 0..40_000 {
            pts.push(Point3::new(
                rng.random_range(-1.0..1.0),
                -0.8 + 0.001 * gauss(&mut rng),
                rng.random_range(0.5..2.0),
            ));
        }
        let free = find_seabed(&pts, None, &SeabedConfig::default()).unwrap();
        assert!(free.plane.normal.y.abs() > 0.99, "without a prior the wall wins");
        // A rough prior, 30° off the true normal.
        let up = Vector3::new(0.0, (30f64).to_radians().sin(), -(30f64).to_radians().cos());
        let fit = find_seabed(&pts, Some(&up), &SeabedConfig::default()).unwrap();
        assert!(fit.plane.normal.dot(&truth.normal) > 0.9999);
        assert!((fit.angle_to_up_deg.unwrap() - 30.0).abs() < 0.5);
    }

    #[test]
    fn no_plane_near_up_is_a_failed_run() {
        let (pts, _, _) = scene(0.001, 0.0, 0.0, 7);
        let err = find_seabed(&pts, Some(&Vector3::x()), &SeabedConfig::default()).unwrap_err();
        assert_eq!(err.exit_code(), 1, "{err}");
        assert!(err.to_string().starts_with("seabed: no plane"), "{err}");
        let err = find_seabed(&pts[..2], None, &SeabedConfig::default()).unwrap_err();
        assert_eq!(err.exit_code(), 1);
        let err = find_seabed(&pts, Some(&Vector3::zeros()), &SeabedConfig::default()).unwrap_err();
        assert_eq!(err.exit_code(), 2);
    }

    #[test]
    fn object_side_keeps_what_stands_on_the_seabed() {
        let (mut pts, _, n_seabed) = scene(0.001, 0.0, 0.0, 10);
        let n_object = pts.len() - n_seabed;
        // Points above the plane but beyond the seabed's edge (a background), and below it.
        pts.extend((0..500).map(|i| Point3::new(0.9 + 0.0001 * i as f64, 0.0, 0.95)));
        pts.extend((0..500).map(|i| Point3::new(0.0001 * i as f64, 0.0, 1.05)));
        let cfg = SeabedConfig::default();
        let fit = find_seabed(&pts, None, &cfg).unwrap();
        let obj = object_side(&pts, &fit, &cfg);
        // Every object point, none of the background or below the plane, and only the 3σ tail of
        // the seabed's noise (0.13 %).
        let objects = obj
            .iter()
            .filter(|&&i| (n_seabed..n_seabed + n_object).contains(&i))
            .count();
        let tail = obj.iter().filter(|&&i| i < n_seabed).count();
        assert_eq!(objects, n_object);
        assert!(tail < n_seabed / 200, "{tail}");
        assert_eq!(obj.len(), objects + tail);
        let all = object_side(
            &pts,
            &fit,
            &SeabedConfig {
                object_on_footprint: false,
                ..cfg.clone()
            },
        );
        assert_eq!(all.len(), obj.len() + 500);
        let low = object_side(
            &pts,
            &fit,
            &SeabedConfig {
                object_max_height_m: 0.05,
                ..cfg
            },
        );
        assert!(low.len() < n_object && low.iter().all(|&i| fit.residuals[i] <= 0.05));
    }

    #[test]
    fn hull_and_inside() {
        let h = convex_hull_2d(vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [0.5, 0.5],
            [0.2, 0.7],
        ]);
        assert_eq!(h.len(), 4);
        assert!(inside_convex(&h, [0.5, 0.5]) && !inside_convex(&h, [1.5, 0.5]));
    }

    /// The extremes' pre-filter leaves the hull as the chain finds it over all the points:
    /// a disc, a square's grid (collinear points on every edge, duplicates) and a thin sliver.
    #[test]
    fn prefiltered_hull_equals_the_chains() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let disc: Vec<[f64; 2]> = (0..5000)
            .map(|_| {
                let (r, t) = (rng.random::<f64>().sqrt(), rng.random_range(0.0..2.0 * PI));
                [3.0 + r * t.cos(), -2.0 + 0.5 * r * t.sin()]
            })
            .collect();
        let grid: Vec<[f64; 2]> = (0..2000)
            .map(|i| [f64::from(i % 40) * 0.1, f64::from((i / 40) % 40) * 0.1])
            .collect();
        let sliver: Vec<[f64; 2]> = (0..500)
            .map(|_| {
                let x = rng.random_range(-1.0..1.0);
                [x, 1e-6 * rng.random_range(-1.0..1.0) + 0.3 * x]
            })
            .collect();
        for p in [disc, grid, sliver] {
            let h = convex_hull_2d(p.clone());
            assert_eq!(h, monotone_chain(p.clone()));
            assert!(h.len() >= 3);
            // The wedge search answers as every edge's side does, on the points, the hull's
            // vertices and points around it.
            let (lo, hi) = p.iter().fold(([f64::MAX; 2], [f64::MIN; 2]), |(l, u), q| {
                ([l[0].min(q[0]), l[1].min(q[1])], [u[0].max(q[0]), u[1].max(q[1])])
            });
            let around = (0..2000).map(|_| {
                [0, 1].map(|k| rng.random_range(lo[k] - 0.2 * (hi[k] - lo[k])..hi[k] + 0.2 * (hi[k] - lo[k])))
            });
            for q in p.iter().copied().chain(h.iter().copied()).chain(around) {
                let every_edge = (0..h.len()).all(|i| cross(h[i], h[(i + 1) % h.len()], q) >= 0.0);
                assert_eq!(inside_convex(&h, q), every_edge, "{q:?}");
            }
        }
    }

    #[test]
    fn same_seed_same_plane() {
        let (pts, _, _) = scene(0.002, 0.002, 10.0, 8);
        let cfg = SeabedConfig::default();
        let a = find_seabed(&pts, None, &cfg).unwrap();
        let b = find_seabed(&pts, None, &cfg).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn nan_heights_and_unbounded_counts_are_rejected() {
        use crate::perception::assert_bad_input;
        let (pts, _, _) = scene(0.001, 0.0, 0.0, 11);
        let with = |f: &dyn Fn(&mut SeabedConfig)| {
            let mut c = SeabedConfig::default();
            f(&mut c);
            c
        };
        for (cfg, field) in [
            (
                with(&|c| c.object_min_height_m = f64::NAN),
                "seabed.object_min_height_m",
            ),
            (
                with(&|c| c.object_min_height_m = -1.0),
                "seabed.object_min_height_m",
            ),
            (
                with(&|c| c.object_max_height_m = f64::NAN),
                "seabed.object_max_height_m",
            ),
            (
                with(&|c| {
                    c.object_min_height_m = 0.2;
                    c.object_max_height_m = 0.1;
                }),
                "seabed.object_max_height_m",
            ),
            (
                with(&|c| c.max_threshold_m = f64::INFINITY),
                "seabed.max_threshold_m",
            ),
            (with(&|c| c.max_iterations = usize::MAX), "seabed.max_iterations"),
            (with(&|c| c.refit_rounds = usize::MAX), "seabed.refit_rounds"),
        ] {
            assert_bad_input(find_seabed(&pts, None, &cfg), field);
        }
    }

    #[test]
    fn a_long_up_is_scaled_before_it_is_normalised() {
        // (1e300, 1e300, 1e300) overflowed the norm and normalised to the zero vector.
        let u = unit_up(&Vector3::new(1e300, 1e300, 1e300)).unwrap();
        assert!((u - Vector3::repeat(1.0 / 3f64.sqrt())).norm() < 1e-15, "{u:?}");
        let u = unit_up(&Vector3::new(0.0, 1e-310, 0.0)).unwrap();
        assert_eq!(u, Vector3::y());
        for bad in [
            Vector3::zeros(),
            Vector3::new(f64::NAN, 0.0, -1.0),
            Vector3::new(f64::INFINITY, 0.0, 0.0),
        ] {
            let e = unit_up(&bad).unwrap_err();
            assert_eq!(e.exit_code(), 2);
            assert!(
                e.to_string()
                    .starts_with("--up: must be a finite non-zero vector"),
                "{e}"
            );
        }
        // The same plane as the unit prior.
        let (pts, truth, _) = scene(0.001, 0.0, 0.0, 12);
        let far = truth.normal * 1e300;
        let fit = find_seabed(&pts, Some(&far), &SeabedConfig::default()).unwrap();
        assert!(fit.plane.normal.dot(&truth.normal) > 0.9999);
        assert!(fit.angle_to_up_deg.unwrap() < 1.0);
    }
}
