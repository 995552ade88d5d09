//! Euclidean cluster extraction (Rusu 2009, §6.2; PCL's `EuclideanClusterExtraction`).
//!
//! Two points belong to the same cluster when a chain of points joins them with every link at
//! most `tolerance_m` long. Computed as connected components on a uniform grid of cell edge
//! `tolerance_m / √3` (the grid-based exact DBSCAN of Gunawan 2013 and Gan & Tao 2015, with
//! one point as the core): all points of one cell are within the tolerance of each other, so a
//! cell is joined whole; two cells at most two cells apart on every axis are joined (union-find)
//! as soon as one pair of their points is within the tolerance, and no other cells can be. The
//! points of a cluster are reported in increasing index order. Clusters with fewer than
//! `min_points` or more than `max_points` points are dropped. Units: metres.

use crate::cloud::pca::{PrincipalAxes, principal_axes};
use crate::error::{Error, Result};
use nalgebra::Point3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Configuration of the clustering stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClusterConfig {
    /// Run the stage (off: all points above the seabed form one cluster).
    pub enabled: bool,
    /// Largest link between two points of one cluster, metres: the shortest, lengthened to
    /// `spacing_factor` times the points' spacing where that is longer.
    pub tolerance_m: f64,
    /// The link is at least this many times the median distance between the clustered points
    /// and their nearest (a scan from a farther camera is sparser: at 1.6 m the bottle's
    /// points lie 7.6 mm apart, and a 10 mm link broke it into pieces, the object kept 0.52 m
    /// of its 0.72 m); 0 keeps `tolerance_m` whatever the spacing.
    pub spacing_factor: f64,
    /// Fewest points of a cluster.
    pub min_points: usize,
    /// Most points of a cluster.
    pub max_points: usize,
    /// Quantile used for cluster spans along the principal axes (spans run from `q` to `1 − q`;
    /// `q` in [0, 0.5)).
    pub span_quantile: f64,
}

impl Default for ClusterConfig {
    fn default() -> Self {
        ClusterConfig {
            enabled: true,
            tolerance_m: 0.01,
            spacing_factor: 2.0,
            min_points: 100,
            max_points: 5_000_000,
            span_quantile: 0.01,
        }
    }
}

/// Largest `spacing_factor`: a link a hundred points long joins what is not one object.
pub const MAX_SPACING_FACTOR: f64 = 100.0;

impl ClusterConfig {
    /// The link for points `spacing` apart (median distance to the nearest), metres.
    pub fn link_m(&self, spacing: f64) -> f64 {
        self.tolerance_m.max(self.spacing_factor * spacing)
    }

    /// Checks every value. `min_points` and `max_points` only filter the clusters found, so
    /// they need no upper bound.
    ///
    /// # Errors
    /// [`Error::Input`] naming the field (`cluster.…`).
    pub fn validate(&self) -> Result<()> {
        crate::config::positive("cluster.tolerance_m", self.tolerance_m)?;
        crate::config::require(
            self.spacing_factor >= 0.0 && self.spacing_factor <= MAX_SPACING_FACTOR,
            "cluster.spacing_factor",
            format!(
                "must be from 0 to {MAX_SPACING_FACTOR} (times the points' spacing), got {}",
                crate::config::shown(self.spacing_factor)
            ),
        )?;
        crate::config::require(
            self.min_points >= 1 && self.min_points <= self.max_points,
            "cluster.min_points",
            format!(
                "must be ≥ 1 and ≤ cluster.max_points ({}), got {}",
                self.max_points, self.min_points
            ),
        )?;
        // Spans run from the q to the 1 − q quantile: q = 0.5 leaves nothing between them.
        crate::config::require(
            self.span_quantile >= 0.0 && self.span_quantile < 0.5,
            "cluster.span_quantile",
            format!(
                "must be a quantile in [0, 0.5) (spans run from q to 1 − q), got {}",
                crate::config::shown(self.span_quantile)
            ),
        )
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

/// Euclidean clusters of `points`.
///
/// # Errors
/// [`Error::Input`] naming the field of a bad configuration ([`ClusterConfig::validate`]).
pub fn euclidean_clusters(points: &[Point3<f64>], cfg: &ClusterConfig) -> Result<Clustering> {
    cfg.validate()?;
    let Some((lo, hi)) = crate::cloud::bbox(points) else {
        return Ok(Clustering {
            clusters: Vec::new(),
            small_points: 0,
            large_clusters: 0,
        });
    };
    if points.len() > u32::MAX as usize {
        return Err(Error::input("cluster", "more than 4 294 967 295 points"));
    }
    let tol2 = cfg.tolerance_m * cfg.tolerance_m;
    let edge = cfg.tolerance_m / 3f64.sqrt();
    if (hi - lo).max() / edge > 2f64.powi(40) {
        return Err(Error::input(
            "cluster.tolerance_m",
            "too small for the extent of the cloud (more than 2^40 cells across)",
        ));
    }
    // Points sorted by cell; `cells[c]` = (cell, first, end) in that order.
    let cell_of = |p: &Point3<f64>| [0, 1, 2].map(|k| ((p[k] - lo[k]) / edge).floor() as i64);
    let mut order: Vec<([i64; 3], u32)> = points
        .par_iter()
        .enumerate()
        .map(|(i, p)| (cell_of(p), i as u32))
        .collect();
    order.par_sort_unstable();
    let mut cells: Vec<([i64; 3], usize, usize)> = Vec::new();
    for (at, &(c, _)) in order.iter().enumerate() {
        match cells.last_mut() {
            Some(last) if last.0 == c => last.2 = at + 1,
            _ => cells.push((c, at, at + 1)),
        }
    }
    let sorted: Vec<Point3<f64>> = order.iter().map(|&(_, i)| points[i as usize]).collect();
    let touch = |a: usize, b: usize| {
        let (pa, pb) = (&sorted[cells[a].1..cells[a].2], &sorted[cells[b].1..cells[b].2]);
        pa.iter()
            .any(|p| pb.iter().any(|q| (p - q).norm_squared() <= tol2))
    };
    // Union-find over cells; each pair of cells is looked at once (the offsets in one half of
    // the 5×5×5 block). The cells are sorted, so the five z-neighbours of a column (x, y) are one
    // run, found by one binary search.
    let mut parent: Vec<usize> = (0..cells.len()).collect();
    let find = |parent: &mut Vec<usize>, mut x: usize| {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    };
    let columns: Vec<([i64; 2], i64)> = (-2..=2)
        .flat_map(|x| (-2..=2).map(move |y| [x, y]))
        .filter(|d| *d >= [0, 0])
        .map(|d| (d, if d == [0, 0] { 1 } else { -2 }))
        .collect();
    for (a, &(c, _, _)) in cells.iter().enumerate() {
        for &([dx, dy], dz0) in &columns {
            let (x, y) = (c[0] + dx, c[1] + dy);
            let from = cells.partition_point(|e| e.0 < [x, y, c[2] + dz0]);
            for (b, e) in cells.iter().enumerate().skip(from) {
                if e.0 > [x, y, c[2] + 2] {
                    break;
                }
                let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                if ra != rb && touch(a, b) {
                    parent[ra.max(rb)] = ra.min(rb);
                }
            }
        }
    }
    // Members by root, in increasing point index.
    let mut root_of_point = vec![0usize; points.len()];
    for (cell, &(_, from, to)) in cells.iter().enumerate() {
        let r = find(&mut parent, cell);
        for &(_, i) in &order[from..to] {
            root_of_point[i as usize] = r;
        }
    }
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); cells.len()];
    for (i, &r) in root_of_point.iter().enumerate() {
        members[r].push(i);
    }
    let (mut small_points, mut large_clusters) = (0, 0);
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for m in members.into_iter().filter(|m| !m.is_empty()) {
        if m.len() < cfg.min_points {
            small_points += m.len();
        } else if m.len() > cfg.max_points {
            large_clusters += 1;
        } else {
            groups.push(m);
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
        let cfg = ClusterConfig {
            tolerance_m: 0.02,
            min_points: 50,
            ..Default::default()
        };
        let c = euclidean_clusters(&pts, &cfg).unwrap();
        assert_eq!(c.clusters.len(), 2);
        assert_eq!(c.clusters[0].indices, (0..3000).collect::<Vec<_>>());
        assert_eq!(c.clusters[1].indices, (3000..4000).collect::<Vec<_>>());
        assert_eq!(c.small_points, 30);
        assert!((c.clusters[1].shape.centroid - Point3::new(0.3, 0.0, 1.0)).norm() < 0.005);
        let c = euclidean_clusters(
            &pts,
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
                &ClusterConfig {
                    tolerance_m: 0.0,
                    ..cfg
                }
            )
            .is_err()
        );
    }

    #[test]
    fn components_match_brute_force() {
        // Random points at several densities: the clusters are exactly the connected components
        // of the graph "within the tolerance", found here by brute force.
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(9);
        for (n, tol) in [(400, 0.05), (400, 0.1), (800, 0.03), (300, 0.2)] {
            let pts: Vec<Point3<f64>> = (0..n)
                .map(|_| {
                    Point3::new(
                        rng.random::<f64>(),
                        rng.random::<f64>(),
                        0.3 * rng.random::<f64>(),
                    )
                })
                .collect();
            let mut label = vec![usize::MAX; n];
            let mut expect: Vec<Vec<usize>> = Vec::new();
            for s in 0..n {
                if label[s] != usize::MAX {
                    continue;
                }
                label[s] = expect.len();
                let (mut stack, mut members) = (vec![s], vec![s]);
                while let Some(i) = stack.pop() {
                    for j in 0..n {
                        if label[j] == usize::MAX && (pts[i] - pts[j]).norm() <= tol {
                            label[j] = label[s];
                            stack.push(j);
                            members.push(j);
                        }
                    }
                }
                members.sort_unstable();
                expect.push(members);
            }
            expect.sort_by(|a, b| b.len().cmp(&a.len()).then(a[0].cmp(&b[0])));
            let cfg = ClusterConfig {
                tolerance_m: tol,
                min_points: 1,
                ..Default::default()
            };
            let got: Vec<Vec<usize>> = euclidean_clusters(&pts, &cfg)
                .unwrap()
                .clusters
                .into_iter()
                .map(|c| c.indices)
                .collect();
            assert_eq!(got, expect, "n {n}, tolerance {tol}");
        }
    }

    #[test]
    fn a_chain_is_one_cluster() {
        // Points 9 mm apart along a line: one cluster at 10 mm tolerance, none joined at 8 mm.
        let pts: Vec<Point3<f64>> = (0..200)
            .map(|i| Point3::new(0.009 * i as f64, 0.0, 0.0))
            .collect();
        let mut cfg = ClusterConfig {
            min_points: 1,
            ..Default::default()
        };
        assert_eq!(euclidean_clusters(&pts, &cfg).unwrap().clusters.len(), 1);
        cfg.tolerance_m = 0.008;
        assert_eq!(euclidean_clusters(&pts, &cfg).unwrap().clusters.len(), 200);
    }

    #[test]
    fn span_quantile_must_be_a_quantile_below_a_half() {
        let pts: Vec<Point3<f64>> = (0..200)
            .map(|i| Point3::new(0.001 * i as f64, 0.0, 1.0))
            .collect();
        // NaN (and any value past 0.5) made every span 0: "no cluster fits", exit 1.
        for q in [f64::NAN, f64::INFINITY, 1e300, -1.0, 0.5] {
            let cfg = ClusterConfig {
                span_quantile: q,
                ..Default::default()
            };
            crate::perception::assert_bad_input(euclidean_clusters(&pts, &cfg), "cluster.span_quantile");
        }
    }
}
