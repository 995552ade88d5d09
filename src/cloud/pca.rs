//! Principal component analysis of point sets: centroid, covariance, principal axes and spans.
//!
//! The covariance is computed in two passes (centroid first) for accuracy on clouds far from the
//! origin. Axes are the eigenvectors of the 3×3 covariance, sorted by decreasing variance and made
//! right-handed. Spans are the extents of the points along each axis between two quantiles, so
//! that a few stray points do not inflate them. Units: metres (variances in m²).

use nalgebra::{Matrix3, Point3, SymmetricEigen, Vector3};

/// Centroid and covariance (divided by `n`) of the points `indices` of `points`, or `None` when
/// `indices` is empty.
pub fn mean_covariance_of(
    points: &[Point3<f64>],
    indices: impl Iterator<Item = usize> + Clone,
) -> Option<(Point3<f64>, Matrix3<f64>)> {
    let mut n = 0usize;
    let mut sum = Vector3::zeros();
    for i in indices.clone() {
        sum += points[i].coords;
        n += 1;
    }
    if n == 0 {
        return None;
    }
    let c = sum / n as f64;
    let mut cov = Matrix3::zeros();
    for i in indices {
        let d = points[i].coords - c;
        cov += d * d.transpose();
    }
    Some((Point3::from(c), cov / n as f64))
}

/// Centroid and covariance (divided by `n`) of all `points`, or `None` when there are none.
pub fn mean_covariance(points: &[Point3<f64>]) -> Option<(Point3<f64>, Matrix3<f64>)> {
    mean_covariance_of(points, 0..points.len())
}

/// Eigen-decomposition of a symmetric 3×3 matrix: eigenvalues in **decreasing** order and the
/// matching unit eigenvectors as the columns of a right-handed rotation matrix.
pub fn sorted_eigen(m: &Matrix3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
    let e = SymmetricEigen::new(*m);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| e.eigenvalues[b].total_cmp(&e.eigenvalues[a]));
    let values = Vector3::from_fn(|r, _| e.eigenvalues[order[r]]);
    let mut axes = Matrix3::from_fn(|r, c| e.eigenvectors[(r, order[c])]);
    if axes.determinant() < 0.0 {
        let flipped = -axes.column(2);
        axes.set_column(2, &flipped);
    }
    (values, axes)
}

/// The unit eigenvector of the **smallest** eigenvalue of a symmetric 3×3 matrix (sign
/// arbitrary), in closed form (Eberly's robust variant of the trigonometric solution of the
/// characteristic cubic, Smith 1961): the eigenvalue farthest from the other two is computed first
/// (well separated, so its eigenvector — the longest cross product of two rows of `m − λ I` — is
/// accurate); if that is the largest one, the smallest's eigenvector is found in the plane
/// orthogonal to it from the 2×2 problem there. Where the two smallest eigenvalues are equal (e.g.
/// collinear points) any unit vector of their plane is returned; where `m` is a multiple of the
/// identity (or zero, or not finite), `z`. A fraction of the cost of [`sorted_eigen`], for a local
/// plane's normal.
pub fn least_eigenvector(m: &Matrix3<f64>) -> Vector3<f64> {
    // Scaled to unit largest entry: no overflow or underflow in the powers below.
    let scale = m.amax();
    if !(scale > 0.0 && scale.is_finite()) {
        return Vector3::z();
    }
    let a = m / scale;
    let q = a.trace() / 3.0;
    let off = a[(0, 1)].powi(2) + a[(0, 2)].powi(2) + a[(1, 2)].powi(2);
    let p2 = (a[(0, 0)] - q).powi(2) + (a[(1, 1)] - q).powi(2) + (a[(2, 2)] - q).powi(2) + 2.0 * off;
    let p = (p2 / 6.0).sqrt();
    if p <= 1e-15 {
        return Vector3::z();
    }
    let b = (a - Matrix3::identity() * q) / p;
    let half_det = (b.determinant() / 2.0).clamp(-1.0, 1.0);
    let phi = half_det.acos() / 3.0;
    // The eigenvector of the simple eigenvalue `l`: the longest cross product of two rows of
    // `a − l I` (rank 2).
    let vector_for = |l: f64| {
        let d = a - Matrix3::identity() * l;
        let rows = [0, 1, 2].map(|i| d.row(i).transpose());
        [
            rows[0].cross(&rows[1]),
            rows[0].cross(&rows[2]),
            rows[1].cross(&rows[2]),
        ]
        .into_iter()
        .max_by(|x, y| x.norm_squared().total_cmp(&y.norm_squared()))
        .and_then(|c| c.try_normalize(1e-300))
        .unwrap_or_else(Vector3::z)
    };
    if half_det < 0.0 {
        // The smallest eigenvalue is the one farthest from the other two.
        return vector_for(q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos());
    }
    // The largest is: its eigenvector first, then the 2×2 problem in the plane orthogonal to it.
    let v = vector_for(q + 2.0 * p * phi.cos());
    let u = v.cross(&Vector3::ith(v.iamin(), 1.0)).normalize();
    let w = v.cross(&u);
    let (au, aw) = (a * u, a * w);
    let (uu, uw, ww) = (u.dot(&au), u.dot(&aw), w.dot(&aw));
    // The larger eigenvalue's direction is at `theta` from `u`; the smaller's at a right angle.
    let theta = 0.5 * (2.0 * uw).atan2(uu - ww);
    (w * theta.cos() - u * theta.sin()).normalize()
}

/// The principal axes of a point set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrincipalAxes {
    /// Centroid, metres.
    pub centroid: Point3<f64>,
    /// Unit axes as columns, by decreasing variance; a right-handed rotation (axis signs are
    /// arbitrary).
    pub axes: Matrix3<f64>,
    /// Variance along each axis, m², decreasing.
    pub variances: Vector3<f64>,
    /// Extent along each axis between the `q` and `1 − q` quantiles of the projections, metres.
    pub spans: Vector3<f64>,
}

/// Principal axes of `points` with spans between the `quantile` and `1 − quantile` projections
/// (`quantile` in [0, 0.5); 0 gives the full extent). `None` when `points` is empty.
pub fn principal_axes(points: &[Point3<f64>], quantile: f64) -> Option<PrincipalAxes> {
    let (centroid, cov) = mean_covariance(points)?;
    let (variances, axes) = sorted_eigen(&cov);
    let spans = Vector3::from_fn(|k, _| {
        let a = axes.column(k);
        let mut proj: Vec<f64> = points.iter().map(|p| (p - centroid).dot(&a)).collect();
        quantile_span(&mut proj, quantile)
    });
    Some(PrincipalAxes {
        centroid,
        axes,
        variances,
        spans,
    })
}

/// Distance between the `q` and `1 − q` quantiles of `values` (reorders `values`); 0 when empty.
pub fn quantile_span(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let n = values.len();
    let q = q.clamp(0.0, 0.5);
    let lo_i = ((n - 1) as f64 * q).round() as usize;
    let hi_i = ((n - 1) as f64 * (1.0 - q)).round() as usize;
    let hi = *values.select_nth_unstable_by(hi_i, f64::total_cmp).1;
    let lo = *values.select_nth_unstable_by(lo_i, f64::total_cmp).1;
    hi - lo
}

/// The median of `values` (reorders them); `None` when empty.
pub fn median(values: &mut [f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mid = values.len() / 2;
    Some(*values.select_nth_unstable_by(mid, f64::total_cmp).1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};
    use rand::{RngExt, SeedableRng};

    #[test]
    fn least_eigenvector_matches_the_full_decomposition() {
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(5);
        let spectra: [[f64; 3]; 9] = [
            [1.0, 0.5, 0.01],
            [1.0, 0.9, 1e-8],
            [1.0, 1.0, 1e-6],
            [1.0, 1e-3, 1e-3],
            [1.0, 1e-7, 0.0],
            [1.0, 1.0, 1.0],
            [2.0, 2.0, 0.0],
            [1e-9, 5e-10, 1e-12],
            [3.0, 1.0, 1.0 - 1e-9],
        ];
        for _ in 0..200 {
            let spectrum = spectra[rng.random_range(0..spectra.len())];
            let r = Rotation3::from_euler_angles(
                rng.random_range(-3.2..3.2),
                rng.random_range(-1.6..1.6),
                rng.random_range(-3.2..3.2),
            );
            let m = r.matrix() * Matrix3::from_diagonal(&Vector3::from(spectrum)) * r.matrix().transpose();
            let m = (m + m.transpose()) / 2.0;
            let v = least_eigenvector(&m);
            assert!((v.norm() - 1.0).abs() < 1e-12, "{spectrum:?}");
            let low = spectrum[2];
            // An eigenvector of the smallest eigenvalue, to working precision.
            assert!(
                (m * v - v * low).norm() <= 1e-9 * spectrum[0],
                "{spectrum:?}: {v}"
            );
            let (_, axes) = sorted_eigen(&m);
            if spectrum[1] - low > 1e-4 * spectrum[0] {
                assert!(v.dot(&axes.column(2)).abs() > 1.0 - 1e-9, "{spectrum:?}");
            }
        }
        // Random covariances of random points.
        for _ in 0..500 {
            let pts: Vec<Point3<f64>> = (0..rng.random_range(3..30))
                .map(|_| {
                    Point3::new(
                        rng.random::<f64>(),
                        0.3 * rng.random::<f64>(),
                        0.01 * rng.random::<f64>(),
                    )
                })
                .collect();
            let (_, m) = mean_covariance(&pts).unwrap();
            let v = least_eigenvector(&m);
            let (values, axes) = sorted_eigen(&m);
            assert!((m * v - v * values[2]).norm() <= 1e-12 * values[0].max(1e-300));
            if values[1] - values[2] > 1e-4 * values[0] {
                assert!(v.dot(&axes.column(2)).abs() > 1.0 - 1e-9);
            }
        }
        assert_eq!(least_eigenvector(&Matrix3::zeros()), Vector3::z());
        assert_eq!(least_eigenvector(&Matrix3::from_element(f64::NAN)), Vector3::z());
    }

    #[test]
    fn box_axes_and_spans() {
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(1);
        let rot = Rotation3::from_euler_angles(0.3, -0.7, 1.1);
        let c = Vector3::new(5.0, -2.0, 100.0);
        let dims = Vector3::new(0.4, 0.2, 0.1);
        let pts: Vec<Point3<f64>> = (0..20000)
            .map(|_| {
                let u = Vector3::from_fn(|i, _| (rng.random::<f64>() - 0.5) * dims[i]);
                Point3::from(rot * u + c)
            })
            .collect();
        let pa = principal_axes(&pts, 0.0).unwrap();
        assert!((pa.centroid.coords - c).norm() < 5e-3);
        for k in 0..3 {
            let true_axis = rot.matrix().column(k);
            assert!(pa.axes.column(k).dot(&true_axis).abs() > 0.999, "axis {k}");
            assert!((pa.spans[k] - dims[k]).abs() < 2e-3, "span {k}: {}", pa.spans[k]);
            // Uniform distribution: variance = L²/12.
            assert!((pa.variances[k] / (dims[k] * dims[k] / 12.0) - 1.0).abs() < 0.05);
        }
        assert!((pa.axes.determinant() - 1.0).abs() < 1e-9);
        let trimmed = principal_axes(&pts, 0.01).unwrap();
        assert!((trimmed.spans[0] - 0.98 * dims[0]).abs() < 3e-3);
    }

    #[test]
    fn quantiles_and_median() {
        let mut v: Vec<f64> = (0..101).map(|i| i as f64).collect();
        assert_eq!(quantile_span(&mut v, 0.0), 100.0);
        assert_eq!(quantile_span(&mut v, 0.1), 80.0);
        assert_eq!(median(&mut v), Some(50.0));
        assert_eq!(median(&mut []), None);
        assert!(principal_axes(&[], 0.0).is_none());
    }
}
