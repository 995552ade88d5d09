//! Frames, poses and pose files.
//!
//! Frames (see DESIGN.md): `W` world NED (z down); `C` vehicle body (x forward, y starboard, z
//! down, origin at the centre of buoyancy); `0` manipulator base at `d0` in `C`; `1..6` DH link
//! frames; `G` tool (`z_G` into the surface, `x_G` along the motion); `S` camera (z optical axis,
//! x right, y down in the image). A transform named `t_a_b` maps coordinates in `b` into `a`.
//!
//! A pose file is JSON whose key (e.g. `"t_scan_reference"`) holds a 4×4 row-major matrix.

use crate::error::{Error, Result};
use nalgebra::{Isometry3, Matrix3, Matrix4, Rotation3, Translation3, UnitQuaternion};

/// A rigid transform (rotation + translation), metres.
pub type Pose = Isometry3<f64>;

/// The 4×4 homogeneous matrix of a pose, as rows (the JSON layout).
pub fn pose_to_rows(pose: &Pose) -> [[f64; 4]; 4] {
    let m = pose.to_homogeneous();
    std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]))
}

/// A pose from a 4×4 row-major matrix; the rotation block must be orthonormal with determinant
/// +1 (to 1e-6) and the last row `0 0 0 1`. `what` names the source in errors.
///
/// # Errors
/// [`Error::Input`] naming `what` when the matrix is not a rigid transform.
pub fn pose_from_rows(rows: &[[f64; 4]; 4], what: &str) -> Result<Pose> {
    let m = Matrix4::from_fn(|r, c| rows[r][c]);
    if m.iter().any(|v| !v.is_finite()) {
        return Err(Error::input(what, "pose matrix has a non-finite entry"));
    }
    let last = m.row(3);
    if (last[0].abs() + last[1].abs() + last[2].abs() + (last[3] - 1.0).abs()) > 1e-9 {
        return Err(Error::input(what, "pose matrix's last row is not 0 0 0 1"));
    }
    let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
    if (r.transpose() * r - Matrix3::identity()).abs().max() > 1e-6 || (r.determinant() - 1.0).abs() > 1e-6 {
        return Err(Error::input(
            what,
            "pose matrix's rotation block is not a rotation",
        ));
    }
    let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    Ok(Isometry3::from_parts(
        Translation3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]),
        rot,
    ))
}

/// Reads the pose stored under `key` in the JSON pose file `path`.
///
/// # Errors
/// [`Error::Input`] naming the file and key if it is missing, unreadable or not a rigid transform.
pub fn read_pose_file(path: &std::path::Path, key: &str) -> Result<Pose> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::input(path.display(), format!("cannot read: {e}")))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| Error::input(path.display(), format!("not JSON: {e}")))?;
    let what = format!("{} key {key}", path.display());
    let rows: [[f64; 4]; 4] = serde_json::from_value(
        v.get(key)
            .cloned()
            .ok_or_else(|| Error::input(&what, "missing"))?,
    )
    .map_err(|e| Error::input(&what, format!("expected a 4x4 matrix of numbers: {e}")))?;
    pose_from_rows(&rows, &what)
}

/// Rotation angle between two poses, degrees, and the distance between their translations, metres.
pub fn pose_error(estimate: &Pose, truth: &Pose) -> (f64, f64) {
    let d = truth.inverse() * estimate;
    (
        d.rotation.angle().to_degrees(),
        (estimate.translation.vector - truth.translation.vector).norm(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn rows_round_trip() {
        let p = Isometry3::new(Vector3::new(0.1, -0.2, 1.0), Vector3::new(0.3, -0.5, 0.2));
        let back = pose_from_rows(&pose_to_rows(&p), "t").unwrap();
        assert!((back.to_homogeneous() - p.to_homogeneous()).abs().max() < 1e-12);
        assert_eq!(pose_error(&back, &p).1, 0.0);
    }

    #[test]
    fn rejects_a_scaled_rotation() {
        let mut rows = pose_to_rows(&Pose::identity());
        rows[0][0] = 2.0;
        assert_eq!(pose_from_rows(&rows, "t").unwrap_err().exit_code(), 2);
    }
}
