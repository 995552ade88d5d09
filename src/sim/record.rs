//! What a run records: the time series (`timeseries.csv`), the figures of the summary, and the
//! plots after the seed's Figures 6–8 and 12–15.
//!
//! # `timeseries.csv`
//! One row per log period (100 Hz by default), SI units, world frame `W` (NED) unless named:
//! `t_s` (simulated time), `clock_s` (the trajectory's clock, which stops while a dwell waits for
//! the force), `phase`, `q1..q6` and `q1_ref..q6_ref` (rad), `tau1..tau6` (drive torques, N·m),
//! `mez1_true..` and `mez1_id..` (external joint moments: true `J_vᵀ F_imp`, and identified
//! `M_dz − M_wz`, N·m), `fex_true, fey_true, fez_true` and `fex_id..` (the surface's force on
//! the tool `ᴳF_e` in the tool frame `G`, true and identified, N), `fk_true_n`, `fk_id_n` (the
//! tool's force along `k`; the true values of these three pairs are the previous control
//! period's, the one whose sensor readings the identification was made of, taken along this
//! period's `k` and tool frame, so `fk_true_n` may differ from the force the summary's figures
//! count at that period by the turn of `k` over one period: up to 0.03 N), `f_set_n`,
//! `offset_m` (the FCU's `x̃`), `tool_x_m..` (tool tip),
//! `e_x_m, e_y_m, e_z_m, e_m` (tool tip minus where the control system wants it, `P* + ΔP*`),
//! `r_x_m, r_y_m, r_z_m, r_m` (vehicle minus its stabilisation point), `phi_rad, theta_rad,
//! psi_rad` (the vehicle's attitude relative to its stabilisation attitude, roll–pitch–yaw),
//! `current_x_m_s, current_y_m_s, current_z_m_s` (the sea current), `thrust1_n..`, `contact`
//! (1 in contact).

use super::Scenario;
use crate::arm::JointVector;
use crate::error::{Error, Result};
use crate::multibody::State;
use crate::plot::{Figure, Panel, Series, Stroke};
use crate::trajectory::{Phase, Sample};
use nalgebra::{Isometry3, Vector3};
use serde::Serialize;
use std::fmt::Write as _;
use std::io::Write;

/// One row of the time series.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// Simulated time, s.
    pub t: f64,
    /// The trajectory's clock, s.
    pub clock: f64,
    /// The trajectory's phase.
    pub phase: Phase,
    /// Joint angles, rad.
    pub q: JointVector,
    /// Filtered joint references, rad.
    pub q_ref: JointVector,
    /// Drive torques commanded, N·m.
    pub tau: JointVector,
    /// True external moments, N·m.
    pub m_ez_true: JointVector,
    /// Identified external moments, N·m.
    pub m_ez_id: JointVector,
    /// The surface's force on the tool in `G`, true, N.
    pub fe_true: Vector3<f64>,
    /// The same, identified, N.
    pub fe_id: Vector3<f64>,
    /// True force along `k`, N.
    pub f_k_true: f64,
    /// Identified force along `k`, N.
    pub f_k_id: f64,
    /// Desired force, N.
    pub f_set: f64,
    /// The FCU's offset, m.
    pub offset: f64,
    /// Tool tip, m.
    pub tool: Vector3<f64>,
    /// Tool deviation `e`, m.
    pub e: Vector3<f64>,
    /// Vehicle deviation `r`, m.
    pub r: Vector3<f64>,
    /// Roll, pitch, yaw relative to the stabilisation attitude, rad.
    pub rpy: [f64; 3],
    /// The sea current the plant moves in (world), m/s.
    pub current: Vector3<f64>,
    /// Thrusts, N.
    pub thrusts: Vec<f64>,
    /// In contact.
    pub contact: bool,
}

/// What a row is made from.
#[derive(Debug, Clone, Copy)]
pub struct RowInput<'a> {
    /// Simulated time, s.
    pub t: f64,
    /// The trajectory's clock, s.
    pub clock: f64,
    /// The desired state.
    pub sample: &'a Sample,
    /// The FCU's offset, m.
    pub offset: f64,
    /// The tool tip minus where the control system wants it (`P* + ΔP*`), m.
    pub deviation: &'a Vector3<f64>,
    /// The plant's state.
    pub state: &'a State,
    /// The stabilisation pose.
    pub hover: &'a Isometry3<f64>,
    /// Joint references.
    pub q_ref: &'a JointVector,
    /// Drive torques.
    pub tau: &'a JointVector,
    /// True external moments.
    pub m_ez_true: &'a JointVector,
    /// Identified external moments.
    pub m_ez_id: &'a JointVector,
    /// The surface's force on the tool (world), true.
    pub f_env_true: &'a Vector3<f64>,
    /// The tool's force on the surface (world), identified.
    pub f_imp_est: &'a Vector3<f64>,
    /// The true tool pose.
    pub t_world_tool: &'a Isometry3<f64>,
    /// The sea current (world), m/s.
    pub current: &'a Vector3<f64>,
    /// Thrusts, N.
    pub thrusts: &'a [f64],
    /// In contact.
    pub in_contact: bool,
}

impl Row {
    /// A row from the loop's quantities.
    pub fn new(i: &RowInput) -> Self {
        let s = i.sample;
        let r_g = i.t_world_tool.rotation.inverse();
        let tip = i.t_world_tool.translation.vector;
        let rel = i.hover.rotation.inverse() * i.state.t_world_body.rotation;
        let (phi, theta, psi) = rel.euler_angles();
        Row {
            t: i.t,
            clock: i.clock,
            phase: s.phase,
            q: i.state.q,
            q_ref: *i.q_ref,
            tau: *i.tau,
            m_ez_true: *i.m_ez_true,
            m_ez_id: *i.m_ez_id,
            fe_true: r_g * i.f_env_true,
            fe_id: r_g * -i.f_imp_est,
            f_k_true: -s.k.dot(i.f_env_true),
            f_k_id: s.k.dot(i.f_imp_est),
            f_set: if matches!(s.phase, Phase::Dwell | Phase::Contact) {
                s.force
            } else {
                0.0
            },
            offset: i.offset,
            tool: tip,
            e: *i.deviation,
            r: i.state.t_world_body.translation.vector - i.hover.translation.vector,
            rpy: [phi, theta, psi],
            current: *i.current,
            thrusts: i.thrusts.to_vec(),
            contact: i.in_contact,
        }
    }
}

/// One control period's figures, for the summary.
#[derive(Debug, Clone, Copy)]
pub struct Observation {
    /// The trajectory's phase.
    pub phase: Phase,
    /// Simulated time, s.
    pub t: f64,
    /// True force along `k`, N.
    pub f_k_true: f64,
    /// The force along `k` the trajectory asks for this period, N.
    pub f_set: f64,
    /// The identified force along `k` minus the true one at the instant the identification
    /// refers to (the previous control period, whose sensor readings it is made of), N.
    pub f_k_id_error: f64,
    /// Magnitude of the true contact force, N.
    pub f_norm: f64,
    /// In contact.
    pub in_contact: bool,
    /// Out of contact while the trajectory asks the tool to touch the surface (in the dwell or
    /// the contact phase, a force or a target inside the material deeper than a skim).
    pub lost_contact: bool,
    /// Largest error of the identified external moments, N·m.
    pub m_ez_error: f64,
    /// Tool deviation `‖e‖`, m.
    pub deviation: f64,
    /// Distance from the planned path across `k`, m.
    pub path_error: f64,
    /// Vehicle deviation `‖r‖`, m.
    pub r: f64,
    /// Vehicle attitude deviation, rad.
    pub attitude: f64,
    /// The FCU's offset `x̃` along `k`, m.
    pub offset: f64,
    /// The thrust the stabilisation asked for, as the largest `|T_j|/T_max,j` of its
    /// allocation before any scaling (over 1: saturated).
    pub thrust_utilisation: f64,
}

/// The figures the recorder gathers over a run (keys of the `sim` summary).
#[derive(Debug, Clone, Serialize)]
pub struct Figures {
    /// The desired force in contact, N (the largest along the trajectory).
    pub force_setpoint_n: f64,
    /// The smallest desired force in the contact phase, N (`force_setpoint_n` for a constant
    /// force).
    pub force_setpoint_min_n: f64,
    /// Mean true force along `k` in the contact phase once settled, N.
    pub force_settled_mean_n: f64,
    /// Largest true force along `k` over the whole run (every control period, the approach's
    /// included), N.
    pub force_max_n: f64,
    /// Largest true force along `k` in the transients, from the first contact until
    /// `settle_time_s` after the path starts (the contact phase): the overshoot of the force's
    /// rise in the dwell and of its response to the tool starting to slide (to the run's end
    /// if the path never starts), N (`force_max_n` also holds the peaks of the settled force's
    /// fluctuation).
    pub force_overshoot_n: f64,
    /// Largest magnitude of the true contact force (normal and tangential), N.
    pub contact_force_max_n: f64,
    /// RMS of the true force's error along `k` (against each period's set-point) in the
    /// contact phase once settled, N.
    pub force_rms_error_n: f64,
    /// Mean of the true force's error along `k` (against each period's set-point) in the
    /// contact phase once settled, N.
    pub force_settled_error_mean_n: f64,
    /// Smallest true force along `k` in the contact phase once settled, N.
    pub force_settled_min_n: f64,
    /// Largest distance of the tool tip from where the control system wants it (`P* + ΔP*`), m.
    pub tool_deviation_max_m: f64,
    /// Largest distance of the tool tip from the planned path across `k` (along the surface), m.
    pub tool_path_error_max_m: f64,
    /// Largest distance of the vehicle from its stabilisation point, `‖r‖`, m.
    pub auv_deviation_max_m: f64,
    /// Largest rotation of the vehicle from its stabilisation attitude, rad.
    pub attitude_deviation_max_rad: f64,
    /// Time without contact after the first contact while force was demanded, s.
    pub contact_lost_s: f64,
    /// Time of the first contact, s (none: never touched).
    pub first_contact_s: Option<f64>,
    /// Largest error of the identified external joint moments (the largest over the joints,
    /// every control period of the run), N·m.
    pub moment_id_error_max_nm: f64,
    /// Median over the control periods in contact of the identified external joint moments'
    /// error (the largest over the joints each period), N·m (none: never in contact).
    pub moment_id_error_contact_median_nm: Option<f64>,
    /// Its 95th percentile, N·m.
    pub moment_id_error_contact_p95_nm: Option<f64>,
    /// Its largest value, N·m.
    pub moment_id_error_contact_max_nm: Option<f64>,
    /// Largest error of the identified force along `k` once settled, N.
    pub force_id_error_max_n: f64,
    /// Median over the control periods in contact of the thrust the stabilisation asked for,
    /// as the largest `|T_j|/T_max,j` (over 1: saturated; none: never in contact): the
    /// thrusters' load that the hover point's static `hover_thrust_utilisation` estimates.
    pub thrust_utilisation_contact_median: Option<f64>,
    /// Its largest value.
    pub thrust_utilisation_contact_max: Option<f64>,
    /// Largest magnitude of the FCU's offset `x̃` along `k` (eq. 14), m: at
    /// `sim.force.max_offset_m` the force loop could not push further.
    pub force_offset_max_m: f64,
}

impl Figures {
    /// Whether the force asked for in contact varies along the path.
    pub fn setpoint_varies(&self) -> bool {
        self.force_setpoint_min_n != self.force_setpoint_n
    }
}

/// Collects the rows and the running figures.
#[derive(Debug, Clone)]
pub struct Recorder {
    rows: Vec<Row>,
    setpoint: (f64, f64),
    settle_time: f64,
    first_contact: Option<f64>,
    /// When the path (the contact phase) started after the first contact, s.
    path_start: Option<f64>,
    force_max: f64,
    overshoot: f64,
    contact_force_max: f64,
    /// Once settled: the sums of the force and of its error and squared error, their count,
    /// the smallest force.
    settled: (f64, f64, f64, usize, f64),
    force_id_error: f64,
    lost: f64,
    last_t: Option<f64>,
    m_ez_error: f64,
    m_ez_errors_contact: Vec<f64>,
    thrust_contact: Vec<f64>,
    offset: f64,
    deviation: f64,
    path_error: f64,
    r: f64,
    attitude: f64,
}

impl Recorder {
    /// A recorder for a run whose desired force in contact runs from `setpoint.0` to
    /// `setpoint.1`, settled `settle_time` after the first contact.
    pub fn new(setpoint: (f64, f64), settle_time: f64) -> Self {
        Recorder {
            rows: Vec::new(),
            setpoint,
            settle_time,
            first_contact: None,
            path_start: None,
            force_max: 0.0,
            overshoot: 0.0,
            contact_force_max: 0.0,
            settled: (0.0, 0.0, 0.0, 0, f64::INFINITY),
            force_id_error: 0.0,
            lost: 0.0,
            last_t: None,
            m_ez_error: 0.0,
            m_ez_errors_contact: Vec::new(),
            thrust_contact: Vec::new(),
            offset: 0.0,
            deviation: 0.0,
            path_error: 0.0,
            r: 0.0,
            attitude: 0.0,
        }
    }

    /// Adds a row.
    pub fn push(&mut self, row: Row) {
        self.rows.push(row);
    }

    /// Takes one control period into the figures.
    pub fn observe(&mut self, o: &Observation) {
        let dt = self.last_t.map_or(0.0, |t_prev| o.t - t_prev);
        self.last_t = Some(o.t);
        if o.in_contact && self.first_contact.is_none() {
            self.first_contact = Some(o.t);
        }
        if let Some(t1) = self.first_contact {
            if o.lost_contact {
                self.lost += dt;
            }
            if o.phase == Phase::Contact && self.path_start.is_none() {
                self.path_start = Some(o.t);
            }
            if self.path_start.is_none_or(|t2| o.t < t2 + self.settle_time) {
                self.overshoot = self.overshoot.max(o.f_k_true);
            }
            if o.phase == Phase::Contact && o.t >= t1 + self.settle_time {
                let e = o.f_k_true - o.f_set;
                self.settled.0 += o.f_k_true;
                self.settled.1 += e;
                self.settled.2 += e * e;
                self.settled.3 += 1;
                self.settled.4 = self.settled.4.min(o.f_k_true);
                self.force_id_error = self.force_id_error.max(o.f_k_id_error.abs());
            }
        }
        self.force_max = self.force_max.max(o.f_k_true);
        self.contact_force_max = self.contact_force_max.max(o.f_norm);
        self.m_ez_error = self.m_ez_error.max(o.m_ez_error);
        if o.in_contact {
            self.m_ez_errors_contact.push(o.m_ez_error);
            self.thrust_contact.push(o.thrust_utilisation);
        }
        self.offset = self.offset.max(o.offset.abs());
        self.deviation = self.deviation.max(o.deviation);
        self.path_error = self.path_error.max(o.path_error);
        self.r = self.r.max(o.r);
        self.attitude = self.attitude.max(o.attitude);
    }

    /// The figures so far.
    pub fn figures(&self) -> Figures {
        let (sum, sum_e, sum_e2, n, min) = self.settled;
        let nf = n.max(1) as f64;
        let settled = |x: f64| if n > 0 { x } else { f64::NAN };
        let mut errors = self.m_ez_errors_contact.clone();
        let mut thrust = self.thrust_contact.clone();
        Figures {
            force_setpoint_n: self.setpoint.1,
            force_setpoint_min_n: self.setpoint.0,
            force_settled_mean_n: settled(sum / nf),
            force_max_n: self.force_max,
            force_overshoot_n: self.overshoot,
            contact_force_max_n: self.contact_force_max,
            force_rms_error_n: settled((sum_e2 / nf).sqrt()),
            force_settled_error_mean_n: settled(sum_e / nf),
            force_settled_min_n: settled(min),
            tool_deviation_max_m: self.deviation,
            tool_path_error_max_m: self.path_error,
            auv_deviation_max_m: self.r,
            attitude_deviation_max_rad: self.attitude,
            contact_lost_s: self.lost,
            first_contact_s: self.first_contact,
            moment_id_error_max_nm: self.m_ez_error,
            moment_id_error_contact_median_nm: quantile(&mut errors, 0.5),
            moment_id_error_contact_p95_nm: quantile(&mut errors, 0.95),
            moment_id_error_contact_max_nm: quantile(&mut errors, 1.0),
            force_id_error_max_n: self.force_id_error,
            thrust_utilisation_contact_median: quantile(&mut thrust, 0.5),
            thrust_utilisation_contact_max: quantile(&mut thrust, 1.0),
            force_offset_max_m: self.offset,
        }
    }

    /// The rows.
    pub fn into_rows(self) -> Vec<Row> {
        self.rows
    }
}

/// The `q` quantile of `values` (the nearest rank; reorders them); `None` when empty.
fn quantile(values: &mut [f64], q: f64) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let i = ((values.len() - 1) as f64 * q.clamp(0.0, 1.0)).round() as usize;
    Some(*values.select_nth_unstable_by(i, f64::total_cmp).1)
}

/// Writes `timeseries.csv` (the module docs give the columns).
///
/// # Errors
/// [`Error::Failed`] if the writer fails.
pub fn write_csv(rows: &[Row], w: &mut dyn Write) -> Result<()> {
    let io = |e: std::io::Error| Error::failed("write timeseries.csv", e);
    let n_thr = rows.first().map_or(0, |r| r.thrusts.len());
    let mut head: Vec<String> = vec!["t_s".into(), "clock_s".into(), "phase".into()];
    for prefix in ["q{}", "q{}_ref", "tau{}", "mez{}_true", "mez{}_id"] {
        head.extend((1..=6).map(|i| prefix.replace("{}", &i.to_string())));
    }
    for s in ["true", "id"] {
        head.extend(["fex", "fey", "fez"].iter().map(|c| format!("{c}_{s}")));
    }
    for c in [
        "fk_true_n",
        "fk_id_n",
        "f_set_n",
        "offset_m",
        "tool_x_m",
        "tool_y_m",
        "tool_z_m",
        "e_x_m",
        "e_y_m",
        "e_z_m",
        "e_m",
        "r_x_m",
        "r_y_m",
        "r_z_m",
        "r_m",
        "phi_rad",
        "theta_rad",
        "psi_rad",
        "current_x_m_s",
        "current_y_m_s",
        "current_z_m_s",
    ] {
        head.push(c.into());
    }
    head.extend((1..=n_thr).map(|i| format!("thrust{i}_n")));
    head.push("contact".into());
    writeln!(
        w,
        "# uvms sim time series: SI units, world frame W (NED) unless named; see README"
    )
    .map_err(io)?;
    writeln!(w, "{}", head.join(",")).map_err(io)?;
    // One line and one list of values reused for every row: the numbers are written straight
    // into the line (formatting each into a string of its own and joining them cost a third
    // of the file's time).
    let (mut v, mut line) = (Vec::<f64>::new(), String::new());
    for r in rows {
        v.clear();
        for j in [&r.q, &r.q_ref, &r.tau, &r.m_ez_true, &r.m_ez_id] {
            v.extend(j.iter());
        }
        v.extend(r.fe_true.iter());
        v.extend(r.fe_id.iter());
        v.extend([r.f_k_true, r.f_k_id, r.f_set, r.offset]);
        v.extend(r.tool.iter());
        v.extend(r.e.iter());
        v.push(r.e.norm());
        v.extend(r.r.iter());
        v.push(r.r.norm());
        v.extend(r.rpy);
        v.extend(r.current.iter());
        v.extend(r.thrusts.iter());
        line.clear();
        // Writing into a `String` cannot fail.
        let _ = write!(line, "{:.6e},{:.6e},{}", r.t, r.clock, r.phase.as_str());
        for x in &v {
            // `+ 0.0` writes a negative zero as 0.
            let _ = write!(line, ",{:.6e}", x + 0.0);
        }
        let _ = writeln!(line, ",{}", u8::from(r.contact));
        w.write_all(line.as_bytes()).map_err(io)?;
    }
    Ok(())
}

fn series(rows: &[Row], label: &str, f: impl Fn(&Row) -> f64) -> Series {
    Series {
        label: label.to_string(),
        x: rows.iter().map(|r| r.t).collect(),
        y: rows.iter().map(f).collect(),
        ..Series::default()
    }
}

/// `s` in palette colour `color`, drawn as `stroke`.
fn styled(s: Series, color: usize, stroke: Stroke) -> Series {
    Series {
        color: Some(color),
        stroke,
        ..s
    }
}

/// A reference drawn as a band of colour `color` with the line of colour `color` that tracks it.
fn tracked(reference: Series, line: Series, color: usize) -> [Series; 2] {
    [
        styled(reference, color, Stroke::Band),
        styled(line, color, Stroke::Line),
    ]
}

/// The identification limit the seed reports for the joint moments, N·m, drawn in their error
/// panel.
const SEED_MOMENT_ERROR_NM: f64 = 0.5;

/// The run's figures after the seed's: `joint_moments` (Figures 6 and 12: external moments,
/// true and identified, and the identification error), `force` (Figures 7 and 13: the force
/// components in `G` and the force along `k`, true and identified, against its setpoint, and
/// the identification error along `k`), `deviations` (Figures 8 and 15: `‖r‖`, `‖e‖`, φ θ ψ)
/// and `joints` (Figure 14: joint coordinates and their references). A true value or a
/// reference is a pale band under the line of the same colour that identifies or tracks it.
pub fn figures(rows: &[Row], scenario: &Scenario) -> Vec<(&'static str, Figure)> {
    let tag = if scenario.open_loop && scenario.trajectory_correction && scenario.force_loop {
        String::new()
    } else {
        format!(
            " (open loop {}, correction {}, force loop {})",
            on(scenario.open_loop),
            on(scenario.trajectory_correction),
            on(scenario.force_loop)
        )
    };
    let mut moments = joint_panels(
        rows,
        ("External joint moments", "N m"),
        ["M", " true", " identified"],
        |r| (&r.m_ez_true, &r.m_ez_id),
    );
    // The seed's limit holds in contact: drawn from the first contact to the last.
    let touching = || rows.iter().filter(|r| r.contact).map(|r| r.t);
    let limit = touching()
        .next()
        .zip(touching().next_back())
        .map(|(t0, t1)| Series {
            label: format!("seed: {SEED_MOMENT_ERROR_NM} N m in contact"),
            x: vec![t0, t1, f64::NAN, t0, t1],
            y: vec![
                SEED_MOMENT_ERROR_NM,
                SEED_MOMENT_ERROR_NM,
                f64::NAN,
                -SEED_MOMENT_ERROR_NM,
                -SEED_MOMENT_ERROR_NM,
            ],
            color: Some(7),
            stroke: Stroke::Line,
        });
    moments.push(Panel {
        title: "Joint moments' identification error, identified - true (logged samples)".into(),
        y_label: "N m".into(),
        // Joint `j` is the panel's `j`-th series: the joint's colour.
        series: (0..6)
            .map(|j| {
                series(rows, &format!("M{}", j + 1), move |r| {
                    r.m_ez_id[j] - r.m_ez_true[j]
                })
            })
            .chain(limit)
            .collect(),
    });
    let comps = ["x", "y", "z"];
    let force = vec![
        Panel {
            title: "Force on the tool, tool frame G".into(),
            y_label: "N".into(),
            series: (0..3)
                .flat_map(|c| {
                    tracked(
                        series(rows, &format!("F{} true", comps[c]), move |r| r.fe_true[c]),
                        series(rows, &format!("F{} identified", comps[c]), move |r| r.fe_id[c]),
                        c,
                    )
                })
                .collect(),
        },
        Panel {
            title: "Force along k".into(),
            y_label: "N".into(),
            series: tracked(
                series(rows, "true", |r| r.f_k_true),
                series(rows, "identified", |r| r.f_k_id),
                0,
            )
            .into_iter()
            .chain([styled(series(rows, "desired", |r| r.f_set), 3, Stroke::Line)])
            .collect(),
        },
        Panel {
            title: "Force's identification error along k, identified - true (logged samples)".into(),
            y_label: "N".into(),
            series: vec![series(rows, "Fk", |r| r.f_k_id - r.f_k_true)],
        },
    ];
    let deviations = vec![
        Panel {
            title: "Deviations of the vehicle |r| and the tool |e|".into(),
            y_label: "m".into(),
            series: vec![
                series(rows, "|r|", |r| r.r.norm()),
                series(rows, "|e|", |r| r.e.norm()),
            ],
        },
        Panel {
            title: "Vehicle attitude".into(),
            y_label: "rad".into(),
            series: ["roll", "pitch", "yaw"]
                .iter()
                .enumerate()
                .map(|(c, n)| series(rows, n, move |r| r.rpy[c]))
                .collect(),
        },
    ];
    let joints = joint_panels(rows, ("Joint coordinates", "rad"), ["q", "*", ""], |r| {
        (&r.q_ref, &r.q)
    });
    let fig = |title: &str, panels| Figure {
        title: format!("{title}{tag}"),
        x_label: "t, s".into(),
        panels,
    };
    vec![
        ("joint_moments", fig("Joint moments", moments)),
        ("force", fig("Contact force", force)),
        ("deviations", fig("Vehicle and tool deviations", deviations)),
        ("joints", fig("Joint coordinates", joints)),
    ]
}

/// Two panels (joints 1-3, 4-6) of a pair of joint vectors per row, a reference (e.g. true) and
/// the value that identifies or tracks it, in the joint's colour; the series of joint `j` are
/// named `{name}{j}{first}` and `{name}{j}{second}`.
fn joint_panels(
    rows: &[Row],
    (title, unit): (&str, &str),
    [name, first, second]: [&str; 3],
    pair: fn(&Row) -> (&JointVector, &JointVector),
) -> Vec<Panel> {
    (0..2)
        .map(|g| Panel {
            title: format!("{title}, joints {}-{}", 3 * g + 1, 3 * g + 3),
            y_label: unit.into(),
            series: (3 * g..3 * g + 3)
                .flat_map(|j| {
                    tracked(
                        series(rows, &format!("{name}{}{first}", j + 1), move |r| pair(r).0[j]),
                        series(rows, &format!("{name}{}{second}", j + 1), move |r| pair(r).1[j]),
                        j,
                    )
                })
                .collect(),
        })
        .collect()
}

fn on(b: bool) -> &'static str {
    if b { "on" } else { "off" }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn observation(t: f64, in_contact: bool, m_ez_error: f64) -> Observation {
        Observation {
            phase: if in_contact {
                Phase::Contact
            } else {
                Phase::Approach
            },
            t,
            f_k_true: 0.0,
            f_set: 60.0,
            f_k_id_error: 0.0,
            f_norm: 0.0,
            in_contact,
            lost_contact: false,
            m_ez_error,
            deviation: 0.0,
            path_error: 0.0,
            r: 0.0,
            attitude: 0.0,
            offset: 0.0,
            thrust_utilisation: 0.0,
        }
    }

    /// The overshoot's window runs from the first contact, through the dwell, until
    /// `settle_time` after the path starts: the slide's start is in it, the settled force's
    /// later peaks only in the largest force.
    #[test]
    fn overshoot_spans_the_dwell_and_the_slide_s_start() {
        let mut rec = Recorder::new((60.0, 60.0), 1.0);
        let at = |t: f64, phase: Phase, f: f64| Observation {
            phase,
            f_k_true: f,
            in_contact: phase != Phase::Approach,
            ..observation(t, false, 0.0)
        };
        rec.observe(&at(0.0, Phase::Approach, 0.0));
        rec.observe(&at(0.5, Phase::Dwell, 50.0));
        rec.observe(&at(1.9, Phase::Dwell, 60.0));
        rec.observe(&at(2.0, Phase::Contact, 61.0));
        rec.observe(&at(2.9, Phase::Contact, 64.0));
        rec.observe(&at(3.1, Phase::Contact, 70.0));
        let f = rec.figures();
        assert_eq!(f.force_overshoot_n, 64.0);
        assert_eq!(f.force_max_n, 70.0);
    }

    /// The settled figures count the contact phase from `settle_time` after the first contact
    /// (a lost contact there too, as 0 N); contact is lost only after the first contact, in
    /// the periods the run found it lost (the dwell or the contact phase out of contact); the
    /// identification's quantiles take the periods in contact alone.
    #[test]
    fn settled_force_lost_contact_and_quantiles_from_hand_made_periods() {
        let mut rec = Recorder::new((60.0, 60.0), 1.0);
        let at = |t: f64, phase: Phase, in_contact: bool, f: f64| Observation {
            phase,
            f_k_true: f,
            in_contact,
            lost_contact: !in_contact && matches!(phase, Phase::Dwell | Phase::Contact),
            m_ez_error: if in_contact { 1.0 } else { 9.0 },
            ..observation(t, false, 0.0)
        };
        rec.observe(&at(0.0, Phase::Approach, false, 0.0));
        // A dwell before the first contact: not lost.
        rec.observe(&at(0.0625, Phase::Dwell, false, 0.0));
        rec.observe(&at(0.125, Phase::Dwell, true, 30.0));
        rec.observe(&at(0.5, Phase::Dwell, true, 55.0));
        // The path, within a second of the first contact: not settled yet.
        rec.observe(&at(1.0, Phase::Contact, true, 58.0));
        rec.observe(&at(1.25, Phase::Contact, true, 62.0));
        rec.observe(&at(1.375, Phase::Contact, false, 0.0));
        rec.observe(&at(1.5, Phase::Contact, true, 57.0));
        // The retreat leaves the surface: not lost.
        rec.observe(&at(1.625, Phase::Retreat, false, 0.0));
        let f = rec.figures();
        assert_eq!(f.first_contact_s, Some(0.125));
        assert_eq!(f.contact_lost_s, 0.125);
        assert!((f.force_settled_mean_n - 119.0 / 3.0).abs() < 1e-12);
        assert!((f.force_rms_error_n - (3613.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!((f.force_settled_error_mean_n + 61.0 / 3.0).abs() < 1e-12);
        assert_eq!(f.force_settled_min_n, 0.0);
        assert_eq!(f.moment_id_error_contact_max_nm, Some(1.0));
        assert_eq!(f.moment_id_error_max_nm, 9.0);
    }

    /// A set-point that varies along the path: each period's force is scored against that
    /// period's set-point, not the largest one.
    #[test]
    fn a_varying_set_point_scores_each_period_against_its_own() {
        let mut rec = Recorder::new((40.0, 65.0), 0.5);
        // The force follows a set-point rising from 40 to 65 N, 1 N above it.
        for k in 0..=25 {
            let f_set = 40.0 + k as f64;
            rec.observe(&Observation {
                f_set,
                f_k_true: f_set + 1.0,
                ..observation(0.1 * k as f64, true, 0.0)
            });
        }
        let f = rec.figures();
        assert_eq!((f.force_setpoint_min_n, f.force_setpoint_n), (40.0, 65.0));
        assert!((f.force_rms_error_n - 1.0).abs() < 1e-12);
        assert!((f.force_settled_error_mean_n - 1.0).abs() < 1e-12);
        // From 0.5 s on: set-points 45 … 65 N, forces 46 … 66 N.
        assert!((f.force_settled_mean_n - 56.0).abs() < 1e-12);
    }

    /// The identification error's and the thrust's quantiles are taken over the periods in
    /// contact only; the run's largest error over every period.
    #[test]
    fn quantiles_in_contact() {
        let mut rec = Recorder::new((60.0, 60.0), 1.0);
        rec.observe(&Observation {
            thrust_utilisation: 3.0,
            ..observation(0.0, false, 50.0)
        });
        let f = rec.figures();
        assert_eq!(f.moment_id_error_contact_median_nm, None);
        assert_eq!(f.thrust_utilisation_contact_max, None);
        // 1, 2, ..., 100 N·m in contact, shuffled, with thrusts of a hundredth of that.
        for k in 0..100 {
            let e = ((k * 37) % 100 + 1) as f64;
            rec.observe(&Observation {
                thrust_utilisation: e / 100.0,
                ..observation(1.0 + k as f64 * 1e-3, true, e)
            });
        }
        let f = rec.figures();
        assert_eq!(f.moment_id_error_max_nm, 100.0);
        assert_eq!(f.moment_id_error_contact_median_nm, Some(51.0));
        assert_eq!(f.moment_id_error_contact_p95_nm, Some(95.0));
        assert_eq!(f.moment_id_error_contact_max_nm, Some(100.0));
        assert_eq!(f.thrust_utilisation_contact_median, Some(0.51));
        assert_eq!(f.thrust_utilisation_contact_max, Some(1.0));
    }

    fn row(t: f64) -> Row {
        let v = |k: f64| JointVector::from_fn(|j, _| k * t + j as f64);
        Row {
            t,
            clock: t,
            phase: Phase::Contact,
            q: v(0.1),
            q_ref: v(0.2),
            tau: v(0.0),
            m_ez_true: v(1.0),
            m_ez_id: v(1.5),
            fe_true: Vector3::new(t, 2.0 * t, 3.0 * t),
            fe_id: Vector3::new(t, 2.0 * t, 3.5 * t),
            f_k_true: 60.0 * t,
            f_k_id: 61.0 * t,
            f_set: 60.0,
            offset: 0.0,
            tool: Vector3::zeros(),
            e: Vector3::zeros(),
            r: Vector3::zeros(),
            rpy: [0.0; 3],
            current: Vector3::zeros(),
            thrusts: vec![0.0; 8],
            contact: true,
        }
    }

    #[test]
    fn figures_draw_each_reference_as_a_band_under_its_line_and_plot_the_errors() {
        let mut rows: Vec<Row> = (0..5).map(|k| row(f64::from(k) * 0.1)).collect();
        rows[0].contact = false;
        rows[4].contact = false;
        let figs = figures(&rows, &Scenario::default());
        let panels = |name: &str| &figs.iter().find(|(n, _)| *n == name).unwrap().1.panels;
        // Every band (a true value or a reference) is followed by the line of its colour.
        for (name, _) in &figs {
            for p in panels(name) {
                for (k, s) in p.series.iter().enumerate() {
                    if s.stroke == Stroke::Band {
                        let line = &p.series[k + 1];
                        assert_eq!((line.stroke, line.color), (Stroke::Line, s.color), "{name}");
                    }
                }
            }
        }
        // Joint moments: true as bands, one colour per joint over both panels, then the error.
        let m = panels("joint_moments");
        assert_eq!(m.len(), 3);
        for (g, p) in m[..2].iter().enumerate() {
            for (k, s) in p.series.iter().enumerate() {
                let j = 3 * g + k / 2;
                assert_eq!(s.color, Some(j));
                let (stroke, label, value) = if k % 2 == 0 {
                    (Stroke::Band, format!("M{} true", j + 1), rows[4].m_ez_true[j])
                } else {
                    (Stroke::Line, format!("M{} identified", j + 1), rows[4].m_ez_id[j])
                };
                assert_eq!((s.stroke, &s.label, s.y[4]), (stroke, &label, value));
            }
        }
        for (j, s) in m[2].series[..6].iter().enumerate() {
            for (y, r) in s.y.iter().zip(&rows) {
                assert!((y - (r.m_ez_id[j] - r.m_ez_true[j])).abs() < 1e-12);
            }
        }
        let limit = &m[2].series[6];
        assert_eq!(limit.y[..2], [SEED_MOMENT_ERROR_NM; 2]);
        assert_eq!(limit.y[3..], [-SEED_MOMENT_ERROR_NM; 2]);
        // Over the contact only: from the first row in contact to the last.
        assert_eq!(
            (limit.x[0], limit.x[1], limit.x[3], limit.x[4]),
            (rows[1].t, rows[3].t, rows[1].t, rows[3].t)
        );
        rows.iter_mut().for_each(|r| r.contact = false);
        let untouched = figures(&rows, &Scenario::default());
        assert_eq!(untouched[0].1.panels[2].series.len(), 6, "no contact, no limit");
        // Force: the error along k is identified minus true.
        let f = panels("force");
        for (y, r) in f[2].series[0].y.iter().zip(&rows) {
            assert!((y - (r.f_k_id - r.f_k_true)).abs() < 1e-12);
        }
        // Joints: the reference q* is the band, the measured q the line.
        let q = &panels("joints")[1].series;
        assert_eq!((q[0].label.as_str(), q[0].stroke), ("q4*", Stroke::Band));
        assert_eq!((q[0].y[2], q[1].y[2]), (rows[2].q_ref[3], rows[2].q[3]));
    }

    #[test]
    fn the_time_series_writes_a_negative_zero_as_zero() {
        let mut r = row(0.0);
        r.e = Vector3::new(-0.0, -1e-9, 0.0);
        let mut buf = Vec::new();
        write_csv(&[r], &mut buf).unwrap();
        let text = String::from_utf8(buf).unwrap();
        let data = text.lines().last().unwrap();
        assert!(!data.contains("-0.000000e0"), "{data}");
        assert!(data.contains(",0.000000e0,-1.000000e-9,0.000000e0,"), "{data}");
    }
}
