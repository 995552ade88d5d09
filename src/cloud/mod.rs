//! Point clouds and the operations on them.
//!
//! Positions are `f64` in metres, in the frame the file or stage states (scans are in the camera
//! frame `S` unless said otherwise).

pub mod filter;
pub mod knn;
pub mod normals;
pub mod pca;

use crate::error::{Error, Result};
use nalgebra::{Point3, Vector3};

/// A point cloud: positions with optional per-point colours and normals.
///
/// Invariant: `colors` and `normals`, when present, have one entry per point.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PointCloud {
    /// Positions, metres.
    pub points: Vec<Point3<f64>>,
    /// Per-point colours (red, green, blue).
    pub colors: Option<Vec<[u8; 3]>>,
    /// Per-point unit normals.
    pub normals: Option<Vec<Vector3<f64>>>,
}

impl PointCloud {
    /// A cloud of bare positions.
    pub fn from_points(points: Vec<Point3<f64>>) -> Self {
        PointCloud {
            points,
            colors: None,
            normals: None,
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when the cloud has no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The sub-cloud of the given point indices, in that order, with their colours and normals.
    pub fn select(&self, indices: &[usize]) -> PointCloud {
        PointCloud {
            points: indices.iter().map(|&i| self.points[i]).collect(),
            colors: self
                .colors
                .as_ref()
                .map(|c| indices.iter().map(|&i| c[i]).collect()),
            normals: self
                .normals
                .as_ref()
                .map(|n| indices.iter().map(|&i| n[i]).collect()),
        }
    }

    /// Axis-aligned bounding box `(min, max)`, or `None` for an empty cloud.
    pub fn bbox(&self) -> Option<(Point3<f64>, Point3<f64>)> {
        bbox(&self.points)
    }
}

/// The bounding box `(min, max)` of an object model whose diagonal is 1 cm to 20 m, the size of
/// an object a tool can work on; outside, the file's units are most likely not metres.
///
/// # Errors
/// [`Error::Input`] naming `what` when the model has no points or is outside that span.
pub fn object_size(what: &str, points: &[Point3<f64>]) -> Result<(Point3<f64>, Point3<f64>)> {
    let (lo, hi) = bbox(points).ok_or_else(|| Error::input(what, "the model has no points"))?;
    let size = (hi - lo).norm();
    if (0.01..=20.0).contains(&size) {
        Ok((lo, hi))
    } else {
        Err(Error::input(
            what,
            format!(
                "the model is {} m across; expected 0.01 m to 20 m (units must be metres)",
                crate::config::shown_significant(size, 3)
            ),
        ))
    }
}

/// Axis-aligned bounding box `(min, max)` of points, or `None` when there are none.
pub fn bbox(points: &[Point3<f64>]) -> Option<(Point3<f64>, Point3<f64>)> {
    let first = *points.first()?;
    Some(
        points
            .iter()
            .fold((first, first), |(lo, hi), p| (lo.inf(p), hi.sup(p))),
    )
}
