//! `KdIndex`: nearest-neighbour and radius queries on a fixed set of 3-D points.
//!
//! A thin wrapper over kiddo 6's `ImmutableKdTree`, so that kiddo's generics and its squared
//! distances stay here: every radius and distance in this API is in metres, not squared.
//! Items are indices into the slice the index was built from.

use crate::error::{Error, Result};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use nalgebra::{Point3, Vector3};
use std::num::NonZero;

/// A k-d tree over points; query results are indices into the building slice.
pub struct KdIndex {
    tree: ImmutableKdTree<f64, 3>,
    len: usize,
}

/// One neighbour: its index and its distance in metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Neighbour {
    /// Index into the slice the index was built from.
    pub index: usize,
    /// Euclidean distance, metres.
    pub distance: f64,
}

impl KdIndex {
    /// Builds the index. Points must be finite (the readers drop non-finite points).
    ///
    /// # Errors
    /// [`Error::Input`] if a point is not finite or there are more than `u32::MAX` points.
    pub fn new(points: &[Point3<f64>]) -> Result<Self> {
        if points.len() > u32::MAX as usize {
            return Err(Error::input("kd-tree", "more than 4 294 967 295 points"));
        }
        if let Some(i) = points
            .iter()
            .position(|p| !p.coords.iter().all(|v| v.is_finite()))
        {
            return Err(Error::input("kd-tree", format!("point {i} is not finite")));
        }
        let raw: Vec<[f64; 3]> = points.iter().map(|p| [p.x, p.y, p.z]).collect();
        let tree = ImmutableKdTree::new_from_slice(&raw).map_err(|e| Error::failed("kd-tree", e))?;
        Ok(KdIndex {
            tree,
            len: points.len(),
        })
    }

    /// Number of indexed points.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when no point is indexed.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The nearest indexed point, or `None` when the index is empty.
    pub fn nearest(&self, q: &Point3<f64>) -> Option<Neighbour> {
        if self.len == 0 {
            return None;
        }
        let r = self
            .tree
            .query(&[q.x, q.y, q.z])
            .nearest_one::<SquaredEuclidean<f64>>()
            .execute();
        Some(Neighbour {
            index: r.item as usize,
            distance: r.distance.sqrt(),
        })
    }

    /// The nearest indexed point within `radius` metres (inclusive), or `None` when there is none.
    /// kiddo's nearest-one query is several times faster than its bounded nearest-n one (which
    /// collects into a vector), so this is [`KdIndex::nearest`] filtered by the distance.
    pub fn nearest_within(&self, q: &Point3<f64>, radius: f64) -> Option<Neighbour> {
        self.nearest(q).filter(|nb| nb.distance <= radius)
    }

    /// The `k` nearest indexed points, nearest first (fewer if the index holds fewer).
    pub fn knn(&self, q: &Point3<f64>, k: usize) -> Vec<Neighbour> {
        self.knn_bounded(q, k, None)
    }

    /// The `k` nearest indexed points within `radius` metres (inclusive), nearest first: the
    /// first of [`KdIndex::knn`] that lie within the radius, found without visiting the cells
    /// beyond it.
    pub fn knn_within(&self, q: &Point3<f64>, k: usize, radius: f64) -> Vec<Neighbour> {
        self.knn_bounded(q, k, Some(radius))
    }

    fn knn_bounded(&self, q: &Point3<f64>, k: usize, radius: Option<f64>) -> Vec<Neighbour> {
        let Some(k) = NonZero::new(k.min(self.len)) else {
            return Vec::new();
        };
        let at = [q.x, q.y, q.z];
        let query = self.tree.query(&at).nearest_n::<SquaredEuclidean<f64>>(k);
        let found = match radius {
            Some(r) => query.within(r * r).execute(),
            None => query.execute(),
        };
        found
            .into_iter()
            .map(|r| Neighbour {
                index: r.item as usize,
                distance: r.distance.sqrt(),
            })
            .collect()
    }

    /// Every indexed point within `radius` metres (inclusive), in no particular order.
    pub fn within(&self, q: &Point3<f64>, radius: f64) -> Vec<Neighbour> {
        let mut out = Vec::new();
        self.within_visit(q, radius, |n| out.push(n));
        out
    }

    /// Calls `f` for every indexed point within `radius` metres, without allocating.
    pub fn within_visit(&self, q: &Point3<f64>, radius: f64, mut f: impl FnMut(Neighbour)) {
        if self.len == 0 {
            return;
        }
        self.tree
            .query(&[q.x, q.y, q.z])
            .within::<SquaredEuclidean<f64>>(radius * radius)
            .unsorted()
            .execute()
            .into_iter()
            .for_each(|r| {
                f(Neighbour {
                    index: r.item as usize,
                    distance: r.distance.sqrt(),
                })
            });
    }
}

/// Two unit vectors that make a right-handed orthonormal frame `(e1, e2, n)` with the unit
/// vector `n`: `e1` perpendicular to `n` and to the axis (x, or y when `n` lies near x) least
/// along it, `e2 = n × e1`.
pub fn perpendicular_basis(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let e1 = n
        .cross(&if n.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        })
        .normalize();
    (e1, n.cross(&e1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    fn cloud(n: usize) -> Vec<Point3<f64>> {
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(7);
        (0..n)
            .map(|_| Point3::new(rng.random::<f64>(), rng.random::<f64>(), rng.random::<f64>()))
            .collect()
    }

    #[test]
    fn queries_match_brute_force() {
        let pts = cloud(2000);
        let idx = KdIndex::new(&pts).unwrap();
        let q = Point3::new(0.4, 0.5, 0.6);
        let mut brute: Vec<(usize, f64)> = pts.iter().enumerate().map(|(i, p)| (i, (p - q).norm())).collect();
        brute.sort_by(|a, b| a.1.total_cmp(&b.1));
        let n = idx.nearest(&q).unwrap();
        assert_eq!(n.index, brute[0].0);
        assert!((n.distance - brute[0].1).abs() < 1e-12);
        // Bounded: the same point when it lies within the radius, none otherwise.
        assert_eq!(idx.nearest_within(&q, 1.01 * brute[0].1), Some(n));
        assert_eq!(idx.nearest_within(&q, 0.99 * brute[0].1), None);
        let k: Vec<usize> = idx.knn(&q, 10).iter().map(|n| n.index).collect();
        assert_eq!(k, brute[..10].iter().map(|b| b.0).collect::<Vec<_>>());
        let mut w: Vec<usize> = idx.within(&q, 0.1).iter().map(|n| n.index).collect();
        w.sort();
        let mut bw: Vec<usize> = brute.iter().filter(|b| b.1 <= 0.1).map(|b| b.0).collect();
        bw.sort();
        assert_eq!(w, bw);
    }

    #[test]
    fn empty_and_non_finite() {
        let idx = KdIndex::new(&[]).unwrap();
        assert!(idx.nearest(&Point3::origin()).is_none());
        assert!(idx.knn(&Point3::origin(), 3).is_empty());
        assert!(KdIndex::new(&[Point3::new(f64::NAN, 0.0, 0.0)]).is_err());
    }
}
