//! Exact k nearest neighbours of every point of a cloud (the "all-kNN" problem), on a uniform
//! grid.
//!
//! Filters and estimators that look at every point's neighbourhood (statistical outlier removal,
//! k-NN normals) ask n queries whose answers lie a few point spacings away. A uniform grid
//! answers those faster than a general kd-tree. The points are sorted by cell (x, then y, then z
//! index) and processed cell by cell: every point of a cell scans the same 3×3×3 block of cells,
//! and its k best candidates are exact when the k-th distance `d_k` satisfies `d_k ≤ h + m`
//! (`h` the cell edge, `m` the point's distance to the faces of its own cell): no point outside
//! the block can be closer. Otherwise the search goes on ring by ring (Chebyshev distance
//! r = 2, 3, with the test `d_k ≤ r·h + m`), and a point that needs more than three rings
//! (isolated points, outliers) is answered by a linear scan, or by a kd-tree ([`KdIndex`]) when
//! there are many such points. The cell edge is 1.25 × the median k-th-neighbour distance of a
//! sample of points, so most points stop at the block.
//! Candidates are gathered unsorted and cut to the k best by selection, pre-filtered by the
//! previous point's k-th distance.
//!
//! Distances are Euclidean, in the units of the points (metres). Ties are broken by index, so
//! results are deterministic (and independent of the number of threads).

use crate::error::{Error, Result};
use crate::spatial::{KdIndex, Neighbour};
use nalgebra::Point3;
use rayon::prelude::*;

/// Rings scanned before a query is left to the linear scan or the kd-tree.
const MAX_RINGS: i64 = 3;
/// Points sampled to choose the cell edge.
const SAMPLE: usize = 256;
/// At most this many points the ring search gives up on are answered by a linear scan each
/// (cheaper than building a kd-tree over the cloud for a few isolated points).
const BRUTE_FORCE_QUERIES: usize = 64;
/// Cell edge over the sample's median k-th neighbour distance (measured: 1.0 to 1.5 are within
/// 10 % of each other on the milk scene, 1.25 the fastest).
const CELL_FACTOR: f64 = 1.25;

/// The grid: points sorted by cell (x, y, z index), and where each (x, y) column starts.
struct Grid {
    h: f64,
    base: [f64; 3],
    dims: [i64; 3],
    /// `columns[x·dims_y + y] .. columns[x·dims_y + y + 1]`: the sorted points of column (x, y).
    columns: Vec<u32>,
    /// z cell index of each sorted point.
    z: Vec<u32>,
    sorted: Vec<[f64; 3]>,
    order: Vec<u32>,
}

impl Grid {
    /// A grid of cell edge `h` (or larger, so that the column table stays within a few entries
    /// per point).
    fn new(points: &[Point3<f64>], lo: &Point3<f64>, hi: &Point3<f64>, mut h: f64) -> Option<Grid> {
        let base = [lo.x, lo.y, lo.z];
        let dims = loop {
            let d = [0, 1, 2].map(|k| ((hi[k] - lo[k]) / h).floor() + 1.0);
            if d[2] >= 2f64.powi(31) {
                return None;
            }
            if d[0] * d[1] <= (4 * points.len()).max(1 << 16) as f64 {
                break d.map(|v| v as i64);
            }
            h *= 2.0;
        };
        let cell = |p: &Point3<f64>| [0, 1, 2].map(|k| (((p[k] - base[k]) / h) as i64).clamp(0, dims[k] - 1));
        let mut keyed: Vec<(u64, u32, u32)> = points
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                let [x, y, z] = cell(p);
                (((x * dims[1] + y) as u64), z as u32, i as u32)
            })
            .collect();
        keyed.par_sort_unstable();
        let n_cols = (dims[0] * dims[1]) as usize;
        let mut columns = vec![0u32; n_cols + 1];
        for &(col, _, _) in &keyed {
            columns[col as usize + 1] += 1;
        }
        for c in 0..n_cols {
            columns[c + 1] += columns[c];
        }
        Some(Grid {
            h,
            base,
            dims,
            columns,
            z: keyed.iter().map(|t| t.1).collect(),
            sorted: keyed
                .iter()
                .map(|t| {
                    let p = points[t.2 as usize];
                    [p.x, p.y, p.z]
                })
                .collect(),
            order: keyed.iter().map(|t| t.2).collect(),
        })
    }

    fn cell(&self, q: &[f64; 3]) -> [i64; 3] {
        [0, 1, 2].map(|k| (((q[k] - self.base[k]) / self.h) as i64).clamp(0, self.dims[k] - 1))
    }

    /// Scans the points of cells (x, y, z0..=z1) into `best`.
    #[inline]
    fn scan(&self, [x, y]: [i64; 2], [z0, z1]: [i64; 2], q: &[f64; 3], skip: u32, best: &mut Best) {
        if x < 0 || y < 0 || x >= self.dims[0] || y >= self.dims[1] {
            return;
        }
        let (z0, z1) = (z0.max(0), z1.min(self.dims[2] - 1));
        if z0 > z1 {
            return;
        }
        let (z0, z1) = (z0 as u32, z1 as u32);
        let col = (x * self.dims[1] + y) as usize;
        let (a, b) = (self.columns[col] as usize, self.columns[col + 1] as usize);
        let zs = &self.z[a..b];
        let from = a + zs.partition_point(|&z| z < z0);
        let to = a + zs.partition_point(|&z| z <= z1);
        for s in from..to {
            let p = &self.sorted[s];
            let d2 = (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2);
            let i = self.order[s];
            if i != skip {
                best.offer(d2, i);
            }
        }
    }

    /// Ring search for the k nearest of a point (`skip` is its own index): `false` when it
    /// needs more than `MAX_RINGS` rings.
    /// Rings `from..` are scanned; `best` must already hold the candidates of the inner rings.
    fn query(&self, q: &[f64; 3], skip: u32, best: &mut Best, from: i64) -> bool {
        let c = self.cell(q);
        let margin = self.margin(q, c);
        let whole = self.dims.iter().copied().max().unwrap_or(1);
        for r in from..=MAX_RINGS {
            for dx in -r..=r {
                let x = c[0] + dx;
                let gx = self.gap(q[0], x, 0);
                for dy in -r..=r {
                    let y = c[1] + dy;
                    let gxy = gx + self.gap(q[1], y, 1);
                    if dx.abs() == r || dy.abs() == r {
                        // The whole z-run, trimmed to the cells that can still hold a better
                        // point than the current k-th best.
                        let (mut z0, mut z1) = (c[2] - r, c[2] + r);
                        if best.full() {
                            let w = best.worst();
                            while z0 <= z1 && gxy + self.gap(q[2], z0, 2) > w {
                                z0 += 1;
                            }
                            while z1 >= z0 && gxy + self.gap(q[2], z1, 2) > w {
                                z1 -= 1;
                            }
                        }
                        self.scan([x, y], [z0, z1], q, skip, best);
                    } else {
                        for z in [c[2] - r, c[2] + r] {
                            if !(best.full() && gxy + self.gap(q[2], z, 2) > best.worst()) {
                                self.scan([x, y], [z, z], q, skip, best);
                            }
                        }
                    }
                }
            }
            best.settle();
            let reach = r as f64 * self.h + margin;
            if best.settled(reach) || r >= whole {
                return true;
            }
        }
        false
    }

    /// Distance from `q` to the nearest face of its cell `c`.
    #[inline]
    fn margin(&self, q: &[f64; 3], c: [i64; 3]) -> f64 {
        (0..3)
            .map(|k| {
                let o = q[k] - self.base[k] - c[k] as f64 * self.h;
                o.min(self.h - o).max(0.0)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The occupied cells: their indices and their range of sorted positions.
    fn cells(&self) -> Vec<([i64; 3], usize, usize)> {
        let mut out = Vec::new();
        for x in 0..self.dims[0] {
            for y in 0..self.dims[1] {
                let col = (x * self.dims[1] + y) as usize;
                let (mut a, b) = (self.columns[col] as usize, self.columns[col + 1] as usize);
                while a < b {
                    let z = self.z[a];
                    let e = a + self.z[a..b].partition_point(|&v| v <= z);
                    out.push(([x, y, i64::from(z)], a, e));
                    a = e;
                }
            }
        }
        out
    }

    /// Sorted-position ranges covering the 3×3×3 block of cells around `c`.
    fn block(&self, c: [i64; 3]) -> Vec<(usize, usize)> {
        let mut out = Vec::with_capacity(9);
        let (z0, z1) = ((c[2] - 1).max(0) as u32, (c[2] + 1).min(self.dims[2] - 1) as u32);
        for x in (c[0] - 1).max(0)..=(c[0] + 1).min(self.dims[0] - 1) {
            for y in (c[1] - 1).max(0)..=(c[1] + 1).min(self.dims[1] - 1) {
                let col = (x * self.dims[1] + y) as usize;
                let (a, b) = (self.columns[col] as usize, self.columns[col + 1] as usize);
                let zs = &self.z[a..b];
                let (from, to) = (
                    a + zs.partition_point(|&z| z < z0),
                    a + zs.partition_point(|&z| z <= z1),
                );
                if from < to {
                    out.push((from, to));
                }
            }
        }
        out
    }

    /// Squared distance along `axis` from coordinate `v` to the slab of cell index `i`.
    #[inline]
    fn gap(&self, v: f64, i: i64, axis: usize) -> f64 {
        let a = self.base[axis] + i as f64 * self.h;
        let d = if v < a {
            a - v
        } else if v > a + self.h {
            v - a - self.h
        } else {
            0.0
        };
        d * d
    }
}

/// A candidate: squared distance as its IEEE bits (non-negative, so the bits order like the
/// values), then the point index (ties broken by index).
type Candidate = (u64, u32);

/// The k best candidates. Candidates are appended unsorted and cut down to the k best by
/// selection now and then: cheaper than keeping a sorted list when most candidates arrive before
/// the k-th best is known.
struct Best {
    k: usize,
    items: Vec<Candidate>,
    /// The k-th best squared distance once k candidates have been settled, else infinity.
    worst: f64,
    /// Candidates farther than this (squared) are not wanted.
    cap: f64,
}

impl Best {
    fn new(k: usize, cap: f64) -> Self {
        Best {
            k,
            items: Vec::with_capacity(8 * k + 8),
            worst: f64::INFINITY,
            cap,
        }
    }

    fn clear(&mut self) {
        self.items.clear();
        self.worst = f64::INFINITY;
    }

    /// Offers a candidate (dropped at once if farther than the current k-th best).
    #[inline]
    fn offer(&mut self, d2: f64, i: u32) {
        if d2 <= self.worst && d2 <= self.cap {
            self.items.push((d2.to_bits(), i));
            if self.items.len() >= 8 * self.k + 8 {
                self.settle();
            }
        }
    }

    /// Cuts the candidates down to the k best and updates `worst`.
    fn settle(&mut self) {
        if self.items.len() >= self.k {
            let (_, kth, _) = self.items.select_nth_unstable(self.k - 1);
            self.worst = f64::from_bits(kth.0);
            self.items.truncate(self.k);
        }
    }

    fn full(&self) -> bool {
        self.worst < f64::INFINITY
    }

    fn worst(&self) -> f64 {
        self.worst
    }

    /// Whether the candidates are final once every point within `reach` of the query has been
    /// offered: the k best lie within it, or nothing beyond it is wanted.
    fn settled(&self, reach: f64) -> bool {
        let r2 = reach * reach;
        self.full() && self.worst <= r2 || self.cap <= r2
    }

    /// Writes the k best, in no particular order, into `out`.
    fn finish(&mut self, out: &mut Vec<Neighbour>) {
        self.settle();
        out.clear();
        out.extend(self.items.iter().map(|&(d2, j)| Neighbour {
            index: j as usize,
            distance: f64::from_bits(d2).sqrt(),
        }));
    }
}

/// Calls `f(i, neighbours)` for every point `i` with its `k` nearest other points (in no
/// particular order; fewer when the cloud has fewer than `k + 1` points) and collects the results
/// in point order. Runs in parallel (rayon).
///
/// # Errors
/// [`Error::Input`] if `k` is 0, a point is not finite, or there are more than `u32::MAX` points.
pub fn map_knn<T: Send>(
    points: &[Point3<f64>],
    k: usize,
    f: impl Fn(usize, &[Neighbour]) -> T + Sync,
) -> Result<Vec<T>> {
    map_knn_within(points, k, f64::INFINITY, f)
}

/// [`map_knn`] with the neighbours capped to `radius` metres (inclusive): the first of the `k`
/// nearest that lie within it. The cell edge is at most the radius, so that the 3×3×3 block of a
/// point holds everything within the radius and no point needs the ring search.
///
/// # Errors
/// As [`map_knn`], and [`Error::Input`] if `radius` is not positive.
pub fn map_knn_within<T: Send>(
    points: &[Point3<f64>],
    k: usize,
    radius: f64,
    f: impl Fn(usize, &[Neighbour]) -> T + Sync,
) -> Result<Vec<T>> {
    if radius.is_nan() || radius <= 0.0 {
        return Err(Error::input("k nearest neighbours", "the radius must be > 0"));
    }
    if k == 0 {
        return Err(Error::input("k nearest neighbours", "k must be at least 1"));
    }
    if points.len() > u32::MAX as usize {
        return Err(Error::input(
            "k nearest neighbours",
            "more than 4 294 967 295 points",
        ));
    }
    if let Some(i) = points
        .iter()
        .position(|p| !p.coords.iter().all(|v| v.is_finite()))
    {
        return Err(Error::input(
            "k nearest neighbours",
            format!("point {i} is not finite"),
        ));
    }
    let k = k.min(points.len().saturating_sub(1));
    let Some((lo, hi)) = crate::cloud::bbox(points) else {
        return Ok(Vec::new());
    };
    if k == 0 {
        return Ok((0..points.len()).map(|i| f(i, &[])).collect());
    }
    let cap = radius * radius;
    let edge = cell_edge(points, k, (hi - lo).norm())?;
    let h = edge.min(radius);
    // The sample's median k-th distance, ×1.5 and squared: the filter a cell's first point starts
    // with (see below; ×1.5 the fastest of 1.2, 1.5 and 2 on the milk scene).
    let typical = 2.25 * (edge / CELL_FACTOR).powi(2);
    let Some(grid) = Grid::new(points, &lo, &hi, h) else {
        let tree = KdIndex::new(points).map_err(|e| Error::failed("kNN", e))?;
        return Ok(points
            .par_iter()
            .enumerate()
            .map(|(i, p)| f(i, &tree_knn(&tree, p, i, k, radius)))
            .collect());
    };
    // Cell by cell: every point of a cell scans the same 3×3×3 block, which answers it exactly
    // when its k-th distance is within h + margin; the others take the ring search, and those
    // it gives up on are answered afterwards.
    let cells = grid.cells();
    let answered: Vec<(u32, Option<T>)> = cells
        .par_iter()
        .map_init(
            || (Best::new(k, cap), Vec::with_capacity(k)),
            |(best, out), &(c, start, end)| {
                let block = grid.block(c);
                let mut res = Vec::with_capacity(end - start);
                // The previous point's k-th distance (×1.2, the fastest of 1.1 to 1.5 on the milk
                // scene) filters candidates before selection; when fewer than k pass, the block is
                // scanned again without it. A cell's first point takes the sample's median k-th
                // distance instead (not the last cell's: the neighbours' order, and so the
                // round-off of what `f` sums over them, would depend on how rayon split the work).
                let mut hint = typical;
                for sp in start..end {
                    let q = &grid.sorted[sp];
                    let i = grid.order[sp];
                    let mut exact = false;
                    for bound in [hint.min(cap), cap] {
                        best.clear();
                        for &(a, b) in &block {
                            // Branch-free (whether a point passes is a coin toss): every point
                            // is written, and the end moves past it when it passes.
                            let mut m = best.items.len();
                            best.items.resize(m + b - a, (0, 0));
                            for t in a..b {
                                let p = &grid.sorted[t];
                                let d2 =
                                    (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2);
                                best.items[m] = (d2.to_bits(), grid.order[t]);
                                m += usize::from(d2 <= bound && t != sp);
                            }
                            best.items.truncate(m);
                        }
                        if best.items.len() >= k || bound == cap {
                            break;
                        }
                    }
                    best.settle();
                    let reach = grid.h + grid.margin(q, c);
                    if best.settled(reach) {
                        exact = true;
                        if best.full() {
                            hint = 1.44 * best.worst();
                        }
                    }
                    // Not settled within the block: continue with rings 2, 3, ...
                    exact = exact || grid.query(q, i, best, 2);
                    res.push((
                        i,
                        exact.then(|| {
                            best.finish(out);
                            f(i as usize, out)
                        }),
                    ));
                }
                res
            },
        )
        .flatten()
        .collect();
    let mut slots: Vec<Option<T>> = (0..points.len()).map(|_| None).collect();
    let mut far = Vec::new();
    for (i, t) in answered {
        match t {
            Some(t) => slots[i as usize] = Some(t),
            None => far.push(i as usize),
        }
    }
    // The points the rings gave up on (isolated ones): a linear scan each while they are few,
    // else a kd-tree over the whole cloud.
    if far.len() <= BRUTE_FORCE_QUERIES {
        let mut best = Best::new(k, cap);
        let mut out = Vec::with_capacity(k);
        for i in far {
            best.clear();
            for (j, p) in points.iter().enumerate() {
                if j != i {
                    best.offer((p - points[i]).norm_squared(), j as u32);
                }
            }
            best.finish(&mut out);
            slots[i] = Some(f(i, &out));
        }
    } else {
        let tree = KdIndex::new(points).map_err(|e| Error::failed("kNN", e))?;
        let done: Vec<(usize, T)> = far
            .into_par_iter()
            .map(|i| (i, f(i, &tree_knn(&tree, &points[i], i, k, radius))))
            .collect();
        for (i, t) in done {
            slots[i] = Some(t);
        }
    }
    let out: Vec<T> = slots.into_iter().flatten().collect();
    if out.len() != points.len() {
        return Err(Error::failed("kNN", "a point was not answered (internal error)"));
    }
    Ok(out)
}

/// The grid's cell edge: `CELL_FACTOR` × the median k-th neighbour distance over a spread-out
/// sample of points. The distances are measured in one point of `s`, whose (k/s)-th neighbour
/// lies about as far as the whole cloud's k-th whatever the cloud's dimension (the same count of
/// points within the radius): a tree `s` times smaller.
fn cell_edge(points: &[Point3<f64>], k: usize, diag: f64) -> Result<f64> {
    let s = (k / 4).max(1);
    // A pseudo-random subset (a cloud's storage order is often spatial: a plain stride would thin
    // it along one direction only).
    let subset: Vec<Point3<f64>> = points
        .iter()
        .enumerate()
        .filter(|&(i, _)| ((i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32).is_multiple_of(s as u64))
        .map(|(_, p)| *p)
        .collect();
    let m = k.div_ceil(s).min(subset.len().saturating_sub(1)).max(1);
    let tree = KdIndex::new(&subset).map_err(|e| Error::failed("kNN", e))?;
    let step = (subset.len() / SAMPLE).max(1);
    // m + 1: the sample point itself is in the subset.
    let mut kth: Vec<f64> = subset
        .iter()
        .step_by(step)
        .map(|p| tree.knn(p, m + 1).last().map_or(0.0, |n| n.distance))
        .collect();
    kth.sort_by(f64::total_cmp);
    Ok((CELL_FACTOR * kth[kth.len() / 2])
        .max(diag * 1e-9)
        .max(f64::MIN_POSITIVE))
}

/// The `k` nearest other points of point `i` (at `q`) within `radius` from a kd-tree over all
/// points.
fn tree_knn(tree: &KdIndex, q: &Point3<f64>, i: usize, k: usize, radius: f64) -> Vec<Neighbour> {
    // k + 1 so that the point itself (or one exact duplicate) can be dropped.
    let mut v = if radius.is_finite() {
        tree.knn_within(q, k + 1, radius)
    } else {
        tree.knn(q, k + 1)
    };
    match v.iter().position(|n| n.index == i) {
        Some(at) => {
            v.remove(at);
        }
        None => {
            v.pop();
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    fn brute(points: &[Point3<f64>], i: usize, k: usize) -> Vec<(f64, usize)> {
        let mut d: Vec<(f64, usize)> = points
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .map(|(j, p)| ((p - points[i]).norm(), j))
            .collect();
        let by = |a: &(f64, usize), b: &(f64, usize)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
        if k < d.len() {
            d.select_nth_unstable_by(k, by);
            d.truncate(k);
        }
        d.sort_by(by);
        d
    }

    #[test]
    fn matches_brute_force_on_a_surface_with_outliers_and_duplicates() {
        // Few outliers: the rings' leftovers get a linear scan each; many: a kd-tree.
        for outliers in [15, 3 * BRUTE_FORCE_QUERIES] {
            matches_brute_force(outliers);
        }
    }

    fn matches_brute_force(outliers: usize) {
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(5);
        // A wavy sheet at the bottom of the box (so it sits in the first z cells), outliers above
        // and around it, and two exact duplicates.
        let mut pts: Vec<Point3<f64>> = (0..1500)
            .map(|_| {
                let (u, v) = (rng.random_range(0.0..1.0), rng.random_range(0.0..1.0f64));
                Point3::new(u, v, 0.02 * (6.0 * u).sin())
            })
            .collect();
        for _ in 0..outliers {
            pts.push(Point3::new(
                rng.random_range(-1.0..2.0),
                rng.random_range(-1.0..2.0),
                rng.random_range(0.0..1.0),
            ));
        }
        pts.push(pts[10]);
        pts.push(pts[10]);
        // Unbounded, and capped to radii below and above the typical k-th distance (the cap
        // makes the cell edge at most the radius: no ring search).
        for (k, radius) in [1, 8, 20]
            .into_iter()
            .flat_map(|k| [(k, f64::INFINITY), (k, 0.01), (k, 0.3)])
        {
            let got = map_knn_within(&pts, k, radius, |_, nb| {
                let mut v: Vec<(f64, usize)> = nb.iter().map(|n| (n.distance, n.index)).collect();
                v.sort_by(|a, b| a.0.total_cmp(&b.0));
                v
            })
            .unwrap();
            for (i, g) in got.iter().enumerate() {
                let mut b = brute(&pts, i, k);
                b.retain(|x| x.0 <= radius);
                assert_eq!(g.len(), b.len(), "point {i}, k {k}, radius {radius}");
                let mut idx: Vec<usize> = g.iter().map(|x| x.1).collect();
                idx.sort();
                idx.dedup();
                assert_eq!(idx.len(), b.len(), "point {i}: a neighbour twice: {g:?}");
                assert!(!idx.contains(&i), "point {i} is its own neighbour");
                for (x, y) in g.iter().zip(&b) {
                    // Same distances; indices may differ only between equidistant points.
                    assert!((x.0 - y.0).abs() < 1e-12, "point {i}: {g:?} vs {b:?}");
                }
            }
        }
    }

    #[test]
    fn small_and_degenerate_clouds() {
        let one = [Point3::new(1.0, 2.0, 3.0)];
        let r = map_knn(&one, 5, |_, nb| nb.len()).unwrap();
        assert_eq!(r, vec![0]);
        let line: Vec<Point3<f64>> = (0..5).map(|i| Point3::new(i as f64, 0.0, 0.0)).collect();
        let r = map_knn(&line, 10, |_, nb| nb.len()).unwrap();
        assert_eq!(r, vec![4; 5]);
        let r = map_knn(&line, 1, |_, nb| nb[0].distance).unwrap();
        assert_eq!(r, vec![1.0; 5]);
        assert!(map_knn(&line, 0, |_, _| ()).is_err());
        assert!(map_knn_within(&line, 1, 0.0, |_, _| ()).is_err());
        assert!(map_knn(&[Point3::new(f64::NAN, 0.0, 0.0)], 1, |_, _| ()).is_err());
        // All points identical: every distance 0.
        let same = vec![Point3::new(0.5, 0.5, 0.5); 50];
        let r = map_knn(&same, 3, |_, nb| nb.iter().map(|n| n.distance).sum::<f64>()).unwrap();
        assert!(r.iter().all(|&s| s == 0.0));
    }
}
