//! Frames, poses and pose files.
//!
//! Frames (see DESIGN.md): `W` world NED (z down); `C` vehicle body (x forward, y starboard, z
//! down, origin at the centre of buoyancy); `0` manipulator base at `d0` in `C`; `1..6` DH link
//! frames; `G` tool (`z_G` into the surface, `x_G` along the motion); `S` camera (z optical axis,
//! x right, y down in the image). A transform named `t_a_b` maps coordinates in `b` into `a`.
//!
//! A pose file is JSON whose key (e.g. `"t_scan_reference"`) holds a 4×4 row-major matrix.

use crate::error::{Error, Result};
use nalgebra::{Isometry3, Matrix3, Matrix4, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// A rigid transform (rotation + translation), metres.
pub type Pose = Isometry3<f64>;

/// The 4×4 homogeneous matrix of a pose, as rows (the JSON layout).
pub fn pose_to_rows(pose: &Pose) -> [[f64; 4]; 4] {
    let m = pose.to_homogeneous();
    std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]))
}

/// The largest translation a pose may have, m: a thousand kilometres, past any scene, short of
/// the magnitudes whose errors overflow.
const MAX_TRANSLATION_M: f64 = 1e6;

/// A pose from a 4×4 row-major matrix; the rotation block must be orthonormal with determinant
/// +1 (to 1e-6), the last row `0 0 0 1` and the translation within 10⁶ m. `what` names the
/// source in errors.
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
    let (skew, det) = (
        (r.transpose() * r - Matrix3::identity()).abs().max(),
        r.determinant(),
    );
    if skew > 1e-6 || (det - 1.0).abs() > 1e-6 {
        return Err(Error::input(
            what,
            format!(
                "pose matrix's rotation block is not a rotation to 1e-6: RᵀR is off the identity by up to {} and det R is {}{}",
                crate::config::shown_significant(skew, 2),
                crate::config::shown_significant(det, 7),
                if skew < 1e-3 && (det - 1.0).abs() < 1e-3 {
                    " (entries rounded to fewer than 7 decimals?)"
                } else {
                    ""
                }
            ),
        ));
    }
    let t = Vector3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]);
    if t.amax() > MAX_TRANSLATION_M {
        return Err(Error::input(
            what,
            format!(
                "pose matrix's translation is {} m along an axis: more than {MAX_TRANSLATION_M:.0e} m, beyond any scene (a pose in other units?)",
                crate::config::shown(t.amax())
            ),
        ));
    }
    let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    Ok(Isometry3::from_parts(Translation3::from(t), rot))
}

/// Reads the pose stored under `key` in the JSON pose file `path`.
///
/// # Errors
/// [`Error::Input`] naming the file and key if it is missing, unreadable or not a rigid transform.
pub fn read_pose_file(path: &std::path::Path, key: &str) -> Result<Pose> {
    let text = crate::config::read_text(path, "a JSON pose file")?;
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

/// A pose written for people in a configuration file: a translation and roll, pitch, yaw angles
/// (Z-Y-X Tait–Bryan, as in Fossen: `R = Rz(yaw) · Ry(pitch) · Rx(roll)`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PoseConfig {
    /// Translation of the child frame's origin in the parent frame, metres.
    pub xyz_m: [f64; 3],
    /// Roll, pitch, yaw of the child frame relative to the parent frame, degrees.
    pub rpy_deg: [f64; 3],
}

impl Default for PoseConfig {
    fn default() -> Self {
        PoseConfig {
            xyz_m: [0.0; 3],
            rpy_deg: [0.0; 3],
        }
    }
}

impl PoseConfig {
    /// The transform `t_parent_child` this configuration describes.
    pub fn pose(&self) -> Pose {
        let [r, p, y] = self.rpy_deg.map(f64::to_radians);
        Isometry3::from_parts(
            Translation3::from(Vector3::from(self.xyz_m)),
            UnitQuaternion::from_euler_angles(r, p, y),
        )
    }

    /// Rejects non-finite entries; `what` names the field in errors.
    ///
    /// # Errors
    /// [`Error::Input`] naming `what`.
    pub fn validate(&self, what: &str) -> Result<()> {
        if self.xyz_m.iter().chain(&self.rpy_deg).all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(Error::input(what, "pose has a non-finite entry"))
        }
    }
}

/// Where the scan was taken from: the camera `S` mounted on the vehicle `C`, and the vehicle's
/// pose in the world `W` at the moment of the scan. The one place the chain
/// `t_world_scan = t_world_vehicle · t_vehicle_camera` is written.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScanFrames {
    /// The camera's pose in the vehicle frame, `t_vehicle_camera`. Default: 0.6 m forward of and
    /// 0.3 m below the centre of buoyancy, image x to starboard, optical axis pitched 60° below
    /// the vehicle's forward axis (looking down and forward under the hull).
    pub camera_in_vehicle: PoseConfig,
    /// The vehicle's pose in the world when the scan was taken, `t_world_vehicle`. Default: at
    /// the world origin, level, heading north.
    pub vehicle_in_world: PoseConfig,
}

impl Default for ScanFrames {
    fn default() -> Self {
        ScanFrames {
            camera_in_vehicle: PoseConfig {
                xyz_m: [0.6, 0.0, 0.3],
                rpy_deg: [30.0, 0.0, 90.0],
            },
            vehicle_in_world: PoseConfig::default(),
        }
    }
}

impl ScanFrames {
    /// `t_world_scan`: maps scan (camera) coordinates into the world frame.
    pub fn t_world_scan(&self) -> Pose {
        self.vehicle_in_world.pose() * self.camera_in_vehicle.pose()
    }

    /// The unit vector opposite to gravity ("up", `-z_W`) in the scan frame.
    pub fn up_in_scan(&self) -> Vector3<f64> {
        self.t_world_scan().inverse_transform_vector(&-Vector3::z())
    }

    /// Rejects non-finite entries.
    ///
    /// # Errors
    /// [`Error::Input`] naming the field.
    pub fn validate(&self) -> Result<()> {
        self.camera_in_vehicle.validate("frames.camera_in_vehicle")?;
        self.vehicle_in_world.validate("frames.vehicle_in_world")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    #[test]
    fn rows_round_trip() {
        let p = Isometry3::new(Vector3::new(0.1, -0.2, 1.0), Vector3::new(0.3, -0.5, 0.2));
        let back = pose_from_rows(&pose_to_rows(&p), "t").unwrap();
        assert!((back.to_homogeneous() - p.to_homogeneous()).abs().max() < 1e-12);
        assert_eq!(pose_error(&back, &p).1, 0.0);
    }

    #[test]
    fn default_camera_looks_down_and_forward() {
        let t = ScanFrames::default().t_world_scan();
        // Image x to starboard (east when heading north), optical axis forward and down (z_W > 0)
        // at 60° below the horizontal.
        let x = t * Vector3::x();
        let z = t * Vector3::z();
        assert!((x - Vector3::y()).norm() < 1e-12, "{x}");
        let expect = Vector3::new(30f64.to_radians().sin(), 0.0, 60f64.to_radians().sin());
        assert!((z - expect).norm() < 1e-12, "{z}");
        assert!((t.translation.vector - Vector3::new(0.6, 0.0, 0.3)).norm() < 1e-12);
        let up = ScanFrames::default().up_in_scan();
        assert!((t * up + Vector3::z()).norm() < 1e-12);
    }

    #[test]
    fn rpy_is_zyx() {
        let p = PoseConfig {
            xyz_m: [1.0, 2.0, 3.0],
            rpy_deg: [10.0, 20.0, 30.0],
        };
        let [r, pi, y] = [10f64, 20.0, 30.0].map(f64::to_radians);
        let expect = Rotation3::from_axis_angle(&Vector3::z_axis(), y)
            * Rotation3::from_axis_angle(&Vector3::y_axis(), pi)
            * Rotation3::from_axis_angle(&Vector3::x_axis(), r);
        assert!(
            (p.pose().rotation.to_rotation_matrix().matrix() - expect.matrix())
                .abs()
                .max()
                < 1e-12
        );
        // Composition order: the vehicle pose applies after the mounting.
        let f = ScanFrames {
            camera_in_vehicle: p,
            vehicle_in_world: PoseConfig {
                xyz_m: [0.0, 0.0, 5.0],
                rpy_deg: [0.0, 0.0, 90.0],
            },
        };
        let w = f.t_world_scan() * Point3::origin();
        assert!((w.coords - Vector3::new(-2.0, 1.0, 8.0)).norm() < 1e-12, "{w}");
    }

    #[test]
    fn rejects_a_scaled_rotation() {
        let mut rows = pose_to_rows(&Pose::identity());
        rows[0][0] = 2.0;
        assert_eq!(pose_from_rows(&rows, "t").unwrap_err().exit_code(), 2);
        // A rotation rounded to four decimals is off by some 1e-5: the message says how far.
        let turned = pose_to_rows(&Isometry3::new(Vector3::zeros(), Vector3::new(0.3, -0.5, 0.2)));
        let rounded = turned.map(|row| row.map(|v| (v * 1e4).round() / 1e4));
        let e = pose_from_rows(&rounded, "t").unwrap_err().to_string();
        assert!(
            e.contains("off the identity by up to") && e.contains("e-5"),
            "{e}"
        );
    }

    /// Finite but past any scene: the errors against it would overflow (a ground truth 1e300 m
    /// away gave an infinite translation error, `null` in the summary).
    #[test]
    fn rejects_a_translation_past_any_scene() {
        let mut rows = pose_to_rows(&Pose::identity());
        rows[1][3] = -1e300;
        let e = pose_from_rows(&rows, "truth.json key t").unwrap_err();
        assert!(
            e.to_string().contains("translation is 1e300 m along an axis"),
            "{e}"
        );
        rows[1][3] = -9e5;
        assert!(pose_from_rows(&rows, "t").is_ok());
    }
}
