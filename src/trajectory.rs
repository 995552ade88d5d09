//! The tool trajectory handed from planning to the simulation: its type and its files.
//!
//! A [`Trajectory`] is a time series of tool poses in the world frame `W` (NED, z down, metres):
//! the tool-tip position, the orientation of the tool frame `G` (`z_G` into the surface, `x_G`
//! along the motion; the `X_G`, `Y_G` of the seed's eq. 18 are its first two columns), the unit
//! direction `k` of the desired force (eq. 13–16) and its magnitude, and flags: the phase
//! (approach, dwell, contact, retreat) and whether the point lies on the aligned reference mesh
//! because the scan had a hole there.
//!
//! # CSV format (`trajectory.csv`)
//! Comment lines start with `#` and state the frames and units; blank lines are ignored. The
//! first other line is the header, exactly
//! `t_s,x_m,y_m,z_m,qw,qx,qy,qz,kx,ky,kz,force_n,phase,fallback`, and every following line one
//! sample:
//!
//! | column | meaning |
//! | --- | --- |
//! | `t_s` | time from the start of the trajectory, s; ≥ 0 and strictly increasing |
//! | `x_m,y_m,z_m` | tool-tip position in `W`, m |
//! | `qw,qx,qy,qz` | unit quaternion: rotation of `G` in `W` (columns `x_G`, `y_G`, `z_G`) |
//! | `kx,ky,kz` | unit direction of the desired force in `W` (`k = z_G`) |
//! | `force_n` | desired force magnitude along `k`, N, ≥ 0 (0: position control only) |
//! | `phase` | `approach`, `dwell`, `contact` or `retreat`, in this order (each may be absent) |
//! | `fallback` | `1` if the point was projected onto the aligned reference mesh (a hole in the scan), else `0` |
//!
//! Numbers are written in the shortest form that reads back to the same value, so a trajectory
//! written and read again is the one written, bit for bit. Consecutive quaternions have a
//! non-negative dot product (no sign flips), so a reader can interpolate them directly.
//! [`Trajectory::read_csv`] validates every field and reports the line and column of the first
//! bad one (exit code 2).
//!
//! # PLY export (`trajectory.ply`)
//! A line set in the scan frame `S`, to view over the scan and its surfaces in CloudCompare,
//! MeshLab or Open3D: the path (white in
//! contact, yellow approach, orange dwell, cyan retreat, magenta where it lies on the reference
//! mesh) and, every few samples, the tool axes `x_G` (red), `y_G` (green), `z_G` (blue).

use crate::error::{Error, Result};
use crate::frames::{Pose, pose_from_rows, pose_to_rows};
use nalgebra::{Isometry3, Point3, Quaternion, SVector, Translation3, UnitQuaternion, Vector3};
use std::io::Write;
use std::path::Path;

/// The phase of the operation a sample belongs to, ordered as a trajectory goes through them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Phase {
    /// Moving from the stand-off towards the first contact point along `k`, no force demanded.
    Approach,
    /// Holding the first contact point while the force settles (the seed's advice for critical
    /// operations: start moving only once the desired force is established).
    Dwell,
    /// Moving along the surface in contact, at the tool speed.
    Contact,
    /// Leaving the surface along `-k` after the last contact point, no force demanded.
    Retreat,
}

impl Phase {
    /// Every phase, in the order a trajectory goes through them.
    pub const ALL: [Phase; 4] = [Phase::Approach, Phase::Dwell, Phase::Contact, Phase::Retreat];

    /// The phase's name in the CSV file.
    pub fn as_str(self) -> &'static str {
        match self {
            Phase::Approach => "approach",
            Phase::Dwell => "dwell",
            Phase::Contact => "contact",
            Phase::Retreat => "retreat",
        }
    }

    fn parse(s: &str) -> Option<Phase> {
        Phase::ALL.into_iter().find(|p| p.as_str() == s)
    }
}

/// One sample of a trajectory. Everything is in the world frame `W`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time from the start of the trajectory, s.
    pub t: f64,
    /// Tool-tip position, m.
    pub position: Point3<f64>,
    /// Rotation of the tool frame `G` in `W` (columns `x_G`, `y_G`, `z_G`).
    pub orientation: UnitQuaternion<f64>,
    /// Unit direction of the desired force (`z_G`).
    pub k: Vector3<f64>,
    /// Desired force magnitude along `k`, N.
    pub force: f64,
    /// The phase this sample belongs to.
    pub phase: Phase,
    /// True if the point lies on the aligned reference mesh (a hole in the scan).
    pub fallback: bool,
}

impl Sample {
    /// The tool's pose in `W`: its frame `G` at the tip.
    pub fn pose(&self) -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::from(self.position.coords), self.orientation)
    }

    /// The tool axes `x_G`, `y_G`, `z_G` in `W`.
    pub fn axes(&self) -> [Vector3<f64>; 3] {
        let r = self.orientation.to_rotation_matrix();
        [0, 1, 2].map(|c| r.matrix().column(c).into_owned())
    }
}

/// A tool trajectory: samples in time order, plus free-text notes kept as comments in the CSV.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trajectory {
    /// The samples, strictly increasing in time.
    pub samples: Vec<Sample>,
    /// One-line notes (the pattern, the source files...) written as `#` comments.
    pub notes: Vec<String>,
}

/// How the note of [`Trajectory::t_world_scan_note`] starts.
const T_WORLD_SCAN_NOTE: &str = "t_world_scan: ";

/// The CSV columns, in order.
pub const CSV_COLUMNS: [&str; 14] = [
    "t_s", "x_m", "y_m", "z_m", "qw", "qx", "qy", "qz", "kx", "ky", "kz", "force_n", "phase", "fallback",
];

/// How far from 1 the norm of a quaternion or of `k` may be in a file (it is then renormalised).
const UNIT_TOLERANCE: f64 = 1e-3;

const CSV_PREAMBLE: &str = "\
# uvms trajectory, format 1
# frame W: world, NED (x north, y east, z down); origin at the vehicle's stabilization point at t = 0; lengths in m
# t_s: time from the start, s; x_m,y_m,z_m: tool-tip position in W, m
# qw,qx,qy,qz: unit quaternion, rotation of the tool frame G in W (z_G into the surface, x_G along the motion)
# kx,ky,kz: unit direction of the desired force in W (k = z_G); force_n: desired force along k, N
# phase: approach | dwell | contact | retreat; fallback: 1 where the scan had a hole and the point lies on the aligned reference mesh
";

impl Trajectory {
    /// Total duration, s (0 for fewer than two samples).
    pub fn duration(&self) -> f64 {
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) => b.t - a.t,
            _ => 0.0,
        }
    }

    /// Length of the path travelled in contact, m: the sum of the distances between consecutive
    /// contact samples.
    pub fn contact_length(&self) -> f64 {
        self.samples
            .windows(2)
            .filter(|w| w[0].phase == Phase::Contact && w[1].phase == Phase::Contact)
            .map(|w| (w[1].position - w[0].position).norm())
            .sum()
    }

    /// The samples of one phase.
    pub fn phase(&self, phase: Phase) -> impl Iterator<Item = &Sample> {
        self.samples.iter().filter(move |s| s.phase == phase)
    }

    /// The desired state at time `t` (clamped to the trajectory's span): position, `k` and force
    /// interpolated linearly, orientation by slerp; phase and flags of the sample at or before
    /// `t`, except that the move towards a retreat sample is the retreat. `None` for an empty
    /// trajectory.
    pub fn sample_at(&self, t: f64) -> Option<Sample> {
        let first = self.samples.first()?;
        let i = self.samples.partition_point(|s| s.t <= t);
        if i == 0 {
            return Some(*first);
        }
        let a = &self.samples[i - 1];
        let Some(b) = self.samples.get(i) else {
            return Some(*a);
        };
        let u = ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0);
        Some(Sample {
            t,
            position: a.position + (b.position - a.position) * u,
            orientation: a.orientation.slerp(&b.orientation, u),
            k: a.k.lerp(&b.k, u).try_normalize(1e-12).unwrap_or(a.k),
            force: a.force + (b.force - a.force) * u,
            // The move towards a retreat sample is the retreat.
            phase: if b.phase == Phase::Retreat {
                b.phase
            } else {
                a.phase
            },
            fallback: a.fallback,
        })
    }

    /// The note recording the scan frame's pose in the world the trajectory was planned with.
    pub fn t_world_scan_note(t_world_scan: &Pose) -> String {
        format!(
            "{T_WORLD_SCAN_NOTE}{}",
            serde_json::to_string(&pose_to_rows(t_world_scan)).unwrap_or_default()
        )
    }

    /// The scan frame's pose in the world the trajectory was planned with, from its note
    /// ([`Trajectory::t_world_scan_note`]); `None` without one.
    ///
    /// # Errors
    /// [`Error::Input`] naming `origin` for a note that is not a rigid 4×4 pose.
    pub fn planned_t_world_scan(&self, origin: &str) -> Result<Option<Pose>> {
        let Some(rows) = self.notes.iter().find_map(|n| n.strip_prefix(T_WORLD_SCAN_NOTE)) else {
            return Ok(None);
        };
        let what = format!("{origin}: note '{}'", T_WORLD_SCAN_NOTE.trim_end());
        let rows: [[f64; 4]; 4] =
            serde_json::from_str(rows).map_err(|e| Error::input(&what, format!("not a 4×4 matrix: {e}")))?;
        pose_from_rows(&rows, &what).map(Some)
    }

    /// Writes the CSV file (module docs give the format).
    ///
    /// # Errors
    /// [`Error::Failed`] if the writer fails.
    pub fn write_csv(&self, w: &mut dyn Write) -> Result<()> {
        let io = |e: std::io::Error| Error::failed("write trajectory CSV", e);
        w.write_all(CSV_PREAMBLE.as_bytes()).map_err(io)?;
        for n in &self.notes {
            writeln!(w, "# {}", n.replace(['\n', '\r'], " ")).map_err(io)?;
        }
        writeln!(w, "{}", CSV_COLUMNS.join(",")).map_err(io)?;
        for s in &self.samples {
            let p = s.position;
            let q = s.orientation.quaternion();
            writeln!(
                w,
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                s.t,
                p.x,
                p.y,
                p.z,
                q.w,
                q.i,
                q.j,
                q.k,
                s.k.x,
                s.k.y,
                s.k.z,
                s.force,
                s.phase.as_str(),
                u8::from(s.fallback)
            )
            .map_err(io)?;
        }
        Ok(())
    }

    /// Reads and validates a trajectory CSV file.
    ///
    /// # Errors
    /// [`Error::Input`] naming the file, line and column of the first problem: unreadable file,
    /// wrong header, wrong number of columns, a value that is not a finite number, time not
    /// strictly increasing or negative, a quaternion or `k` that is not unit length, a negative
    /// force, an unknown phase or one out of order, a fallback flag other than 0 or 1, no samples.
    pub fn read_csv(path: &Path) -> Result<Trajectory> {
        let text = crate::config::read_text(path, "a trajectory CSV file")?;
        Self::from_csv_str(&text, &path.display().to_string())
    }

    /// Parses and validates trajectory CSV text; `origin` names it in errors.
    ///
    /// # Errors
    /// As [`Trajectory::read_csv`].
    pub fn from_csv_str(text: &str, origin: &str) -> Result<Trajectory> {
        let mut traj = Trajectory::default();
        let mut header_seen = false;
        for (i, raw) in text.lines().enumerate() {
            let line_no = i + 1;
            let line = raw.trim();
            if line.is_empty() {
                continue;
            }
            if let Some(c) = line.strip_prefix('#') {
                if !header_seen
                    && !CSV_PREAMBLE
                        .lines()
                        .any(|p| p.trim_start_matches("# ") == c.trim())
                {
                    traj.notes.push(c.trim().to_string());
                }
                continue;
            }
            if !header_seen {
                let names: Vec<&str> = line.split(',').map(str::trim).collect();
                if names != CSV_COLUMNS {
                    return Err(Error::input(
                        format!("{origin} line {line_no}"),
                        format!("expected the header {}", CSV_COLUMNS.join(",")),
                    ));
                }
                header_seen = true;
                continue;
            }
            let s = parse_row(line, &format!("{origin} line {line_no}"))?;
            if let Some(prev) = traj.samples.last() {
                if s.t <= prev.t {
                    return Err(Error::input(
                        format!("{origin} line {line_no} column 1 (t_s)"),
                        format!("time {} does not increase (previous {})", s.t, prev.t),
                    ));
                }
                if s.phase < prev.phase {
                    return Err(Error::input(
                        format!("{origin} line {line_no} column 13 (phase)"),
                        format!(
                            "{} after {}: the phases run approach, dwell, contact, retreat, in this order",
                            s.phase.as_str(),
                            prev.phase.as_str()
                        ),
                    ));
                }
            }
            traj.samples.push(s);
        }
        if !header_seen {
            return Err(Error::input(origin, "no header line; not a trajectory CSV file"));
        }
        if traj.samples.is_empty() {
            return Err(Error::input(origin, "holds no samples"));
        }
        Ok(traj)
    }

    /// Writes the PLY line set (module docs give the colours) in the frame `V`, given by
    /// `t_view_world` (the scan frame, to view over the scan's surfaces). Axes of length
    /// `axis_length` metres are drawn at every `axis_every`-th contact sample (none if 0).
    ///
    /// # Errors
    /// [`Error::Failed`] if the writer fails.
    pub fn write_ply(
        &self,
        w: &mut dyn Write,
        t_view_world: &Pose,
        axis_length: f64,
        axis_every: usize,
    ) -> Result<()> {
        let n = self.samples.len();
        let mut points: Vec<Point3<f64>> = self.samples.iter().map(|s| t_view_world * s.position).collect();
        let mut colors: Vec<[u8; 3]> = self
            .samples
            .iter()
            .map(|s| match (s.fallback, s.phase) {
                (true, _) => [255, 0, 255],
                (_, Phase::Approach) => [255, 220, 0],
                (_, Phase::Dwell) => [255, 128, 0],
                (_, Phase::Contact) => [255, 255, 255],
                (_, Phase::Retreat) => [0, 200, 255],
            })
            .collect();
        let mut edges: Vec<[u32; 2]> = (1..n).map(|i| [i as u32 - 1, i as u32]).collect();
        if axis_every > 0 {
            for s in self.phase(Phase::Contact).step_by(axis_every) {
                for (axis, color) in s.axes().iter().zip([[255, 0, 0], [0, 255, 0], [0, 0, 255]]) {
                    let base = points.len() as u32;
                    let base_point = t_view_world * s.position;
                    points.push(base_point);
                    points.push(base_point + t_view_world.rotation * axis * axis_length);
                    colors.extend([color, color]);
                    edges.push([base, base + 1]);
                }
            }
        }
        crate::io::ply::write_lines(w, &points, &colors, &edges)
    }
}

/// Parses one data row; `at` is "FILE line N".
fn parse_row(line: &str, at: &str) -> Result<Sample> {
    let fields: Vec<&str> = line.split(',').map(str::trim).collect();
    if fields.len() != CSV_COLUMNS.len() {
        return Err(Error::input(
            at,
            format!("expected {} columns, found {}", CSV_COLUMNS.len(), fields.len()),
        ));
    }
    let col = |c: usize| format!("{at} column {} ({})", c + 1, CSV_COLUMNS[c]);
    let num = |c: usize| -> Result<f64> {
        let v: f64 = fields[c]
            .parse()
            .map_err(|_| Error::input(col(c), format!("'{}' is not a number", fields[c])))?;
        if v.is_finite() {
            crate::config::within_max(v, || col(c))?;
            Ok(v)
        } else {
            Err(Error::input(col(c), format!("'{}' is not finite", fields[c])))
        }
    };
    let t = num(0)?;
    if t < 0.0 {
        return Err(Error::input(col(0), format!("time {t} is negative")));
    }
    let position = Point3::new(num(1)?, num(2)?, num(3)?);
    let q = Quaternion::new(num(4)?, num(5)?, num(6)?, num(7)?);
    if (q.norm() - 1.0).abs() > UNIT_TOLERANCE {
        return Err(Error::input(
            col(4),
            format!("quaternion norm {:.6} is not 1", q.norm()),
        ));
    }
    let k = Vector3::new(num(8)?, num(9)?, num(10)?);
    if (k.norm() - 1.0).abs() > UNIT_TOLERANCE {
        return Err(Error::input(col(8), format!("k has norm {:.6}, not 1", k.norm())));
    }
    let force = num(11)?;
    if force < 0.0 {
        return Err(Error::input(col(11), format!("force {force} is negative")));
    }
    let phase = Phase::parse(fields[12]).ok_or_else(|| {
        Error::input(
            col(12),
            format!("'{}' is not one of approach, dwell, contact, retreat", fields[12]),
        )
    })?;
    let fallback = match fields[13] {
        "0" => false,
        "1" => true,
        other => return Err(Error::input(col(13), format!("'{other}' is not 0 or 1"))),
    };
    let orientation = UnitQuaternion::new_unchecked(unit(q.coords).into());
    let k = unit(k);
    // `k = z_G`: the force is pressed along the tool's own axis.
    let z_g = orientation * Vector3::z();
    if (k - z_g).norm() > UNIT_TOLERANCE {
        return Err(Error::input(
            col(8),
            format!(
                "k is {:.3}° from the tool's z axis (the quaternion's z_G), where it must be z_G",
                k.angle(&z_g).to_degrees()
            ),
        ));
    }
    Ok(Sample {
        t,
        position,
        orientation,
        k,
        force,
        phase,
        fallback,
    })
}

/// `v` scaled to unit length, unless it is unit within 1e-12 already (a unit vector's rounding,
/// some ε): a unit vector written and read back is the one written, bit for bit.
fn unit<const N: usize>(v: SVector<f64, N>) -> SVector<f64, N> {
    if (v.norm_squared() - 1.0).abs() <= 1e-12 {
        v
    } else {
        v.normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn demo() -> Trajectory {
        let samples = (0..5)
            .map(|i| {
                let q = UnitQuaternion::from_euler_angles(0.1 * i as f64, -0.2, 0.3);
                Sample {
                    t: 0.05 * i as f64,
                    position: Point3::new(0.001 * i as f64, 0.5, 1.25),
                    orientation: q,
                    k: q * Vector3::z(),
                    force: if i == 0 { 0.0 } else { 60.0 },
                    phase: if i == 0 { Phase::Approach } else { Phase::Contact },
                    fallback: i == 3,
                }
            })
            .collect();
        Trajectory {
            samples,
            notes: vec!["pattern ring".into()],
        }
    }

    fn csv(t: &Trajectory) -> String {
        let mut buf = Vec::new();
        t.write_csv(&mut buf).unwrap();
        String::from_utf8(buf).unwrap()
    }

    #[test]
    fn csv_round_trip() {
        let t = demo();
        let back = Trajectory::from_csv_str(&csv(&t), "t.csv").unwrap();
        assert_eq!(back.notes, t.notes);
        assert_eq!(back.samples.len(), t.samples.len());
        // Bit for bit: the shortest round-trip numbers, unit vectors kept as written.
        for (a, b) in t.samples.iter().zip(&back.samples) {
            assert_eq!((a.t, a.position, a.orientation), (b.t, b.position, b.orientation));
            assert_eq!(
                (a.k, a.force, a.phase, a.fallback),
                (b.k, b.force, b.phase, b.fallback)
            );
        }
        // A quaternion and a k off unit length within the tolerance are scaled to unit length.
        let (text, _) = edited(0, |c, v| match c {
            4..=10 => (v.parse::<f64>().unwrap() * 1.0002).to_string(),
            _ => v.to_string(),
        });
        let back = Trajectory::from_csv_str(&text, "t.csv").unwrap();
        let b = &back.samples[0];
        assert!((b.orientation.quaternion().norm() - 1.0).abs() < 1e-15);
        assert!((b.k.norm() - 1.0).abs() < 1e-15);
        assert!(b.orientation.angle_to(&t.samples[0].orientation) < 1e-12);
        assert!((t.contact_length() - 0.003).abs() < 1e-12);
        assert!((t.duration() - 0.2).abs() < 1e-12);
    }

    /// Replaces field `col` (0-based) of data row `row` (0-based) and returns the error message.
    fn corrupt(row: usize, col: usize, value: &str) -> String {
        corrupt_fields(row, &[(col, value.to_string())])
    }

    /// As [`corrupt`], several fields of the row.
    fn corrupt_fields(row: usize, values: &[(usize, String)]) -> String {
        let (text, line_no) = edited(row, |c, v| {
            values
                .iter()
                .find(|(col, _)| *col == c)
                .map_or_else(|| v.to_string(), |(_, value)| value.clone())
        });
        let err = Trajectory::from_csv_str(&text, "t.csv").unwrap_err();
        assert_eq!(err.exit_code(), 2);
        let msg = err.to_string();
        assert!(msg.contains(&format!("t.csv line {line_no}")), "{msg}");
        msg
    }

    /// The demo's CSV with data row `row` (0-based) edited field by field (`edit(column,
    /// value)`), and that row's line number.
    fn edited(row: usize, edit: impl Fn(usize, &str) -> String) -> (String, usize) {
        let mut lines: Vec<String> = csv(&demo()).lines().map(String::from).collect();
        let i = lines.iter().position(|l| l.starts_with("t_s")).unwrap() + 1 + row;
        let fields: Vec<String> = lines[i].split(',').enumerate().map(|(c, v)| edit(c, v)).collect();
        lines[i] = fields.join(",");
        (lines.join("\n"), i + 1)
    }

    #[test]
    fn reader_names_line_and_column() {
        assert!(corrupt(1, 2, "abc").contains("column 3 (y_m): 'abc' is not a number"));
        assert!(corrupt(1, 3, "inf").contains("column 4 (z_m)"));
        assert!(corrupt(2, 0, "0.01").contains("does not increase"));
        assert!(corrupt(0, 0, "-1").contains("negative"));
        assert!(corrupt(2, 4, "0.5").contains("column 5 (qw)"));
        assert!(corrupt(2, 8, "2").contains("column 9 (kx)"));
        // A unit k 0.01 rad off the tool's axis.
        let k = demo().samples[2].k;
        let tilted = UnitQuaternion::from_scaled_axis(k.cross(&Vector3::x()).normalize() * 0.01) * k;
        let fields: Vec<(usize, String)> = (0..3).map(|i| (8 + i, tilted[i].to_string())).collect();
        let msg = corrupt_fields(2, &fields);
        assert!(
            msg.contains("column 9 (kx): k is 0.573° from the tool's z axis"),
            "{msg}"
        );
        assert!(corrupt(2, 11, "-3").contains("column 12 (force_n)"));
        assert!(corrupt(2, 11, "1e300").contains("column 12 (force_n): 1e300 is beyond"));
        assert!(corrupt(3, 12, "hover").contains("column 13 (phase)"));
        // A phase out of order (it ran: a retreat amid the contact).
        assert!(corrupt(2, 12, "approach").contains("column 13 (phase): approach after contact"));
        assert!(corrupt(3, 13, "yes").contains("column 14 (fallback)"));
    }

    #[test]
    fn reader_rejects_bad_shapes() {
        let text = csv(&demo());
        let no_header = text.replace("t_s,x_m", "time,x_m");
        assert!(
            Trajectory::from_csv_str(&no_header, "t.csv")
                .unwrap_err()
                .to_string()
                .contains("header")
        );
        let short = format!("{text}1.0,2,3\n");
        assert!(
            Trajectory::from_csv_str(&short, "t.csv")
                .unwrap_err()
                .to_string()
                .contains("expected 14 columns")
        );
        let empty: String = text
            .lines()
            .filter(|l| l.starts_with('#') || l.starts_with("t_s"))
            .collect::<Vec<_>>()
            .join("\n");
        assert!(
            Trajectory::from_csv_str(&empty, "t.csv")
                .unwrap_err()
                .to_string()
                .contains("no samples")
        );
        assert_eq!(Trajectory::from_csv_str("", "t.csv").unwrap_err().exit_code(), 2);
        let missing = Trajectory::read_csv(Path::new("/nonexistent/t.csv")).unwrap_err();
        assert_eq!(missing.exit_code(), 2);
    }

    #[test]
    fn sample_at_interpolates() {
        let t = demo();
        let s = t.sample_at(0.075).unwrap();
        let (a, b) = (&t.samples[1], &t.samples[2]);
        assert!((s.position - Point3::from((a.position.coords + b.position.coords) / 2.0)).norm() < 1e-12);
        let half = a.orientation.angle_to(&b.orientation) / 2.0;
        assert!((s.orientation.angle_to(&a.orientation) - half).abs() < 1e-9);
        assert_eq!(t.sample_at(-1.0).unwrap(), t.samples[0]);
        assert_eq!(t.sample_at(9.0).unwrap(), t.samples[4]);
        assert!(Trajectory::default().sample_at(0.0).is_none());
        // Between two samples the phase is the earlier's, but the move towards a retreat sample
        // is the retreat (the force loop lets go as the tool leaves the last point).
        assert_eq!(s.phase, Phase::Contact);
        let mut t = demo();
        t.samples[4].phase = Phase::Retreat;
        assert_eq!(t.sample_at(0.175).unwrap().phase, Phase::Retreat);
        assert_eq!(t.sample_at(0.125).unwrap().phase, Phase::Contact);
    }

    #[test]
    fn ply_has_path_and_axes() {
        let mut buf = Vec::new();
        // Written in a view frame (the scan's) turned and moved from the world.
        let view = Isometry3::new(Vector3::new(0.1, -0.2, 0.3), Vector3::new(0.2, 0.1, -0.3));
        demo().write_ply(&mut buf, &view, 0.02, 2).unwrap();
        let text = String::from_utf8_lossy(&buf);
        // 5 path vertices + 2 axis frames (contact samples 1 and 3) × 3 axes × 2 vertices.
        assert!(text.contains("element vertex 17\n"), "{text}");
        assert!(text.contains("element edge 10\n"));
        let header_len = text.find("end_header\n").unwrap() + "end_header\n".len();
        assert_eq!(buf.len(), header_len + 17 * 27 + 10 * 8);
        // The crate's own reader walks past the edge element and returns the vertices.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.ply");
        std::fs::write(&path, &buf).unwrap();
        let (cloud, info) = crate::io::ply::read_cloud(&path).unwrap();
        assert_eq!(cloud.len(), 17);
        assert!(info.has_colors);
        let t = demo();
        assert!((cloud.points[2] - view * t.samples[2].position).norm() < 1e-12);
        // The z axis of the first drawn frame (contact sample 1) ends 2 cm along k.
        let tip = cloud.points[5 + 5];
        assert!((tip - view * (t.samples[1].position + t.samples[1].k * 0.02)).norm() < 1e-12);
        assert_eq!(cloud.colors.unwrap()[10], [0, 0, 255]);
    }
}
