//! Point-cloud filters for stereo scans: voxel down-sampling, statistical outlier removal, crop
//! by an axis-aligned box and by range from a viewpoint.
//!
//! - **Voxel down-sampling** (as PCL's `VoxelGrid`): space is cut into cubes of side `voxel_m`
//!   anchored at the frame's origin (voxel `(i, j, k)` holds `i·v ≤ x < (i+1)·v`, ...), and each
//!   occupied voxel becomes the centroid of its points, with their colours averaged (rounded) and
//!   their normals averaged and re-normalised. Open3D anchors its grid at the cloud's bounding box
//!   instead, so voxel counts differ slightly; the origin-anchored grid does not move when the
//!   cloud changes. Output is ordered by voxel (x index, then y, then z): deterministic.
//! - **Statistical outlier removal** (Rusu et al. 2008; PCL `StatisticalOutlierRemoval`): for every
//!   point the mean distance `d̄ᵢ` to its `k` nearest neighbours (itself excluded) is computed;
//!   with `μ` and `σ` (sample standard deviation) of all `d̄ᵢ`, points with
//!   `d̄ᵢ > μ + std_ratio·σ` are removed. Open3D's `remove_statistical_outlier(nb_neighbors = k)`
//!   counts the point itself among the `k`, i.e. it uses `k − 1` true neighbours.
//! - **Crops** keep the points inside a closed box, or within `[min_m, max_m]` of a viewpoint
//!   (the camera centre: stereo depth noise grows with range, flying pixels sit far behind).
//!
//! Units: metres, in whatever frame the cloud is in. Filters keep input order except the voxel
//! filter (voxel order); the index-selecting filters also return the kept indices.

use super::PointCloud;
use super::knn::map_knn;
use crate::config::shown;
use crate::error::{Error, Result};
use nalgebra::{Point3, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Voxel down-sampling settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VoxelConfig {
    /// Edge of a voxel, metres (> 0).
    pub voxel_m: f64,
}

impl Default for VoxelConfig {
    fn default() -> Self {
        VoxelConfig { voxel_m: 0.005 }
    }
}

/// What voxel down-sampling produced.
#[derive(Debug, Clone, PartialEq)]
pub struct VoxelResult {
    /// One point per occupied voxel (centroid, mean colour, mean normal).
    pub cloud: PointCloud,
    /// Input points that fell in each output voxel (same order as `cloud`).
    pub points_per_voxel: Vec<u32>,
}

/// Statistical outlier removal settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OutlierConfig {
    /// Neighbours per point, the point itself excluded (1 to [`MAX_OUTLIER_NEIGHBOURS`]).
    pub neighbours: usize,
    /// Points whose mean neighbour distance exceeds mean + `std_ratio`·σ are removed (≥ 0).
    pub std_ratio: f64,
}

impl Default for OutlierConfig {
    fn default() -> Self {
        OutlierConfig {
            neighbours: 20,
            std_ratio: 2.0,
        }
    }
}

/// Most neighbours of the statistical outlier removal: 50 times the default, 10 times the
/// usual values (PCL's and Open3D's examples use 20 to 100); the removal costs a k-NN query per
/// point.
pub const MAX_OUTLIER_NEIGHBOURS: usize = 1000;

impl OutlierConfig {
    /// Checks `neighbours` (1 to [`MAX_OUTLIER_NEIGHBOURS`]) and `std_ratio` (finite, ≥ 0);
    /// `prefix` names the table in errors (`clean.outliers`).
    ///
    /// # Errors
    /// [`Error::Input`] naming the field.
    pub fn validate(&self, prefix: &str) -> Result<()> {
        crate::config::count_between(
            format!("{prefix}.neighbours"),
            self.neighbours,
            1,
            MAX_OUTLIER_NEIGHBOURS,
        )?;
        crate::config::non_negative(format!("{prefix}.std_ratio"), self.std_ratio)
    }
}

/// What statistical outlier removal produced.
#[derive(Debug, Clone, PartialEq)]
pub struct OutlierResult {
    /// The kept points, in input order.
    pub cloud: PointCloud,
    /// Indices (into the input) of the kept points.
    pub kept: Vec<usize>,
    /// Mean over all points of the mean neighbour distance, metres.
    pub mean_distance_m: f64,
    /// Sample standard deviation of the mean neighbour distances, metres.
    pub std_distance_m: f64,
    /// The rejection threshold `mean + std_ratio·σ`, metres.
    pub threshold_m: f64,
}

/// An axis-aligned box to keep.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoxCropConfig {
    /// Smallest corner, metres.
    pub min: [f64; 3],
    /// Largest corner, metres.
    pub max: [f64; 3],
}

impl Default for BoxCropConfig {
    /// A box that keeps everything.
    fn default() -> Self {
        BoxCropConfig {
            min: [f64::NEG_INFINITY; 3],
            max: [f64::INFINITY; 3],
        }
    }
}

/// A range gate around a viewpoint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RangeCropConfig {
    /// The viewpoint (usually the camera centre, the origin of the scan frame), metres.
    pub viewpoint: [f64; 3],
    /// Closest kept distance from the viewpoint, metres.
    pub min_m: f64,
    /// Farthest kept distance from the viewpoint, metres.
    pub max_m: f64,
}

impl Default for RangeCropConfig {
    /// A gate that keeps everything.
    fn default() -> Self {
        RangeCropConfig {
            viewpoint: [0.0; 3],
            min_m: 0.0,
            max_m: f64::INFINITY,
        }
    }
}

/// What a crop kept.
#[derive(Debug, Clone, PartialEq)]
pub struct CropResult {
    /// The kept points, in input order.
    pub cloud: PointCloud,
    /// Indices (into the input) of the kept points.
    pub kept: Vec<usize>,
}

/// The error of a voxel `v` too small for the cloud spanning `lo` to `hi`: its extent shows a
/// point far from the rest (which `clean.max_range_m` drops).
fn too_small(v: f64, lo: &Point3<f64>, hi: &Point3<f64>, why: &str) -> Error {
    let extent = [0, 1, 2].map(|k| hi[k] - lo[k]);
    Error::input(
        "clean.voxel_m",
        format!(
            "{} m is too small for the cloud's extent{why}, {} m: a point far from the rest? (clean.max_range_m drops those beyond a range)",
            shown(v),
            crate::config::shown_xyz(&extent, 3)
        ),
    )
}

/// Voxel down-sampling: the centroid of every occupied voxel.
///
/// # Errors
/// [`Error::Input`] if `voxel_m` is not a positive finite number, or so small that the voxel
/// indices of the cloud's extent do not fit in 64 bits, or if a point is not finite.
///
/// # Performance
/// One pass over the points through a hash table (voxel key → running sums) per thread, each
/// thread owning a share of the voxels, then the occupied voxels are sorted by key:
/// O(n + m log m) for m voxels.
pub fn voxel_downsample(cloud: &PointCloud, config: &VoxelConfig) -> Result<VoxelResult> {
    let v = config.voxel_m;
    if !(v.is_finite() && v > 0.0) {
        return Err(Error::input(
            "clean.voxel_m",
            format!("must be a positive length in metres, got {}", shown(v)),
        ));
    }
    if cloud
        .points
        .par_iter()
        .any(|p| !p.coords.iter().all(|c| c.is_finite()))
    {
        return Err(Error::input(
            "voxel down-sampling",
            "the cloud has a non-finite point",
        ));
    }
    let Some((lo, hi)) = cloud.bbox() else {
        return Ok(VoxelResult {
            cloud: PointCloud {
                colors: cloud.colors.as_ref().map(|_| Vec::new()),
                normals: cloud.normals.as_ref().map(|_| Vec::new()),
                ..PointCloud::default()
            },
            points_per_voxel: Vec::new(),
        });
    };
    let cell = |c: f64| (c / v).floor();
    let base = lo.map(cell);
    let mut bits = [0u32; 3];
    for k in 0..3 {
        let span = cell(hi[k]) - base[k];
        if span >= 2f64.powi(63) {
            return Err(too_small(v, &lo, &hi, ""));
        }
        bits[k] = 64 - (span as u64).leading_zeros();
    }
    if bits.iter().sum::<u32>() > 64 {
        return Err(too_small(v, &lo, &hi, " (more than 2^64 voxels)"));
    }
    let (sy, sz) = (bits[2], bits[1] + bits[2]);
    let key = |p: &Point3<f64>| {
        let [x, y, z] = [0, 1, 2].map(|k| (cell(p[k]) - base[k]) as u64);
        (x << sz) | (y << sy) | z
    };
    // The voxels are split by key hash into one part per thread; each part takes one pass in
    // point order (so every voxel's sums are the same whatever the split) through an
    // open-addressing table from voxel key to accumulator.
    #[derive(Clone)]
    struct Acc {
        key: u64,
        sum: Vector3<f64>,
        rgb: [u64; 3],
        normal: Vector3<f64>,
        count: u32,
    }
    let hash = |k: u64| k.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    let keys: Vec<u64> = cloud.points.par_iter().map(key).collect();
    let parts = rayon::current_num_threads().clamp(1, 64) as u64;
    let mut accs: Vec<Acc> = (0..parts)
        .into_par_iter()
        .flat_map_iter(|part| {
            let mine = |k: u64| (hash(k) >> 32) % parts == part;
            let n = keys.iter().filter(|&&k| mine(k)).count();
            let table_bits = (2 * n).next_power_of_two().trailing_zeros().max(4);
            let mask = (1usize << table_bits) - 1;
            let mut slots = vec![u32::MAX; mask + 1];
            let mut accs: Vec<Acc> = Vec::new();
            for (i, &k) in keys.iter().enumerate() {
                if !mine(k) {
                    continue;
                }
                let mut s = (hash(k) >> (64 - table_bits)) as usize;
                let a = loop {
                    match slots[s] {
                        u32::MAX => {
                            slots[s] = accs.len() as u32;
                            accs.push(Acc {
                                key: k,
                                sum: Vector3::zeros(),
                                rgb: [0; 3],
                                normal: Vector3::zeros(),
                                count: 0,
                            });
                            break accs.len() - 1;
                        }
                        id if accs[id as usize].key == k => break id as usize,
                        _ => s = (s + 1) & mask,
                    }
                };
                let acc = &mut accs[a];
                acc.sum += cloud.points[i].coords;
                acc.count += 1;
                if let Some(c) = &cloud.colors {
                    for (t, &v) in acc.rgb.iter_mut().zip(&c[i]) {
                        *t += u64::from(v);
                    }
                }
                if let Some(n) = &cloud.normals {
                    acc.normal += n[i];
                }
            }
            accs
        })
        .collect();
    accs.par_sort_unstable_by_key(|a| a.key);
    let out = PointCloud {
        points: accs
            .iter()
            .map(|a| Point3::from(a.sum / f64::from(a.count)))
            .collect(),
        colors: cloud.colors.as_ref().map(|_| {
            accs.iter()
                .map(|a| a.rgb.map(|t| (t as f64 / f64::from(a.count)).round() as u8))
                .collect()
        }),
        normals: cloud.normals.as_ref().map(|_| {
            accs.iter()
                .map(|a| {
                    a.normal
                        .try_normalize(1e-12)
                        .unwrap_or(a.normal / f64::from(a.count))
                })
                .collect()
        }),
    };
    Ok(VoxelResult {
        cloud: out,
        points_per_voxel: accs.iter().map(|a| a.count).collect(),
    })
}

/// Statistical outlier removal (k-NN mean distance against mean + `std_ratio`·σ).
///
/// A cloud with fewer than two points is returned unchanged; with fewer than `neighbours + 1`
/// points every other point is a neighbour. Neighbours whose distance overflows (a point
/// some 1e154 m away) are left out of a point's mean; a point with no other neighbour is an
/// outlier whatever the threshold, and out of the statistics.
///
/// # Errors
/// [`Error::Input`] if `neighbours` is not between 1 and [`MAX_OUTLIER_NEIGHBOURS`] or
/// `std_ratio` is negative or not finite, or if a point is not finite.
///
/// # Performance
/// One exact k-NN query per point on a uniform grid ([`map_knn`]), in parallel (rayon).
pub fn remove_statistical_outliers(cloud: &PointCloud, config: &OutlierConfig) -> Result<OutlierResult> {
    config.validate("outliers")?;
    let n = cloud.len();
    // Nothing to judge by: the cloud as it is.
    let unchanged = || OutlierResult {
        cloud: cloud.clone(),
        kept: (0..n).collect(),
        mean_distance_m: 0.0,
        std_distance_m: 0.0,
        threshold_m: 0.0,
    };
    if n < 2 {
        return Ok(unchanged());
    }
    let k = config.neighbours.min(n - 1);
    // A neighbour so far that its distance overflows does not count in a point's mean (in a
    // small cloud a stray point is every point's neighbour); a point with no other neighbour
    // is the stray one: its mean is infinite, an outlier, and out of the statistics. The
    // others' are taken in units of a power of two near the largest (the same figures as
    // unscaled, barring subnormals), so that the squares cannot overflow: one stray point at
    // 1e160 m must not make the threshold NaN and empty the cloud.
    let mean_d = map_knn(&cloud.points, k, |_, nb| {
        let (sum, m) = nb
            .iter()
            .filter(|x| x.distance.is_finite())
            .fold((0.0, 0usize), |(s, m), x| (s + x.distance, m + 1));
        if m == 0 { f64::INFINITY } else { sum / m as f64 }
    })?;
    let finite: Vec<f64> = mean_d.iter().copied().filter(|d| d.is_finite()).collect();
    if finite.is_empty() {
        // No two points within a finite distance of each other, as with fewer than two.
        return Ok(unchanged());
    }
    let largest = finite.iter().copied().fold(0.0, f64::max);
    let unit = if largest > 0.0 {
        largest.log2().floor().exp2()
    } else {
        1.0
    };
    let m = finite.len() as f64;
    let mean = finite.iter().map(|d| d / unit).sum::<f64>() / m;
    let var = finite.iter().map(|d| (d / unit - mean).powi(2)).sum::<f64>() / (m - 1.0).max(1.0);
    let (mean, std) = (mean * unit, var.sqrt() * unit);
    let threshold = mean + config.std_ratio * std;
    let kept: Vec<usize> = (0..n).filter(|&i| mean_d[i] <= threshold).collect();
    Ok(OutlierResult {
        cloud: cloud.select(&kept),
        kept,
        mean_distance_m: mean,
        std_distance_m: std,
        threshold_m: threshold,
    })
}

/// Keeps the points inside a closed axis-aligned box.
///
/// # Errors
/// [`Error::Input`] if a corner coordinate is NaN or `min` exceeds `max` on an axis.
pub fn crop_box(cloud: &PointCloud, config: &BoxCropConfig) -> Result<CropResult> {
    for k in 0..3 {
        let (a, b) = (config.min[k], config.max[k]);
        if a.is_nan() || b.is_nan() || a > b {
            return Err(Error::input(
                "crop box",
                format!("min {a} and max {b} on axis {k} do not form an interval"),
            ));
        }
    }
    let lo = Point3::from(config.min);
    let hi = Point3::from(config.max);
    Ok(keep(cloud, |p| (0..3).all(|k| p[k] >= lo[k] && p[k] <= hi[k])))
}

/// Keeps the points whose distance from the viewpoint lies in `[min_m, max_m]`.
///
/// # Errors
/// [`Error::Input`] if the viewpoint is not finite or the range is not an interval of
/// non-negative distances.
pub fn crop_range(cloud: &PointCloud, config: &RangeCropConfig) -> Result<CropResult> {
    let (a, b) = (config.min_m, config.max_m);
    if !(a >= 0.0 && a <= b) {
        return Err(Error::input(
            "range crop",
            format!("min_m {a} and max_m {b} do not form an interval of distances ≥ 0"),
        ));
    }
    if !config.viewpoint.iter().all(|v| v.is_finite()) {
        return Err(Error::input("range crop", "the viewpoint is not finite"));
    }
    let o = Point3::from(config.viewpoint);
    let (a2, b2) = (a * a, b * b);
    Ok(keep(cloud, |p| {
        let d2 = (p - o).norm_squared();
        d2 >= a2 && d2 <= b2
    }))
}

/// The points passing `test`, in input order, with their indices.
fn keep(cloud: &PointCloud, test: impl Fn(&Point3<f64>) -> bool + Sync) -> CropResult {
    let kept: Vec<usize> = cloud
        .points
        .par_iter()
        .enumerate()
        .filter(|(_, p)| test(p))
        .map(|(i, _)| i)
        .collect();
    CropResult {
        cloud: cloud.select(&kept),
        kept,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn voxel_centroids_and_colours_by_hand() {
        // Voxel 1.0: (0.2,0.2,0.2) and (0.6,0.8,0.4) share voxel (0,0,0); (1.5,0.5,0.5) is in
        // (1,0,0); (-0.5,0.1,0.1) in (-1,0,0).
        let cloud = PointCloud {
            points: vec![
                Point3::new(0.2, 0.2, 0.2),
                Point3::new(1.5, 0.5, 0.5),
                Point3::new(0.6, 0.8, 0.4),
                Point3::new(-0.5, 0.1, 0.1),
            ],
            colors: Some(vec![[10, 20, 30], [0, 0, 0], [21, 40, 60], [255, 255, 255]]),
            normals: Some(vec![Vector3::x(), Vector3::z(), Vector3::y(), Vector3::z()]),
        };
        let r = voxel_downsample(&cloud, &VoxelConfig { voxel_m: 1.0 }).unwrap();
        // Ordered by voxel x index: -1, 0, 1.
        let expect = [
            Point3::new(-0.5, 0.1, 0.1),
            Point3::new(0.4, 0.5, 0.3),
            Point3::new(1.5, 0.5, 0.5),
        ];
        assert_eq!(r.cloud.len(), 3);
        for (p, e) in r.cloud.points.iter().zip(&expect) {
            assert!((p - e).norm() < 1e-12, "{p} vs {e}");
        }
        // (10+21)/2 = 15.5 -> 16, (20+40)/2 = 30, (30+60)/2 = 45.
        assert_eq!(r.cloud.colors.as_ref().unwrap()[1], [16, 30, 45]);
        let n = r.cloud.normals.as_ref().unwrap()[1];
        assert!((n - Vector3::new(1.0, 1.0, 0.0).normalize()).norm() < 1e-12);
        assert_eq!(r.points_per_voxel, vec![1, 2, 1]);
    }

    #[test]
    fn voxel_grid_of_a_lattice() {
        // A 10×10×10 lattice with spacing 1 cm, voxel 2 cm anchored at the origin: each voxel
        // holds a 2×2×2 block whose centroid is the block's centre.
        let mut pts = Vec::new();
        for i in 0..10 {
            for j in 0..10 {
                for k in 0..10 {
                    pts.push(Point3::new(i as f64, j as f64, k as f64) * 0.01 + Vector3::repeat(0.001));
                }
            }
        }
        let r = voxel_downsample(&PointCloud::from_points(pts), &VoxelConfig { voxel_m: 0.02 }).unwrap();
        assert_eq!(r.cloud.len(), 125);
        assert!(r.points_per_voxel.iter().all(|&c| c == 8));
        for p in &r.cloud.points {
            for k in 0..3 {
                // centre of {2m, 2m+1} cm + 1 mm = (2m + 0.5) cm + 1 mm.
                let m = ((p[k] - 0.001) / 0.02 - 0.25).round();
                assert!((p[k] - (m * 0.02 + 0.005 + 0.001)).abs() < 1e-12, "{p}");
            }
        }
        assert!(
            voxel_downsample(&PointCloud::default(), &VoxelConfig { voxel_m: 0.02 })
                .unwrap()
                .cloud
                .is_empty()
        );
        assert!(voxel_downsample(&PointCloud::default(), &VoxelConfig { voxel_m: 0.0 }).is_err());
        // One point far from the rest: the key and the extent that shows it, one line.
        let far = PointCloud::from_points(vec![Point3::origin(), Point3::new(1e9, 1e9, 1e9)]);
        let e = voxel_downsample(&far, &VoxelConfig { voxel_m: 0.005 }).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(
            e.to_string()
                .starts_with("clean.voxel_m: 0.005 m is too small for the cloud's extent")
                && e.to_string()
                    .contains("[1.000e9, 1.000e9, 1.000e9] m: a point far from the rest?"),
            "{e}"
        );
    }

    #[test]
    fn outliers_planted_in_a_plane_are_removed() {
        // A 50×50 grid at 1 cm spacing on z = 0, plus 10 points 0.5 m above it, far apart.
        let mut pts = Vec::new();
        for i in 0..50 {
            for j in 0..50 {
                pts.push(Point3::new(i as f64 * 0.01, j as f64 * 0.01, 0.0));
            }
        }
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(3);
        let planted: Vec<usize> = (0..10)
            .map(|m| {
                pts.push(Point3::new(
                    rng.random_range(0.0..0.5),
                    rng.random_range(0.0..0.5),
                    0.5 + 0.2 * m as f64,
                ));
                pts.len() - 1
            })
            .collect();
        let cloud = PointCloud::from_points(pts);
        let r = remove_statistical_outliers(&cloud, &OutlierConfig::default()).unwrap();
        assert_eq!(r.kept.len(), 2500);
        assert!(planted.iter().all(|i| !r.kept.contains(i)));
        assert_eq!(r.kept, (0..2500).collect::<Vec<_>>());
        // One stray point so far that its distances' squares overflow: it goes, and the rest
        // are judged as without it.
        let grid = PointCloud::from_points(cloud.points[..2500].to_vec());
        let alone = remove_statistical_outliers(&grid, &OutlierConfig::default()).unwrap();
        let mut pts = grid.points.clone();
        for far in [1e160, 1e300] {
            pts.push(Point3::new(far, 0.0, 0.0));
            let r =
                remove_statistical_outliers(&PointCloud::from_points(pts.clone()), &OutlierConfig::default())
                    .unwrap();
            assert!(
                r.kept == alone.kept,
                "a point at {far:e} m: {} kept",
                r.kept.len()
            );
            assert_eq!(r.threshold_m, alone.threshold_m, "a point at {far:e} m");
            pts.pop();
        }
        // In a cloud as small as the neighbourhood the stray point is every point's neighbour:
        // it still goes alone.
        let mut few = grid.points[..20].to_vec();
        few.push(Point3::new(1e160, 0.0, 0.0));
        let r =
            remove_statistical_outliers(&PointCloud::from_points(few), &OutlierConfig::default()).unwrap();
        assert_eq!(r.kept.len(), 20, "{:?}", r.threshold_m);
        assert!(r.kept.iter().all(|&i| i < 20));
    }

    #[test]
    fn sor_statistics_match_a_direct_computation() {
        // Four points on a line at 0, 1, 2, 10 with k = 1: mean distances 1, 1, 1, 8;
        // μ = 2.75, σ (n−1) = 3.5, threshold at std_ratio 1 = 6.25 → the point at 10 goes.
        let cloud = PointCloud::from_points(
            [0.0, 1.0, 2.0, 10.0]
                .iter()
                .map(|&x| Point3::new(x, 0.0, 0.0))
                .collect(),
        );
        let r = remove_statistical_outliers(
            &cloud,
            &OutlierConfig {
                neighbours: 1,
                std_ratio: 1.0,
            },
        )
        .unwrap();
        assert!((r.mean_distance_m - 2.75).abs() < 1e-12);
        assert!((r.std_distance_m - 3.5).abs() < 1e-12);
        assert!((r.threshold_m - 6.25).abs() < 1e-12);
        assert_eq!(r.kept, vec![0, 1, 2]);
    }

    #[test]
    fn crops_keep_the_right_points() {
        let cloud = PointCloud {
            points: vec![
                Point3::new(0.0, 0.0, 1.0),
                Point3::new(0.5, 0.5, 0.5),
                Point3::new(2.0, 0.0, 0.0),
                Point3::new(0.0, 0.0, 3.0),
            ],
            colors: Some(vec![[1, 1, 1], [2, 2, 2], [3, 3, 3], [4, 4, 4]]),
            normals: None,
        };
        let b = crop_box(
            &cloud,
            &BoxCropConfig {
                min: [0.0, 0.0, 0.5],
                max: [1.0, 1.0, 1.0],
            },
        )
        .unwrap();
        assert_eq!(b.kept, vec![0, 1]);
        assert_eq!(b.cloud.colors.unwrap(), vec![[1, 1, 1], [2, 2, 2]]);
        // |p| = 1, 0.866, 2, 3; keep 0.9..=2.
        let r = crop_range(
            &cloud,
            &RangeCropConfig {
                viewpoint: [0.0; 3],
                min_m: 0.9,
                max_m: 2.0,
            },
        )
        .unwrap();
        assert_eq!(r.kept, vec![0, 2]);
        // From a viewpoint at (0, 0, 3): distances 2, 2.6, 3.6, 0.
        let r = crop_range(
            &cloud,
            &RangeCropConfig {
                viewpoint: [0.0, 0.0, 3.0],
                min_m: 0.0,
                max_m: 2.0,
            },
        )
        .unwrap();
        assert_eq!(r.kept, vec![0, 3]);
        assert_eq!(crop_box(&cloud, &BoxCropConfig::default()).unwrap().kept.len(), 4);
        assert!(
            crop_box(
                &cloud,
                &BoxCropConfig {
                    min: [1.0, 0.0, 0.0],
                    max: [0.0, 1.0, 1.0]
                }
            )
            .is_err()
        );
        assert!(
            crop_range(
                &cloud,
                &RangeCropConfig {
                    min_m: 2.0,
                    max_m: 1.0,
                    ..Default::default()
                }
            )
            .is_err()
        );
    }

    #[test]
    fn configs_round_trip_through_toml() {
        let b: BoxCropConfig =
            crate::config::from_toml_str(&toml::to_string(&BoxCropConfig::default()).unwrap(), "box.toml")
                .unwrap();
        assert_eq!(b, BoxCropConfig::default());
        let r: RangeCropConfig = crate::config::from_toml_str("max_m = 1.5\n", "range.toml").unwrap();
        assert_eq!(r.max_m, 1.5);
        assert_eq!(r.min_m, 0.0);
        assert!(crate::config::from_toml_str::<OutlierConfig>("k = 3\n", "sor.toml").is_err());
    }

    #[test]
    fn outlier_neighbours_are_bounded() {
        let cloud = PointCloud::from_points((0..50).map(|i| Point3::new(i as f64, 0.0, 0.0)).collect());
        for (neighbours, std_ratio, field) in [
            (usize::MAX, 2.0, "outliers.neighbours"),
            (0, 2.0, "outliers.neighbours"),
            (20, f64::NAN, "outliers.std_ratio"),
        ] {
            let cfg = OutlierConfig {
                neighbours,
                std_ratio,
            };
            crate::perception::assert_bad_input(remove_statistical_outliers(&cloud, &cfg), field);
        }
    }
}
