//! Euclidean cluster extraction (Rusu 2009, §6.2; PCL's `EuclideanClusterExtraction`).
//!
//! Two points belong to the same cluster when a chain of points joins them with every link at
//! most `tolerance_m` long. Clusters grow breadth-first on the [`KdIndex`]; the radius queries of
//! each breadth-first front run in parallel, and the points of a cluster are reported in
//! increasing index order, so the result does not depend on the number of threads. Clusters with
//! fewer than `min_points` or more than `max_points` points are dropped. Units: metres.

use crate::cloud::pca::{PrincipalAxes, principal_axes};
use crate::error::{Error, Result};
use crate::spatial::KdIndex;
use nalgebra::Point3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Configuration of the clustering stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClusterConfig {
    /// Run the stage (off: all points above the seabed form one cluster).
    pub enabled: bool,
    /// Largest link between two points of one cluster, metres.
    pub tolerance_m: f64,
    /// Fewest points of a cluster.
    pub min_points: usize,
    /// Most points of a cluster.
    pub max_points: usize,
    /// Quantile used for cluster spans along the principal axes (spans run from `q` to `1 − q`).
    pub span_quantile: f64,
}

impl Default for ClusterConfig {
    fn default() -> Self {
        ClusterConfig {
            enabled: true,
            tolerance_m: 0.01,
            min_points: 100,
            max_points: 5_000_000,
            span_quantile: 0.01,
        }
    }
}

/// One cluster.
#[derive(Debug, Clone, PartialEq)]
pub struct Cluster {
    /// Indices of its points in the clustered slice, increasing.
    pub indices: Vec<usize>,
    /// Its principal axes, centroid and spans (metres).
    pub shape: PrincipalAxes,
}

/// The clusters found, largest first (ties: the one holding the smallest index first).
#[derive(Debug, Clone, PartialEq)]
pub struct Clustering {
    /// Clusters within the size limits.
    pub clusters: Vec<Cluster>,
    /// Points in groups smaller than `min_points`.
    pub small_points: usize,
    /// Groups larger than `max_points` (dropped).
    pub large_clusters: usize,
}

/// Euclidean clusters of `points` (`index` built on the same slice).
///
/// # Errors
/// [`Error::Input`] naming `cluster.tolerance_m` or `cluster.min_points` when they are not
/// usable.
pub fn euclidean_clusters(
    points: &[Point3<f64>],
    index: &KdIndex,
    cfg: &ClusterConfig,
) -> Result<Clustering> {
    if !(cfg.tolerance_m > 0.0 && cfg.tolerance_m.is_finite()) {
        return Err(Error::input("cluster.tolerance_m", "must be > 0"));
    }
    if cfg.min_points == 0 || cfg.min_points > cfg.max_points {
        return Err(Error::input(
            "cluster.min_points",
            "must be ≥ 1 and ≤ cluster.max_points",
        ));
    }
    let n = points.len();
    let mut visited = vec![false; n];
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut small_points = 0;
    let mut large_clusters = 0;
    for seed in 0..n {
        if visited[seed] {
            continue;
        }
        visited[seed] = true;
        let mut members = vec![seed];
        let mut front = vec![seed];
        while !front.is_empty() {
            let found: Vec<Vec<usize>> = front
                .par_iter()
                .map(|&i| {
                    let mut v = Vec::new();
                    index.within_visit(&points[i], cfg.tolerance_m, |nb| v.push(nb.index));
                    v
                })
                .collect();
            front.clear();
            for j in found.into_iter().flatten() {
                if !visited[j] {
                    visited[j] = true;
                    front.push(j);
                }
            }
            members.extend_from_slice(&front);
        }
        if members.len() < cfg.min_points {
            small_points += members.len();
        } else if members.len() > cfg.max_points {
            large_clusters += 1;
        } else {
            members.sort_unstable();
            groups.push(members);
        }
    }
    groups.sort_by(|a, b| b.len().cmp(&a.len()).then(a[0].cmp(&b[0])));
    let clusters = groups
        .into_par_iter()
        .map(|indices| {
            let pts: Vec<Point3<f64>> = indices.iter().map(|&i| points[i]).collect();
            let shape = principal_axes(&pts, cfg.span_quantile).unwrap_or(PrincipalAxes {
                centroid: pts[0],
                axes: nalgebra::Matrix3::identity(),
                variances: nalgebra::Vector3::zeros(),
                spans: nalgebra::Vector3::zeros(),
            });
            Cluster { indices, shape }
        })
        .collect();
    Ok(Clustering {
        clusters,
        small_points,
        large_clusters,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    fn blob(rng: &mut rand::rngs::ChaCha8Rng, c: Point3<f64>, r: f64, n: usize) -> Vec<Point3<f64>> {
        (0..n)
            .map(|_| {
                c + nalgebra::Vector3::new(
                    rng.random_range(-r..r),
                    rng.random_range(-r..r),
                    rng.random_range(-r..r),
                )
            })
            .collect()
    }

    #[test]
    fn separates_blobs_and_applies_size_limits() {
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(2);
        let mut pts = blob(&mut rng, Point3::new(0.0, 0.0, 1.0), 0.05, 3000);
        pts.extend(blob(&mut rng, Point3::new(0.3, 0.0, 1.0), 0.03, 1000));
        pts.extend(blob(&mut rng, Point3::new(-0.3, 0.0, 1.0), 0.01, 20)); // too small
        // Far-apart single points (noise).
        pts.extend((0..10).map(|i| Point3::new(1.0 + i as f64, 5.0, 1.0)));
        let idx = KdIndex::new(&pts).unwrap();
        let cfg = ClusterConfig {
            tolerance_m: 0.02,
            min_points: 50,
            ..Default::default()
        };
        let c = euclidean_clusters(&pts, &idx, &cfg).unwrap();
        assert_eq!(c.clusters.len(), 2);
        assert_eq!(c.clusters[0].indices, (0..3000).collect::<Vec<_>>());
        assert_eq!(c.clusters[1].indices, (3000..4000).collect::<Vec<_>>());
        assert_eq!(c.small_points, 30);
        assert!((c.clusters[1].shape.centroid - Point3::new(0.3, 0.0, 1.0)).norm() < 0.005);
        let c = euclidean_clusters(
            &pts,
            &idx,
            &ClusterConfig {
                max_points: 2000,
                ..cfg.clone()
            },
        )
        .unwrap();
        assert_eq!((c.clusters.len(), c.large_clusters), (1, 1));
        assert!(
            euclidean_clusters(
                &pts,
                &idx,
                &ClusterConfig {
                    tolerance_m: 0.0,
                    ..cfg
                }
            )
            .is_err()
        );
    }

    #[test]
    fn a_chain_is_one_cluster() {
        // Points 9 mm apart along a line: one cluster at 10 mm tolerance, none joined at 8 mm.
        let pts: Vec<Point3<f64>> = (0..200)
            .map(|i| Point3::new(0.009 * i as f64, 0.0, 0.0))
            .collect();
        let idx = KdIndex::new(&pts).unwrap();
        let mut cfg = ClusterConfig {
            min_points: 1,
            ..Default::default()
        };
        assert_eq!(euclidean_clusters(&pts, &idx, &cfg).unwrap().clusters.len(), 1);
        cfg.tolerance_m = 0.008;
        assert_eq!(euclidean_clusters(&pts, &idx, &cfg).unwrap().clusters.len(), 200);
    }
}
