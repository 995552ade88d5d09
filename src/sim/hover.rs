//! The hover point: where the vehicle should hold station so that its manipulator can follow
//! the whole trajectory.
//!
//! Candidates: the vehicle level, at headings every `yaw_step_deg`, on a grid of positions
//! around the trajectory's centroid (`horizontal_range_m` either way, heights from
//! `height_range_m` above it), never closer than `min_clearance_m` above the trajectory's
//! highest point. For each candidate and each inverse-kinematics branch at the first sample,
//! the branch is followed along the trajectory (every `stride`-th sample, then the analytic IK
//! nearest the previous solution); it reaches the trajectory if every sample has a solution
//! within the joint limits, no joint jumps by more than `max_joint_step_rad` between
//! samples (no flip of the wrist or elbow), every joint keeps `min_limit_margin_rad` inside its
//! limits (0 by default) and the wrist keeps `min_wrist_angle_rad` from its
//! singularity (`|q₅|`, on one side of it throughout: near it the wrist's rates grow as
//! `1/sin q₅` of the tool's turning, and a station whose ring passed 0.4 mrad from it took the
//! bottle's tool 10 mm off at 90 N). The vehicle must also hold the contact: at each
//! checked sample of the dwell and contact phases the tool is loaded with the planned force
//! (`force` along `k`) and the expected resistance to its motion (`drag_n` against `x_G`), and
//! the thrusters must cancel that force at the tool's lever, `[F; p × F]` in `C`, with the
//! hull's drag in the sea current the station is chosen for (`current_m_s`, the controllers'
//! model of the vehicle's damping; the arm's links add a few per cent); the largest
//! `|T_j|/T_max` of that allocation is the candidate's thrust utilisation (a horizontal drag
//! across the vehicle loads the roll axis, which only two vertical thrusters 2h apart
//! control; along it, the two surge thrusters and the pitch axis). The drives must hold it
//! too: the static joint torques that press the tool there with that force and carry the arm's
//! weight in water (the inverse dynamics at rest, the vehicle level), of which the largest
//! `|τ_i|/τ_max,i` is the candidate's drive utilisation. Its load is the larger of the two
//! utilisations, each as a fraction of its limit (`max_thrust_utilisation`,
//! `max_drive_utilisation`). Among the candidates that reach, those within both limits (load at
//! most 1) are preferred, and of them the one with the largest worst-case manipulability
//! `min |det J(q)|` (Yoshikawa, in closed form for the PUMA class) wins, the less loaded of two
//! within a millionth of each other (if none is within, the least loaded); a second, finer grid
//! around it refines the choice. No candidate reaching the whole trajectory is an error that
//! says how far the best got, and so is a winner whose thrusters or drives would need more than
//! they have (the least loaded when none is within the limits: no candidate can hold the
//! contact), or whose branch, followed through every sample of the trajectory, fails one
//! between those checked once the search has run again checking twice and four times as many.

use crate::arm::{Arm, BaseMotion, JointVector};
use crate::config::{non_negative, positive, require, shown, shown_to, shown_xyz};
use crate::error::{Error, Result};
use crate::multibody::Multibody;
use crate::spatial_algebra::{Force, Motion};
use crate::trajectory::{Phase, Trajectory};
use crate::vehicle::thrusters::Thrusters;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3, Vector6};
use serde::{Deserialize, Serialize};

/// Hover-point search (`[sim.hover]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HoverConfig {
    /// A fixed stabilisation position (world, m) instead of the search.
    pub position_m: Option<[f64; 3]>,
    /// The heading with `position_m`, degrees.
    pub yaw_deg: f64,
    /// Horizontal half-width of the search grid around the trajectory's centroid, m.
    pub horizontal_range_m: f64,
    /// Heights of the vehicle's origin above the centroid searched, [lowest, highest], m.
    pub height_range_m: [f64; 2],
    /// Grid step of the coarse search, m.
    pub step_m: f64,
    /// Heading step of the coarse search, degrees.
    pub yaw_step_deg: f64,
    /// Least height of the vehicle's origin above the trajectory's highest point, m.
    pub min_clearance_m: f64,
    /// Largest joint change between checked samples, rad.
    pub max_joint_step_rad: f64,
    /// Least distance of the wrist from its singularity (`|q₅|`) at the checked samples, rad.
    pub min_wrist_angle_rad: f64,
    /// Least distance of every joint from its limits at the checked samples, rad: room for the
    /// joint control to correct the vehicle's motion (0: the limits themselves).
    pub min_limit_margin_rad: f64,
    /// Samples checked: about this many, evenly spread (up to four times as
    /// many when the chosen station fails between them).
    pub samples: usize,
    /// Expected resistance to the tool's motion in contact (soil, friction), N.
    pub drag_n: f64,
    /// Largest thrust utilisation (`|T_j|/T_max`) the contact may take.
    pub max_thrust_utilisation: f64,
    /// Largest static drive utilisation (`|τ_i|/τ_max,i`) the contact may take: the rest is
    /// the joint control's, for the arm's accelerations and friction.
    pub max_drive_utilisation: f64,
    /// The sea current the station is chosen for (world, NED), m/s: the thrusters hold the
    /// hull's drag in it too. The controllers do not know the scenario's current; this is what
    /// the operator expects.
    pub current_m_s: [f64; 3],
}

impl Default for HoverConfig {
    fn default() -> Self {
        HoverConfig {
            position_m: None,
            yaw_deg: 0.0,
            horizontal_range_m: 0.6,
            height_range_m: [0.3, 1.2],
            step_m: 0.1,
            yaw_step_deg: 45.0,
            min_clearance_m: 0.45,
            max_joint_step_rad: 0.5,
            min_wrist_angle_rad: 0.1,
            min_limit_margin_rad: 0.0,
            samples: 60,
            drag_n: 0.0,
            max_thrust_utilisation: 0.5,
            max_drive_utilisation: 0.8,
            current_m_s: [0.0; 3],
        }
    }
}

impl HoverConfig {
    /// Checks the values.
    ///
    /// # Errors
    /// [`Error::Input`] naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        let [lo, hi] = self.height_range_m;
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(Error::input(
                "sim.hover.height_range_m",
                "must be [lowest, highest] with lowest ≤ highest",
            ));
        }
        positive("sim.hover.step_m", self.step_m)?;
        positive("sim.hover.yaw_step_deg", self.yaw_step_deg)?;
        positive("sim.hover.max_joint_step_rad", self.max_joint_step_rad)?;
        non_negative("sim.hover.horizontal_range_m", self.horizontal_range_m)?;
        non_negative("sim.hover.min_clearance_m", self.min_clearance_m)?;
        non_negative("sim.hover.min_wrist_angle_rad", self.min_wrist_angle_rad)?;
        require(
            self.min_wrist_angle_rad < std::f64::consts::FRAC_PI_2,
            "sim.hover.min_wrist_angle_rad",
            format!(
                "must be less than π/2 (the wrist's farthest from its singularity), got {}",
                shown(self.min_wrist_angle_rad)
            ),
        )?;
        non_negative("sim.hover.min_limit_margin_rad", self.min_limit_margin_rad)?;
        non_negative("sim.hover.drag_n", self.drag_n)?;
        for (key, value, of) in [
            (
                "sim.hover.max_thrust_utilisation",
                self.max_thrust_utilisation,
                "thrusters' thrust",
            ),
            (
                "sim.hover.max_drive_utilisation",
                self.max_drive_utilisation,
                "drives' torque",
            ),
        ] {
            positive(key, value)?;
            require(
                value <= 1.0,
                key,
                format!("must be at most 1 (a fraction of the {of}), got {}", shown(value)),
            )?;
        }
        super::check_current("sim.hover.current_m_s", self.current_m_s)?;
        if self.samples < 2 || self.samples > 100_000 {
            return Err(Error::input("sim.hover.samples", "must be between 2 and 100000"));
        }
        if let Some(p) = self.position_m
            && !p.iter().all(|v| v.is_finite())
        {
            return Err(Error::input("sim.hover.position_m", "must be finite"));
        }
        require(self.yaw_deg.is_finite(), "sim.hover.yaw_deg", "must be finite")?;
        // The coarse grid's candidates: positions across, heights, headings.
        let across = 2.0 * (self.horizontal_range_m / self.step_m).floor() + 1.0;
        let candidates = across * across * (((hi - lo) / self.step_m).floor() + 1.0) * self.headings() as f64;
        if candidates.is_nan() || candidates > MAX_CANDIDATES {
            return Err(Error::input(
                "sim.hover",
                format!(
                    "the search grid (horizontal_range_m, height_range_m, step_m, yaw_step_deg) has {candidates:.2e} candidates: at most {MAX_CANDIDATES:.0e}"
                ),
            ));
        }
        Ok(())
    }

    /// Headings of the coarse search: every `yaw_step_deg` around.
    fn headings(&self) -> i64 {
        (360.0 / self.yaw_step_deg).round().max(1.0) as i64
    }
}

/// The most candidates of the coarse search: 10⁶, some 70 times the default grid's.
const MAX_CANDIDATES: f64 = 1e6;

/// The chosen stabilisation pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hover {
    /// The vehicle's stabilisation pose, `t_world_body`.
    pub t_world_body: Isometry3<f64>,
    /// The arm's configuration at the trajectory's first sample.
    pub q_start: JointVector,
    /// The worst-case manipulability `min |det J|` along the trajectory.
    pub manipulability: f64,
    /// The largest thrust utilisation of holding the contact (see the module docs).
    pub thrust_utilisation: f64,
    /// The largest static drive utilisation of holding the contact.
    pub drive_utilisation: f64,
}

/// How far one candidate got.
struct Reach {
    q_start: JointVector,
    /// Checked samples reached before the first failure (all: the whole trajectory).
    reached: usize,
    manipulability: f64,
    /// The largest thrust utilisation of the contact over the reached samples.
    thrust: f64,
    /// The largest static drive utilisation over the reached samples, the joint (0-based) and
    /// its torque there, N·m.
    drive: (f64, usize, f64),
    /// Why it stopped short of the next checked sample (`None`: it did not, or it was given up
    /// as unable to beat the best).
    stop: Option<Stop>,
}

/// Manipulabilities within this fraction of each other are equal: the arm's first joint takes
/// up a turn of the vehicle about the vertical, so headings apart by a multiple of the search's
/// step reach the trajectory with the same manipulability but for round-off, and the load
/// decides between them.
const SAME_MANIPULABILITY: f64 = 1e-6;

impl Reach {
    /// The larger of the thrust and drive utilisations, each as a fraction of its limit in
    /// `cfg` (NaN counts as over every limit).
    fn load(&self, cfg: &HoverConfig) -> f64 {
        let load = (self.thrust / cfg.max_thrust_utilisation).max(self.drive.0 / cfg.max_drive_utilisation);
        if self.thrust.is_nan() || self.drive.0.is_nan() {
            f64::INFINITY
        } else {
            load
        }
    }

    /// Whether `self` is a better candidate than `other` (see the module docs): more samples
    /// reached; then within the limits; then, within them, the larger manipulability and on a
    /// tie the lower load, beyond them the lower load.
    fn beats(&self, other: &Reach, cfg: &HoverConfig) -> bool {
        let within = |r: &Reach| r.load(cfg) <= 1.0;
        if (self.reached, within(self)) != (other.reached, within(other)) {
            return (self.reached, within(self)) > (other.reached, within(other));
        }
        let tied = (self.manipulability - other.manipulability).abs()
            <= SAME_MANIPULABILITY * self.manipulability.max(other.manipulability);
        if within(self) && !tied {
            self.manipulability > other.manipulability
        } else {
            self.load(cfg) < other.load(cfg)
        }
    }

    /// Whether a branch at `self` (going on to all `n` samples) could still beat `bar`: its
    /// manipulability only falls and its load only grows as it goes on, so once it, reaching
    /// every sample as it is, does not beat a `bar` that reached every sample, following it
    /// further changes nothing.
    fn can_beat(&self, bar: Option<&Reach>, n: usize, cfg: &HoverConfig) -> bool {
        bar.is_none_or(|b| b.reached < n || Reach { reached: n, ..*self }.beats(b, cfg))
    }
}

/// The vehicle pose at `position`, level, heading `yaw`.
fn level_pose(position: Vector3<f64>, yaw: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(position),
        UnitQuaternion::from_euler_angles(0.0, 0.0, yaw),
    )
}

/// The thrust utilisation of holding the environment's force `f_env` (world) on the tool at
/// `tool` (world) and the water's drag `drag` on the hull (`C`) with the vehicle at
/// `t_world_body`.
fn utilisation(
    thrusters: &Thrusters,
    t_world_body: &Isometry3<f64>,
    tool: &Vector3<f64>,
    f_env: &Vector3<f64>,
    drag: &Force,
) -> f64 {
    let f = t_world_body.rotation.inverse() * f_env;
    let p = t_world_body.inverse_transform_point(&(*tool).into()).coords;
    let mut tau = Vector6::zeros();
    tau.fixed_rows_mut::<3>(0).copy_from(&-(f + drag.lin));
    tau.fixed_rows_mut::<3>(3).copy_from(&-(p.cross(&f) + drag.ang));
    thrusters.utilisation(&tau)
}

/// The largest static drive utilisation `|τ_i|/τ_max,i` at `q`, its joint and torque: the arm
/// at rest on a base at rest (`base`), the environment pressing on the tool with `f_env`
/// (base axes).
fn drive_load(arm: &Arm, q: &JointVector, base: &BaseMotion, f_env: &Vector3<f64>) -> (f64, usize, f64) {
    let zero = JointVector::zeros();
    let tau = arm
        .inverse_dynamics(q, &zero, &zero, base, Some(&Force::new(*f_env, Vector3::zeros())))
        .tau;
    (0..tau.len())
        .map(|i| (tau[i].abs() / arm.links[i].torque_limit, i, tau[i]))
        .fold((0.0, 0, 0.0), more_loaded)
}

/// The more loaded of two drive loads `(utilisation, joint, torque)`, a NaN utilisation
/// counting as the most.
fn more_loaded(a: (f64, usize, f64), b: (f64, usize, f64)) -> (f64, usize, f64) {
    if b.0 > a.0 || b.0.is_nan() { b } else { a }
}

/// What keeps a branch from `q`, if anything: its wrist past its singularity from the side
/// `side` (the sign of `q₅` it started with) or within `min_wrist_angle_rad` of it, or a joint
/// within `min_limit_margin_rad` of its limits (at 0, the IK's solutions are within the limits
/// up to its round-off).
fn blocked(arm: &Arm, q: &JointVector, side: f64, cfg: &HoverConfig) -> Option<Stop> {
    if q[4] * side <= 0.0 {
        return Some(Stop::Through);
    }
    if q[4].abs() < cfg.min_wrist_angle_rad {
        return Some(Stop::Near(q[4].abs()));
    }
    if cfg.min_limit_margin_rad > 0.0 {
        let (margin, joint) = arm.limit_margin(q);
        if margin < cfg.min_limit_margin_rad {
            return Some(Stop::NearLimit(margin, joint));
        }
    }
    None
}

/// Why a branch cannot go on to the next sample.
#[derive(Debug, Clone, Copy)]
enum Stop {
    /// No IK solution within the joint limits.
    OutOfReach,
    /// The nearest solution needs a joint to turn this far, rad.
    Jump(f64),
    /// The wrist would cross its singularity (`q₅` changes sign).
    Through,
    /// The wrist would come this near its singularity, rad.
    Near(f64),
    /// A joint (0-based) would come this near its limit, rad.
    NearLimit(f64, usize),
}

/// What stopped a branch at a sample, for a message: "the point … {text}".
fn stop_text(stop: Stop, cfg: &HoverConfig) -> String {
    match stop {
        Stop::OutOfReach => "is out of the arm's reach".to_string(),
        Stop::Jump(jump) => format!(
            "needs a joint to turn by {} rad from the sample before (sim.hover.max_joint_step_rad {})",
            shown_to(jump, 2),
            shown(cfg.max_joint_step_rad)
        ),
        Stop::Through => "takes the wrist through its singularity".to_string(),
        Stop::Near(q5) => format!(
            "brings the wrist within {} rad of its singularity (sim.hover.min_wrist_angle_rad {})",
            shown_to(q5, 3),
            shown(cfg.min_wrist_angle_rad)
        ),
        Stop::NearLimit(margin, joint) => format!(
            "brings joint {} within {} rad of its limit (sim.hover.min_limit_margin_rad {})",
            joint + 1,
            shown_to(margin, 3),
            shown(cfg.min_limit_margin_rad)
        ),
    }
}

/// The branch at `q`, its wrist on `side`, moved on to `target` (base frame): the IK solution
/// nearest `q`, unless it is out of reach, a joint jumps by more than `max_joint_step_rad`, the
/// wrist leaves `min_wrist_angle_rad` from its singularity on that side, or a joint
/// `min_limit_margin_rad` from its limits.
fn step(
    arm: &Arm,
    target: &Isometry3<f64>,
    q: &JointVector,
    side: f64,
    cfg: &HoverConfig,
) -> Result<std::result::Result<JointVector, Stop>> {
    let Some(next) = arm.ik_nearest(target, q)? else {
        return Ok(Err(Stop::OutOfReach));
    };
    let jump = (next - q).amax();
    if jump > cfg.max_joint_step_rad {
        return Ok(Err(Stop::Jump(jump)));
    }
    Ok(blocked(arm, &next, side, cfg).map_or(Ok(next), Err))
}

/// Follows the chosen station's branch from `q_start` through every sample of `trajectory`
/// (the search checked about `samples` of them), each a [`step`] from the last.
///
/// # Errors
/// [`Error::Failed`] (stage `hover`) naming the first sample that is not.
fn follow_every_sample(
    arm: &Arm,
    t_world_body: &Isometry3<f64>,
    q_start: &JointVector,
    trajectory: &Trajectory,
    cfg: &HoverConfig,
    samples: usize,
) -> Result<()> {
    let t_base_world = (t_world_body * arm.t_body_base()).inverse();
    let side = q_start[4].signum();
    let mut q = *q_start;
    for s in &trajectory.samples {
        let why = match step(arm, &(t_base_world * s.pose()), &q, side, cfg)? {
            Ok(next) => {
                q = next;
                continue;
            }
            Err(stop) => stop_text(stop, cfg),
        };
        return Err(Error::failed(
            "hover",
            format!(
                "the best station reaches the samples the search checks (about {}), but the point at t = {:.2} s between them ({} phase, at {} m) {why}: check more samples",
                if samples == cfg.samples {
                    format!("sim.hover.samples = {samples}")
                } else {
                    format!(
                        "{samples}: sim.hover.samples = {} doubled, each search's station missing a point between those it checked",
                        cfg.samples
                    )
                },
                s.t,
                s.phase.as_str(),
                shown_xyz(&s.position.coords.into(), 3)
            ),
        ));
    }
    Ok(())
}

/// Follows each IK branch of the first target along `targets` (world tool poses, with the
/// environment's expected force on the tool where it is pressed: none where it is free) for
/// the vehicle of `system` at `t_world_body`; the best branch. A branch is given up as soon as it cannot beat `bar` (the best candidate
/// so far).
fn follow(
    system: &Multibody,
    thrusters: &Thrusters,
    t_world_body: &Isometry3<f64>,
    targets: &[(Isometry3<f64>, Option<Vector3<f64>>)],
    cfg: &HoverConfig,
    bar: Option<&Reach>,
) -> Result<Option<Reach>> {
    let (arm, n) = (&system.arm, targets.len());
    let t_base_world = (t_world_body * arm.t_body_base()).inverse();
    if targets.is_empty() {
        return Ok(None);
    }
    // The targets in the base frame and the thrust utilisation of each are the same for every
    // branch.
    let in_base: Vec<Isometry3<f64>> = targets.iter().map(|(t, _)| t_base_world * t).collect();
    // Once a candidate has reached every sample, one with a sample out of the arm's reach
    // cannot beat it: no branch needs following.
    if bar.is_some_and(|b| b.reached == n) && !in_base.iter().all(|t| arm.within_reach(t)) {
        return Ok(None);
    }
    let starts = arm.ik(&in_base[0], &JointVector::zeros())?;
    if starts.is_empty() {
        return Ok(None);
    }
    // The hull at rest in the current moves through the water at minus the current.
    let against = t_world_body.rotation.inverse() * -Vector3::from(cfg.current_m_s);
    let drag = system
        .vehicle
        .drag_on_body(&Motion::new(against, Vector3::zeros()));
    let loads: Vec<f64> = targets
        .iter()
        .map(|(t, f)| {
            let f = f.unwrap_or_else(Vector3::zeros);
            utilisation(thrusters, t_world_body, &t.translation.vector, &f, &drag)
        })
        .collect();
    // The drives' static load where the tool is pressed, with or without a force (free of the
    // surface, the arm at rest weighs on them far below their limits).
    let base = BaseMotion::on_vehicle(
        arm,
        &t_world_body.rotation,
        &Vector6::zeros(),
        &Vector6::zeros(),
        system.gravity,
        &Vector3::zeros(),
    );
    // The forces in the base frame, once for every branch.
    let f_base: Vec<Option<Vector3<f64>>> = targets
        .iter()
        .map(|(_, f)| f.map(|f| t_base_world.rotation * f))
        .collect();
    let drive_at = |i: usize, q: &JointVector| match &f_base[i] {
        Some(f) => drive_load(arm, q, &base, f),
        None => (0.0, 0, 0.0),
    };
    let mut best: Option<Reach> = None;
    for q0 in starts.as_slice() {
        let mut q = *q0;
        let side = q0[4].signum();
        let stop = blocked(arm, q0, side, cfg);
        let mut r = Reach {
            q_start: *q0,
            reached: usize::from(stop.is_none()),
            manipulability: arm.manipulability_at(&in_base[0], &q)?,
            thrust: loads[0],
            drive: drive_at(0, &q),
            stop,
        };
        for i in 1..n {
            if r.reached < i || !r.can_beat(bar, n, cfg) {
                break;
            }
            q = match step(arm, &in_base[i], &q, side, cfg)? {
                Ok(next) => next,
                Err(stop) => {
                    r.stop = Some(stop);
                    break;
                }
            };
            r.manipulability = r.manipulability.min(arm.manipulability_at(&in_base[i], &q)?);
            r.thrust = r.thrust.max(loads[i]);
            r.drive = more_loaded(r.drive, drive_at(i, &q));
            r.reached += 1;
        }
        if best.as_ref().is_none_or(|b| r.beats(b, cfg)) {
            best = Some(r);
        }
    }
    Ok(best)
}

/// The hover point for `trajectory` (world frame) with the controller's model of the vehicle
/// and arm, `system`, and of the `thrusters`.
///
/// # Errors
/// [`Error::Input`] for a bad configuration or an empty trajectory; [`Error::Failed`] (stage
/// `hover`) if no candidate reaches the whole trajectory, saying which part is out of reach,
/// or if the thrusters or the drives cannot hold the contact at any that does.
pub fn choose(
    system: &Multibody,
    thrusters: &Thrusters,
    trajectory: &Trajectory,
    cfg: &HoverConfig,
) -> Result<Hover> {
    cfg.validate()?;
    let n = trajectory.samples.len();
    if n == 0 {
        return Err(Error::input("trajectory", "has no samples"));
    }
    let mut samples = cfg.samples;
    loop {
        match search(system, thrusters, trajectory, cfg, samples)? {
            Ok(hover) => return Ok(hover),
            Err(_) if samples < n && samples < MAX_SAMPLES_FACTOR * cfg.samples => samples *= 2,
            Err(missed) => return Err(missed),
        }
    }
}

/// How many times `samples` the search checks at most: when the chosen station's branch fails
/// between the checked samples, the search runs again with twice as many (a multi-pass ring's
/// turns between passes flipped the wrist between samples 28 apart), while that is fewer than the
/// trajectory's samples and at most this many times the configured count.
const MAX_SAMPLES_FACTOR: usize = 4;

/// [`choose`]'s search checking about `samples` of the trajectory's samples; `Ok(Err(_))` when
/// the chosen station's branch fails between them (a failed run naming the sample).
fn search(
    system: &Multibody,
    thrusters: &Thrusters,
    trajectory: &Trajectory,
    cfg: &HoverConfig,
    samples: usize,
) -> Result<std::result::Result<Hover, Error>> {
    let n = trajectory.samples.len();
    let stride = n.div_ceil(samples).max(1);
    let mut idx: Vec<usize> = (0..n).step_by(stride).collect();
    if idx.last() != Some(&(n - 1)) {
        idx.push(n - 1);
    }
    let targets: Vec<(Isometry3<f64>, Option<Vector3<f64>>)> = idx
        .iter()
        .map(|&i| {
            let s = &trajectory.samples[i];
            // The surface pushes back along −k and resists the motion along x_G.
            let f_env = matches!(s.phase, Phase::Dwell | Phase::Contact)
                .then(|| -s.k * s.force - s.orientation * Vector3::x() * cfg.drag_n);
            (s.pose(), f_env)
        })
        .collect();
    let centroid = targets
        .iter()
        .map(|(t, _)| t.translation.vector)
        .sum::<Vector3<f64>>()
        / targets.len() as f64;
    // NED: "higher" is smaller z.
    let top = targets
        .iter()
        .map(|(t, _)| t.translation.vector.z)
        .fold(f64::INFINITY, f64::min);
    let z_max = top - cfg.min_clearance_m;
    let mut evaluated = 0usize;
    let mut best: Option<(Isometry3<f64>, Reach)> = None;
    let mut consider = |pose: Isometry3<f64>, best: &mut Option<(Isometry3<f64>, Reach)>| -> Result<()> {
        evaluated += 1;
        let bar = best.as_ref().map(|(_, r)| r);
        if let Some(r) = follow(system, thrusters, &pose, &targets, cfg, bar)?
            && best.as_ref().is_none_or(|(_, b)| r.beats(b, cfg))
        {
            *best = Some((pose, r));
        }
        Ok(())
    };
    if let Some(p) = cfg.position_m {
        consider(level_pose(Vector3::from(p), cfg.yaw_deg.to_radians()), &mut best)?;
    } else {
        let grid = |half: f64, step: f64| {
            let k = (half / step).floor() as i64;
            (-k..=k).map(move |i| i as f64 * step)
        };
        let heights = |step: f64| {
            let [lo, hi] = cfg.height_range_m;
            let k = ((hi - lo) / step).floor() as i64;
            (0..=k).map(move |i| lo + i as f64 * step)
        };
        let yaws: Vec<f64> = (0..cfg.headings())
            .map(|i| (i as f64 * cfg.yaw_step_deg).to_radians())
            .collect();
        for &yaw in &yaws {
            for h in heights(cfg.step_m) {
                let z = (centroid.z - h).min(z_max);
                for dx in grid(cfg.horizontal_range_m, cfg.step_m) {
                    for dy in grid(cfg.horizontal_range_m, cfg.step_m) {
                        let p = Vector3::new(centroid.x + dx, centroid.y + dy, z);
                        consider(level_pose(p, yaw), &mut best)?;
                    }
                }
            }
        }
        // Refine around the best: half the step, a third of the heading step.
        if let Some((pose, _)) = best.as_ref().map(|(p, r)| (*p, r.reached)) {
            let c = pose.translation.vector;
            let yaw0 = pose.rotation.euler_angles().2;
            let (fine, fine_yaw) = (cfg.step_m / 2.0, cfg.yaw_step_deg.to_radians() / 3.0);
            for dyaw in [-fine_yaw, 0.0, fine_yaw] {
                for dz in [-fine, 0.0, fine] {
                    for dx in [-fine, 0.0, fine] {
                        for dy in [-fine, 0.0, fine] {
                            let p = c + Vector3::new(dx, dy, dz);
                            if p.z <= z_max {
                                consider(level_pose(p, yaw0 + dyaw), &mut best)?;
                            }
                        }
                    }
                }
            }
        }
    }
    // What the trajectory asks of the contact, for the messages.
    let asks = || {
        let force = trajectory.samples.iter().map(|s| s.force).fold(0.0, f64::max);
        format!(
            "the trajectory asks for up to {} N, sim.hover.drag_n {} N",
            shown_to(force, 1),
            shown_to(cfg.drag_n, 1)
        )
    };
    match best {
        // The least loaded of the candidates that reach, when even it needs more than the
        // thrusters or the drives have: the run would saturate them at once.
        Some((_, r)) if r.reached == targets.len() && (r.thrust.is_nan() || r.thrust > 1.0) => {
            Err(Error::failed(
                "hover",
                format!(
                    "the thrusters cannot hold the contact at any hover point searched that reaches the trajectory: the least loaded needs {} times the most loaded thruster's thrust ({})",
                    shown_to(r.thrust, 2),
                    asks()
                ),
            ))
        }
        Some((_, r)) if r.reached == targets.len() && (r.drive.0.is_nan() || r.drive.0 > 1.0) => {
            let (ratio, joint, tau) = r.drive;
            Err(Error::failed(
                "hover",
                format!(
                    "the drives cannot hold the contact at any hover point searched that reaches the trajectory: at the least loaded, joint {} needs {} N·m, {} times its torque limit ({})",
                    joint + 1,
                    shown_to(tau, 1),
                    shown_to(ratio, 2),
                    asks()
                ),
            ))
        }
        Some((pose, r)) if r.reached == targets.len() => {
            Ok(
                follow_every_sample(&system.arm, &pose, &r.q_start, trajectory, cfg, samples).map(|()| {
                    Hover {
                        t_world_body: pose,
                        q_start: r.q_start,
                        manipulability: r.manipulability,
                        thrust_utilisation: r.thrust,
                        drive_utilisation: r.drive.0,
                    }
                }),
            )
        }
        best => {
            let (reached, stop) = best.map_or((0, None), |(_, r)| (r.reached, r.stop));
            let fail = &trajectory.samples[idx[reached.min(idx.len() - 1)]];
            // A branch given up against a better one has no reason of its own.
            let why = stop_text(stop.unwrap_or(Stop::OutOfReach), cfg);
            Err(Error::failed(
                "hover",
                format!(
                    "no hover point reaches the whole trajectory within the joint limits{} and with the wrist at least {} rad from its singularity (sim.hover.min_wrist_angle_rad): the best of {evaluated} candidates {} and the point at t = {:.2} s ({} phase, at {} m) {}",
                    if cfg.min_limit_margin_rad > 0.0 {
                        format!(
                            " (every joint at least {} rad inside them, sim.hover.min_limit_margin_rad)",
                            shown(cfg.min_limit_margin_rad)
                        )
                    } else {
                        String::new()
                    },
                    shown(cfg.min_wrist_angle_rad),
                    match reached {
                        0 => "reaches none of it".to_string(),
                        _ => format!(
                            "follows it to t = {:.2} s",
                            trajectory.samples[idx[reached - 1]].t
                        ),
                    },
                    fail.t,
                    fail.phase.as_str(),
                    shown_xyz(&fail.position.coords.into(), 3),
                    why
                ),
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::UvmsModel;
    use crate::multibody::{Multibody, State};
    use crate::trajectory::{Phase, Sample};
    use nalgebra::Point3;

    /// A straight stroke the arm made from a known vehicle pose.
    fn stroke(mb: &Multibody, from: &Isometry3<f64>, length: f64) -> Trajectory {
        let q = JointVector::new(0.0, 0.9, -2.0, 0.0, 0.6, 0.0);
        let start = mb.t_world_tool(&State::at_rest(*from, q));
        let samples = (0..=40)
            .map(|i| {
                let u = i as f64 / 40.0;
                let p = start.translation.vector + Vector3::new(0.0, length * u, 0.0);
                Sample {
                    t: i as f64,
                    position: Point3::from(p),
                    orientation: start.rotation,
                    k: start.rotation * Vector3::z(),
                    force: 60.0,
                    phase: Phase::Contact,
                    fallback: false,
                }
            })
            .collect();
        Trajectory {
            samples,
            notes: vec![],
        }
    }

    /// The default system, a 0.3 m stroke from the identity pose and a coarse search.
    fn coarse_stroke() -> (Multibody, Trajectory, HoverConfig) {
        let mb = Multibody::new(&UvmsModel::default()).unwrap();
        let traj = stroke(&mb, &Isometry3::identity(), 0.3);
        let cfg = HoverConfig {
            step_m: 0.15,
            yaw_step_deg: 90.0,
            ..HoverConfig::default()
        };
        (mb, traj, cfg)
    }

    #[test]
    fn finds_a_pose_that_reaches_every_sample() {
        let (mb, traj, cfg) = coarse_stroke();
        let h = choose(&mb, &thrusters(), &traj, &cfg).unwrap();
        assert!(h.manipulability > 0.0);
        // Check it independently: every sample has an IK solution from the chosen pose.
        let t_base_world = (h.t_world_body * mb.arm.t_body_base()).inverse();
        let mut q = h.q_start;
        for s in &traj.samples {
            q = *mb
                .arm
                .ik(&(t_base_world * s.pose()), &q)
                .unwrap()
                .nearest()
                .unwrap();
        }
        let top = traj
            .samples
            .iter()
            .map(|s| s.position.z)
            .fold(f64::INFINITY, f64::min);
        assert!(h.t_world_body.translation.z <= top - cfg.min_clearance_m + 1e-12);
    }

    fn thrusters() -> Thrusters {
        Thrusters::new(&UvmsModel::default().thrusters).unwrap()
    }

    /// Dragging the tool along the world's y axis: the vehicle turns to take the drag along
    /// its own x axis (surge thrusters, pitch) rather than across it (one sway thruster, roll).
    #[test]
    fn a_drag_along_the_path_turns_the_vehicle_along_it() {
        let mb = Multibody::new(&UvmsModel::default()).unwrap();
        let traj = stroke(&mb, &Isometry3::identity(), 0.3);
        let cfg = HoverConfig {
            step_m: 0.15,
            yaw_step_deg: 45.0,
            drag_n: 70.0,
            ..HoverConfig::default()
        };
        let h = choose(&mb, &thrusters(), &traj, &cfg).unwrap();
        let x_body = h.t_world_body.rotation * Vector3::x();
        assert!(x_body.y.abs() > 0.7, "heading {x_body}");
    }

    /// The drives' static load: the torques that hold the arm's weight in water (the inverse
    /// dynamics without a force) and press the tool, `−J_vᵀ f` for the environment's force `f`
    /// on the tool (the Jacobian's virtual work, not the RNEA's force propagation).
    #[test]
    fn the_drive_load_is_the_weight_and_the_jacobians_transpose_of_the_force() {
        let mb = Multibody::new(&UvmsModel::default()).unwrap();
        let arm = &mb.arm;
        let q = JointVector::new(0.3, 0.9, -2.0, 0.4, 0.6, -0.2);
        let tilted = UnitQuaternion::from_euler_angles(0.1, -0.05, 1.0);
        let base = BaseMotion::on_vehicle(
            arm,
            &tilted,
            &Vector6::zeros(),
            &Vector6::zeros(),
            9.81,
            &Vector3::zeros(),
        );
        let f = Vector3::new(20.0, -35.0, 50.0);
        let zero = JointVector::zeros();
        let weight = arm.inverse_dynamics(&q, &zero, &zero, &base, None).tau;
        let tau = weight - arm.jacobian(&q).fixed_rows::<3>(0).transpose() * f;
        let (ratio, joint, torque) = drive_load(arm, &q, &base, &f);
        assert!((torque - tau[joint]).abs() < 1e-9, "{torque} vs {}", tau[joint]);
        for i in 0..6 {
            assert!(tau[i].abs() / arm.links[i].torque_limit <= ratio + 1e-12);
        }
        assert!((ratio - tau[joint].abs() / arm.links[joint].torque_limit).abs() < 1e-12);
    }

    /// Of the candidates that reach, one whose drives would take more than
    /// `max_drive_utilisation` is passed over for one within it; drives too weak for the
    /// contact at every candidate are a failed run naming the joint.
    #[test]
    fn the_drives_must_hold_the_contact() {
        let (mb, traj, cfg) = coarse_stroke();
        let free = choose(&mb, &thrusters(), &traj, &cfg).unwrap();
        assert!(free.drive_utilisation > 0.0 && free.drive_utilisation <= cfg.max_drive_utilisation);
        let tight = HoverConfig {
            max_drive_utilisation: 0.9 * free.drive_utilisation,
            ..cfg
        };
        let h = choose(&mb, &thrusters(), &traj, &tight).unwrap();
        assert!(h.drive_utilisation < free.drive_utilisation, "{h:?}");
        assert!(h.manipulability <= free.manipulability, "{h:?}");
        let mut weak = mb.clone();
        weak.arm.links[1].torque_limit = 1.0;
        let e = choose(&weak, &thrusters(), &traj, &cfg).unwrap_err();
        assert_eq!(e.exit_code(), 1);
        assert!(
            e.to_string().contains("the drives cannot hold the contact")
                && e.to_string().contains("joint 2 needs"),
            "{e}"
        );
    }

    /// A path followed by position (no force asked for, no drag expected) still loads the
    /// drives with the arm's weight in water where the tool is pressed: the station's drive
    /// utilisation is that weight's, at the chosen branch's joint angles.
    #[test]
    fn a_path_without_a_force_loads_the_drives_with_the_weight() {
        let (mb, mut traj, cfg) = coarse_stroke();
        for s in &mut traj.samples {
            s.force = 0.0;
        }
        let h = choose(&mb, &thrusters(), &traj, &cfg).unwrap();
        let base = BaseMotion::on_vehicle(
            &mb.arm,
            &h.t_world_body.rotation,
            &Vector6::zeros(),
            &Vector6::zeros(),
            mb.gravity,
            &Vector3::zeros(),
        );
        let zero = JointVector::zeros();
        let ratios: Vec<f64> = followed(&mb, &traj, &h)
            .iter()
            .map(|q| {
                let tau = mb.arm.inverse_dynamics(q, &zero, &zero, &base, None).tau;
                (0..6)
                    .map(|i| tau[i].abs() / mb.arm.links[i].torque_limit)
                    .fold(0.0, f64::max)
            })
            .collect();
        let most = ratios.iter().copied().fold(0.0, f64::max);
        assert!(ratios[0] > 0.0, "{ratios:?}");
        assert!(
            h.drive_utilisation >= ratios[0] - 1e-12 && h.drive_utilisation <= most + 1e-12,
            "{} against {ratios:?}",
            h.drive_utilisation
        );
    }

    /// In a current the station's heading takes the hull's drag where the thrusters hold it
    /// best: the chosen point's thrust utilisation in the current is at most that of the point
    /// chosen for still water, in the same current, and a current no thruster can hold is a
    /// failed run.
    #[test]
    fn the_station_is_chosen_for_the_expected_current() {
        let (mb, traj, cfg) = coarse_stroke();
        let cfg = HoverConfig {
            yaw_step_deg: 45.0,
            ..cfg
        };
        let current = [0.3, 0.6, 0.0];
        let still = choose(&mb, &thrusters(), &traj, &cfg).unwrap();
        let within = HoverConfig {
            current_m_s: current,
            ..cfg
        };
        let h = choose(&mb, &thrusters(), &traj, &within).unwrap();
        // The still-water point in the current, with the same loads as the search.
        let fixed = |pose: &Isometry3<f64>| HoverConfig {
            position_m: Some(pose.translation.vector.into()),
            yaw_deg: pose.rotation.euler_angles().2.to_degrees(),
            ..within
        };
        let still_in_current = choose(&mb, &thrusters(), &traj, &fixed(&still.t_world_body)).unwrap();
        assert!(
            h.thrust_utilisation < still_in_current.thrust_utilisation,
            "{h:?} against {still_in_current:?}"
        );
        assert!(
            h.thrust_utilisation > still.thrust_utilisation,
            "{h:?} against {still:?}"
        );
        let torrent = HoverConfig {
            current_m_s: [0.0, 4.5, 0.0],
            ..cfg
        };
        let e = choose(&mb, &thrusters(), &traj, &torrent).unwrap_err();
        assert!(e.to_string().contains("the thrusters cannot hold"), "{e}");
    }

    /// The joints at every sample of `traj` from the station `h`, each the IK solution nearest
    /// the last (an independent check of the search's branch).
    fn followed(mb: &Multibody, traj: &Trajectory, h: &Hover) -> Vec<JointVector> {
        let t_base_world = (h.t_world_body * mb.arm.t_body_base()).inverse();
        let mut q = h.q_start;
        let mut out = Vec::new();
        for s in &traj.samples {
            q = mb
                .arm
                .ik_nearest(&(t_base_world * s.pose()), &q)
                .unwrap()
                .unwrap();
            out.push(q);
        }
        out
    }

    /// The chosen station keeps the wrist `min_wrist_angle_rad` from its singularity at every
    /// sample (checked independently by following the IK from the chosen start), on one side.
    #[test]
    fn the_wrist_keeps_clear_of_its_singularity() {
        let (mb, traj, cfg) = coarse_stroke();
        let free = choose(&mb, &thrusters(), &traj, &cfg).unwrap();
        let wrist = |h: &Hover| {
            followed(&mb, &traj, h)
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                    (lo.min(q[4]), hi.max(q[4]))
                })
        };
        let (lo, hi) = wrist(&free);
        let margin = 0.5 * (lo.abs().min(hi.abs()) + 1.5);
        let clear = HoverConfig {
            min_wrist_angle_rad: margin,
            ..cfg
        };
        let h = choose(&mb, &thrusters(), &traj, &clear).unwrap();
        let (lo, hi) = wrist(&h);
        assert!(
            lo * hi > 0.0 && lo.abs().min(hi.abs()) >= margin,
            "q5 in [{lo}, {hi}], margin {margin}"
        );
    }

    /// With `min_limit_margin_rad`, the chosen station keeps every joint that far inside its
    /// limits at every sample (followed independently from the chosen start), where the free
    /// choice came nearer; a margin no station can keep is a failure naming the key.
    #[test]
    fn the_joints_keep_their_margin_from_the_limits() {
        let (mb, traj, cfg) = coarse_stroke();
        let closest = |h: &Hover| {
            followed(&mb, &traj, h)
                .iter()
                .map(|q| mb.arm.limit_margin(q).0)
                .fold(f64::INFINITY, f64::min)
        };
        let free = closest(&choose(&mb, &thrusters(), &traj, &cfg).unwrap());
        let margin = free + 0.1;
        let kept = HoverConfig {
            min_limit_margin_rad: margin,
            ..cfg
        };
        let least = closest(&choose(&mb, &thrusters(), &traj, &kept).unwrap());
        assert!(
            least >= margin,
            "closest {least} rad, margin {margin} (free {free})"
        );
        let wide = HoverConfig {
            min_limit_margin_rad: 2.0,
            ..cfg
        };
        let e = choose(&mb, &thrusters(), &traj, &wide).unwrap_err().to_string();
        // It says what stopped the best candidate: the margin, not the reach.
        assert!(
            e.contains("within the joint limits (every joint at least 2 rad inside them")
                && e.contains("of its limit (sim.hover.min_limit_margin_rad 2)")
                && !e.contains("out of the arm's reach"),
            "{e}"
        );
        let bad = HoverConfig {
            min_limit_margin_rad: -0.1,
            ..cfg
        };
        assert!(bad.validate().is_err());
    }

    /// A tool held at one point but for a 5 m excursion at sample 48 of 101, between those the
    /// search checks (`samples = 4`: every 26th; doubled twice, every 13th and every 7th):
    /// every station reaches the checked ones, and following the chosen one through every
    /// sample finds the excursion out of reach, a failed run naming it and the samples checked.
    #[test]
    fn the_chosen_station_is_followed_through_every_sample() {
        let mb = Multibody::new(&UvmsModel::default()).unwrap();
        let at = stroke(&mb, &Isometry3::identity(), 0.0).samples[0];
        let samples = (0..=100)
            .map(|i| {
                let out = if i == 48 { 5.0 } else { 0.0 };
                Sample {
                    t: i as f64,
                    position: at.position + Vector3::new(0.0, out, 0.0),
                    ..at
                }
            })
            .collect();
        let traj = Trajectory {
            samples,
            notes: vec![],
        };
        let cfg = HoverConfig {
            step_m: 0.3,
            yaw_step_deg: 90.0,
            samples: 4,
            ..HoverConfig::default()
        };
        let e = choose(&mb, &thrusters(), &traj, &cfg).unwrap_err();
        assert_eq!(e.exit_code(), 1);
        let e = e.to_string();
        assert!(
            e.contains("about 16: sim.hover.samples = 4 doubled")
                && e.contains("t = 48.00 s")
                && e.contains("is out of the arm's reach"),
            "{e}"
        );
    }

    #[test]
    fn a_trajectory_out_of_reach_is_a_failed_run_naming_the_point() {
        let mb = Multibody::new(&UvmsModel::default()).unwrap();
        // Five metres long: no station reaches both ends.
        let traj = stroke(&mb, &Isometry3::identity(), 5.0);
        let cfg = HoverConfig {
            step_m: 0.3,
            yaw_step_deg: 90.0,
            ..HoverConfig::default()
        };
        let e = choose(&mb, &thrusters(), &traj, &cfg).unwrap_err();
        assert_eq!(e.exit_code(), 1);
        assert!(
            e.to_string().contains("out of the arm's reach")
                && e.to_string().contains("wrist at least 0.1 rad"),
            "{e}"
        );
    }
}
