//! The contact operation in closed loop: the seed's control system (Konoplin et al. 2024,
//! section 3 and Figure 4) around the simulated plant ([`crate::plant::Plant`]).
//!
//! One module per block of Figure 4:
//! - [`contact`]: the tool against the *true* surface (penalty, friction, soil) — plant side;
//! - [`current`]: the sea current, steady or fluctuating — plant side;
//! - [`sensors`] and [`navigation`] (NS): encoders, joint-torque sensors, gyros,
//!   accelerometers, the delayed vision fix, and the attitude, position and velocity estimated
//!   from them;
//! - [`icu`] (ICU): eq. (1)–(12), the tool force from the external joint moments;
//! - [`fcu`] (FCU): eq. (13)–(16), the force PID giving the extra tool offset;
//! - [`tcu`] (TCU): eq. (18), the desired tool pose corrected by the measured vehicle pose, and
//!   the analytic inverse kinematics;
//! - [`joints`] (MM and its CS): computed-torque joint control with the IDP and the
//!   compensation of the identified external moments;
//! - [`vehicle_control`] (AUV SS): closed loop on the measured pose plus the open loop of
//!   eq. (17), allocated to the thrusters;
//! - [`hover`]: the stabilisation pose that lets the arm follow the whole trajectory.
//!
//! [`simulate`] runs them at the control rate. The controllers see the plant only through
//! [`sensors::Sensors`]; every sensor reading refers to the plant's state one control period
//! earlier (the joint-torque sensor reads the shaft torque of the last step). The controllers
//! use their own model of the vehicle and the arm ([`ModelMismatch`] makes it differ from the
//! plant's). The contact force they act on is always the one identified from joint moments;
//! the true one is only logged.

pub mod contact;
pub mod current;
pub mod fcu;
pub mod hover;
pub mod icu;
pub mod joints;
pub mod navigation;
pub mod record;
pub mod sensors;
pub mod tcu;
pub mod vehicle_control;

use crate::arm::JointVector;
use crate::arm::dynamics::BaseMotion;
use crate::config::{non_negative, positive, require, shown, shown_to, shown_xyz};
use crate::error::{Error, Result};
use crate::integrate::Integrator;
use crate::mesh::TriangleMesh;
use crate::model::UvmsModel;
use crate::multibody::{Accelerations, GenVector, Inputs, Multibody, State, ToolDamping};
use crate::plant::{Plant, PlantInput};
use crate::spatial_algebra::Force;
use crate::trajectory::{Phase, Trajectory};
use crate::vehicle::thrusters::{Allocation, Thrusters};
use contact::{Contact, ContactConfig};
use current::SeaCurrent;
use fcu::{Fcu, FcuConfig, force_error};
use hover::{Hover, HoverConfig};
use icu::{Icu, IcuConfig};
use joints::{JointControl, JointControlConfig};
use nalgebra::{Isometry3, Matrix6, Translation3, Vector3, Vector6};
use navigation::{Navigation, NavigationConfig};
use record::{Figures, Recorder, Row};
use sensors::{SensorConfig, Sensors, Truth};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use vehicle_control::{VehicleControl, VehicleControlConfig};

/// The frame the contact surface's file is given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum SurfaceFrame {
    /// The scan (camera) frame `S`, mapped into `W` by the scan's frames (`uvms synth`'s
    /// `scene_mesh.ply`).
    #[default]
    Scan,
    /// The world frame `W`.
    World,
}

/// How the controllers' model differs from the plant's (`[sim.controller_model]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ModelMismatch {
    /// Factor on every link's mass and inertia.
    pub link_mass_scale: f64,
    /// Factor on the links' drag and added-mass coefficients (0: no arm hydrodynamics in the
    /// controller's model).
    pub link_hydro_scale: f64,
    /// Factor on the vehicle's damping.
    pub vehicle_damping_scale: f64,
    /// Factor on the drives' viscous and Coulomb friction (the ICU's drive equation and the
    /// joint control use it).
    pub drive_friction_scale: f64,
    /// Factor on the drives' rotor inertia (the ICU's drive equation, the joint control's
    /// feed-forward and the whole system's inertia use it).
    pub rotor_inertia_scale: f64,
    /// Factor on the vehicle's added mass (the whole system's inertia of the ICU and the hover
    /// point, the stabilisation's model).
    pub vehicle_added_mass_scale: f64,
    /// Factor on the thrusters' thrust: the controllers command each rotor for the thrust their
    /// model says it gives, so at 1.25 the plant's thrusters give 20 % less than asked (worn or
    /// fouled propellers), at 0.8 a quarter more.
    pub thrust_scale: f64,
}

impl Default for ModelMismatch {
    fn default() -> Self {
        ModelMismatch {
            link_mass_scale: 1.02,
            link_hydro_scale: 0.8,
            vehicle_damping_scale: 0.8,
            drive_friction_scale: 1.0,
            rotor_inertia_scale: 1.0,
            vehicle_added_mass_scale: 1.0,
            thrust_scale: 1.0,
        }
    }
}

impl ModelMismatch {
    /// The controllers' model made from the plant's.
    pub fn apply(&self, plant: &UvmsModel) -> UvmsModel {
        let mut m = plant.clone();
        for link in &mut m.arm.links {
            link.mass *= self.link_mass_scale;
            link.viscous_friction *= self.drive_friction_scale;
            link.coulomb_friction = link.coulomb_friction.map(|c| c * self.drive_friction_scale);
            link.motor_inertia *= self.rotor_inertia_scale;
            for row in &mut link.inertia {
                for v in row {
                    *v *= self.link_mass_scale;
                }
            }
            if let Some(h) = &mut link.hydro {
                h.drag_cross *= self.link_hydro_scale;
                h.drag_axial *= self.link_hydro_scale;
                h.added_mass_coefficient *= self.link_hydro_scale;
                for v in &mut h.linear_damping {
                    *v *= self.link_hydro_scale;
                }
            }
        }
        for v in m
            .vehicle
            .linear_damping
            .iter_mut()
            .chain(m.vehicle.quadratic_damping.iter_mut())
        {
            *v *= self.vehicle_damping_scale;
        }
        for v in m.vehicle.added_mass.iter_mut().flatten() {
            *v *= self.vehicle_added_mass_scale;
        }
        for unit in &mut m.thrusters.units {
            unit.max_thrust *= self.thrust_scale;
        }
        // The controllers do not know the sea current.
        m.environment.current = [0.0; 3];
        m
    }

    fn validate(&self) -> Result<()> {
        positive("sim.controller_model.link_mass_scale", self.link_mass_scale)?;
        non_negative("sim.controller_model.link_hydro_scale", self.link_hydro_scale)?;
        non_negative(
            "sim.controller_model.vehicle_damping_scale",
            self.vehicle_damping_scale,
        )?;
        non_negative(
            "sim.controller_model.drive_friction_scale",
            self.drive_friction_scale,
        )?;
        non_negative(
            "sim.controller_model.rotor_inertia_scale",
            self.rotor_inertia_scale,
        )?;
        non_negative(
            "sim.controller_model.vehicle_added_mass_scale",
            self.vehicle_added_mass_scale,
        )?;
        positive("sim.controller_model.thrust_scale", self.thrust_scale)
    }
}

/// Scenario knobs and the ablation switches (`[sim.scenario]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Scenario {
    /// Sea current in the world (NED), m/s: its mean when it varies.
    pub current_m_s: [f64; 3],
    /// Stationary standard deviation of the current's fluctuation on each world axis, m/s
    /// (zero: a steady current).
    pub current_variation_m_s: [f64; 3],
    /// Correlation time of the current's fluctuation, s.
    pub current_correlation_s: f64,
    /// Smoothing time of the current's fluctuation, s: the lag that gives the water an
    /// acceleration (see [`current`]).
    pub current_smoothing_s: f64,
    /// The open loop of eq. (17) in the vehicle's stabilisation.
    pub open_loop: bool,
    /// The trajectory correction of eq. (18).
    pub trajectory_correction: bool,
    /// The force loop of eq. (14).
    pub force_loop: bool,
}

impl Default for Scenario {
    fn default() -> Self {
        Scenario {
            current_m_s: [0.0; 3],
            current_variation_m_s: [0.0; 3],
            current_correlation_s: 10.0,
            current_smoothing_s: 1.0,
            open_loop: true,
            trajectory_correction: true,
            force_loop: true,
        }
    }
}

impl Scenario {
    /// Checks the current's fluctuation: finite, non-negative spreads whose four standard
    /// deviations with the mean stay within the fastest current, positive correlation and
    /// smoothing times (their upper bounds are checked with the other times').
    fn check_variation(&self) -> Result<()> {
        let key = "sim.scenario.current_variation_m_s";
        for s in self.current_variation_m_s {
            non_negative(key, s)?;
        }
        let widest: [f64; 3] =
            std::array::from_fn(|i| self.current_m_s[i].abs() + 4.0 * self.current_variation_m_s[i]);
        check_current(&format!("{key} (its mean and four standard deviations)"), widest)?;
        positive("sim.scenario.current_correlation_s", self.current_correlation_s)?;
        positive("sim.scenario.current_smoothing_s", self.current_smoothing_s)
    }

    /// Whether the current fluctuates.
    pub fn current_varies(&self) -> bool {
        self.current_variation_m_s != [0.0; 3]
    }
}

/// Waiting at the end of a dwell until the force has settled (the seed's advice for critical
/// operations), `[sim.dwell]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DwellConfig {
    /// The force counts as settled once within this of the setpoint, N (by default 3 N, 5 % of
    /// the seed's 60 N: a 1 mm error of the vision fix is 10 N against the 1e4 N/m contact, so
    /// the force wanders ±2–3 N at rest and a 1 N band is held for half a second only by
    /// chance)...
    pub tolerance_n: f64,
    /// ...for this long, s.
    pub hold_s: f64,
    /// Longest extra wait before moving on anyway, s.
    pub max_wait_s: f64,
    /// The dwell's guarded start: until the identified force along `k` first reaches this, N (or
    /// the dwell's force, if less), or the dwell ends, the force loop's target moves towards the
    /// surface at least at the approach's speed (its last step's, into the dwell; no guard for a
    /// trajectory without an approach), the loop's own advance standing where it is faster (0: no
    /// guard). On the bottle's ramp of the set-point from zero (60 N/s) the loop moves the target
    /// 0.18 mm in the first 0.1 s, which the arm, settling after the approach, lags: a grazing
    /// touch (0.2 N on bottle seed 1 with a noise-free attitude) was lost for 0.14 s.
    pub touch_n: f64,
}

impl Default for DwellConfig {
    fn default() -> Self {
        DwellConfig {
            tolerance_n: 3.0,
            hold_s: 0.5,
            max_wait_s: 10.0,
            touch_n: 3.0,
        }
    }
}

/// Where the true surface the tool touches comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum SurfaceSource {
    /// The mesh file `surface`, in `surface_frame`.
    #[default]
    File,
    /// `uvms run` only: the surface the trajectory was planned on, as the check stage
    /// triangulated it from the scan (the object's `scan_surface.ply`; the seabed's for the line
    /// pattern): for a real scan, with no truer mesh, the tool touches what the camera saw.
    Scan,
    /// `uvms run` only: the reference model aligned to the scan (`reference_surface.ply`).
    Reference,
}

impl SurfaceSource {
    /// The value as the configuration spells it.
    pub fn as_str(self) -> &'static str {
        match self {
            SurfaceSource::File => "file",
            SurfaceSource::Scan => "scan",
            SurfaceSource::Reference => "reference",
        }
    }
}

/// The simulation's configuration (`[sim]` of a pipeline, or `uvms sim --config`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimConfig {
    /// Seed of every random draw (sensor noise).
    pub seed: u64,
    /// The plant's model file (TOML); none: the built-in AUV300 + PUMA 560.
    pub model: Option<PathBuf>,
    /// The true surface the tool touches (PLY mesh), with `surface_from = "file"`.
    pub surface: Option<PathBuf>,
    /// The frame of `surface`.
    pub surface_frame: SurfaceFrame,
    /// Where the true surface comes from: the file `surface` (default), or in `uvms run` the
    /// run's own scanned (`"scan"`) or aligned reference (`"reference"`) surface.
    pub surface_from: SurfaceSource,
    /// Control rate, Hz.
    pub control_rate_hz: f64,
    /// Plant integration steps per control period.
    pub plant_substeps: usize,
    /// The plant's integrator.
    pub integrator: Integrator,
    /// Rate of the rows of `timeseries.csv`, Hz.
    pub log_rate_hz: f64,
    /// Time simulated after the trajectory's end, s.
    pub tail_s: f64,
    /// From this long after the first contact the force counts as settled (the window of
    /// `force_settled_mean_n` and `force_rms_error_n`), and this long after the path starts
    /// the window of `force_overshoot_n` ends, s.
    pub settle_time_s: f64,
    /// A run whose tool strays farther than this from where the control system wants it
    /// (`‖e‖`, at any period) failed: the tool was not where the operation needed it, m.
    pub max_tool_deviation_m: f64,
    /// Contact model.
    pub contact: ContactConfig,
    /// NS: the sensors.
    pub sensors: SensorConfig,
    /// NS: the navigation filters.
    pub navigation: NavigationConfig,
    /// ICU.
    pub icu: IcuConfig,
    /// FCU.
    pub force: FcuConfig,
    /// Joint controllers.
    pub joints: JointControlConfig,
    /// AUV SS.
    pub vehicle: VehicleControlConfig,
    /// Hover-point search.
    pub hover: HoverConfig,
    /// Dwell until settled.
    pub dwell: DwellConfig,
    /// How the controllers' model differs from the plant's.
    pub controller_model: ModelMismatch,
    /// Current and ablations.
    pub scenario: Scenario,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            seed: 1,
            model: None,
            surface: None,
            surface_frame: SurfaceFrame::Scan,
            surface_from: SurfaceSource::File,
            control_rate_hz: 1000.0,
            plant_substeps: 1,
            integrator: Integrator::SemiImplicitEuler,
            log_rate_hz: 100.0,
            tail_s: 0.5,
            settle_time_s: 1.5,
            max_tool_deviation_m: 0.05,
            contact: ContactConfig::default(),
            sensors: SensorConfig::default(),
            navigation: NavigationConfig::default(),
            icu: IcuConfig::default(),
            force: FcuConfig::default(),
            joints: JointControlConfig::default(),
            vehicle: VehicleControlConfig::default(),
            hover: HoverConfig::default(),
            dwell: DwellConfig::default(),
            controller_model: ModelMismatch::default(),
            scenario: Scenario::default(),
        }
    }
}

impl SimConfig {
    /// How deep inside the material a target may lie and still be a skim, not a demand for
    /// contact, m: the depth whose spring force is within the force tolerance
    /// (`dwell.tolerance_n / contact.stiffness_n_m`; the planned surface, a scan, may lie a
    /// fraction of a millimetre off the true one).
    pub fn skim_depth_m(&self) -> f64 {
        self.dwell.tolerance_n / self.contact.stiffness_n_m
    }

    /// Checks every value.
    ///
    /// # Errors
    /// [`Error::Input`] naming the first bad field.
    pub fn validate(&self) -> Result<()> {
        positive("sim.control_rate_hz", self.control_rate_hz)?;
        require(
            self.control_rate_hz <= 100_000.0,
            "sim.control_rate_hz",
            format!("must be at most 100000 Hz, got {}", shown(self.control_rate_hz)),
        )?;
        positive("sim.log_rate_hz", self.log_rate_hz)?;
        self.sensors.validate()?;
        // What is logged or read happens at most once a control period.
        for (key, rate) in [
            ("sim.log_rate_hz", self.log_rate_hz),
            ("sim.sensors.vision_rate_hz", self.sensors.vision_rate_hz),
            (
                "sim.sensors.water_track_rate_hz",
                self.sensors.water_track_rate_hz,
            ),
        ] {
            if rate > self.control_rate_hz {
                return Err(Error::input(key, "must not exceed sim.control_rate_hz"));
            }
        }
        if !(1..=1000).contains(&self.plant_substeps) {
            return Err(Error::input("sim.plant_substeps", "must be between 1 and 1000"));
        }
        non_negative("sim.tail_s", self.tail_s)?;
        if self.surface_from != SurfaceSource::File {
            let from = self.surface_from.as_str();
            if self.surface.is_some() {
                return Err(Error::input(
                    "sim.surface",
                    format!(
                        "is given with sim.surface_from = \"{from}\", whose surface is the run's own: give one of them"
                    ),
                ));
            }
            if self.surface_frame == SurfaceFrame::World {
                return Err(Error::input(
                    "sim.surface_frame",
                    format!(
                        "the run's own surface (sim.surface_from = \"{from}\") is in the scan frame: drop surface_frame or set it to \"scan\""
                    ),
                ));
            }
        }
        for (key, v) in [
            ("sim.tail_s", self.tail_s),
            ("sim.dwell.max_wait_s", self.dwell.max_wait_s),
            (
                "sim.scenario.current_correlation_s",
                self.scenario.current_correlation_s,
            ),
            (
                "sim.scenario.current_smoothing_s",
                self.scenario.current_smoothing_s,
            ),
        ] {
            // (NaN is left to each value's own check below.)
            require(
                v.is_nan() || v <= MAX_WAIT_S,
                key,
                format!("must be at most {MAX_WAIT_S:.0e} s, got {v:e}"),
            )?;
        }
        non_negative("sim.settle_time_s", self.settle_time_s)?;
        positive("sim.max_tool_deviation_m", self.max_tool_deviation_m)?;
        check_current("sim.scenario.current_m_s", self.scenario.current_m_s)?;
        self.scenario.check_variation()?;
        // The plant holds the water's rate over a control period: a lag shorter than the
        // period would be lost between the samples. A correlation time shorter than it makes
        // the fluctuation white between the samples, its driving part `(τ + τ_s)/τ` times the
        // current's variance (1e-9 s: the water accelerating at 10³ m/s², a runaway at once).
        for (key, v) in [
            (
                "sim.scenario.current_smoothing_s",
                self.scenario.current_smoothing_s,
            ),
            (
                "sim.scenario.current_correlation_s",
                self.scenario.current_correlation_s,
            ),
        ] {
            require(
                !self.scenario.current_varies() || v.is_nan() || v * self.control_rate_hz >= 1.0,
                key,
                format!(
                    "must be at least the control period (1/control_rate_hz = {} s), got {}",
                    shown(1.0 / self.control_rate_hz),
                    shown(v)
                ),
            )?;
        }
        positive("sim.dwell.tolerance_n", self.dwell.tolerance_n)?;
        non_negative("sim.dwell.hold_s", self.dwell.hold_s)?;
        non_negative("sim.dwell.max_wait_s", self.dwell.max_wait_s)?;
        non_negative("sim.dwell.touch_n", self.dwell.touch_n)?;
        self.contact.validate()?;
        self.navigation.validate()?;
        self.icu.validate()?;
        self.force.validate()?;
        self.joints.validate()?;
        self.vehicle.validate()?;
        self.hover.validate()?;
        self.controller_model.validate()?;
        if self.vehicle.current_filter_s > 0.0 && self.controller_model.vehicle_damping_scale == 0.0 {
            return Err(Error::input(
                "sim.controller_model.vehicle_damping_scale",
                "must be positive for the controllers to estimate the current from their vehicle's drag (or set sim.vehicle.current_filter_s = 0)",
            ));
        }
        // What the checks above leave unbounded (noise, gains, stiffness...).
        crate::config::within_range(self, "sim.")
    }
}

/// The summary of a run (DESIGN.md's `sim` keys, and more).
#[derive(Debug, Clone, Serialize)]
pub struct SimSummary {
    /// The figures of the force, the deviations and the identification.
    #[serde(flatten)]
    pub figures: Figures,
    /// Simulated seconds per wall-clock second.
    pub realtime_factor: f64,
    /// Simulated time, s.
    pub simulated_s: f64,
    /// Extra time spent at the end of the dwell waiting for the force to settle, s.
    pub dwell_wait_s: f64,
    /// Control periods along the path (not the tail after it) in which the corrected tool pose
    /// had no IK solution (set-point held).
    pub unreachable_steps: usize,
    /// The arm's least distance from a joint limit over the run, rad: a station that leaves the
    /// path close to a limit leaves the vehicle's motion little room.
    pub joint_limit_margin_rad: f64,
    /// The joint (1-based) that came closest to its limit.
    pub joint_limit_margin_joint: usize,
    /// Fraction of control periods with the thrust command scaled down to the limits.
    pub thrust_saturated_fraction: f64,
    /// The stabilisation pose: position (m) and heading (deg).
    pub hover_position_m: [f64; 3],
    /// The stabilisation heading, degrees.
    pub hover_yaw_deg: f64,
    /// Worst-case manipulability `|det J|` along the trajectory at the hover point.
    pub hover_manipulability: f64,
    /// The largest fraction of a thruster's thrust that holding the planned contact takes
    /// there (static, with `sim.hover.drag_n` and the hull's drag in `sim.hover.current_m_s`).
    pub hover_thrust_utilisation: f64,
    /// The largest fraction of a drive's torque limit that holding the planned contact takes
    /// there (static, the arm's weight in water included).
    pub hover_drive_utilisation: f64,
    /// The ablation switches and the current of the run.
    pub scenario: Scenario,
}

/// A finished run.
#[derive(Debug, Clone)]
pub struct SimOutput {
    /// The logged time series.
    pub rows: Vec<Row>,
    /// The figures.
    pub summary: SimSummary,
    /// How deep the trajectory's deepest contact-phase point lies in the true surface's
    /// material, m (negative when every one is outside: minus the least distance from the
    /// surface); `None` without a contact phase.
    pub contact_depth_m: Option<f64>,
}

/// Simulates the contact operation along `trajectory` (world frame) against the true `surface`
/// (world frame) with the plant `plant_model`. `progress` is called with the fraction done.
///
/// # Errors
/// [`Error::Input`] for a bad configuration, model or trajectory; [`Error::Failed`] (stage
/// `hover`) if no stabilisation pose reaches the trajectory, (stage `sim`) if the simulation
/// diverges, naming the time and the state.
pub fn simulate(
    trajectory: &Trajectory,
    surface: &TriangleMesh,
    plant_model: &UvmsModel,
    cfg: &SimConfig,
    progress: &mut dyn FnMut(f64),
) -> Result<SimOutput> {
    cfg.validate()?;
    let (t0, t_end) = check_trajectory(trajectory, cfg, "trajectory")?;
    check_plant_model(plant_model)?;
    let mut plant_model = plant_model.clone();
    plant_model.environment.current = cfg.scenario.current_m_s;
    let (ctrl_model, ctrl) = controllers_model(cfg, &plant_model)?;
    let arm = &ctrl.arm;
    let g = ctrl_model.environment.gravity;
    let allocator = Thrusters::new(&ctrl_model.thrusters)?;
    let hover = hover::choose(&ctrl, &allocator, trajectory, &cfg.hover)?;
    let h = hover.t_world_body;
    let mut plant = Plant::new(&plant_model, State::at_rest(h, hover.q_start), cfg.integrator)?;
    let sc = &cfg.scenario;
    let mut contact = Contact::new(surface, &cfg.contact)?;
    check_approach(&mut contact, trajectory)?;
    let dt = 1.0 / cfg.control_rate_hz;
    let mut sea = SeaCurrent::new(
        sc.current_m_s,
        sc.current_variation_m_s,
        sc.current_correlation_s,
        sc.current_smoothing_s,
        dt,
        cfg.seed,
    );
    let mut sensors = Sensors::new(&cfg.sensors, cfg.seed, h.translation.vector, dt);
    let mut fcu = Fcu::new(&cfg.force);
    let mut icu = Icu::new(&cfg.icu, &cfg.sensors, dt).on_vehicle(&ctrl);
    let mut joints = JointControl::new(&cfg.joints, &hover.q_start);
    let units = &ctrl_model.thrusters.units;
    let thruster_lag = units.iter().map(|u| u.time_constant).sum::<f64>() / units.len().max(1) as f64;
    let mut vc = VehicleControl::new(&cfg.vehicle, &h, thruster_lag);
    let mut nav = Navigation::new(&cfg.navigation, &cfg.sensors, h.translation.vector, g);
    // A water track, if the vehicle has one, pinged while the station was held: the flow past
    // the vehicle at rest is the current.
    let pings = (cfg.navigation.levelling_s * cfg.sensors.water_track_rate_hz).round() as usize;
    let flow_at_rest = h.rotation.inverse() * plant.system.current;
    vc.settle_water_track(sensors.water_track_mean(&flow_at_rest, pings), &h.rotation);

    // The station was held before the run, in the current if there is one: the thrusters held
    // the vehicle and the arm at rest against their weight, buoyancy and the water (the
    // plant's static wrench), the drives the arm's static load as the controllers' model has
    // it, and over the hold the stabilisation's integral and the controllers' estimate of the
    // current had converged. Their fixed point: the current the closed loop's thrust gives,
    // the arm's static load in that current (the open loop takes its drag), and the thrust
    // left to the closed loop. Started from the model's wrench in still water, a current set
    // the vehicle drifting at the start and the ICU took the arm's changing drag for a touch.
    let held = plant
        .system
        .inverse_dynamics(&plant.state, &GenVector::zeros(), &Force::ZERO)
        .fixed_rows::<6>(0)
        .into_owned();
    // The controllers' thrust is `thrust_scale` times the plant's: what they command for a
    // thrust `T` of their model, the plant's thrusters give as `T / thrust_scale`; they hold
    // the plant's static wrench by asking for `held_asked`.
    let to_plant = 1.0 / cfg.controller_model.thrust_scale;
    let held_asked = held * cfg.controller_model.thrust_scale;
    let to_plant_commands = |mut alloc: Allocation| {
        for t in &mut alloc.thrusts {
            *t *= to_plant;
        }
        alloc
    };
    // At rest the accelerometers read the specific force `−g` (`C` axes): as the controllers
    // expect it, and as the plant's gravity gives it.
    let rest_force = |g: f64| h.rotation.inverse() * Vector3::new(0.0, 0.0, -g);
    let f_rest = rest_force(g);
    let zero = JointVector::zeros();
    let mut trim = Vector6::zeros();
    let mut current = Vector3::zeros();
    let static_in = |current: &Vector3<f64>| {
        let at_rest =
            BaseMotion::on_vehicle(arm, &h.rotation, &Vector6::zeros(), &Vector6::zeros(), g, current);
        arm.inverse_dynamics(&hover.q_start, &zero, &zero, &at_rest, None)
    };
    let mut static_id = static_in(&current);
    let (mut moved, mut relax) = (f64::INFINITY, HOLD_RELAXATION);
    // The thrust the trim leaves unheld: zero where the loop integrates, and what it cannot
    // hold at the station where it does not (an axis without integral gain). The trim has
    // converged when it stops changing (the current may stop first: still water assumed).
    let mut unheld: Option<Vector6<f64>> = None;
    for _ in 0..HOLD_ITERATIONS {
        let open0 = -arm.base_wrench_in_body(&static_id.wrench_on_base);
        let asked = vc.wrench(&held_station(&hover, f_rest), &nav, &ctrl.vehicle, g, &open0, 0.0);
        let left = held_asked - asked;
        let trimmed = unheld.is_some_and(|u| (left - u).norm() < HOLD_TOLERANCE_N);
        unheld = Some(left);
        trim += left * relax;
        vc.trim(&trim);
        let next = vc.current(&ctrl.vehicle, &h.rotation);
        let step = (next - current).norm();
        if step >= moved {
            relax *= 0.5;
        }
        moved = step;
        current = next;
        static_id = static_in(&current);
        if moved < HOLD_TOLERANCE_M_S && trimmed {
            break;
        }
    }
    let speed = current.norm();
    if speed.is_nan() || speed > MAX_CURRENT_M_S {
        let (speed, sea) = (shown_to(speed, 2), shown_to(plant.system.current.norm(), 2));
        let estimate = format!(
            "the controllers' estimate of the current at the station held before the run is {speed} m/s (the sea's {sea} m/s), faster than any sea"
        );
        // With a water track the estimate is its reading; without, the thrust's through the
        // controllers' model of the vehicle's drag.
        return Err(if cfg.sensors.water_track_rate_hz > 0.0 {
            Error::failed(
                "sim",
                format!(
                    "{estimate}: the water track's mean reading, [sim.sensors] water_track_noise_m_s {} m/s over {} pings",
                    shown(cfg.sensors.water_track_noise_m_s),
                    pings.max(1)
                ),
            )
        } else {
            Error::input(
                "sim.controller_model",
                format!(
                    "{estimate}: their vehicle's drag (the model's damping times vehicle_damping_scale) is too weak against their links' (times link_hydro_scale) to read the current from the thrust (or set [sim.vehicle] current_filter_s = 0 to assume still water)"
                ),
            )
        });
    }
    if moved >= HOLD_TOLERANCE_M_S {
        return Err(Error::failed(
            "sim",
            format!(
                "the station held before the run has no equilibrium in the current: the controllers' estimate of it, {} m/s, still moved by {moved:.1e} m/s after {HOLD_ITERATIONS} iterations (the arm's drag outweighs the vehicle's; [sim.vehicle] current_filter_s = 0 assumes still water)",
                shown_xyz(&current.into(), 3)
            ),
        ));
    }
    plant
        .thrusters
        .hold(&to_plant_commands(allocator.allocate(&held_asked)).thrusts)?;
    let first_eval = plant.system.accelerations(
        &plant.state,
        &Inputs {
            tau_drive: static_id.tau,
            body_wrench: plant.thrusters.wrench(),
            f_env_on_tool: Force::ZERO,
        },
    )?;
    // What the sensors read comes of the plant's gravity (the controllers' is the same value
    // today, but theirs is a belief).
    let g_plant = plant_model.environment.gravity;
    let mut truth_prev = truth_of(&plant.state, &first_eval, g_plant, &plant.system.current);
    // NS levelled the accelerometers while the station was held.
    let at_rest = Truth {
        specific_force: rest_force(g_plant),
        ..truth_prev
    };
    let levelling = (cfg.navigation.levelling_s * cfg.control_rate_hz).round() as usize;
    nav.level(&sensors.accelerometers_mean(&at_rest, levelling), &h.rotation);

    let force_setpoint = (
        trajectory
            .phase(Phase::Contact)
            .map(|s| s.force)
            .reduce(f64::min)
            .unwrap_or(0.0),
        trajectory.samples.iter().map(|s| s.force).fold(0.0, f64::max),
    );
    let log_every = ((cfg.control_rate_hz / cfg.log_rate_hz).round() as usize).max(1);
    let mut rec = Recorder::new(force_setpoint, cfg.settle_time_s);
    let mut clock = t0;
    let mut q_set = hover.q_start;
    // The feed-forward rate's refresh: every `rate_every` periods, from the target then.
    let rate_every =
        ((cfg.control_rate_hz / (20.0 * cfg.joints.rate_feedforward_hz)).floor() as usize).max(1);
    let mut rate_from: Option<Isometry3<f64>> = None;
    let mut qd_set = JointVector::zeros();
    // The true values of the previous period, which the identification (made of that period's
    // sensor readings) is scored against.
    let mut m_ez_true_prev = JointVector::zeros();
    let mut f_env_true_prev = Vector3::zeros();
    // The force the bumpless start holds (below), from the period the force loop takes over;
    // zero once the trajectory's ramp has reached it.
    let mut held: Option<f64> = None;
    // The force the dwell's ramp rises to (the first contact point's).
    let ramp_to = trajectory
        .phase(Phase::Contact)
        .next()
        .map_or(force_setpoint.1, |s| s.force);
    // The guarded start's speed: the approach's, into its last point.
    let guard_speed = trajectory
        .samples
        .windows(2)
        .find(|w| w[0].phase == Phase::Approach && w[1].phase != Phase::Approach)
        .map_or(0.0, |w| {
            (w[1].position - w[0].position).norm() / (w[1].t - w[0].t)
        });
    let mut guarding = cfg.dwell.touch_n > 0.0 && guard_speed > 0.0;
    let (mut dwell_wait, mut settled_for) = (0.0, 0.0);
    let (mut unreachable, mut saturated) = (0usize, 0usize);
    // The arm's least distance from a joint limit (the plant's joints, for the record), rad,
    // and the joint.
    let mut limit_margin = (f64::INFINITY, 0usize);
    let wall = std::time::Instant::now();
    let mut k = 0usize;
    let sub_dt = dt / cfg.plant_substeps as f64;
    loop {
        let t = k as f64 * dt;
        if clock > t_end + cfg.tail_s - 1e-12 {
            break;
        }
        // NS: what the controllers know (of the state one period ago), with the attitude,
        // position and velocity estimated.
        let meas = nav.update(sensors.read(t, &truth_prev), t, dt);
        let omega = meas.omega;
        let nu_est = Vector6::new(0.0, 0.0, 0.0, omega.x, omega.y, omega.z);
        // The sea current as the stabilisation has felt it (learnt until the touch, then held).
        let current = vc.current(&ctrl.vehicle, &meas.attitude);
        let base = BaseMotion::on_vehicle(arm, &meas.attitude, &nu_est, &Vector6::zeros(), g, &current)
            .with_current_rate(arm, &meas.attitude, &vc.current_rate());
        // The desired tool state.
        let mut s = trajectory
            .sample_at(clock)
            .ok_or_else(|| Error::input("trajectory", "has no samples"))?;
        // ICU (the commanded accelerations are its fallback, `[sim.icu] acceleration`), zeroed
        // in the approach until the touch.
        let approach = s.phase == Phase::Approach;
        // The ICU's and the joint controllers' inverse dynamics at the measured state share
        // their velocity terms.
        let vt = arm.velocity_terms(&meas.q, &meas.qd, &base);
        let id = icu.identify(arm, &meas, &vt, &joints.drive(), &base, approach, dt);
        let r_w0 = meas.attitude * arm.t_body_base().rotation;
        let f_imp_est = r_w0 * id.f_imp_base;
        // FCU.
        // Force control where the trajectory asks for a force; a sampler dragged at a set depth
        // (force 0) is position-controlled.
        let pressing = matches!(s.phase, Phase::Dwell | Phase::Contact) && s.force > 0.0;
        // A bumpless start: where the tool already presses when the force loop takes over (the
        // true surface stands out of the planned one, and the approach touched it), the
        // set-point rises from that force, held until the trajectory's ramp reaches it (or the
        // dwell ends). Ramping from zero, the loop pulled the tool back off the surface.
        if pressing {
            let from = held.get_or_insert_with(|| s.k.dot(&f_imp_est).min(ramp_to).max(0.0));
            if s.force >= *from || s.phase == Phase::Contact {
                *from = 0.0;
            } else {
                s.force = *from;
            }
        }
        let offset = if !cfg.scenario.force_loop {
            0.0
        } else if pressing {
            let before = fcu.offset();
            let after = fcu.update(force_error(s.force, &s.k, &f_imp_est), dt);
            // The dwell's guarded start (`[sim.dwell] touch_n`): until the tool is felt
            // pressing, its target moves towards the surface at least at the approach's speed.
            if guarding && s.phase == Phase::Dwell {
                if s.k.dot(&f_imp_est) >= cfg.dwell.touch_n.min(ramp_to) {
                    guarding = false;
                } else {
                    fcu.advance((before + guard_speed * dt - after).max(0.0));
                }
            }
            fcu.offset()
        } else if s.phase == Phase::Retreat {
            fcu.offset()
        } else {
            0.0
        };
        // TCU: eq. (18) and the IK.
        let target = Isometry3::from_parts(
            Translation3::from(s.position.coords + s.k * offset),
            s.orientation,
        );
        let believed = if cfg.scenario.trajectory_correction {
            tcu::vehicle_pose(&nav.position, &meas.attitude)
        } else {
            h
        };
        // The IK refuses only a target that is not finite: the controllers' estimates ran out
        // of range.
        let out_of_range = |e: Error| {
            Error::failed(
                "sim",
                format!(
                    "at t = {t:.3} s the controllers' tool target is not finite ({e}): a value out of range (a sensor noise, a force set-point, a model scale?); last finite state: {}",
                    describe(&plant.state)
                ),
            )
        };
        match tcu::set_point(arm, &tcu::tool_in_base(arm, &target, &believed), &q_set)
            .map_err(out_of_range)?
        {
            Some(q) => q_set = q,
            // Along the path; in the tail the last target is held and the run is done.
            None if clock <= t_end => unreachable += 1,
            None => {}
        }
        // The set-points' rate from the desired tool motion alone (the trajectory and the
        // FCU's offset), the vehicle held where NS believes it now: the target of the last
        // refresh at today's belief. The vehicle's own turning is left to the reference filter:
        // fed forward too it took the bottle's force transient from 66–72 to 63–66 N, but pumped
        // the arm's reaction into the soil run's roll (‖r‖ 0.011 → 0.026 m). The rate passes a
        // `rate_feedforward_hz` low-pass, which is all but blind above twenty times its cut-off,
        // so it is refreshed at that rate (every `rate_every` periods, one IK solve instead of
        // one a period) over the refresh's whole interval.
        if cfg.joints.rate_feedforward_hz > 0.0 && k.is_multiple_of(rate_every) {
            if let Some(prev) = rate_from {
                qd_set = tcu::set_point(arm, &tcu::tool_in_base(arm, &prev, &believed), &q_set)
                    .map_err(out_of_range)?
                    .map_or_else(JointVector::zeros, |q| (q_set - q) / (rate_every as f64 * dt));
            }
            rate_from = Some(target);
        }
        joints.follow(&q_set, &qd_set, dt);
        // The drive torques, and the arm's wrench on the vehicle for the commanded motion under
        // the identified tool force (the open loop of eq. 17) from the same inverse dynamics.
        let f_e = Force::new(-id.f_imp_base, Vector3::zeros());
        let (tau, arm_on_base) = joints.torque(arm, &vt, &id.m_ez, &f_e, dt);
        // AUV SS with the open loop of eq. (17).
        let open = if cfg.scenario.open_loop {
            -arm.base_wrench_in_body(&arm_on_base)
        } else {
            Force::ZERO
        };
        vc.learn_current(!icu.touched());
        let tau_vehicle = vc.wrench(&meas, &nav, &ctrl.vehicle, g, &open, dt);
        let alloc = to_plant_commands(allocator.allocate(&tau_vehicle));
        if alloc.scale < 1.0 {
            saturated += 1;
        }
        // The plant: contact against the true surface, then the step, the contact's velocity
        // dependence linearly implicit. The sensors sample the plant at the period's start
        // (`StepReport::sample`), so the true contact force of the period (logged, and the
        // true external moments) is the one at that instant, which the sampled shaft torques
        // answer.
        let state = plant.state;
        let (t_world_tool, cs, jacobian, damping) = touch(&mut contact, &plant.system, &state);
        let tip = t_world_tool.translation.vector;
        // ‖e‖: the tool tip minus where the control system wants it, `P* + ΔP*`.
        let deviation = tip - target.translation.vector;
        let m_ez_true = external_moments(&plant.system, &state, &jacobian, &cs.wrench.lin);
        if k.is_multiple_of(log_every) {
            rec.push(Row::new(&record::RowInput {
                t,
                clock,
                sample: &s,
                offset,
                deviation: &deviation,
                state: &state,
                hover: &h,
                q_ref: &joints.q_ref,
                tau: &tau,
                m_ez_true: &m_ez_true_prev,
                m_ez_id: &id.m_ez,
                f_env_true: &f_env_true_prev,
                f_imp_est: &f_imp_est,
                t_world_tool: &t_world_tool,
                current: &plant.system.current,
                thrusts: plant.thrusters.thrusts(),
                in_contact: cs.in_contact(),
            }));
        }
        let margin = plant.system.arm.limit_margin(&state.q);
        if margin.0 < limit_margin.0 {
            limit_margin = margin;
        }
        // Out of contact while the trajectory asks for it: a force, or a target inside the
        // material deeper than a skim (the depth is looked up only out of contact).
        let lost_contact = !cs.in_contact()
            && matches!(s.phase, Phase::Dwell | Phase::Contact)
            && (s.force > 0.0 || contact.depth(&s.position) > cfg.skim_depth_m());
        rec.observe(&record::Observation {
            phase: s.phase,
            t,
            lost_contact,
            f_k_true: -s.k.dot(&cs.wrench.lin),
            f_set: s.force,
            f_norm: cs.wrench.lin.norm(),
            f_k_id_error: s.k.dot(&(f_imp_est + f_env_true_prev)),
            in_contact: cs.in_contact(),
            m_ez_error: (id.m_ez - m_ez_true_prev).amax(),
            deviation: deviation.norm(),
            path_error: {
                let d = tip - s.position.coords;
                (d - s.k * s.k.dot(&d)).norm()
            },
            r: (state.t_world_body.translation.vector - h.translation.vector).norm(),
            attitude: state.t_world_body.rotation.angle_to(&h.rotation),
            offset,
            thrust_utilisation: alloc.utilisation,
        });
        // The plant's water over the period ahead.
        plant.system.current = sea.step();
        plant.system.current_rate = sea.rate();
        let mut first_acc = None;
        for sub in 0..cfg.plant_substeps {
            let (contact_now, damping_now) = if sub > 0 {
                let (_, c, _, d) = touch(&mut contact, &plant.system, &plant.state);
                (c, d)
            } else {
                (cs, damping)
            };
            let input = PlantInput {
                tau_drive: tau,
                thrust_cmd: &alloc.thrusts,
                f_env_on_tool: contact_now.wrench,
            };
            let report = plant
                .step_with_tool_damping(sub_dt, &input, damping_now.as_ref())
                .map_err(|e| diverged(&e, t, &plant.state))?;
            first_acc.get_or_insert(report.sample);
        }
        check_runaway(&plant.state, &h, t + dt, || {
            let station = if cfg.scenario.current_m_s == cfg.hover.current_m_s {
                String::new()
            } else {
                format!(
                    "; the station was chosen for a current of {} m/s, the scenario's is {} m/s ([sim.hover] current_m_s)",
                    shown_xyz(&cfg.hover.current_m_s, 2),
                    shown_xyz(&cfg.scenario.current_m_s, 2)
                )
            };
            let varying = if cfg.scenario.current_varies() {
                format!(
                    "; the current varies (standard deviations {} m/s) and was {} m/s",
                    shown_xyz(&cfg.scenario.current_variation_m_s, 2),
                    shown_xyz(&sea.now().into(), 2)
                )
            } else {
                String::new()
            };
            format!(
                "; the thrusters saturated in {:.1} % of the periods{station}{varying}",
                100.0 * saturated as f64 / (k + 1) as f64
            )
        })?;
        if let Some(acc) = &first_acc {
            truth_prev = truth_of(&state, acc, g_plant, &plant.system.current);
        }
        m_ez_true_prev = m_ez_true;
        f_env_true_prev = cs.wrench.lin;
        // The trajectory's clock: it waits at the end of a dwell until the force has settled.
        let next = clock + dt;
        let leaving_dwell = s.phase == Phase::Dwell
            && trajectory
                .sample_at(next)
                .is_some_and(|n| n.phase != Phase::Dwell);
        let settled = (s.k.dot(&f_imp_est) - s.force).abs() < cfg.dwell.tolerance_n;
        settled_for = if settled { settled_for + dt } else { 0.0 };
        if leaving_dwell && settled_for < cfg.dwell.hold_s && dwell_wait < cfg.dwell.max_wait_s {
            dwell_wait += dt;
        } else {
            clock = next;
        }
        k += 1;
        if k.is_multiple_of(1000) {
            progress(((clock - t0) / (t_end - t0 + cfg.tail_s).max(1e-9)).min(1.0));
        }
    }
    let simulated = k as f64 * dt;
    let wall_s = wall.elapsed().as_secs_f64();
    let rpy = h.rotation.euler_angles();
    let p = h.translation.vector;
    let summary = SimSummary {
        figures: rec.figures(),
        realtime_factor: if wall_s > 0.0 {
            simulated / wall_s
        } else {
            f64::INFINITY
        },
        simulated_s: simulated,
        dwell_wait_s: dwell_wait,
        unreachable_steps: unreachable,
        joint_limit_margin_rad: limit_margin.0,
        joint_limit_margin_joint: limit_margin.1 + 1,
        thrust_saturated_fraction: saturated as f64 / k.max(1) as f64,
        hover_position_m: [p.x, p.y, p.z],
        hover_yaw_deg: rpy.2.to_degrees(),
        hover_manipulability: hover.manipulability,
        hover_thrust_utilisation: hover.thrust_utilisation,
        hover_drive_utilisation: hover.drive_utilisation,
        scenario: cfg.scenario,
    };
    Ok(SimOutput {
        rows: rec.into_rows(),
        summary,
        contact_depth_m: trajectory
            .phase(Phase::Contact)
            .map(|s| contact.depth(&s.position))
            .reduce(f64::max),
    })
}

/// Checks that the surface of `contact` faces the tool where the trajectory first presses on
/// it, and that the trajectory's approach, if it has one, starts outside it.
///
/// # Errors
/// [`Error::Input`] naming `surface` when the surface's normal where the tool first presses
/// points along the tool's push `k` and the approach (if any) starts inside the material: the
/// surface is wound inside out (or is not the one the trajectory was planned on). Without the
/// check the run failed as the tool, touching from the start, pushed off a surface that is not
/// where the normals say. Either sign alone can mislead on a real scan (an approach starting
/// behind a fragment of it, a normal turned on a sliver), both together do not.
fn check_approach(contact: &mut Contact, trajectory: &Trajectory) -> Result<()> {
    let Some(touch) = trajectory.samples.iter().find(|s| s.phase != Phase::Approach) else {
        return Ok(());
    };
    let (_, normal) = contact.depth_and_normal(&touch.position);
    let start = trajectory
        .samples
        .first()
        .filter(|s| s.phase == Phase::Approach)
        .map(|s| contact.depth(&s.position));
    if normal.dot(&touch.k) > 0.0 && start.is_none_or(|d| d > 0.0) {
        let starts = start.map_or(String::new(), |d| {
            format!(
                "the trajectory's approach starts {:.1} mm inside the material by its normals, and ",
                d * 1e3
            )
        });
        return Err(Error::input(
            "surface",
            format!(
                "{starts}where the tool first presses on it (t = {:.2} s) its normal points along the tool's push, {:.0}° from facing the tool: its triangles are wound inside out, their normals pointing into the material (or it is not the surface the trajectory was planned on)",
                touch.t,
                normal.angle(&-touch.k).to_degrees()
            ),
        ));
    }
    Ok(())
}

/// The fastest sea current a configuration may set, m/s.
const MAX_CURRENT_M_S: f64 = 5.0;

/// Checks the sea current `current` (m/s) of the configuration's `key`.
///
/// # Errors
/// [`Error::Input`] naming `key` unless it is finite and at most [`MAX_CURRENT_M_S`] fast.
pub(crate) fn check_current(key: &str, current: [f64; 3]) -> Result<()> {
    let [cx, cy, cz] = current;
    let speed = cx.hypot(cy).hypot(cz);
    // The strongest tidal races run at some 5 m/s; an AUV works in a fraction of that.
    require(
        speed <= MAX_CURRENT_M_S,
        key,
        format!(
            "must be finite and at most {MAX_CURRENT_M_S} m/s fast (no sea current is faster), got {} m/s",
            shown(speed)
        ),
    )
}

/// Checks what the simulation needs of a plant's model beyond its own validation: no sea
/// current of its own (the scenario's is the simulation's).
///
/// # Errors
/// [`Error::Input`] naming `environment.current`.
pub fn check_plant_model(model: &UvmsModel) -> Result<()> {
    require(
        model.environment.current == [0.0; 3],
        "environment.current",
        "the simulation's sea current is [sim.scenario] current_m_s; set it there and leave the model's at zero",
    )
}

/// What only the trajectory tells of a run configured by `cfg`: its length in plant steps
/// (control periods times `plant_substeps`, at most 10⁸) and a settling time that leaves a
/// settled force to measure. `uvms run` asks this of the plan before any stage writes.
/// Returns the trajectory's first and last times.
///
/// # Errors
/// [`Error::Input`] naming the trajectory (as `name`: its file, say) or the key.
pub fn check_trajectory(trajectory: &Trajectory, cfg: &SimConfig, name: &str) -> Result<(f64, f64)> {
    let (Some(first), Some(last)) = (trajectory.samples.first(), trajectory.samples.last()) else {
        return Err(Error::input(name, "has no samples"));
    };
    let (t0, t_end) = (first.t, last.t);
    // The longest run the trajectory, the tail and the dwell's wait can make, in periods, and
    // in the plant's steps (a fine control rate times many substeps is as long a run).
    let periods = (t_end - t0 + cfg.tail_s + cfg.dwell.max_wait_s) * cfg.control_rate_hz;
    let steps = periods * cfg.plant_substeps as f64;
    if steps.is_nan() || steps > MAX_STEPS {
        return Err(Error::input(
            name,
            format!(
                "the run could take {periods:.3e} control periods (trajectory {:.3e} s, sim.tail_s {:.3e} s, sim.dwell.max_wait_s {:.3e} s at sim.control_rate_hz {}) of sim.plant_substeps {} plant steps each, {steps:.3e} steps: at most {MAX_STEPS:.0e}",
                t_end - t0,
                cfg.tail_s,
                cfg.dwell.max_wait_s,
                cfg.control_rate_hz,
                cfg.plant_substeps
            ),
        ));
    }
    // The settled force is measured from `settle_time_s` after the first contact (about the
    // dwell's start) to the contact phase's end: a settling time as long leaves nothing of it.
    let touching = trajectory
        .samples
        .iter()
        .find(|s| matches!(s.phase, Phase::Dwell | Phase::Contact));
    if let (Some(start), Some(end)) = (touching, trajectory.phase(Phase::Contact).last())
        && cfg.settle_time_s >= end.t - start.t
    {
        return Err(Error::input(
            "sim.settle_time_s",
            format!(
                "{} s from the first contact would outlast the trajectory's dwell and contact phases ({:.2} s): no settled force would be left to measure",
                cfg.settle_time_s,
                end.t - start.t
            ),
        ));
    }
    Ok((t0, t_end))
}

/// The controllers' model of the system: the plant's `plant_model` with `[sim.controller_model]`'s
/// scales, and its multibody.
///
/// # Errors
/// [`Error::Input`] naming `sim.controller_model` if the scaled model is not a valid one, or
/// `sim.vehicle.current_filter_s` if its vehicle has no drag to read the current from.
pub fn controllers_model(cfg: &SimConfig, plant_model: &UvmsModel) -> Result<(UvmsModel, Multibody)> {
    let model = cfg.controller_model.apply(plant_model);
    let system = Multibody::new(&model).map_err(|e| {
        Error::input(
            "sim.controller_model",
            format!("the controllers' model, the plant's with these scales, is not a valid model: {e}"),
        )
    })?;
    if cfg.vehicle.current_filter_s > 0.0 && system.vehicle.velocity_against_drag(&Vector3::zeros()).is_none()
    {
        return Err(Error::input(
            "sim.vehicle.current_filter_s",
            "the controllers' vehicle has no damping on some linear axis to estimate the current with (sim.controller_model.vehicle_damping_scale = 0, or a model without Fossen damping); set it to 0 to assume still water",
        ));
    }
    Ok((model, system))
}

/// The longest tail, dwell wait and current correlation time, s: about a day, the longest run
/// at 1 kHz.
const MAX_WAIT_S: f64 = 1e5;

/// The most plant steps (control periods times substeps) a run may take: 10⁸, a day of
/// simulated time at 1 kHz (some ten minutes of computing at 150× real time).
const MAX_STEPS: f64 = 1e8;

/// Iterations of the held station's fixed point, the step below which it has settled, m/s,
/// and the share of the thrust's residual an iteration first takes. The full residual
/// overshoots by the arm's share of the water's force on the system (more estimated current,
/// more of the arm's drag in the open loop, less thrust left to the closed loop), and in a
/// vertical current, across the arm's links, that share is about the vehicle's own and the
/// plain iteration swung. The share halves whenever a step is no shorter than the last: across
/// a strong current the drag's slope is the linear damping's alone, steep against the
/// quadratic's along it, and a 0.8 m/s current swung the estimate's cross component by
/// ±0.05 m/s for good at half the residual.
const HOLD_ITERATIONS: usize = 200;
const HOLD_TOLERANCE_M_S: f64 = 1e-9;
const HOLD_RELAXATION: f64 = 0.5;
/// The held station's trim has converged when the thrust it leaves unheld changes by less, N.
const HOLD_TOLERANCE_N: f64 = 1e-6;

/// What the sensors report of the station held before the run (no vision fix yet), with the
/// accelerometers reading `specific_force`.
fn held_station(hover: &Hover, specific_force: Vector3<f64>) -> sensors::Measurements {
    let h = &hover.t_world_body;
    sensors::Measurements {
        q: hover.q_start,
        qd: JointVector::zeros(),
        m_dz: JointVector::zeros(),
        attitude: h.rotation,
        omega: Vector3::zeros(),
        specific_force,
        position: h.translation.vector,
        position_time: f64::NEG_INFINITY,
        water_flow: None,
    }
}

/// The true tool pose at `s`, the contact there, the arm's Jacobian of the tool point and, in
/// contact, the contact force's slope against the tool point's velocity mapped to the whole
/// system's generalised velocity (for the plant's linearly implicit step).
fn touch(
    contact: &mut Contact,
    system: &Multibody,
    s: &State,
) -> (
    Isometry3<f64>,
    contact::ContactState,
    Matrix6<f64>,
    Option<ToolDamping>,
) {
    let (t_world_tool, v, jacobian) = system.tool_kinematics(s);
    let v = v.fixed_rows::<3>(0).into_owned();
    let state = contact.evaluate(&t_world_tool.translation.vector.into(), &v);
    let damping = state.in_contact().then(|| ToolDamping {
        damping: state.damping,
        jacobian: system.tool_point_jacobian(s, &t_world_tool, &jacobian),
    });
    (t_world_tool, state, jacobian, damping)
}

/// What the sensors read of `s` with the accelerations `acc` of its step (gravity `g`), in
/// the sea current `current` (world).
fn truth_of(s: &State, acc: &Accelerations, g: f64, current: &Vector3<f64>) -> Truth {
    let r = s.t_world_body.rotation;
    let v = Vector3::new(s.nu[0], s.nu[1], s.nu[2]);
    let omega = Vector3::new(s.nu[3], s.nu[4], s.nu[5]);
    // The classical acceleration of `C`'s origin from the body-axes rate of ν (Fossen).
    let a = Vector3::new(acc.nu_dot[0], acc.nu_dot[1], acc.nu_dot[2]) + omega.cross(&v);
    Truth {
        q: s.q,
        qd: s.qd,
        shaft_torque: acc.shaft_torque,
        attitude: r,
        omega,
        position: s.t_world_body.translation.vector,
        specific_force: a - r.inverse() * Vector3::new(0.0, 0.0, g),
        water_flow: r.inverse() * current - v,
    }
}

/// The true external joint moments of a tool-tip force `f_env` (world axes): `J_vᵀ F_imp`, with
/// `jacobian` the arm's Jacobian of the tool point at `s.q`.
fn external_moments(
    system: &Multibody,
    s: &State,
    jacobian: &Matrix6<f64>,
    f_env: &Vector3<f64>,
) -> JointVector {
    let r_w0 = s.t_world_body.rotation * system.arm.t_body_base().rotation;
    let f_imp_base = r_w0.inverse() * -f_env;
    jacobian.fixed_rows::<3>(0).transpose() * f_imp_base
}

fn describe(s: &State) -> String {
    let p = s.t_world_body.translation.vector;
    let list = |v: &JointVector| v.iter().map(|x| format!("{x:.3}")).collect::<Vec<_>>().join(", ");
    format!(
        "vehicle at [{:.3}, {:.3}, {:.3}] m, q = [{}] rad, q̇ = [{}] rad/s",
        p.x,
        p.y,
        p.z,
        list(&s.q),
        list(&s.qd)
    )
}

fn diverged(e: &Error, t: f64, s: &State) -> Error {
    Error::failed(
        "sim",
        format!("{e} (at t = {t:.3} s, last finite state: {})", describe(s)),
    )
}

/// A runaway (the state finite but far outside anything a hovering vehicle does) ends the run;
/// `context` adds what the run saw to the message.
fn check_runaway(s: &State, hover: &Isometry3<f64>, t: f64, context: impl Fn() -> String) -> Result<()> {
    let r = (s.t_world_body.translation.vector - hover.translation.vector).norm();
    let v = s.nu.fixed_rows::<3>(0).norm();
    let w = s.nu.fixed_rows::<3>(3).norm();
    let qd = s.qd.amax();
    if r > 2.0 || v > 5.0 || w > 10.0 || qd > 20.0 {
        return Err(Error::failed(
            "sim",
            format!(
                "the simulation ran away at t = {t:.3} s (‖r‖ = {r:.3} m, ‖v‖ = {v:.2} m/s, ‖ω‖ = {w:.2} rad/s, max |q̇| = {qd:.2} rad/s): {}{}",
                describe(s),
                context()
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run that leaves any hovering vehicle's range ends as a failed run naming the time,
    /// what ran away and what the run saw; at its station at rest it goes on.
    #[test]
    fn a_runaway_is_a_failed_run() {
        let hover = Isometry3::translation(1.0, 2.0, 3.0);
        let rest = State::at_rest(hover, JointVector::zeros());
        assert!(check_runaway(&rest, &hover, 1.0, String::new).is_ok());
        let mut far = rest;
        far.t_world_body = Isometry3::translation(1.0, 2.0, 5.5);
        let mut fast = rest;
        fast.nu[0] = 6.0;
        let mut spinning = rest;
        spinning.qd[2] = 25.0;
        for s in [far, fast, spinning] {
            let err = check_runaway(&s, &hover, 12.5, || "; what the run saw".into()).unwrap_err();
            assert!(matches!(err, Error::Failed { .. }), "{err}");
            let err = err.to_string();
            assert!(
                err.contains("ran away at t = 12.500 s") && err.ends_with("; what the run saw"),
                "{err}"
            );
        }
    }

    /// Each factor scales its own quantities of the controllers' model and nothing else; the
    /// default's new factors leave the model as it was.
    #[test]
    fn the_controllers_model_scales_the_drive_friction_and_forgets_the_current() {
        let mut plant = UvmsModel::default();
        plant.environment.current = [0.3, 0.0, 0.0];
        let m = ModelMismatch {
            drive_friction_scale: 0.5,
            rotor_inertia_scale: 1.5,
            vehicle_added_mass_scale: 0.7,
            thrust_scale: 1.25,
            ..ModelMismatch::default()
        };
        let c = m.apply(&plant);
        for (a, b) in c.arm.links.iter().zip(&plant.arm.links) {
            assert_eq!(a.viscous_friction, 0.5 * b.viscous_friction);
            assert_eq!(a.coulomb_friction, b.coulomb_friction.map(|v| 0.5 * v));
            assert_eq!(a.mass, m.link_mass_scale * b.mass);
            assert_eq!(a.motor_inertia, 1.5 * b.motor_inertia);
            assert_eq!(a.gear_ratio, b.gear_ratio);
        }
        for (a, b) in c
            .vehicle
            .added_mass
            .iter()
            .flatten()
            .zip(plant.vehicle.added_mass.iter().flatten())
        {
            assert_eq!(*a, 0.7 * b);
        }
        assert_eq!(c.vehicle.mass, plant.vehicle.mass);
        assert_eq!(c.vehicle.inertia, plant.vehicle.inertia);
        for (a, b) in c.thrusters.units.iter().zip(&plant.thrusters.units) {
            assert_eq!(a.max_thrust, 1.25 * b.max_thrust);
            assert_eq!(a.time_constant, b.time_constant);
        }
        assert_eq!(c.environment.current, [0.0; 3]);
        let matched = ModelMismatch {
            link_mass_scale: 1.0,
            link_hydro_scale: 1.0,
            vehicle_damping_scale: 1.0,
            ..ModelMismatch::default()
        };
        plant.environment.current = [0.0; 3];
        assert_eq!(matched.apply(&plant), plant);
        for bad in [
            ModelMismatch {
                drive_friction_scale: -1.0,
                ..ModelMismatch::default()
            },
            ModelMismatch {
                rotor_inertia_scale: -1.0,
                ..ModelMismatch::default()
            },
            ModelMismatch {
                vehicle_added_mass_scale: f64::NAN,
                ..ModelMismatch::default()
            },
            ModelMismatch {
                thrust_scale: 0.0,
                ..ModelMismatch::default()
            },
        ] {
            assert!(bad.validate().is_err());
        }
    }
}
