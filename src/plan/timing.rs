//! Timing: uniform resampling at the tool speed, the orientation-rate limit, and the approach,
//! dwell and retreat segments.
//!
//! The projected path is resampled at a uniform straight-line spacing between consecutive
//! samples, the one nearest to `speed · sample_period` that ends on the path's end, and timed at
//! exactly the tool speed.
//! Where consecutive tool frames differ by more than `max_rate · Δt`, that step is stretched in
//! time to `angle / max_rate` (the tool slows down; spacing stays uniform). Before the path, the
//! tool approaches the first point along `k` from a stand-off at the (lower) approach speed, so
//! that contact builds up without chattering (the seed: "the tool's approach speed should be
//! maintained as relatively low"); it may then dwell there until the force has settled (the
//! seed's advice for critical operations); after the last point it retreats along `-k`. No force
//! is demanded during the approach and the retreat.

use super::project::{MAX_COUNT, PathPoint, bounded_count};
use crate::config::{non_negative, positive, shown};
use crate::error::{Error, Result};
use crate::trajectory::{Phase, Sample};
use nalgebra::UnitQuaternion;
use serde::{Deserialize, Serialize};

/// Settings of the timing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TimingConfig {
    /// Tool speed along the path in contact, m/s.
    pub speed_m_s: f64,
    /// Nominal time between samples, s (the spacing is `speed · sample_period`).
    pub sample_period_s: f64,
    /// Distance from the surface where the approach starts and the retreat ends, metres.
    pub standoff_m: f64,
    /// Speed of the approach along `k`, m/s.
    pub approach_speed_m_s: f64,
    /// Time to hold the first point before moving, s (0: no dwell).
    pub dwell_s: f64,
    /// Time over which the force set-point rises linearly from zero to the first point's
    /// force at the start of the dwell, s (0: a step). A softer touch: the vehicle turns
    /// under the arm's growing reaction slowly enough for the trajectory correction to follow.
    pub force_ramp_s: f64,
    /// Time over which the tool speeds up at a constant rate from rest to `speed_m_s` at the
    /// path's start, and slows down to rest at its end, s (0: the speed steps). On a path too
    /// short for both at that acceleration the tool speeds up over its first half and slows
    /// down over its second.
    pub accel_s: f64,
    /// Speed of the retreat along `-k`, m/s.
    pub retreat_speed_m_s: f64,
}

impl Default for TimingConfig {
    fn default() -> Self {
        TimingConfig {
            speed_m_s: 0.02,
            sample_period_s: 0.05,
            standoff_m: 0.05,
            approach_speed_m_s: 0.005,
            dwell_s: 0.0,
            force_ramp_s: 0.0,
            accel_s: 0.5,
            retreat_speed_m_s: 0.01,
        }
    }
}

impl TimingConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`] naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        positive("timing.speed_m_s", self.speed_m_s)?;
        positive("timing.sample_period_s", self.sample_period_s)?;
        non_negative("timing.standoff_m", self.standoff_m)?;
        positive("timing.approach_speed_m_s", self.approach_speed_m_s)?;
        non_negative("timing.dwell_s", self.dwell_s)?;
        non_negative("timing.force_ramp_s", self.force_ramp_s)?;
        non_negative("timing.accel_s", self.accel_s)?;
        crate::config::require(
            self.accel_s <= 3600.0,
            "timing.accel_s",
            format!("must be at most an hour, 3600 s, got {:e}", self.accel_s),
        )?;
        if self.force_ramp_s > self.dwell_s {
            return Err(Error::input(
                "timing.force_ramp_s",
                "must not be longer than dwell_s, the first point's hold (the force rises while it is held)",
            ));
        }
        positive("timing.retreat_speed_m_s", self.retreat_speed_m_s)?;
        // Each phase's samples, named by what sets its length; the sample period is the
        // other factor of each count.
        let standoff = |key: &str, speed: f64| {
            let set_by = format!(
                "timing.standoff_m {} m at timing.{key} {} m/s",
                shown(self.standoff_m),
                shown(speed)
            );
            (set_by, self.standoff_m / speed)
        };
        let phases = [
            (
                "the approach",
                standoff("approach_speed_m_s", self.approach_speed_m_s),
            ),
            (
                "the retreat",
                standoff("retreat_speed_m_s", self.retreat_speed_m_s),
            ),
            (
                "the dwell",
                (format!("timing.dwell_s {}", shown(self.dwell_s)), self.dwell_s),
            ),
        ];
        for (phase, (set_by, seconds)) in phases {
            let context = format!(
                "{phase} ({set_by}) at {} s a sample ",
                shown(self.sample_period_s)
            );
            bounded_count("timing.sample_period_s", seconds, self.sample_period_s, &context)?;
        }
        if self.spacing() < 1e-6 {
            return Err(Error::input(
                "timing.sample_period_s",
                format!(
                    "times timing.speed_m_s {} m/s places the samples {:.3e} m apart: at least 1 µm",
                    shown(self.speed_m_s),
                    self.spacing()
                ),
            ));
        }
        Ok(())
    }

    /// The nominal distance between samples in contact, metres.
    pub fn spacing(&self) -> f64 {
        self.speed_m_s * self.sample_period_s
    }
}

/// Resamples a path at a uniform straight-line (chord) spacing, so that the tool moves exactly
/// the same distance in every sample period. Each sample is the first point of the path, going
/// forward, at distance `h` from the previous one; `h` is the spacing nearest to `spacing` that
/// makes a whole number of steps end on the path's last point. Returns the samples (both ends
/// kept) and `h`.
///
/// # Errors
/// [`Error::Failed`] for a path of fewer than two points; [`Error::Input`] (naming
/// `timing.speed_m_s`) if the path is shorter than half a spacing.
pub fn resample(points: &[PathPoint], spacing: f64) -> Result<(Vec<PathPoint>, f64)> {
    // (A fold from +0: an empty sum of floats is −0.)
    let length = points
        .windows(2)
        .fold(0.0, |sum, w| sum + (w[1].point - w[0].point).norm());
    if points.len() < 2 {
        return Err(Error::failed(
            "plan",
            "the projected path has fewer than two points",
        ));
    }
    if length < spacing / 2.0 {
        return Err(Error::input(
            "timing.speed_m_s",
            format!(
                "the projected path is {:.1} mm long, shorter than half the samples' spacing of {} mm (speed_m_s times sample_period_s): lower either, or lengthen the pattern",
                length * 1e3,
                shown(spacing * 1e3)
            ),
        ));
    }
    if length / spacing > MAX_COUNT {
        return Err(Error::failed(
            "plan",
            format!(
                "the path ({} m) would need more than {MAX_COUNT:.0e} samples at {} m; raise timing.sample_period_s",
                shown(length),
                shown(spacing)
            ),
        ));
    }
    let n = ((length / spacing).round() as usize).max(1);
    // Where the n-th step ends, as arc length along the path; past the end when the path runs
    // out first (then by the steps still missing). Increasing in h; solved for the path's length
    // by regula falsi (Illinois), which converges in a handful of walks.
    let mut cum = Vec::with_capacity(points.len());
    let mut acc = 0.0;
    for (i, p) in points.iter().enumerate() {
        if i > 0 {
            acc += (p.point - points[i - 1].point).norm();
        }
        cum.push(acc);
    }
    let reach = |h: f64| {
        let w = chord_walk(points, h, n + 1);
        match w.get(n) {
            Some(&(j, u)) => cum[j] + u * (cum[j + 1] - cum[j]),
            None => length + (n + 1 - w.len()) as f64 * h,
        }
    };
    let (mut lo, mut hi) = (0.5 * length / n as f64, 1.5 * length / n as f64);
    while reach(lo) > length && lo > 1e-12 {
        lo *= 0.5;
    }
    while reach(hi) < length && hi < length {
        hi *= 2.0;
    }
    let (mut f_lo, mut f_hi) = (reach(lo) - length, reach(hi) - length);
    let mut side = 0;
    for _ in 0..200 {
        if hi - lo <= 1e-15 * hi || f_lo == 0.0 {
            break;
        }
        let mid = if f_hi > f_lo {
            lo - f_lo * (hi - lo) / (f_hi - f_lo)
        } else {
            0.5 * (lo + hi)
        };
        let mid = if mid > lo && mid < hi {
            mid
        } else {
            0.5 * (lo + hi)
        };
        let f = reach(mid) - length;
        if f.abs() <= 1e-13 * length {
            lo = mid;
            break;
        }
        if f < 0.0 {
            (lo, f_lo) = (mid, f);
            if side == -1 {
                f_hi *= 0.5;
            }
            side = -1;
        } else {
            (hi, f_hi) = (mid, f);
            if side == 1 {
                f_lo *= 0.5;
            }
            side = 1;
        }
    }
    let steps = chord_walk(points, lo, n + 1);
    let mut out: Vec<PathPoint> = steps
        .iter()
        .map(|&(j, u)| points[j].lerp(&points[j + 1], u))
        .collect();
    // The last step ends within the solver's precision of the path's end: put it there.
    if let (Some(last), Some(end)) = (out.last_mut(), points.last()) {
        *last = *end;
    }
    Ok((out, lo))
}

/// Samples at chord distance `h` along the polyline, at most `max` of them, as (segment index,
/// fraction along it). The first sample is the polyline's start.
fn chord_walk(points: &[PathPoint], h: f64, max: usize) -> Vec<(usize, f64)> {
    let mut out = vec![(0usize, 0.0)];
    let (mut j, mut t) = (0usize, 0.0);
    let mut prev = points[0].point;
    let h2 = h * h;
    'samples: while out.len() < max {
        // Each segment starts inside the sphere of radius h about `prev`: the exit is the
        // larger root of |a + s d - prev|² = h².
        while j + 1 < points.len() {
            let (a, b) = (points[j].point, points[j + 1].point);
            let d = b - a;
            let f = a - prev;
            let qa = d.norm_squared();
            if qa > 0.0 {
                let qb = 2.0 * f.dot(&d);
                let disc = qb * qb - 4.0 * qa * (f.norm_squared() - h2);
                if disc >= 0.0 {
                    let r = (-qb + disc.sqrt()) / (2.0 * qa);
                    if r >= t && r <= 1.0 {
                        t = r;
                        prev = a + d * r;
                        out.push((j, r));
                        continue 'samples;
                    }
                }
            }
            j += 1;
            t = 0.0;
        }
        break;
    }
    out
}

/// Facts about the schedule for the summary.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ScheduleStats {
    /// Contact steps slowed down by the orientation-rate limit.
    pub rate_limited_steps: usize,
    /// Duration of the approach, s.
    pub approach_s: f64,
    /// Duration of the dwell, s.
    pub dwell_s: f64,
    /// Duration of the motion in contact, s.
    pub contact_s: f64,
    /// Duration of the retreat, s.
    pub retreat_s: f64,
}

/// Times the resampled path (`spacing` apart) with its tool orientations and adds the approach,
/// dwell and retreat. `max_rate` is in radians per second. Samples are in the path's frame.
pub fn schedule(
    path: &[PathPoint],
    orientations: &[UnitQuaternion<f64>],
    spacing: f64,
    cfg: &TimingConfig,
    max_rate: f64,
) -> (Vec<Sample>, ScheduleStats) {
    let mut stats = ScheduleStats::default();
    let (Some(first), Some(last)) = (path.first(), path.last()) else {
        return (Vec::new(), stats);
    };
    let (q0, q1) = (orientations[0], orientations[orientations.len() - 1]);
    let k0 = q0 * nalgebra::Vector3::z();
    let k1 = q1 * nalgebra::Vector3::z();
    let sample = |t, p: &PathPoint, q: UnitQuaternion<f64>, force, phase| Sample {
        t,
        position: p.point,
        orientation: q,
        k: q * nalgebra::Vector3::z(),
        force,
        phase,
        fallback: p.fallback,
    };
    let mut out = Vec::new();
    // Approach: from the stand-off along k (outside the surface) up to the first point.
    let steps = |length: f64, speed: f64| ((length / (speed * cfg.sample_period_s)).ceil() as usize).max(1);
    // When each of the `n` equal steps of a straight move along `k` ends.
    let move_time = |i: usize, n: usize, speed: f64| {
        time_along(
            cfg.standoff_m * i as f64 / n as f64,
            cfg.standoff_m,
            speed,
            cfg.accel_s,
        )
    };
    let mut t = 0.0;
    if cfg.standoff_m > 0.0 {
        let n = steps(cfg.standoff_m, cfg.approach_speed_m_s);
        for i in 0..n {
            let mut p = *first;
            p.point -= k0 * cfg.standoff_m * (1.0 - i as f64 / n as f64);
            out.push(sample(
                i as f64 * cfg.standoff_m / cfg.approach_speed_m_s / n as f64,
                &p,
                q0,
                0.0,
                Phase::Approach,
            ));
        }
        t = cfg.standoff_m / cfg.approach_speed_m_s;
        stats.approach_s = t;
    }
    if cfg.dwell_s > 0.0 {
        let n = ((cfg.dwell_s / cfg.sample_period_s).ceil() as usize).max(1);
        let dt = cfg.dwell_s / n as f64;
        for i in 0..n {
            let rise = if cfg.force_ramp_s > 0.0 {
                (i as f64 * dt / cfg.force_ramp_s).min(1.0)
            } else {
                1.0
            };
            out.push(sample(t, first, q0, first.force * rise, Phase::Dwell));
            t += dt;
        }
        stats.dwell_s = cfg.dwell_s;
    }
    let t_contact = t;
    let length = spacing * path.len().saturating_sub(1) as f64;
    let at = |i: usize| time_along(i as f64 * spacing, length, cfg.speed_m_s, cfg.accel_s);
    for (i, (p, q)) in path.iter().zip(orientations).enumerate() {
        if i > 0 {
            let dt = at(i) - at(i - 1);
            let turn = orientations[i - 1].angle_to(q) / max_rate;
            if turn > dt {
                stats.rate_limited_steps += 1;
            }
            t += dt.max(turn);
        }
        out.push(sample(t, p, *q, p.force, Phase::Contact));
    }
    stats.contact_s = t - t_contact;
    if cfg.standoff_m > 0.0 {
        let n = steps(cfg.standoff_m, cfg.retreat_speed_m_s);
        for i in 1..=n {
            let mut p = *last;
            p.point -= k1 * cfg.standoff_m * (i as f64 / n as f64);
            out.push(sample(
                t + move_time(i, n, cfg.retreat_speed_m_s),
                &p,
                q1,
                0.0,
                Phase::Retreat,
            ));
        }
        stats.retreat_s = move_time(n, n, cfg.retreat_speed_m_s);
    }
    (out, stats)
}

/// When a tool moving `length` metres at `speed` with the speed-up and slow-down of `accel_s`
/// seconds (constant acceleration `speed / accel_s`) is `s` along: `s / speed` plus half the
/// speed-up in the middle, `√(2 s / a)` while speeding up, symmetric while slowing down.
fn time_along(s: f64, length: f64, speed: f64, accel_s: f64) -> f64 {
    if accel_s <= 0.0 {
        return s / speed;
    }
    let a = speed / accel_s;
    // The distance of each speed change, at most half the path (a triangle profile).
    let ramp = (0.5 * speed * accel_s).min(0.5 * length);
    let ramp_t = (2.0 * ramp / a).sqrt();
    let total = 2.0 * ramp_t + (length - 2.0 * ramp) / speed;
    if s <= ramp {
        (2.0 * s / a).sqrt()
    } else if s >= length - ramp {
        total - (2.0 * (length - s).max(0.0) / a).sqrt()
    } else {
        ramp_t + (s - ramp) / speed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point3, Vector3};

    /// A count of samples too large names the sample period, with the values that set it (a
    /// microscopic period was blamed on `standoff_m`, a microscopic speed on the period alone).
    #[test]
    fn too_many_samples_name_the_period_and_what_sets_the_phase() {
        let refused = |set: fn(&mut TimingConfig)| {
            let mut cfg = TimingConfig::default();
            set(&mut cfg);
            let err = cfg.validate().unwrap_err();
            assert_eq!(err.exit_code(), 2);
            err.to_string()
        };
        let msg = refused(|c| c.sample_period_s = 1e-9);
        assert!(
            msg.starts_with(
                "timing.sample_period_s: the approach (timing.standoff_m 0.05 m at timing.approach_speed_m_s"
            ),
            "{msg}"
        );
        let msg = refused(|c| c.dwell_s = 1e12);
        assert!(
            msg.contains("the dwell (timing.dwell_s 1e12) at 0.05 s a sample would need 2.000e13 steps"),
            "{msg}"
        );
        let msg = refused(|c| c.speed_m_s = 1e-9);
        assert!(
            msg.starts_with("timing.sample_period_s: times timing.speed_m_s 1e-9 m/s places the samples"),
            "{msg}"
        );
    }

    fn pp(x: f64, y: f64) -> PathPoint {
        PathPoint {
            point: Point3::new(x, y, 0.0),
            normal: Vector3::z(),
            fallback: false,
            tau: x,
            force: 60.0,
        }
    }

    #[test]
    fn resample_is_uniform_along_a_polyline() {
        // An L-shaped path 0.3 + 0.1005 m long with uneven input spacing.
        let mut pts: Vec<PathPoint> = [0.0, 0.01, 0.1, 0.25, 0.3].iter().map(|&x| pp(x, 0.0)).collect();
        pts.extend([0.03, 0.1005].iter().map(|&y| pp(0.3, y)));
        let (out, h) = resample(&pts, 0.0011).unwrap();
        assert_eq!(out.len(), 365); // 0.4005 / 0.0011 = 364.1 → 364 intervals
        // The step across the corner (no sample falls on it) spans more path than its chord h:
        // 363 h + (up to √2 h) = 0.4005.
        assert!(h < 0.4005 / 364.0 && h > 0.4005 / (363.0 + 2f64.sqrt()), "{h}");
        for w in out.windows(2) {
            let d = (w[1].point - w[0].point).norm();
            assert!((d - h).abs() < 1e-12, "{d} vs {h}");
        }
        assert_eq!(out[0].point, pts[0].point);
        assert_eq!(out[out.len() - 1].point, pts[pts.len() - 1].point);
        assert!(resample(&pts[..1], 0.001).is_err());
        // A spacing twice the path's length is the timing's bad input, named.
        let e = resample(&pts, 0.81).unwrap_err();
        assert_eq!(e.exit_code(), 2);
        assert!(e.to_string().contains("timing.speed_m_s"), "{e}");
    }

    #[test]
    fn schedule_speeds_and_rate_limit() {
        let cfg = TimingConfig {
            dwell_s: 1.0,
            accel_s: 0.0,
            ..TimingConfig::default()
        };
        let (path, h) = resample(&[pp(0.0, 0.0), pp(0.1, 0.0)], cfg.spacing()).unwrap();
        // Orientations turning 2° per sample over the middle of the path, else constant.
        let q: Vec<UnitQuaternion<f64>> = (0..path.len())
            .map(|i| {
                let turns = i.clamp(40, 60) - 40;
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), (2.0 * turns as f64).to_radians())
            })
            .collect();
        let max_rate = 30f64.to_radians();
        let (s, stats) = schedule(&path, &q, h, &cfg, max_rate);
        let contact: Vec<&Sample> = s.iter().filter(|x| x.phase == Phase::Contact).collect();
        assert_eq!(contact.len(), 101);
        assert_eq!(stats.rate_limited_steps, 20);
        for w in contact.windows(2) {
            let dt = w[1].t - w[0].t;
            let rate = w[0].orientation.angle_to(&w[1].orientation) / dt;
            assert!(rate <= max_rate * (1.0 + 1e-9));
            let v = (w[1].position - w[0].position).norm() / dt;
            if w[0].orientation == w[1].orientation {
                assert!((v - 0.02).abs() < 1e-12, "{v}");
            }
        }
        // 2° at 30°/s takes 1/15 s instead of 0.05 s.
        assert!((stats.contact_s - (80.0 * 0.05 + 20.0 / 15.0)).abs() < 1e-9);
        // Approach: 0.05 m at 5 mm/s, starting 0.05 m back along -k (k = z here: above the path).
        assert!((stats.approach_s - 10.0).abs() < 1e-9);
        assert!((s[0].position - Point3::new(0.0, 0.0, -0.05)).norm() < 1e-12);
        assert_eq!(s[0].force, 0.0);
        let dwell: Vec<&Sample> = s.iter().filter(|x| x.phase == Phase::Dwell).collect();
        assert_eq!(dwell.len(), 20);
        assert!(
            dwell
                .iter()
                .all(|d| d.position == path[0].point && d.force == 60.0)
        );
        let last = s.last().unwrap();
        assert_eq!(last.phase, Phase::Retreat);
        assert!((last.position - Point3::new(0.1, 0.0, -0.05)).norm() < 1e-12);
        assert!((s.last().unwrap().t - (10.0 + 1.0 + stats.contact_s + 5.0)).abs() < 1e-9);
        assert!(s.windows(2).all(|w| w[1].t > w[0].t));
    }

    /// The speed-up and slow-down: constant acceleration from rest to the speed over `accel_s`,
    /// the time along the path continuous, `accel_s` more than at constant speed; on a short
    /// path a triangle whose top stays below the speed.
    #[test]
    fn time_along_speeds_up_and_slows_down() {
        let (v, ta, length) = (0.02, 0.5, 0.1);
        let a = v / ta;
        let t = |s: f64| time_along(s, length, v, ta);
        assert_eq!(t(0.0), 0.0);
        assert!((t(length) - (length / v + ta)).abs() < 1e-12);
        // Speeding up: s = a t² / 2; at the end of it the speed, then constant.
        assert!((t(0.001) - (2.0 * 0.001 / a).sqrt()).abs() < 1e-12);
        let ramp = 0.5 * v * ta;
        assert!((t(ramp) - ta).abs() < 1e-12);
        let ds = 1e-7;
        for s in [ramp + 1e-3, 0.05, length - ramp - 1e-3] {
            assert!((ds / (t(s + ds) - t(s)) - v).abs() < 1e-6);
        }
        // Continuous and symmetric: the time to go the last s equals the time to go the first s.
        for s in [1e-4, ramp - 1e-9, ramp, 0.02] {
            assert!((t(length) - t(length - s) - t(s)).abs() < 1e-9, "{s}");
        }
        // A path shorter than both speed changes: a triangle, top speed √(a L) below v.
        let short = 0.004;
        let ts = |s: f64| time_along(s, short, v, ta);
        assert!((ts(short) - 2.0 * (short / a).sqrt()).abs() < 1e-12);
        let top = ds / (ts(0.5 * short + ds) - ts(0.5 * short));
        assert!((top - (a * short).sqrt()).abs() < 1e-5 && top < v, "{top}");
        // No speed-up: the speed at once.
        assert_eq!(time_along(0.05, length, v, 0.0), 0.05 / v);
    }

    /// With `accel_s` the contact path and the retreat start and end at rest and take `accel_s`
    /// longer; the approach keeps its speed (the tool meets the surface at the approach speed).
    #[test]
    fn schedule_speeds_up_from_rest() {
        let cfg = TimingConfig {
            accel_s: 0.5,
            ..TimingConfig::default()
        };
        let (path, h) = resample(&[pp(0.0, 0.0), pp(0.1, 0.0)], cfg.spacing()).unwrap();
        let q = vec![UnitQuaternion::identity(); path.len()];
        let (s, stats) = schedule(&path, &q, h, &cfg, 1.0);
        assert!((stats.contact_s - (0.1 / 0.02 + 0.5)).abs() < 1e-9);
        assert!((stats.retreat_s - (0.05 / 0.01 + 0.5)).abs() < 1e-9);
        assert!((stats.approach_s - 0.05 / 0.005).abs() < 1e-9);
        let speeds = |phase: Phase| -> Vec<f64> {
            s.windows(2)
                .filter(|w| w[0].phase == phase && w[1].phase == phase)
                .map(|w| (w[1].position - w[0].position).norm() / (w[1].t - w[0].t))
                .collect()
        };
        let contact = speeds(Phase::Contact);
        // The first and last steps' mean speeds: a step of h from rest takes √(2 h / a).
        let first = h / (2.0 * h / (0.02 / 0.5)).sqrt();
        assert!((contact[0] - first).abs() < 1e-9 && (contact[contact.len() - 1] - first).abs() < 1e-9);
        assert!((contact[contact.len() / 2] - 0.02).abs() < 1e-9);
        assert!(speeds(Phase::Approach).iter().all(|v| (v - 0.005).abs() < 1e-9));
        // The retreat's second step (its first between two retreat samples), 0.5 mm from 0.5 mm
        // out: 0.5 mm over √(2 · 1 mm / a) − √(2 · 0.5 mm / a), a = 0.02 m/s².
        let retreat = speeds(Phase::Retreat);
        let second = 5e-4 / ((2.0 * 1e-3 / 0.02f64).sqrt() - (2.0 * 5e-4 / 0.02f64).sqrt());
        assert!((retreat[0] - second).abs() < 1e-9, "{}", retreat[0]);
        assert!((retreat[retreat.len() / 2] - 0.01).abs() < 1e-9);
        assert!(s.windows(2).all(|w| w[1].t > w[0].t));
    }

    /// The force rises linearly over `force_ramp_s` of the dwell, then holds; a ramp longer
    /// than the dwell is an input error.
    #[test]
    fn force_ramps_up_over_the_dwell() {
        let cfg = TimingConfig {
            dwell_s: 1.0,
            force_ramp_s: 0.5,
            ..TimingConfig::default()
        };
        let (path, h) = resample(&[pp(0.0, 0.0), pp(0.1, 0.0)], cfg.spacing()).unwrap();
        let q = vec![UnitQuaternion::identity(); path.len()];
        let (s, _) = schedule(&path, &q, h, &cfg, 1.0);
        let dwell: Vec<&Sample> = s.iter().filter(|x| x.phase == Phase::Dwell).collect();
        let t0 = dwell[0].t;
        for d in &dwell {
            let expected = 60.0 * ((d.t - t0) / 0.5).min(1.0);
            assert!((d.force - expected).abs() < 1e-9, "{} at {}", d.force, d.t - t0);
        }
        assert!(
            s.iter()
                .filter(|x| x.phase == Phase::Contact)
                .all(|x| x.force == 60.0)
        );
        let too_long = TimingConfig {
            force_ramp_s: 1.5,
            ..cfg
        };
        assert!(too_long.validate().is_err());
    }
}
