//! Surface normals by local principal component analysis (Hoppe et al. 1992).
//!
//! For every point, the `k` nearest neighbours (optionally capped to a radius) give a covariance
//! matrix; the normal is its eigenvector of least variance. Normals are oriented towards a
//! viewpoint (the camera, at the origin of the scan frame `S` for a scan), which is how a
//! single-view sensor sees its surface. Runs in parallel (rayon); the result does not depend on the
//! number of threads. Units: metres.

use crate::cloud::knn::map_knn_within;
use crate::cloud::pca::{least_eigenvector, mean_covariance_of};
use crate::error::Result;
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};

/// How normals are estimated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NormalConfig {
    /// Neighbours used for each point's local plane, the point itself included (3 to
    /// [`MAX_NORMAL_NEIGHBOURS`]).
    pub neighbours: usize,
    /// Neighbours farther than this are left out, metres; 0 means no cap.
    pub radius_m: f64,
}

impl Default for NormalConfig {
    fn default() -> Self {
        NormalConfig {
            neighbours: 20,
            radius_m: 0.0,
        }
    }
}

/// Most neighbours of a point's local plane: 50 times the default, 10 times the usual values
/// (10 to 100); the estimate costs a k-NN query and a covariance of `k` points per point.
pub const MAX_NORMAL_NEIGHBOURS: usize = 1000;

impl NormalConfig {
    /// Checks `neighbours` (3 — a plane — to [`MAX_NORMAL_NEIGHBOURS`]) and `radius_m` (finite,
    /// ≥ 0).
    ///
    /// # Errors
    /// [`crate::error::Error::Input`] naming the field (`normals.…`).
    pub fn validate(&self) -> Result<()> {
        crate::config::count_between("normals.neighbours", self.neighbours, 3, MAX_NORMAL_NEIGHBOURS)?;
        crate::config::non_negative("normals.radius_m", self.radius_m)
    }
}

/// The unit normal of each point of `points`, oriented so that it points towards `viewpoint`. A
/// point with fewer than three usable neighbours (itself included) gets the unit direction
/// towards the viewpoint. The neighbourhoods come from the grid all-kNN ([`map_knn_within`]),
/// several times cheaper than a kd-tree query per point.
///
/// # Errors
/// [`crate::error::Error::Input`] for a bad configuration ([`NormalConfig::validate`]) or if a
/// point is not finite.
pub fn estimate_normals(
    points: &[Point3<f64>],
    config: &NormalConfig,
    viewpoint: &Point3<f64>,
) -> Result<Vec<Vector3<f64>>> {
    config.validate()?;
    let k = config.neighbours;
    let radius = if config.radius_m > 0.0 {
        config.radius_m
    } else {
        f64::INFINITY
    };
    // The point itself is one of its `k` neighbours.
    map_knn_within(points, k - 1, radius, |i, nb| {
        let towards = (viewpoint - points[i])
            .try_normalize(1e-300)
            .unwrap_or(Vector3::z());
        if nb.len() < 2 {
            return towards;
        }
        let near = std::iter::once(i).chain(nb.iter().map(|n| n.index));
        let Some((_, cov)) = mean_covariance_of(points, near) else {
            return towards;
        };
        let n = least_eigenvector(&cov);
        match n.try_normalize(1e-300) {
            Some(n) if n.dot(&towards) < 0.0 => -n,
            Some(n) => n,
            None => towards,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn sphere_normals_are_radial_and_face_the_viewpoint() {
        // Points on a sphere of radius 0.2 m centred 1 m in front of the camera.
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(3);
        let c = Point3::new(0.0, 0.0, 1.0);
        let pts: Vec<Point3<f64>> = (0..5000)
            .map(|_| {
                let v = Vector3::new(
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                    rng.random::<f64>() - 0.5,
                );
                c + v.normalize() * 0.2
            })
            .collect();
        let n = estimate_normals(&pts, &NormalConfig::default(), &Point3::origin()).unwrap();
        for (p, n) in pts.iter().zip(&n) {
            let radial = (p - c).normalize();
            assert!(n.dot(&radial).abs() > 0.98, "normal not radial");
            assert!(n.dot(&(Point3::origin() - p)) >= 0.0, "normal faces away");
            assert!((n.norm() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn isolated_points_get_the_view_direction() {
        let pts = vec![Point3::new(0.0, 0.0, 2.0), Point3::new(1.0, 0.0, 2.0)];
        let n = estimate_normals(&pts, &NormalConfig::default(), &Point3::origin()).unwrap();
        assert!((n[0] - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
    }

    #[test]
    fn bad_radius_or_neighbour_count_is_an_input_error() {
        let pts = vec![Point3::new(0.0, 0.0, 2.0), Point3::new(1.0, 0.0, 2.0)];
        for (cfg, field) in [
            (
                NormalConfig {
                    radius_m: f64::NAN,
                    ..Default::default()
                },
                "normals.radius_m",
            ),
            (
                NormalConfig {
                    radius_m: -1.0,
                    ..Default::default()
                },
                "normals.radius_m",
            ),
            (
                NormalConfig {
                    neighbours: usize::MAX,
                    ..Default::default()
                },
                "normals.neighbours",
            ),
            (
                NormalConfig {
                    neighbours: 0,
                    ..Default::default()
                },
                "normals.neighbours",
            ),
        ] {
            crate::perception::assert_bad_input(estimate_normals(&pts, &cfg, &Point3::origin()), field);
        }
    }
}
