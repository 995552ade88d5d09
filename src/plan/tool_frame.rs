//! The tool frame `G` at every point of the path: the `X_G`, `Y_G` of the seed's eq. (18).
//!
//! `z_G` is the (smoothed) surface normal reversed, pointing into the surface; `x_G` is the path
//! tangent projected onto the tangent plane (the direction of motion; with
//! `x_axis = "steady"`, for a tool symmetric about its axis, the previous point's `x_G` projected
//! instead, so that the tool does not turn about `k` where the path reverses, at a raster's row
//! ends); `y_G = z_G × x_G` makes the frame right-handed. An optional service angle then turns the frame about `y_G`, tilting the
//! tool axis towards the direction of motion (positive: the holder trails the tip). The desired
//! force direction is `k = z_G`.
//!
//! Tangents are central differences over a window of samples (the smoothing radius), so that the
//! frame turns smoothly at the corners of a raster; where the tangent is parallel to the normal
//! the previous `x_G` is carried over, so the frame never flips. Consecutive quaternions are kept
//! in the same hemisphere (non-negative dot product).

use crate::error::{Error, Result};
use nalgebra::{Matrix3, Point3, Rotation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// Settings of the tool orientation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ToolConfig {
    /// Tilt of the tool axis from the surface normal towards the direction of motion (a rotation
    /// about `y_G`), degrees.
    pub service_angle_deg: f64,
    /// The fastest the tool's orientation may turn, degrees per second; the tool slows down
    /// where the path would turn it faster.
    pub max_rate_deg_s: f64,
    /// What `x_G` follows.
    pub x_axis: XAxis,
}

/// What the tool frame's `x_G` follows along the path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum XAxis {
    /// The direction of motion (a sampler, a scraper: a tool with a front).
    #[default]
    Travel,
    /// The first point's direction of motion, carried along the surface (each point's `x_G`
    /// the previous one's projected onto its tangent plane): a tool symmetric about its axis (a
    /// brush) turns about `k` only as the surface does, not where the path reverses.
    Steady,
}

impl Default for ToolConfig {
    fn default() -> Self {
        ToolConfig {
            service_angle_deg: 0.0,
            max_rate_deg_s: 30.0,
            x_axis: XAxis::Travel,
        }
    }
}

impl ToolConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`] naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        if !(self.service_angle_deg.is_finite() && self.service_angle_deg.abs() < 90.0) {
            return Err(Error::input(
                "tool.service_angle_deg",
                "must be between -90 and 90",
            ));
        }
        crate::config::positive("tool.max_rate_deg_s", self.max_rate_deg_s)
    }
}

/// The tool frame's axes as the columns of a rotation: `z_G = -normal`, `x_G` along `tangent`
/// in the tangent plane (or along `previous_x` when the tangent is parallel to the normal, or
/// any perpendicular), then turned about `y_G` by `service_angle` radians. `normal` need not be
/// unit; it must not be zero.
pub fn tool_frame(
    normal: &Vector3<f64>,
    tangent: &Vector3<f64>,
    previous_x: Option<&Vector3<f64>>,
    service_angle: f64,
) -> Rotation3<f64> {
    let z = -normal.try_normalize(1e-300).unwrap_or(Vector3::z());
    let in_plane = |v: &Vector3<f64>| (v - z * z.dot(v)).try_normalize(1e-9);
    let x = in_plane(tangent)
        .or_else(|| previous_x.and_then(in_plane))
        .unwrap_or_else(|| super::perpendicular(&z, &Vector3::zeros()));
    let y = z.cross(&x);
    let frame = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
    frame * Rotation3::from_axis_angle(&Vector3::y_axis(), service_angle)
}

/// Normals smoothed along the path: a triangular window of `±window` samples (weights
/// `window + 1 - |j - i|`), renormalised. On top of the smoothing over the surface this
/// removes the remaining sample-to-sample jitter of the tool axis.
pub fn smooth_along(normals: &[Vector3<f64>], window: usize) -> Vec<Vector3<f64>> {
    let n = normals.len();
    (0..n)
        .map(|i| {
            let lo = i.saturating_sub(window);
            let hi = (i + window).min(n.saturating_sub(1));
            let sum: Vector3<f64> = (lo..=hi)
                .map(|j| normals[j] * (window + 1 - j.abs_diff(i)) as f64)
                .sum();
            sum.try_normalize(1e-300).unwrap_or(normals[i])
        })
        .collect()
}

/// Tool orientations along a path sampled at uniform spacing: tangents by central differences
/// over `±window` samples (with [`XAxis::Steady`] the first point's only, then the previous
/// `x_G`), frames by [`tool_frame`], quaternion signs kept continuous.
pub fn tool_frames(
    points: &[Point3<f64>],
    normals: &[Vector3<f64>],
    window: usize,
    service_angle: f64,
    x_axis: XAxis,
) -> Vec<UnitQuaternion<f64>> {
    let n = points.len().min(normals.len());
    let w = window.max(1);
    let mut out: Vec<UnitQuaternion<f64>> = Vec::with_capacity(n);
    let mut previous_x: Option<Vector3<f64>> = None;
    for i in 0..n {
        let tangent = match (x_axis, &previous_x) {
            (XAxis::Steady, Some(x)) => *x,
            _ => points[(i + w).min(n - 1)] - points[i.saturating_sub(w)],
        };
        let r = tool_frame(&normals[i], &tangent, previous_x.as_ref(), service_angle);
        // Keep the un-tilted x_G for the next point's fallback.
        let untilted = r * Rotation3::from_axis_angle(&Vector3::y_axis(), -service_angle);
        previous_x = Some(untilted.matrix().column(0).into_owned());
        let mut q = UnitQuaternion::from_rotation_matrix(&r);
        if let Some(prev) = out.last()
            && prev.coords.dot(&q.coords) < 0.0
        {
            q = UnitQuaternion::new_unchecked(-q.into_inner());
        }
        out.push(q);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn vec3() -> impl Strategy<Value = Vector3<f64>> {
        (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64).prop_map(|(x, y, z)| Vector3::new(x, y, z))
    }

    proptest! {
        #![proptest_config(proptest::test_runner::Config {
            rng_seed: proptest::test_runner::RngSeed::Fixed(18),
            failure_persistence: None,
            ..Default::default()
        })]

        /// Every frame is orthonormal and right-handed, its z axis is the tilted reversed normal
        /// and its x axis lies along the tangent's in-plane part, whatever the inputs (including
        /// tangents nearly parallel to the normal).
        #[test]
        fn frames_are_orthonormal_right_handed(
            n in vec3(), t in vec3(), px in vec3(), angle in -1.2..1.2f64, scale in prop_oneof![Just(1.0), Just(1e-12)]
        ) {
            prop_assume!(n.norm() > 1e-3);
            let t = t * scale + n * 0.5;
            let r = tool_frame(&n, &t, Some(&px), angle);
            let m = r.matrix();
            prop_assert!((m.transpose() * m - Matrix3::identity()).abs().max() < 1e-9);
            prop_assert!((m.determinant() - 1.0).abs() < 1e-9);
            let (x, y, z) = (m.column(0).into_owned(), m.column(1).into_owned(), m.column(2).into_owned());
            prop_assert!((x.cross(&y) - z).norm() < 1e-9);
            // Undo the service angle: z_G0 = -n̂, and x_G0 along the in-plane tangent if any.
            let r0 = r * Rotation3::from_axis_angle(&Vector3::y_axis(), -angle);
            let z0 = r0.matrix().column(2).into_owned();
            prop_assert!((z0 + n.normalize()).norm() < 1e-9);
            prop_assert!((z.dot(&z0) - angle.cos()).abs() < 1e-9);
            let tp = t - z0 * z0.dot(&t);
            if tp.norm() > 1e-6 {
                prop_assert!(r0.matrix().column(0).dot(&tp.normalize()) > 1.0 - 1e-9);
            }
        }
    }

    #[test]
    fn service_angle_tilts_towards_the_motion() {
        let r = tool_frame(&Vector3::z(), &Vector3::x(), None, 10f64.to_radians());
        let z = r.matrix().column(2).into_owned();
        // Without tilt z_G = -z; tilted by 10° towards +x (the motion).
        assert!((z - Vector3::new(10f64.to_radians().sin(), 0.0, -10f64.to_radians().cos())).norm() < 1e-12);
    }

    #[test]
    fn frames_along_a_circle_turn_smoothly_without_flips() {
        // A half circle in the x-z plane, normals pointing out of the circle.
        let pts: Vec<Point3<f64>> = (0..=180)
            .map(|i| {
                let a = (i as f64).to_radians();
                Point3::new(a.cos(), 0.0, a.sin())
            })
            .collect();
        let normals: Vec<Vector3<f64>> = pts.iter().map(|p| p.coords).collect();
        let q = tool_frames(&pts, &normals, 3, 0.0, XAxis::Travel);
        for (i, w) in q.windows(2).enumerate() {
            // One degree of arc turns the frame by one degree.
            assert!((w[0].angle_to(&w[1]).to_degrees() - 1.0).abs() < 1e-6, "{i}");
            assert!(w[0].coords.dot(&w[1].coords) > 0.0);
        }
        let x = q[90] * Vector3::x();
        assert!((x - Vector3::new(-1.0, 0.0, 0.0)).norm() < 1e-9, "{x}");
    }

    /// Back and forth along a line on a plane, as a raster's rows: following the travel, `x_G`
    /// reverses at the turn (a half turn about `k`); steady, it keeps the first row's direction
    /// and the tool does not turn at all. Over a bend (the normal tilting along the row, up to
    /// 120°) the steady `x_G` follows the surface: it stays in the tangent plane.
    #[test]
    fn a_steady_x_axis_does_not_turn_where_the_path_reverses() {
        let pts: Vec<Point3<f64>> = (0..=40)
            .map(|i| Point3::new(if i <= 20 { i as f64 } else { (40 - i) as f64 }, 0.0, 0.0))
            .collect();
        let up = vec![Vector3::z(); pts.len()];
        let travel = tool_frames(&pts, &up, 2, 0.0, XAxis::Travel);
        let steady = tool_frames(&pts, &up, 2, 0.0, XAxis::Steady);
        let x = |q: &UnitQuaternion<f64>| q * Vector3::x();
        assert!((x(&travel[0]) - Vector3::x()).norm() < 1e-12);
        assert!((x(&travel[40]) + Vector3::x()).norm() < 1e-12);
        assert!(travel[0].angle_to(&travel[40]) > std::f64::consts::PI - 1e-9);
        assert!(steady.iter().all(|q| q.angle_to(&steady[0]) < 1e-12));
        let ridge: Vec<Vector3<f64>> = (0..=40)
            .map(|i| {
                let a = (i as f64 * 3.0).to_radians();
                Vector3::new(a.sin(), 0.0, a.cos())
            })
            .collect();
        for (q, n) in tool_frames(&pts, &ridge, 2, 0.0, XAxis::Steady)
            .iter()
            .zip(&ridge)
        {
            assert!((q * Vector3::z() + n).norm() < 1e-12);
            assert!(x(q).dot(n).abs() < 1e-12);
        }
    }
}
