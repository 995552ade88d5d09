//! Hidden-point removal: which points of a point set a camera could see, without a surface
//! (Katz, Tal & Basri, "Direct visibility of point sets", SIGGRAPH 2007).
//!
//! Every point `p` is moved to `C + v (2R/‖v‖ − 1)`, `v = p − C` (a spherical flip about a sphere
//! of radius `R` centred at the viewpoint `C`); the points whose images are vertices of the convex
//! hull of the flipped set plus `C` are the visible ones. `R = radius_factor × max ‖v‖`: larger
//! factors keep more points (Open3D's examples use 100). The single-view scan cannot contain the
//! back of the reference model, so the seed culls those points before ICP; so do we.

use crate::register::hull::hull_vertices;
use crate::surface::convex_hull_vertices;
use nalgebra::Point3;
use serde::{Deserialize, Serialize};

/// Configuration of hidden-point removal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HiddenPointConfig {
    /// Cull the reference points the camera cannot see before ICP.
    pub enabled: bool,
    /// Radius of the flipping sphere over the farthest point's distance (above 1, at most
    /// [`MAX_RADIUS_FACTOR`]).
    pub radius_factor: f64,
}

impl Default for HiddenPointConfig {
    fn default() -> Self {
        HiddenPointConfig {
            enabled: true,
            radius_factor: 100.0,
        }
    }
}

/// Largest `radius_factor`: far past the point where every point is on the hull (the flip
/// then keeps the back of the model too); beyond it the flipped points lose their precision.
pub const MAX_RADIUS_FACTOR: f64 = 1e6;

impl HiddenPointConfig {
    /// Checks `radius_factor`: above 1 (the flipping sphere must enclose the points) and at most
    /// [`MAX_RADIUS_FACTOR`].
    ///
    /// # Errors
    /// [`crate::error::Error::Input`] naming `register.hidden_points.radius_factor`.
    pub fn validate(&self) -> crate::error::Result<()> {
        crate::config::require(
            self.radius_factor > 1.0 && self.radius_factor <= MAX_RADIUS_FACTOR,
            "register.hidden_points.radius_factor",
            format!(
                "must be > 1 and at most {MAX_RADIUS_FACTOR} (the flipping sphere's radius over the \
                 farthest point's distance), got {}",
                crate::config::shown(self.radius_factor)
            ),
        )
    }
}

/// Indices (increasing) of the points of `points` visible from `viewpoint`. When the hull is
/// degenerate (a flat or tiny set, or a viewpoint among the points) every point is returned.
pub fn visible_points(points: &[Point3<f64>], viewpoint: &Point3<f64>, radius_factor: f64) -> Vec<usize> {
    let all = || (0..points.len()).collect();
    let Some(flipped) = flipped(points, viewpoint, radius_factor) else {
        return all();
    };
    // Our quickhull, parry's when ours meets a numerical inconsistency.
    match hull_vertices(&flipped).or_else(|| convex_hull_vertices(&flipped)) {
        Some(v) => v.into_iter().filter(|&i| i < points.len()).collect(),
        None => all(),
    }
}

/// The points flipped about the sphere of radius `radius_factor` × the farthest point's distance
/// around `viewpoint` (moved to the origin), followed by the viewpoint; `None` for fewer than
/// four points, all points at the viewpoint, or a factor not above 1.
fn flipped(points: &[Point3<f64>], viewpoint: &Point3<f64>, radius_factor: f64) -> Option<Vec<Point3<f64>>> {
    let max = points.iter().map(|p| (p - viewpoint).norm()).fold(0.0, f64::max);
    if points.len() < 4 || !(max > 0.0 && radius_factor > 1.0) {
        return None;
    }
    let r = radius_factor * max;
    let mut flipped: Vec<Point3<f64>> = points
        .iter()
        .map(|p| {
            let v = p - viewpoint;
            let d = v.norm();
            if d > 0.0 {
                Point3::from(v * (2.0 * r / d - 1.0))
            } else {
                Point3::origin()
            }
        })
        .collect();
    flipped.push(Point3::origin());
    Some(flipped)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn sees_the_near_cap_of_a_sphere() {
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(4);
        let c = Point3::new(0.0, 0.0, 1.0);
        let radius = 0.1;
        let pts: Vec<Point3<f64>> = (0..4000)
            .map(|_| {
                let v = Vector3::new(
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                );
                c + v.normalize() * radius
            })
            .collect();
        let cam = Point3::origin();
        let vis = visible_points(&pts, &cam, 100.0);
        let mut is_vis = vec![false; pts.len()];
        for &i in &vis {
            is_vis[i] = true;
        }
        // Truly visible: the outward normal faces the camera.
        let truth: Vec<bool> = pts.iter().map(|p| (p - c).dot(&(cam - p)) > 0.0).collect();
        let agree = is_vis.iter().zip(&truth).filter(|(a, b)| a == b).count();
        assert!(agree as f64 > 0.95 * pts.len() as f64, "{agree} of {}", pts.len());
        // No point of the far half is kept.
        assert!(vis.iter().all(|&i| pts[i].z < 1.0 + 0.2 * radius));
    }

    #[test]
    fn our_hull_sees_what_parrys_sees() {
        // The bottle model from around it, near and far, and the sphere at every density.
        let (bottle, _) = crate::register::tests::bottle(6000, 3);
        for (k, cam) in [
            Point3::new(0.0, 0.0, -0.6),
            Point3::new(0.4, 0.3, -0.5),
            Point3::new(-1.5, 0.2, 0.1),
            Point3::new(0.05, -0.2, 0.25),
        ]
        .iter()
        .enumerate()
        {
            for factor in [10.0, 100.0, 1000.0] {
                let f = flipped(&bottle, cam, factor).unwrap();
                let ours = hull_vertices(&f).unwrap();
                let parry = convex_hull_vertices(&f).unwrap();
                assert_eq!(ours, parry, "camera {k}, factor {factor}");
            }
        }
    }

    #[test]
    fn a_factor_that_culls_nothing_or_nonsense_is_rejected() {
        // Each of these silently kept every point (the flip needs a factor above 1).
        for f in [f64::NAN, -1.0, 0.0, 1.0, f64::INFINITY, 1e300] {
            let cfg = HiddenPointConfig {
                radius_factor: f,
                ..HiddenPointConfig::default()
            };
            crate::perception::assert_bad_input(cfg.validate(), "register.hidden_points.radius_factor");
        }
        HiddenPointConfig::default().validate().unwrap();
    }
}
