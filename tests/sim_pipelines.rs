//! `uvms run` end to end on the committed pipelines (`pipelines/`, data in `data/`): the
//! products, the nested summary, the seed's figures the closed loop reaches, the ablations that
//! must be measurably worse, and the exit codes of bad pipelines.

mod common;

use nalgebra::Vector3;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::OnceLock;
use uvms::sim::current::SeaCurrent;

fn repo(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

fn run(args: &[&str]) -> Output {
    run_in(Path::new(env!("CARGO_MANIFEST_DIR")), args)
}

/// `uvms` with the working folder `dir`.
fn run_in(dir: &Path, args: &[&str]) -> Output {
    std::process::Command::new(common::uvms_bin())
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

/// `uvms --quiet ARGS`, expected to fail with exit `code` and a one-line message: the message.
fn refused(args: &[&str], code: i32) -> String {
    refused_output(&run(&[&["--quiet"], args].concat()), code)
}

/// The one-line message of a `--quiet` run `o` expected to fail with exit `code`.
fn refused_output(o: &Output, code: i32) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(code), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    err
}

/// Runs a pipeline file (a relative path from the repository's folder); its summary. A run
/// whose contact operation failed (exit 1, its products written) has the reason under
/// `sim.failure`, and its one-line message on stderr.
fn run_pipeline(pipeline: &Path, out: &Path) -> Value {
    let o = run(&[
        "--json",
        "--quiet",
        "run",
        pipeline.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    let summary: Value = serde_json::from_slice(&o.stdout).unwrap_or_else(|_| panic!("{err}"));
    match summary["sim"]["failure"].as_str() {
        None => assert!(o.status.success(), "{err}"),
        Some(failure) => {
            assert_eq!(o.status.code(), Some(1), "{err}");
            assert!(err.lines().count() == 1 && err.contains(failure), "{err}");
        }
    }
    summary
}

/// The `summary.json` a run wrote into `out`.
fn summary_in(out: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

/// A run's `timeseries.csv` (in the folder `out`): its header and its rows' fields.
struct Series {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Series {
    fn read(out: &Path) -> Series {
        let text = std::fs::read_to_string(out.join("timeseries.csv")).unwrap();
        let mut lines = text.lines().filter(|l| !l.starts_with('#'));
        let split = |l: &str| l.split(',').map(str::to_string).collect::<Vec<_>>();
        let header = split(lines.next().unwrap());
        Series {
            header,
            rows: lines.map(split).collect(),
        }
    }

    /// The index of the column `name`.
    fn col(&self, name: &str) -> usize {
        self.header.iter().position(|h| h == name).unwrap()
    }

    /// The column `name`'s values.
    fn values(&self, name: &str) -> Vec<f64> {
        let c = self.col(name);
        self.rows.iter().map(|r| r[c].parse().unwrap()).collect()
    }
}

/// The text of the committed pipeline `name` with its paths made absolute.
fn pipeline_text(name: &str) -> String {
    std::fs::read_to_string(repo(&format!("pipelines/{name}.toml")))
        .unwrap()
        .replace("../data", repo("data").to_str().unwrap())
}

/// The bottle-cleaning pipeline with extra TOML appended (paths made absolute).
fn variant(dir: &Path, extra: &str) -> PathBuf {
    let text = pipeline_text("bottle_cleaning");
    let p = dir.join("variant.toml");
    std::fs::write(&p, format!("{text}\n{extra}\n")).unwrap();
    p
}

/// The bottle pipeline with each of `extras` appended, run side by side: their `sim`
/// summaries, in order.
fn variants(extras: &[String]) -> Vec<Value> {
    side_by_side(extras.len(), |d, i| variant(d, &extras[i]))
}

/// `n` pipelines, the `i`-th written by `make(dir, i)` into a folder of its own, run side by
/// side: their `sim` summaries, in order.
fn side_by_side(n: usize, make: impl Fn(&Path, usize) -> PathBuf + Sync) -> Vec<Value> {
    let dir = tempfile::tempdir().unwrap();
    let make = &make;
    std::thread::scope(|scope| {
        let handles: Vec<_> = (0..n)
            .map(|i| {
                let d = dir.path().join(i.to_string());
                scope.spawn(move || {
                    std::fs::create_dir_all(&d).unwrap();
                    let p = make(&d, i);
                    run_pipeline(&p, &d.join("out"))["sim"].clone()
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    })
}

/// The committed bottle pipeline's run (the longest of these), made once for the tests that
/// need it: its output folder and summary.
fn bottle_run() -> &'static (PathBuf, Value) {
    static RUN: OnceLock<(PathBuf, Value)> = OnceLock::new();
    RUN.get_or_init(|| {
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("sim_pipelines_bottle");
        let _ = std::fs::remove_dir_all(&out);
        let s = run_pipeline(Path::new("pipelines/bottle_cleaning.toml"), &out);
        (out, s)
    })
}

/// The summary's closest approach to a joint limit is the time series' (logged every tenth
/// period: within what the joints move in 10 ms) on the same joint, measured against the
/// model's limits.
#[test]
fn the_closest_joint_limit_is_the_logged_joints() {
    let (out, s) = bottle_run();
    let limits: Vec<[f64; 2]> = uvms::model::load(None)
        .unwrap()
        .arm
        .links
        .iter()
        .map(|l| l.joint_limits)
        .collect();
    let series = Series::read(out);
    let (mut least, mut joint) = (f64::INFINITY, 0);
    for (j, [lo, hi]) in limits.iter().enumerate() {
        for q in series.values(&format!("q{}", j + 1)) {
            let m = (q - lo).min(hi - q);
            if m < least {
                (least, joint) = (m, j + 1);
            }
        }
    }
    let margin = s["sim"]["joint_limit_margin_rad"].as_f64().unwrap();
    assert_eq!(s["sim"]["joint_limit_margin_joint"].as_u64(), Some(joint as u64));
    assert!(
        margin > 0.0 && margin <= least + 1e-6 && least - margin < 0.01,
        "summary {margin} rad, logged {least} rad"
    );
}

#[test]
fn bottle_cleaning_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let (out, s) = bottle_run();
    for f in [
        "scan_surface.ply",
        "aligned_reference.ply",
        "trajectory.csv",
        "trajectory.ply",
        "timeseries.csv",
        "joint_moments.svg",
        "force.png",
        "deviations.svg",
        "joints.png",
        "summary.json",
        "config.toml",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // The summary nests each stage's; the file holds the same object.
    let on_disk = summary_in(out);
    assert_eq!(on_disk["sim"]["force_setpoint_n"], s["sim"]["force_setpoint_n"]);
    assert!(s["check"]["add_s_m"].as_f64().unwrap() < 0.002, "{}", s["check"]);
    assert_eq!(s["plan"]["pattern"], "ring");
    let sim = &s["sim"];
    // The seed's figures for cleaning (DESIGN.md): contact is made and never lost, the vehicle
    // stays within 0.04 m of its stabilisation point, and the force settles near 60 N — all
    // measured on the plant's true contact force, which the controllers never see.
    assert_eq!(sim["force_setpoint_n"].as_f64().unwrap(), 60.0);
    assert!(sim["first_contact_s"].as_f64().is_some());
    assert_eq!(sim["contact_lost_s"].as_f64().unwrap(), 0.0);
    let mean = sim["force_settled_mean_n"].as_f64().unwrap();
    assert!((mean - 60.0).abs() <= 1.0, "settled mean {mean} N");
    // The transients' peak within the goal of 66 N (60.1-63.8 N on seeds 1-7), and the run's
    // largest force (the settled force's fluctuation under the vision noise too) within the
    // seed's 85 N.
    let overshoot = sim["force_overshoot_n"].as_f64().unwrap();
    let max = sim["force_max_n"].as_f64().unwrap();
    assert!(
        overshoot <= 66.0 && max <= 85.0,
        "overshoot {overshoot} N, largest {max} N"
    );
    let e = sim["tool_deviation_max_m"].as_f64().unwrap();
    assert!(e <= 0.006, "‖e‖ {e} m");
    let r = sim["auv_deviation_max_m"].as_f64().unwrap();
    assert!(r <= 0.04, "‖r‖ {r} m");
    // The timeseries is at least 100 Hz and covers the run.
    let series = Series::read(out);
    let rows = series.rows.len();
    // The joint-moment identification (M_ez from the torque sensors and the controller's model)
    // against the plant's true external moments, in the contact phase: the largest error over
    // the six joints per row, typically well within the seed's 0.5 N·m (0.17-0.18 on seeds
    // 1-3; the torque sensors' noise through the drive equation and the model's heavier links
    // set the floor).
    let phase = series.col("phase");
    let pairs: Vec<(usize, usize)> = (1..=6)
        .map(|j| {
            (
                series.col(&format!("mez{j}_true")),
                series.col(&format!("mez{j}_id")),
            )
        })
        .collect();
    let mut errors: Vec<f64> = series
        .rows
        .iter()
        .filter(|f| f[phase] == "contact")
        .map(|f| {
            let v = |i: usize| f[i].parse::<f64>().unwrap();
            pairs
                .iter()
                .map(|&(t, i)| (v(t) - v(i)).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    errors.sort_by(f64::total_cmp);
    let median = errors[errors.len() / 2];
    assert!(median <= 0.3, "identification error median {median} N·m");
    // The same at every control period in contact (the summary): its 95th percentile and its
    // largest value (0.29-0.30 and 0.61-0.71 N·m on seeds 1-3, 0.27-0.31 and 0.54-0.77 on seeds
    // 1-14; 0.34-0.36 and 0.74-0.86 on seeds 1-3 with the tool force equally weighted and eq. (2)'s
    // moments as they come; 0.52-0.55 and 2.6-3.1 with the
    // contact force along the mesh triangles' own normals, the vision fixes' corrections
    // passed on at once and single noisy readings passed through the ICU's output filter as
    // steps; 4.6 with the plain implicit friction step, which damps a joint held by friction
    // more than the continuous system the ICU's prediction follows; 0.63-0.67 and 3.8-6.7
    // without the vehicle's reaction to the drive torques in the base acceleration, 0.77-0.91
    // and 7.9-10.2 with the earlier observer).
    let id = |key: &str| sim[key].as_f64().unwrap();
    let (median, p95, max) = (
        id("moment_id_error_contact_median_nm"),
        id("moment_id_error_contact_p95_nm"),
        id("moment_id_error_contact_max_nm"),
    );
    assert!(
        median <= 0.3 && p95 <= 0.33 && max <= 1.0 && max <= id("moment_id_error_max_nm"),
        "identification error in contact: median {median}, p95 {p95}, max {max} N·m"
    );
    let simulated = sim["simulated_s"].as_f64().unwrap();
    assert!(
        rows as f64 >= 100.0 * simulated - 1.0,
        "{rows} rows for {simulated} s"
    );
    // The resolved pipeline reproduces the run: same seed, same figures.
    // From another working folder: the pipeline was named relative to the repository, and
    // the resolved file names its inputs wherever it is read from.
    let o = run_in(
        dir.path(),
        &[
            "--json",
            "--quiet",
            "run",
            out.join("config.toml").to_str().unwrap(),
            "--out",
            "again",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let again: Value = serde_json::from_slice(&o.stdout).unwrap();
    for key in [
        "force_max_n",
        "force_settled_mean_n",
        "auv_deviation_max_m",
        "moment_id_error_max_nm",
        "moment_id_error_contact_p95_nm",
    ] {
        assert_eq!(again["sim"][key], sim[key], "{key}");
    }
}

/// Soil sampling (the seed's section 4, Figures 6-8): the sampler dragged 2 cm deep along the
/// rippled sediment. The seed's figures: the vehicle within 0.013 m of its station, the tool
/// within 6 mm of its path, a force on the tool of about 70 N.
#[test]
fn soil_sampling_end_to_end() {
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("sim_pipelines_soil");
    let _ = std::fs::remove_dir_all(&out);
    let s = run_pipeline(&repo("pipelines/soil_sampling.toml"), &out);
    let sim = &s["sim"];
    let f = |key: &str| sim[key].as_f64().unwrap();
    assert!(
        f("auv_deviation_max_m") <= 0.013,
        "‖r‖ {} m",
        f("auv_deviation_max_m")
    );
    assert!(
        f("tool_deviation_max_m") <= 0.006,
        "‖e‖ {} m",
        f("tool_deviation_max_m")
    );
    assert_eq!(f("contact_lost_s"), 0.0);
    // Of the order of the seed's 70 N: the soil's resistance at 2 cm and 0.02 m/s, with its
    // normal reaction and the ripples' slopes (94-96 N on seeds 1-3).
    let force = f("contact_force_max_n");
    assert!((50.0..=140.0).contains(&force), "largest contact force {force} N");
    // The identification in contact (median 0.15-0.16, largest 0.73-0.90 N·m on seeds 1-3; the
    // largest 8.5-17 N·m while the immersion was measured to the closest surface point).
    let (median, max) = (
        f("moment_id_error_contact_median_nm"),
        f("moment_id_error_contact_max_nm"),
    );
    assert!(
        median <= 0.3 && max <= 3.0,
        "identification error in contact: median {median}, max {max} N·m"
    );
}

/// Each ablation is measurably worse on the figure its block protects, against the full system
/// on the same seed: without the open loop of eq. (17) the manipulator's reaction pushes the
/// vehicle off station (‖r‖); without the trajectory correction of eq. (18) the tool drifts
/// with the vehicle (‖e‖); without the force loop of eq. (14) the force is not held, and the
/// tool, once it has touched, leaves the surface: a failed contact operation (exit 1).
#[test]
fn ablations_are_worse_on_the_figure_their_block_protects() {
    let runs = variants(&[
        "[sim.scenario]\nopen_loop = false".into(),
        "[sim.scenario]\ntrajectory_correction = false".into(),
        "[sim.scenario]\nforce_loop = false".into(),
    ]);
    let f = |run: &Value, key: &str| run[key].as_f64().unwrap();
    assert!(runs[0]["failure"].is_null() && runs[1]["failure"].is_null());
    let lost = f(&runs[2], "contact_lost_s");
    assert!(
        lost > 1.0
            && runs[2]["failure"].as_str().is_some_and(
                |e| e.contains("the tool lost the surface") && e.contains(&format!("{lost:.3} s"))
            ),
        "{}",
        runs[2]
    );
    let full = &bottle_run().1["sim"];
    let r = f(&runs[0], "auv_deviation_max_m");
    assert!(
        r > 3.0 * f(full, "auv_deviation_max_m"),
        "‖r‖ {r} m without the open loop"
    );
    let e = f(&runs[1], "tool_deviation_max_m");
    assert!(
        e > 1.5 * f(full, "tool_deviation_max_m"),
        "‖e‖ {e} m without the trajectory correction"
    );
    let err = f(&runs[2], "force_rms_error_n");
    assert!(
        err > 3.0 * f(full, "force_rms_error_n"),
        "force RMS error {err} N without the force loop"
    );
}

/// Thrusters 20 % weaker than the controllers' model says (`[sim.controller_model] thrust_scale =
/// 1.25`: worn or fouled propellers): the controllers command each rotor for the thrust their
/// model gives, the open loop of eq. (17) then cancels four fifths of the arm's reaction, and the
/// stabilisation's integral takes up the rest — the vehicle leaves its station by three times
/// the matched run's ‖r‖ (9–10 mm on seeds 1–3), and the seed's figures hold: within 0.04 m,
/// the force 60 ± 1 N, the contact kept.
#[test]
fn thrusters_weaker_than_the_model_keep_the_seeds_figures() {
    let runs = variants(&["[sim.controller_model]\nthrust_scale = 1.25".into()]);
    let weak = &runs[0];
    let f = |run: &Value, key: &str| run[key].as_f64().unwrap();
    assert!(weak["failure"].is_null(), "{weak}");
    let r = f(weak, "auv_deviation_max_m");
    let matched = f(&bottle_run().1["sim"], "auv_deviation_max_m");
    assert!(r > 2.0 * matched && r <= 0.04, "‖r‖ {r} m (matched {matched} m)");
    let settled = f(weak, "force_settled_mean_n");
    assert!((settled - 60.0).abs() <= 1.0, "settled {settled} N");
    assert_eq!(f(weak, "contact_lost_s"), 0.0);
}

/// A 0.42 m/s sea current across the bottle (`[0.3, 0.3, 0]` m/s, world): the controllers
/// estimate it from the stabilisation's thrust, so the water's drag on the arm goes into the
/// IDP, not into the identified contact — the still-water figures hold (95 % within
/// 0.36-0.37 N·m on seeds 1-3), in a 0.2 m/s current rising across the links too, and in a
/// 0.8 m/s current from a station chosen for it (`[sim.hover] current_m_s`). Assuming still water (`current_filter_s = 0`), the drag reads as some 6 N·m of external
/// moments and the force settles a newton low.
#[test]
fn a_sea_current_is_estimated_and_not_taken_for_contact() {
    let current = "[sim.scenario]\ncurrent_m_s = [0.3, 0.3, 0.0]";
    let runs = variants(&[
        current.to_string(),
        format!("{current}\n[sim.vehicle]\ncurrent_filter_s = 0.0"),
        // Rising across the arm's links, whose drag then matches the vehicle's own: the held
        // station's fixed point must still settle.
        "[sim.scenario]\ncurrent_m_s = [0.0, 0.0, -0.2]".into(),
        // 0.8 m/s, the station chosen for it: the hull faces along it (from the station
        // chosen for still water the vehicle is blown off station).
        "[sim.scenario]\ncurrent_m_s = [0.8, 0.0, 0.0]\n[sim.hover]\ncurrent_m_s = [0.8, 0.0, 0.0]".into(),
    ]);
    let f = |run: &Value, key: &str| run[key].as_f64().unwrap();
    let heading = f(&runs[3], "hover_yaw_deg").to_radians();
    assert!(
        heading.cos().abs() > 0.9,
        "heading {} across 0.8 m/s",
        heading.to_degrees()
    );
    for estimated in [&runs[0], &runs[2], &runs[3]] {
        let settled = f(estimated, "force_settled_mean_n");
        assert!((settled - 60.0).abs() <= 1.0, "settled {settled} N");
        let p95 = f(estimated, "moment_id_error_contact_p95_nm");
        let max = f(estimated, "moment_id_error_contact_max_nm");
        assert!(
            p95 <= 0.5 && max <= 1.5,
            "identification error p95 {p95}, max {max} N·m"
        );
        assert!(f(estimated, "auv_deviation_max_m") <= 0.04);
        assert_eq!(f(estimated, "contact_lost_s"), 0.0);
    }
    let p95 = f(&runs[0], "moment_id_error_contact_p95_nm");
    let p95_still = f(&runs[1], "moment_id_error_contact_p95_nm");
    assert!(p95_still > 5.0 * p95, "p95 {p95_still} N·m assuming still water");
}

/// A changing sea current (each horizontal axis fluctuating by 0.1 m/s, the vertical by a
/// quarter of that, correlated over 10 s and smoothed over 1 s, about still water): the plant
/// feels it — the logged current is the process's and the vehicle strays further than in still
/// water, pushed by the water's drag and its acceleration —
/// and the contact operation still meets the seed's figures for the force, the contact and the
/// deviations. (The identification error grows with it: the controllers' estimate of the current
/// is held from the touch; see the README's "Known limits".)
#[test]
fn a_changing_current_is_felt_and_the_contact_holds() {
    let dir = tempfile::tempdir().unwrap();
    let p = variant(
        dir.path(),
        "[sim.scenario]\ncurrent_variation_m_s = [0.1, 0.1, 0.025]\ncurrent_correlation_s = 10.0",
    );
    let out = dir.path().join("out");
    let sim = run_pipeline(&p, &out)["sim"].clone();
    let f = |key: &str| sim[key].as_f64().unwrap();
    assert!((f("force_settled_mean_n") - 60.0).abs() <= 1.0, "{sim}");
    assert_eq!(f("contact_lost_s"), 0.0, "{sim}");
    assert!(f("tool_deviation_max_m") <= 0.006, "{sim}");
    assert!(f("auv_deviation_max_m") <= 0.04, "{sim}");
    let still = bottle_run().1["sim"]["auv_deviation_max_m"].as_f64().unwrap();
    assert!(
        f("auv_deviation_max_m") > 1.5 * still,
        "‖r‖ {} m against {still} m in still water",
        f("auv_deviation_max_m")
    );
    // The logged current is the plant's, the run's seeded process stepped every period: the
    // same process, built here from the scenario's values and the run's seed (1), gives every
    // row's value (printed to 7 digits), which a steady current, or a wrong σ, τ or seed, would
    // not.
    let series = Series::read(&out);
    let dt = 1e-3;
    let t = series.values("t_s");
    let periods = (t[t.len() - 1] / dt).round() as usize;
    let mut sea = SeaCurrent::new([0.0; 3], [0.1, 0.1, 0.025], 10.0, 1.0, dt, 1);
    let expected: Vec<Vector3<f64>> = std::iter::once(sea.now())
        .chain((0..periods).map(|_| sea.step()))
        .collect();
    let axes = ["x", "y", "z"].map(|a| series.values(&format!("current_{a}_m_s")));
    let logged: Vec<Vector3<f64>> = (0..t.len())
        .map(|i| Vector3::from_fn(|a, _| axes[a][i]))
        .collect();
    // Row k is logged at t = k dt, before the period's step.
    let worst = t
        .iter()
        .zip(&logged)
        .map(|(t, v)| (v - expected[(t / dt).round() as usize]).amax())
        .fold(0.0, f64::max);
    assert!(
        worst < 1e-6,
        "the logged current is off the process by {worst} m/s"
    );
    assert!(logged.iter().any(|v| v.amax() > 0.05), "the current barely moved");
}

/// A water track (a DVL's, `[sim.sensors] water_track_rate_hz`) measures the current the
/// thrust-based estimate, held from the touch, cannot follow: in a current fluctuating by
/// 0.1 m/s the changed current's drag on the links leaves the identification (its median error
/// 0.21 against 0.75 N·m on seed 1), and the rate of the track's estimate gives the IDP the
/// water's acceleration and the stabilisation the thrust that cancels its push on the hull
/// (with the rate, the 95 % point 0.44 N·m and ‖r‖ 11 mm; 0.58 N·m and 18 mm without it); the
/// contact keeps the seed's figures.
#[test]
fn a_water_track_follows_a_changing_current() {
    let current = "[sim.scenario]\ncurrent_variation_m_s = [0.1, 0.1, 0.025]";
    let track = format!("{current}\n[sim.sensors]\nwater_track_rate_hz = 10.0");
    let runs = variants(&[
        current.to_string(),
        track.clone(),
        format!("{track}\n[sim.vehicle]\nwater_track_rate_filter_s = 0.0"),
    ]);
    let f = |run: &Value, key: &str| run[key].as_f64().unwrap();
    let (median, p95) = (
        "moment_id_error_contact_median_nm",
        "moment_id_error_contact_p95_nm",
    );
    let (held, tracked, no_rate) = (&runs[0], &runs[1], &runs[2]);
    assert!(
        f(tracked, median) <= 2.0 / 3.0 * f(held, median) && f(tracked, p95) <= f(held, p95),
        "tracked {} / {}, held {} / {} N·m",
        f(tracked, median),
        f(tracked, p95),
        f(held, median),
        f(held, p95)
    );
    assert!(
        f(tracked, p95) <= 0.85 * f(no_rate, p95),
        "95 % point {} N·m with the water's acceleration, {} without",
        f(tracked, p95),
        f(no_rate, p95)
    );
    let r = "auv_deviation_max_m";
    assert!(
        f(tracked, r) <= 0.85 * f(no_rate, r),
        "‖r‖ {} m cancelling the water's push, {} without",
        f(tracked, r),
        f(no_rate, r)
    );
    assert!((f(tracked, "force_settled_mean_n") - 60.0).abs() <= 1.0);
    assert_eq!(f(tracked, "contact_lost_s"), 0.0);
    assert!(f(tracked, "tool_deviation_max_m") <= 0.006);
    assert!(f(tracked, "auv_deviation_max_m") <= 0.04);
}

/// A stabilisation without integral action (`position_ki = 0`, a valid gain) holds the station
/// on its proportional and rate terms: the hold before the run cannot put the water's or the
/// model's residual wrench into an integral, and leaves the current's estimate at still water
/// (it took the growing trim for a current of 0.26 m/s and the run failed to start, exit 1).
#[test]
fn a_stabilisation_without_integral_action_runs() {
    let dir = tempfile::tempdir().unwrap();
    let p = variant(dir.path(), "[sim.vehicle]\nposition_ki = 0.0");
    let sim = run_pipeline(&p, &dir.path().join("out"))["sim"].clone();
    let f = |key: &str| sim[key].as_f64().unwrap();
    assert!((f("force_settled_mean_n") - 60.0).abs() <= 1.0, "{sim}");
    assert_eq!(f("contact_lost_s"), 0.0, "{sim}");
    assert!(f("auv_deviation_max_m") <= 0.04, "{sim}");
}

/// The seed's bottle figures in the seed's own conditions: its simulation states no sensor
/// noise, and with every sensor noise-free (the encoders' resolution and the vision fix's
/// 0.25 s delay kept) the joint moments are identified within the seed's 0.5 N·m at every
/// control period in contact (0.41 N·m at most, on the first joint where the contact force
/// turns by a degree within one period), and the tool keeps within the 3 mm goal. With the
/// default noise these are the figures the sensors' noise moves (see the README).
#[test]
fn noise_free_sensors_meet_the_seed_s_identification_figure_at_every_instant() {
    let dir = tempfile::tempdir().unwrap();
    let noise_free = [
        "joint_rate_noise_rad_s_per_rt_hz",
        "torque_noise_nm_per_rt_hz",
        "attitude_noise_rad",
        "gyro_noise_rad_s_per_rt_hz",
        "accelerometer_noise_m_s2_per_rt_hz",
        "accelerometer_bias_m_s2",
        "vision_noise_m",
    ]
    .map(|k| format!("{k} = 0.0"))
    .join("\n");
    let p = variant(dir.path(), &format!("[sim.sensors]\n{noise_free}"));
    let s = run_pipeline(&p, &dir.path().join("out"));
    let f = |key: &str| s["sim"][key].as_f64().unwrap();
    let id = f("moment_id_error_contact_max_nm");
    assert!(id <= 0.5, "identification error in contact up to {id} N·m");
    let e = f("tool_deviation_max_m");
    assert!(e <= 0.003, "‖e‖ {e} m");
    assert!(
        f("force_overshoot_n") <= 66.0,
        "overshoot {} N",
        f("force_overshoot_n")
    );
    assert!((f("force_settled_mean_n") - 60.0).abs() <= 1.0);
    assert_eq!(f("contact_lost_s"), 0.0);
}

#[test]
fn bad_pipelines_are_input_errors_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let p = variant(dir.path(), "[sim.joints]\nbandwith_rad_s = 1.0");
    let o = run(&[
        "run",
        p.to_str().unwrap(),
        "--out",
        dir.path().join("o").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("bandwith_rad_s") && err.lines().count() == 1,
        "{err}"
    );
    let p2 = variant(dir.path(), "[sim.dwell]\ntolerance_n = -5.0");
    let o = run(&[
        "run",
        p2.to_str().unwrap(),
        "--out",
        dir.path().join("o2").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("variant.toml: sim.dwell.tolerance_n"));
    // Named with its table in the pipeline file, found before any stage: a perception value, a
    // line whose sampling is astronomic, a depth and a sensor's noise past any scene or sensor, a
    // current faster than any sea (the last three failed mid-run, after earlier products).
    for (extra, named) in [
        (
            "[perception.clean]\nvoxel_m = nan",
            "variant.toml: perception.clean.voxel_m",
        ),
        ("[plan.line]\nlength_m = 1e6", "variant.toml: plan.line.length_m"),
        (
            "[plan.line]\ndepth_m = 1e300",
            "variant.toml: plan.line.depth_m: 1e300 is beyond",
        ),
        (
            "[sim.sensors]\ntorque_noise_nm_per_rt_hz = 1e300",
            "variant.toml: sim.sensors.torque_noise_nm_per_rt_hz: 1e300 is beyond",
        ),
        (
            "[sim.scenario]\ncurrent_m_s = [1e300, 0.0, 0.0]",
            "variant.toml: sim.scenario.current_m_s: must be finite and at most 5 m/s fast (no sea current is faster), got 1e300 m/s",
        ),
        (
            "[sim.scenario]\ncurrent_variation_m_s = [3.0, 0.0, 0.0]",
            "variant.toml: sim.scenario.current_variation_m_s (its mean and four standard deviations): must be finite and at most 5 m/s fast",
        ),
        (
            "[sim.scenario]\ncurrent_correlation_s = 0.0",
            "variant.toml: sim.scenario.current_correlation_s: must be a finite number > 0",
        ),
        (
            "[sim.scenario]\ncurrent_variation_m_s = [0.1, 0.0, 0.0]\ncurrent_smoothing_s = 1e-4",
            "variant.toml: sim.scenario.current_smoothing_s: must be at least the control period (1/control_rate_hz = 0.001 s), got 0.0001",
        ),
        (
            "[sim.scenario]\ncurrent_variation_m_s = [0.1, 0.0, 0.0]\ncurrent_correlation_s = 1e-9",
            "variant.toml: sim.scenario.current_correlation_s: must be at least the control period (1/control_rate_hz = 0.001 s), got 1e-9",
        ),
        (
            "[sim.scenario]\ncurrent_smoothing_s = 1e6",
            "variant.toml: sim.scenario.current_smoothing_s: must be at most 1e5 s",
        ),
        // A ping rate past the control rate (a typo of 1e8 Hz drew 10⁹ pings at the start).
        (
            "[sim.sensors]\nwater_track_rate_hz = 1e8",
            "variant.toml: sim.sensors.water_track_rate_hz: must not exceed sim.control_rate_hz",
        ),
        // Values found wrong only as their stage runs (they were named without the file and
        // table, or by another key).
        (
            "[perception.cluster]\ntolerance_m = 1e-12\nspacing_factor = 0.0",
            "variant.toml: perception.cluster.tolerance_m: too small for the extent of the cloud",
        ),
        // A controllers' model that is none (it was named as the model file's key).
        (
            "[sim.controller_model]\nlink_mass_scale = 1e8",
            "variant.toml: sim.controller_model: the controllers' model, the plant's with these scales, is not a valid model: model: arm.links",
        ),
    ] {
        let p = variant(dir.path(), extra);
        let o5 = dir.path().join("o5");
        let o = run(&["run", p.to_str().unwrap(), "--out", o5.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(named), "{err}");
        assert!(!o5.exists(), "{extra}: files left");
    }
    // The `[input]` keys a stage refuses, named as the pipeline's keys (they were named as
    // `uvms plan`'s options): a ring without a reference, an initial guess without one.
    let ring = repo("data/models/bottle.ply");
    let reference = format!("reference = \"{}\"", ring.display());
    let p = pipeline_with("bottle_cleaning", dir.path(), "noref.toml", &[(&reference, "")]);
    let o8 = dir.path().join("o8");
    let err = refused(&["run", p.to_str().unwrap(), "--out", o8.to_str().unwrap()], 2);
    assert!(
        err.contains("noref.toml: input.reference: the ring pattern needs the reference model"),
        "{err}"
    );
    let scan = format!("scan = \"{}\"", repo("data/scans/sediment/scan.ply").display());
    let p = pipeline_with(
        "soil_sampling",
        dir.path(),
        "init.toml",
        &[(&scan, &format!("{scan}\ninit = \"identity\""))],
    );
    let err = refused(&["run", p.to_str().unwrap(), "--out", o8.to_str().unwrap()], 2);
    assert!(
        err.contains("init.toml: input.init: needs the reference model"),
        "{err}"
    );
    assert!(!o8.exists(), "files left");
    // A missing file is named by its key in the pipeline too.
    let p = pipeline_with(
        "soil_sampling",
        dir.path(),
        "noscan.toml",
        &[(&scan, "scan = \"nope.ply\"")],
    );
    let err = refused(&["run", p.to_str().unwrap(), "--out", o8.to_str().unwrap()], 2);
    assert!(
        err.contains("noscan.toml: input.scan: ") && err.contains("nope.ply: no such file"),
        "{err}"
    );
    assert!(!o8.exists(), "files left");
    // What only the plan tells (a turn so slow the run would take 10¹⁴ periods): found once
    // the plan is made, before its stage writes: nothing written, the folder made gone again.
    let p = variant(dir.path(), "[plan.tool]\nmax_rate_deg_s = 1e-9");
    let o7 = dir.path().join("o7");
    let err = refused(&["run", p.to_str().unwrap(), "--out", o7.to_str().unwrap()], 2);
    assert!(
        err.contains("variant.toml: the planned trajectory: the run could take"),
        "{err}"
    );
    assert!(!o7.exists(), "files left");
    // A fine control rate times many plant substeps is as long a run (4·10⁹ plant steps, some
    // four hours of computing): refused alike.
    let fine = [(
        "seed = 1",
        "seed = 1\ncontrol_rate_hz = 1e5\nplant_substeps = 1000",
    )];
    let p = pipeline_with("bottle_cleaning", dir.path(), "fine.toml", &fine);
    let err = refused(&["run", p.to_str().unwrap(), "--out", o7.to_str().unwrap()], 2);
    assert!(
        err.contains("fine.toml: the planned trajectory: the run could take 4.445e6 control periods")
            && err.ends_with("of sim.plant_substeps 1000 plant steps each, 4.445e9 steps: at most 1e8\n"),
        "{err}"
    );
    assert!(!o7.exists(), "files left");
    // Found before the first stage runs: nothing written.
    assert!(
        !dir.path().join("o2").exists(),
        "a bad value of the simulation left files"
    );
    // A controllers' vehicle without damping cannot estimate the current: found early too.
    let p4 = variant(dir.path(), "[sim.controller_model]\nvehicle_damping_scale = 0.0");
    let o4 = dir.path().join("o4");
    let o = run(&["run", p4.to_str().unwrap(), "--out", o4.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("vehicle_damping_scale"));
    assert!(!o4.exists(), "a bad controller model left files");
    // With a trace of damping, the current it reads from the held thrust is faster than any
    // sea (it was 1e48 m/s, and the run failed at once as a runaway).
    let p6 = variant(dir.path(), "[sim.controller_model]\nvehicle_damping_scale = 1e-9");
    let o6 = dir.path().join("o6");
    let err = refused(&["run", p6.to_str().unwrap(), "--out", o6.to_str().unwrap()], 2);
    assert!(
        err.contains("variant.toml: sim.controller_model: the controllers' estimate of the current"),
        "{err}"
    );
    // With a water track the estimate is the track's reading: a noise no log could make
    // (100 m/s a ping) is a failed run naming it, not the controllers' model.
    let p6 = variant(
        dir.path(),
        "[sim.sensors]\nwater_track_rate_hz = 10.0\nwater_track_noise_m_s = 100.0",
    );
    let err = refused(&["run", p6.to_str().unwrap(), "--out", o6.to_str().unwrap()], 1);
    assert!(
        err.contains("sim: the controllers' estimate of the current")
            && err.contains("[sim.sensors] water_track_noise_m_s 100 m/s over 100 pings"),
        "{err}"
    );
    let p3 = variant(dir.path(), "");
    let text = std::fs::read_to_string(&p3)
        .unwrap()
        .replace("scene_mesh.ply", "no_such_mesh.ply");
    std::fs::write(&p3, text).unwrap();
    let o3 = dir.path().join("o3");
    let o = run(&["run", p3.to_str().unwrap(), "--out", o3.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no_such_mesh.ply"));
    assert!(!o3.exists(), "a missing surface left files");
    // A surface with no triangles, and none named: the file, or the pipeline and the key.
    let points = dir.path().join("points.ply");
    std::fs::write(
        &points,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n",
    )
    .unwrap();
    let text = std::fs::read_to_string(&p3).unwrap();
    let mesh_line = text.lines().find(|l| l.starts_with("surface = ")).unwrap();
    for (surface, named) in [
        (
            format!("surface = {:?}", points.to_str().unwrap()),
            "points.ply: has no triangles",
        ),
        (String::new(), "variant.toml: sim.surface"),
    ] {
        std::fs::write(&p3, text.replace(mesh_line, &surface)).unwrap();
        let o = run(&["run", p3.to_str().unwrap(), "--out", o3.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(named) && err.lines().count() == 1, "{err}");
        assert!(!o3.exists(), "a surface with no triangles left files");
    }
    let o = run(&["run", "no/such/pipeline.toml"]);
    assert_eq!(o.status.code(), Some(2));
}

/// Values that would make the run endless or its search astronomic are input errors found
/// before anything is written, and a run never replaces its own inputs, even halfway.
#[test]
fn endless_runs_and_clashing_outputs_are_refused_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    // A pipeline refused with exit 2, one line holding each of `expect`, no output folder.
    let refused = |pipeline: &Path, expect: &[&str]| {
        let out = pipeline.with_file_name("out");
        let o = run(&["run", pipeline.to_str().unwrap(), "--out", out.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            err.lines().count() == 1 && expect.iter().all(|e| err.contains(e)),
            "{err}"
        );
        assert!(!out.exists(), "{err}: left files");
    };
    for (i, (extra, key)) in [
        ("[sim.hover]\nstep_m = 1e-6", "sim.hover"),
        ("[sim.hover]\nhorizontal_range_m = 1e300", "sim.hover"),
        (
            "[sim.hover]\nposition_m = [0.0, 0.0, 0.0]\nyaw_deg = nan",
            "sim.hover.yaw_deg",
        ),
        (
            "[sim.navigation]\nlevelling_s = 1e300",
            "sim.navigation.levelling_s",
        ),
        ("[sim.dwell]\nmax_wait_s = 1e300", "sim.dwell.max_wait_s"),
        // A fix a million seconds old: it was accepted and described the station held
        // before the run.
        (
            "[sim.sensors]\nvision_delay_s = 1e6",
            "sim.sensors.vision_delay_s",
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let d = dir.path().join(i.to_string());
        std::fs::create_dir_all(&d).unwrap();
        refused(&variant(&d, extra), &[key]);
    }
    // The committed pipeline with `from` replaced by `to`.
    let edited = |from: &str, to: &str| {
        let p = variant(dir.path(), "");
        let text = std::fs::read_to_string(&p).unwrap().replace(from, to);
        std::fs::write(&p, text).unwrap();
        p
    };
    // A zero `up` prior, found with the pipeline's values.
    refused(
        &edited("[input]\n", "[input]\nup = [0.0, 0.0, 0.0]\n"),
        &["variant.toml: input.up"],
    );
    // A point cloud for the true surface: found before the perception stages write.
    refused(&edited("scene_mesh.ply", "scan.ply"), &["scan.ply", "not a mesh"]);
    // A trajectory a billion seconds long.
    let (out, _) = bottle_run();
    let text = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let last = lines.pop().unwrap();
    let (_, rest) = last.split_once(',').unwrap();
    lines.push(format!("1e9,{rest}"));
    let long = dir.path().join("long.csv");
    std::fs::write(&long, lines.join("\n") + "\n").unwrap();
    let sim_out = dir.path().join("long_out");
    let o = run(&[
        "sim",
        "--trajectory",
        long.to_str().unwrap(),
        "--surface",
        repo("data/scans/bottle/scene_mesh.ply").to_str().unwrap(),
        "--out",
        sim_out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("control periods") && err.lines().count() == 1,
        "{err}"
    );
    // Repeating a run from its own folder's config.toml into that folder: refused before the
    // first stage, every product as it was.
    let again = dir.path().join("again");
    std::fs::create_dir_all(&again).unwrap();
    let config = again.join("config.toml");
    std::fs::copy(variant(dir.path(), ""), &config).unwrap();
    std::fs::write(again.join("summary.json"), "{}").unwrap();
    let o = run(&["run", config.to_str().unwrap(), "--out", again.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("config.toml") && err.lines().count() == 1, "{err}");
    let mut left: Vec<_> = std::fs::read_dir(&again)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    left.sort();
    assert_eq!(left, ["config.toml", "summary.json"]);
    assert_eq!(std::fs::read_to_string(again.join("summary.json")).unwrap(), "{}");
}

/// A contact operation whose tool never touches the surface is a failed run (exit 1, one line
/// naming it), its products written whole: the bottle's trajectory from its dwell to a second
/// and a half into the path (the settled force's window after `settle_time_s`), against one triangle 100 m away (off the trajectory: beyond its rim,
/// no material, no contact). The same trajectory on the bottle's own surface touches and
/// exits 0.
#[test]
fn a_contact_operation_that_never_touches_is_a_failed_run() {
    let dir = tempfile::tempdir().unwrap();
    let (out, _) = bottle_run();
    let text = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let mut header = true;
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| {
            if l.starts_with('#') || std::mem::take(&mut header) {
                return true;
            }
            let f: Vec<&str> = l.split(',').collect();
            matches!(f[12], "dwell" | "contact") && f[0].parse::<f64>().unwrap() <= 12.5
        })
        .collect();
    let short = dir.path().join("short.csv");
    std::fs::write(&short, kept.join("\n") + "\n").unwrap();
    let far = dir.path().join("far.ply");
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n100 0 0\n100 1 0\n101 0 0\n3 0 1 2\n";
    std::fs::write(&far, ply).unwrap();
    let sim = |surface: &Path, out: &Path| {
        run(&[
            "--quiet",
            "sim",
            "--trajectory",
            short.to_str().unwrap(),
            "--surface",
            surface.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let missed = dir.path().join("missed");
    let o = sim(&far, &missed);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.lines().count() == 1 && err.contains("never touched"), "{err}");
    for product in ["timeseries.csv", "summary.json", "config.toml", "force.svg"] {
        assert!(missed.join(product).is_file(), "{product} missing");
    }
    let summary = summary_in(&missed);
    assert!(
        summary["failure"]
            .as_str()
            .is_some_and(|f| f.contains("never touched"))
            && summary["first_contact_s"].is_null(),
        "{summary}"
    );
    let touched = dir.path().join("touched");
    let o = sim(&repo("data/scans/bottle/scene_mesh.ply"), &touched);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Asking for no force 10 mm off the surface (every point moved back along its force
    // direction `k`), the tool skims the bottle untouched: no failure. 1 mm further in than
    // planned the path lies some tenths of a millimetre inside the true surface (the fouling's
    // and the scan's difference; the message says how deep), the tool is pressed there,
    // position-controlled, and leaving the surface is a failure. 0.15 mm inside (the surface's
    // spring 1.5 N there, within the 3 N force tolerance: a planned surface a fraction of a
    // millimetre off the true one) it grazes it, touches and leaves: no failure, and no lost
    // contact (a target no deeper than a skim asks for none).
    let shifted = |offset_m: f64, name: &str| {
        let mut header = true;
        let moved: Vec<String> = kept
            .iter()
            .map(|l| {
                if l.starts_with('#') || std::mem::take(&mut header) {
                    return l.to_string();
                }
                let mut f: Vec<String> = l.split(',').map(str::to_string).collect();
                for axis in 0..3 {
                    let x: f64 = f[1 + axis].parse().unwrap();
                    let k: f64 = f[8 + axis].parse().unwrap();
                    f[1 + axis] = format!("{}", x + offset_m * k);
                }
                f[11] = "0".into();
                f.join(",")
            })
            .collect();
        std::fs::write(&short, moved.join("\n") + "\n").unwrap();
        let out = dir.path().join(name);
        let o = sim(&repo("data/scans/bottle/scene_mesh.ply"), &out);
        (o, summary_in(&out))
    };
    let (o, summary) = shifted(-0.01, "skimmed");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        summary["first_contact_s"].is_null() && summary.get("failure").is_none(),
        "{summary}"
    );
    let (o, _) = shifted(0.001, "pressed");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("lost the surface"), "{err}");
    let inside_mm: f64 = err
        .split("runs up to ")
        .nth(1)
        .and_then(|rest| rest.split(" mm inside the material").next())
        .and_then(|d| d.parse().ok())
        .unwrap_or_else(|| panic!("no depth in: {err}"));
    assert!(inside_mm > 0.3 && inside_mm <= 1.0, "{err}");
    let (o, summary) = shifted(0.001 - (inside_mm - 0.15) * 1e-3, "grazed");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        summary["first_contact_s"].is_number()
            && summary["contact_lost_s"].as_f64().unwrap() == 0.0
            && summary.get("failure").is_none(),
        "{summary}"
    );
}

/// `uvms sim` on `trajectory` with the configuration `config` into `out`, and `extra`
/// arguments.
fn sim_on(trajectory: &Path, config: &Path, out: &Path, extra: &[&str]) -> Output {
    let args = [
        "sim",
        "--trajectory",
        trajectory.to_str().unwrap(),
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    run(&[&args[..], extra].concat())
}

/// [`sim_on`] the bottle run's trajectory.
fn sim_bottle_trajectory(config: &Path, out: &Path, extra: &[&str]) -> Output {
    sim_on(&bottle_run().0.join("trajectory.csv"), config, out, extra)
}

/// `uvms sim` places a surface given in the scan frame by the configuration's `[frames]`: other
/// frames than the plan's (its trajectory's note) are bad input, not a run along a surface that
/// is elsewhere.
#[test]
fn a_trajectory_planned_with_other_frames_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("frames.toml");
    std::fs::write(
        &cfg,
        "[frames.camera_in_vehicle]\nxyz_m = [0.6, 0.0, 0.31]\nrpy_deg = [30.0, 0.0, 90.0]\n",
    )
    .unwrap();
    let surface = repo("data/scans/bottle/scene_mesh.ply");
    let o = sim_bottle_trajectory(
        &cfg,
        &dir.path().join("o"),
        &["--surface", surface.to_str().unwrap()],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("trajectory.csv: was planned with the scan frame 0.010 m")
            && err.contains("frames.toml's [frames]")
            && err.lines().count() == 1,
        "{err}"
    );
    assert!(!dir.path().join("o").exists());
    // Without --config the default frames are the ones compared, and the message says so.
    let text = std::fs::read_to_string(bottle_run().0.join("trajectory.csv")).unwrap();
    let moved = text.replacen(",0.3],[0.0,0.0,0.0,1.0]]", ",0.31],[0.0,0.0,0.0,1.0]]", 1);
    assert_ne!(moved, text);
    let trajectory = dir.path().join("trajectory.csv");
    std::fs::write(&trajectory, moved).unwrap();
    let out = dir.path().join("o");
    let o = run(&[
        "sim",
        "--trajectory",
        trajectory.to_str().unwrap(),
        "--surface",
        surface.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("0.010 m and 0.00° from where the default [frames] (no --config) put it")
            && err.contains("give --config the plan's configuration"),
        "{err}"
    );
    assert!(!out.exists());
}

/// A contact surface wound inside out (every triangle turned round: the trajectory's
/// approach then starts 5 cm inside the material and comes out of it) or two-sided (every
/// triangle twice, once each way) is bad input naming the file, and nothing is written: the
/// first used to be a failed run (the tool "lost the surface" it touched from the start), the
/// second a runaway.
#[test]
fn a_surface_inside_out_or_two_sided_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = uvms::io::ply::read_mesh(&repo("data/scans/bottle/scene_mesh.ply")).unwrap();
    let turned: Vec<[u32; 3]> = mesh.triangles.iter().map(|&[a, b, c]| [c, b, a]).collect();
    let inside_out = uvms::mesh::TriangleMesh {
        vertices: mesh.vertices.clone(),
        triangles: turned.clone(),
    };
    let two_sided = uvms::mesh::TriangleMesh {
        vertices: mesh.vertices.clone(),
        triangles: [mesh.triangles.clone(), turned].concat(),
    };
    for (name, surface, says) in [
        ("inside_out", inside_out, "starts 50.3 mm inside the material"),
        ("two_sided", two_sided, "holds 148619 triangles twice"),
    ] {
        let file = dir.path().join(format!("{name}.ply"));
        let mut w = std::io::BufWriter::new(std::fs::File::create(&file).unwrap());
        uvms::io::ply::write_mesh(&mut w, &surface).unwrap();
        drop(w);
        let out = dir.path().join(name);
        let o = sim_bottle_trajectory(
            &bottle_run().0.join("config.toml"),
            &out,
            &["--quiet", "--surface", file.to_str().unwrap()],
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            err.contains(&format!("{name}.ply: ")) && err.contains(says) && err.lines().count() == 1,
            "{err}"
        );
        assert!(!out.exists());
    }
}

/// A trajectory so long the run would take 10¹² control periods is refused naming the
/// trajectory's file (it was named as the configuration's `sim`), before anything is written.
#[test]
fn a_trajectory_too_long_to_simulate_is_refused_naming_its_file() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(bottle_run().0.join("trajectory.csv")).unwrap();
    let last = text.lines().last().unwrap();
    let (_, rest) = last.split_once(',').unwrap();
    let long = dir.path().join("long.csv");
    std::fs::write(&long, text.replace(last, &format!("1e9,{rest}"))).unwrap();
    let out = dir.path().join("o");
    let o = sim_on(&long, &bottle_run().0.join("config.toml"), &out, &["--quiet"]);
    let err = refused_output(&o, 2);
    assert!(
        err.starts_with(&format!(
            "error: {}: the run could take 1.000e12 control periods",
            long.display()
        )),
        "{err}"
    );
    assert!(!out.exists());
}

/// A force no hover point's thrusters can hold is a failed run that says so, before the
/// simulation (5 kN against thrusters of a few hundred newtons).
#[test]
fn a_force_beyond_the_thrusters_is_a_failed_run() {
    let dir = tempfile::tempdir().unwrap();
    let p = variant(dir.path(), "");
    let text = std::fs::read_to_string(&p).unwrap();
    assert!(text.contains("force_n = 60.0"));
    std::fs::write(&p, text.replacen("force_n = 60.0", "force_n = 5000.0", 1)).unwrap();
    // Into the folder of an earlier run: its summary and time series do not stay beside this
    // run's plan as if it had succeeded.
    let out = dir.path().join("o");
    std::fs::create_dir(&out).unwrap();
    for name in ["summary.json", "timeseries.csv", "notes.txt"] {
        std::fs::write(out.join(name), "earlier").unwrap();
    }
    let o = run(&["run", p.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("hover: the thrusters cannot hold the contact") && err.contains("up to 5000.0 N"),
        "{err}"
    );
    assert!(out.join("trajectory.csv").exists() && out.join("notes.txt").exists());
    assert!(!out.join("summary.json").exists() && !out.join("timeseries.csv").exists());
}

/// A station over a load limit is the least loaded one, taken because none searched was within
/// the limits: the report says so, naming the key; within them it says nothing of it.
#[test]
fn a_station_over_the_thrust_limit_is_said_to_be() {
    let dir = tempfile::tempdir().unwrap();
    let config = bottle_run().0.join("config.toml");
    let text = std::fs::read_to_string(&config).unwrap();
    assert!(text.contains("max_thrust_utilisation = 0.5\n"));
    let tight = dir.path().join("tight.toml");
    std::fs::write(
        &tight,
        text.replacen(
            "max_thrust_utilisation = 0.5\n",
            "max_thrust_utilisation = 0.3\n",
            1,
        ),
    )
    .unwrap();
    for (config, limit) in [(config, 0.5), (tight, 0.3)] {
        let o = sim_bottle_trajectory(&config, &dir.path().join("o"), &[]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{err}");
        let s: Value =
            serde_json::from_slice(&std::fs::read(dir.path().join("o/summary.json")).unwrap()).unwrap();
        let over = s["hover_thrust_utilisation"].as_f64().unwrap() > limit;
        assert_eq!(over, limit == 0.3, "{s}");
        assert_eq!(
            err.contains(&format!(
                "over sim.hover.max_thrust_utilisation = {limit}: no station searched was within the limits"
            )),
            over,
            "{err}"
        );
    }
}

/// The `config.toml` a `uvms run` writes configures `uvms sim` as it is (its `[sim]` and
/// `[plan.frames]`): the run's trajectory file simulated again gives the run's time series and
/// figures bit for bit (the file holds every number as it was).
#[test]
fn a_runs_config_reruns_its_simulation() {
    let dir = tempfile::tempdir().unwrap();
    let (out, summary) = bottle_run();
    let again = dir.path().join("again");
    let o = sim_bottle_trajectory(&out.join("config.toml"), &again, &["--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rerun: Value = serde_json::from_slice(&o.stdout).unwrap();
    // The pipeline leaves the initial guess unset: the resolved file states its default.
    let resolved = std::fs::read_to_string(out.join("config.toml")).unwrap();
    assert!(resolved.contains("\ninit = \"auto\"\n"), "{resolved}");
    let read = |d: &Path| std::fs::read(d.join("timeseries.csv")).unwrap();
    assert!(read(out) == read(&again), "the time series differ");
    for key in [
        "force_settled_mean_n",
        "force_overshoot_n",
        "tool_deviation_max_m",
        "auv_deviation_max_m",
        "first_contact_s",
        "moment_id_error_contact_max_nm",
    ] {
        assert_eq!(summary["sim"][key], rerun[key], "{key}");
    }
}

/// The committed pipeline `name` with its scene's mesh replaced by the run's scanned surface
/// (`sim.surface_from = "scan"`), written as `scanned.toml` into `dir` (paths made absolute).
fn on_the_scan(name: &str, dir: &Path) -> PathBuf {
    let text = pipeline_text(name);
    let (lines, replaced): (Vec<_>, Vec<_>) = text
        .lines()
        .map(|l| {
            if l.starts_with("surface = ") {
                ("surface_from = \"scan\"", true)
            } else {
                (l, false)
            }
        })
        .unzip();
    assert_eq!(
        replaced.iter().filter(|r| **r).count(),
        1,
        "{name}: one sim.surface"
    );
    let text = lines.join("\n");
    let p = dir.join("scanned.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// For a real scan, with no truer mesh, the tool touches what the camera saw
/// (`sim.surface_from = "scan"`): the soil pipeline on the seabed the run triangulated from its
/// sediment scan instead of the scene's mesh. The surface it took is written (scan frame) and
/// lies on the true sediment within the stereo noise; the closed loop meets the seed's soil
/// figures on it; `uvms sim --surface` on that file reruns the simulation.
#[test]
fn soil_sampling_on_the_scanned_seabed() {
    let dir = tempfile::tempdir().unwrap();
    let scene = repo("data/scans/sediment/scene_mesh.ply");
    let p = on_the_scan("soil_sampling", dir.path());
    let out = dir.path().join("out");
    let s = run_pipeline(&p, &out);
    let sim = &s["sim"];
    let f = |key: &str| sim[key].as_f64().unwrap();
    assert!(f("auv_deviation_max_m") <= 0.013, "{sim}");
    assert!(f("tool_deviation_max_m") <= 0.006, "{sim}");
    assert_eq!(f("contact_lost_s"), 0.0);
    assert!((50.0..=140.0).contains(&f("contact_force_max_n")), "{sim}");
    // The surface is the scanned one, not the scene's: on the true sediment within the stereo
    // noise (σ_z 1.8 mm at 1 m, the triangulation's smoothing), but not on it.
    let touched = uvms::io::ply::read_mesh(&out.join("contact_surface.ply")).unwrap();
    let truth = uvms::surface::Surface::new(&uvms::io::ply::read_mesh(&scene).unwrap()).unwrap();
    let d: Vec<f64> = touched
        .vertices
        .iter()
        .map(|v| truth.project(v).distance)
        .collect();
    let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
    eprintln!(
        "scanned seabed: {} vertices, RMS {rms:.5} m off the scene's mesh",
        d.len()
    );
    assert!(d.len() > 1000 && (2e-4..=3e-3).contains(&rms), "RMS {rms} m");
    // The written surface reruns the simulation (to its single-precision coordinates).
    let (trajectory, config) = (out.join("trajectory.csv"), out.join("config.toml"));
    let surface = out.join("contact_surface.ply");
    let o = sim_on(
        &trajectory,
        &config,
        &dir.path().join("again"),
        &["--json", "--quiet", "--surface", surface.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rerun: Value = serde_json::from_slice(&o.stdout).unwrap();
    for key in ["tool_deviation_max_m", "auv_deviation_max_m"] {
        let (a, b) = (f(key), rerun[key].as_f64().unwrap());
        assert!((a - b).abs() <= 5e-5, "{key}: run {a}, rerun {b}");
    }
    // Without --surface, uvms sim has no run to take the surface from: it says what to give.
    let refused_dir = dir.path().join("refused");
    let err = refused_output(&sim_on(&trajectory, &config, &refused_dir, &["--quiet"]), 2);
    assert!(
        err.contains("sim.surface_from") && err.contains("--surface OUT/contact_surface.ply"),
        "{err}"
    );
    assert!(!refused_dir.exists());
    // Both a file and the run's own surface: which one is meant is not clear.
    let both = std::fs::read_to_string(&p).unwrap().replace(
        "surface_from = \"scan\"",
        "surface_from = \"scan\"\nsurface = \"x.ply\"",
    );
    std::fs::write(&p, both).unwrap();
    let both = dir.path().join("both");
    let err = refused(&["run", p.to_str().unwrap(), "--out", both.to_str().unwrap()], 2);
    assert!(
        err.contains("scanned.toml: sim.surface: is given with sim.surface_from"),
        "{err}"
    );
}

/// Scan to contact operation on a real stereo scan made by others (`UVMS_REAL_DATA`): PCL's
/// milk carton on its table (`milk.ply`, the carton's points, as the reference), a ring around
/// the carton at 60 N on the surface the camera saw (`sim.surface_from = "scan"`). The table's
/// normal in the camera frame is (0.007, −0.823, −0.568): the camera looked 35° below the
/// horizontal, its mounting here. The real surface is rough (the stereo's noise, the carton's
/// edges), so the friction turns fast: the contact must hold, the settled force and ‖e‖, ‖r‖
/// meet the bottle's figures; with a tool's footprint the identification and the force's
/// peaks too.
#[test]
fn a_ring_around_a_real_milk_carton_on_its_scanned_surface() {
    let (Some(scene), Some(milk)) = (
        common::real_data("milk_cartoon_all_small_clorox.ply"),
        common::real_data("milk.ply"),
    ) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("milk.toml");
    std::fs::write(
        &p,
        format!(
            "[input]\nscan = {:?}\nreference = {:?}\n\n[plan]\npattern = \"ring\"\n\n\
             [plan.timing]\ndwell_s = 1.0\nforce_ramp_s = 1.0\n\n\
             [plan.frames.camera_in_vehicle]\nxyz_m = [0.6, 0.0, 0.3]\nrpy_deg = [55.0, 0.0, 90.0]\n\n\
             [sim]\nseed = 1\nsurface_from = \"scan\"\n",
            scene.to_str().unwrap(),
            milk.to_str().unwrap()
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    let s = run_pipeline(&p, &out);
    let sim = &s["sim"];
    eprintln!("milk carton: {sim}");
    assert!(sim["failure"].is_null(), "{sim}");
    let f = |key: &str| sim[key].as_f64().unwrap();
    assert_eq!(f("contact_lost_s"), 0.0);
    // Settled means 59.2-60.2 N and peaks 70-89 N over seeds 1-5 (the carton's edges and the
    // stereo's roughness: the bottle's 85 N is not a figure for this surface).
    assert!((f("force_settled_mean_n") - 60.0).abs() <= 2.0, "{sim}");
    assert!(f("force_max_n") <= 100.0, "{sim}");
    assert!(f("tool_deviation_max_m") <= 0.006, "{sim}");
    assert!(f("auv_deviation_max_m") <= 0.04, "{sim}");
    // The surface touched is the check stage's triangulation of the carton, as written.
    let touched = uvms::io::ply::read_mesh(&out.join("contact_surface.ply")).unwrap();
    let scanned = uvms::io::ply::read_mesh(&out.join("scan_surface.ply")).unwrap();
    assert_eq!(touched.triangles, scanned.triangles);
    assert_eq!(touched.vertices, scanned.vertices);

    // A tool with a 15 mm footprint sees the surface at its own size: the point contact's
    // steps are gone (identification peaks 7.3-8.1 N·m with a point, 0.46-0.68 with the
    // footprint over seeds 1-5; force peaks 70-89 N against 63-68 N).
    let text = std::fs::read_to_string(&p).unwrap() + "\n[sim.contact]\nfootprint_radius_m = 0.015\n";
    std::fs::write(&p, text).unwrap();
    let s = run_pipeline(&p, &dir.path().join("footprint"));
    let sim = &s["sim"];
    eprintln!("milk carton, 15 mm footprint: {sim}");
    let g = |key: &str| sim[key].as_f64().unwrap();
    assert!(sim["failure"].is_null() && g("contact_lost_s") == 0.0, "{sim}");
    assert!((g("force_settled_mean_n") - 60.0).abs() <= 1.0, "{sim}");
    assert!(
        g("force_max_n") <= 70.0 && g("force_rms_error_n") < f("force_rms_error_n"),
        "{sim}"
    );
    assert!(g("moment_id_error_contact_max_nm") <= 1.0, "{sim}");
    assert!(
        g("moment_id_error_contact_max_nm") < f("moment_id_error_contact_max_nm") / 5.0,
        "{sim}"
    );
}

/// A footprint too small for the surface mesh's triangles (each cut until its pieces are no
/// longer than half the radius: 1 µm on the bottle's scene would take trillions of samples)
/// is bad input found before any stage writes; so is a footprint on soil.
#[test]
fn a_footprint_the_surface_cannot_take_is_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    for (name, radius, says) in [
        ("bottle_cleaning", "1e-6", "samples of the surface mesh"),
        // A plate, not a tool: it took 34 s where the point takes 1.3 s.
        ("bottle_cleaning", "0.5", "wider than a tool's footprint"),
        ("soil_sampling", "0.01", "applies to a rigid surface"),
    ] {
        let footprint = format!("[sim.contact]\nfootprint_radius_m = {radius}");
        let file = format!("{name}.toml");
        let p = pipeline_with(name, dir.path(), &file, &[("[sim.contact]", &footprint)]);
        let out = dir.path().join(name);
        let err = refused(&["run", p.to_str().unwrap(), "--out", out.to_str().unwrap()], 2);
        assert!(
            err.contains("sim.contact.footprint_radius_m") && err.contains(says),
            "{err}"
        );
        assert!(!out.exists());
    }
}

/// The bottle's ring crosses holes of its scan (stereo shadows), where the plan put the points
/// on the aligned reference: on the scanned surface alone the tool would fall into them (tried:
/// the tool off the bottle for 10 s, 554 N on a hole's edge). A failed run before the
/// simulation, naming the holes and what to take instead.
#[test]
fn the_scanned_surface_must_cover_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let p = on_the_scan("bottle_cleaning", dir.path());
    let out = dir.path().join("out");
    let err = refused(&["run", p.to_str().unwrap(), "--out", out.to_str().unwrap()], 1);
    assert!(
        err.contains("points of the dwell and contact phases lie over holes of the scanned surface")
            && err.contains("surface_from = \"reference\""),
        "{err}"
    );
    // The plan's products are whole; the simulation's never started.
    assert!(out.join("trajectory.csv").exists() && !out.join("timeseries.csv").exists());
    // The aligned reference holds the object, not the seabed a line runs on: refused up front.
    let line = std::fs::read_to_string(&p)
        .unwrap()
        .replace("surface_from = \"scan\"", "surface_from = \"reference\"")
        .replace("pattern = \"ring\"", "pattern = \"line\"");
    std::fs::write(&p, line).unwrap();
    let lined = dir.path().join("line");
    let err = refused(&["run", p.to_str().unwrap(), "--out", lined.to_str().unwrap()], 2);
    assert!(err.contains("the line pattern runs on the seabed"), "{err}");
    assert!(!lined.exists());
}

/// The committed pipeline `pipeline` with each of its lines `from` changed to `to`, written into
/// `dir` as `name`.
fn pipeline_with(pipeline: &str, dir: &Path, name: &str, changes: &[(&str, &str)]) -> PathBuf {
    let mut text = pipeline_text(pipeline);
    for (from, to) in changes {
        assert!(text.contains(&format!("\n{from}\n")), "{pipeline}: {from}");
        text = text.replace(&format!("\n{from}\n"), &format!("\n{to}\n"));
    }
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// The bottle pipeline with the surface's stiffness `k` (N/m, as TOML writes it) for the
/// seed's 1e4, written into `dir`.
fn bottle_on_stiffness(dir: &Path, k: &str) -> PathBuf {
    let to = format!("stiffness_n_m = {k}");
    pipeline_with(
        "bottle_cleaning",
        dir,
        &format!("k{k}.toml"),
        &[("stiffness_n_m = 1e4", &to)],
    )
}

/// A stiff surface the approach already presses on (k = 1e5 N/m, ten times the seed's; the
/// fouled bottle stands out of its scan, and bottle seed 1's tool touches it 0.06 s before the
/// dwell, 12 N at its start): the force loop takes over from the force the tool presses with,
/// the set-point's ramp held there until it catches up. Ramping from zero it asked for 0.6 N,
/// pulled the tool back and lost the surface for 0.02 s (a failed run).
#[test]
fn a_stiff_surface_pressed_in_the_approach_keeps_the_contact() {
    let dir = tempfile::tempdir().unwrap();
    let p = bottle_on_stiffness(dir.path(), "1e5");
    let out = dir.path().join("out");
    let s = run_pipeline(&p, &out);
    let sim = &s["sim"];
    assert!(
        sim["failure"].is_null() && sim["contact_lost_s"].as_f64() == Some(0.0),
        "{sim}"
    );
    assert!(
        (sim["force_settled_mean_n"].as_f64().unwrap() - 60.0).abs() <= 1.0,
        "{sim}"
    );
    let series = Series::read(&out);
    let phase = series.col("phase");
    let first_dwell = series.rows.iter().position(|r| r[phase] == "dwell").unwrap();
    let pressed = series.values("fk_id_n")[first_dwell - 1];
    let asked = series.values("f_set_n")[first_dwell];
    assert!(
        pressed > 5.0 && asked >= 0.8 * pressed,
        "pressed {pressed} N, asked {asked} N"
    );
}

/// Small forces need a faster force loop than the seed's: its gains (the default) close the loop
/// on the 1e4 N/m bottle with a time constant of 0.275 s, slower than the vehicle's motion that
/// the force's fluctuation follows (RMS 2.3-2.5 N whatever the set-point), and the bottle's ring
/// at 5 N loses the surface; with four times its integral gain (`ki = 1.6e-3`) the ring holds
/// 5 N, the force's RMS error under half of the seed's gains' at 5 N.
#[test]
fn a_faster_force_loop_holds_small_forces() {
    let gains = ["ki = 4e-4", "ki = 1.6e-3"];
    let runs = side_by_side(gains.len(), |d, i| {
        let changes = [("force_n = 60.0", "force_n = 5.0"), ("ki = 4e-4", gains[i])];
        pipeline_with("bottle_cleaning", d, "small.toml", &changes)
    });
    let (seed_s, faster) = (&runs[0], &runs[1]);
    assert!(
        seed_s["contact_lost_s"].as_f64().unwrap() > 0.1 && seed_s["failure"].is_string(),
        "{seed_s}"
    );
    let f = |key: &str| faster[key].as_f64().unwrap();
    assert!(
        faster["failure"].is_null() && f("contact_lost_s") == 0.0,
        "{faster}"
    );
    assert!((f("force_settled_mean_n") - 5.0).abs() <= 0.5, "{faster}");
    assert!(
        f("force_rms_error_n") < 0.5 * seed_s["force_rms_error_n"].as_f64().unwrap(),
        "{faster} against {seed_s}"
    );
}

/// A grazing touch at the dwell's start: with the attitude sensor noise-free, bottle seed 1's
/// approach ends just touching the fouled bottle (0.2 N), and the arm, still settling after the
/// approach, lags the target the force loop moves on the set-point's ramp: the tool draws back
/// 0.15 mm in 0.1 s. The guarded start (`[sim.dwell] touch_n`) moves the target towards the
/// surface at least at the approach's speed until the tool is felt pressing: the contact is never
/// lost. Without it (`touch_n = 0`) the tool leaves the bottle for 0.14 s, a failed run.
#[test]
fn a_grazing_touch_is_pressed_home() {
    let grazing = "[sim.sensors]\nattitude_noise_rad = 0.0\n";
    let runs = variants(&[
        grazing.to_string(),
        format!("{grazing}\n[sim.dwell]\ntouch_n = 0.0\n"),
    ]);
    let (guarded, unguarded) = (&runs[0], &runs[1]);
    assert!(
        guarded["failure"].is_null() && guarded["contact_lost_s"].as_f64() == Some(0.0),
        "{guarded}"
    );
    assert!(
        (guarded["force_settled_mean_n"].as_f64().unwrap() - 60.0).abs() <= 1.0,
        "{guarded}"
    );
    assert!(
        unguarded["contact_lost_s"].as_f64().unwrap() > 0.05 && unguarded["failure"].as_str().is_some(),
        "{unguarded}"
    );
}

/// Tool targets the arm cannot reach are a failed run: the set-points held, the path was not
/// followed. Without the levelling at the held station the accelerometers' bias comes from a
/// single reading, the vehicle believes itself elsewhere, and its arm is sent out of reach
/// (tried: exit 0 with 3565 targets out of reach and ‖e‖ 55 mm). The run with the levelling
/// reaches every target.
#[test]
fn unreachable_targets_fail_the_run() {
    let levelled = &bottle_run().1["sim"];
    let runs = variants(&["[sim.navigation]\nlevelling_s = 0.0\n".to_string()]);
    let unlevelled = &runs[0];
    assert_eq!(levelled["unreachable_steps"].as_u64(), Some(0), "{levelled}");
    let failure = unlevelled["failure"].as_str().unwrap_or_default();
    let n = unlevelled["unreachable_steps"].as_u64().unwrap();
    assert!(
        n > 0 && failure.starts_with(&format!("sim: the arm could not reach {n} of the tool's targets")),
        "{unlevelled}"
    );
}

/// A tool that strays past `sim.max_tool_deviation_m` from where the control system wants it
/// is a failed run, named by the key (soil seed 2 without eq. (17) struck the sediment 0.2 m
/// off its target in the approach and ended with exit 0). The bottle's run, ‖e‖ 2.3 mm, holds
/// the default 5 cm; a bound of 1 mm fails it.
#[test]
fn a_tool_off_its_target_fails_the_run() {
    let text = pipeline_text("bottle_cleaning");
    assert!(text.contains("[sim]\n"));
    let tight = side_by_side(1, |d, _| {
        let p = d.join("variant.toml");
        std::fs::write(
            &p,
            text.replacen("[sim]\n", "[sim]\nmax_tool_deviation_m = 0.001\n", 1),
        )
        .unwrap();
        p
    });
    let failure = tight[0]["failure"].as_str().unwrap_or_default();
    assert!(
        failure.starts_with("sim: the tool strayed")
            && failure.contains("past sim.max_tool_deviation_m = 0.001 m"),
        "{}",
        tight[0]
    );
    assert!(bottle_run().1["sim"]["failure"].is_null());
}

/// A stretch of the path that asks for no force may leave the surface: the tool off it there
/// is no lost contact (the README's `contact_lost_s`: "while a force is asked for"). The
/// bottle's ring with its force set to 0 N for 1.5 s of its slide leaves the fouled surface
/// for some 70 logged rows, every one at a 0 N set-point, and the run holds its 60 N elsewhere
/// (it failed before, exit 1, "lost the surface for 0.686 s").
#[test]
fn leaving_the_surface_where_no_force_is_asked_is_no_lost_contact() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(bottle_run().0.join("trajectory.csv")).unwrap();
    let mut zeroed = 0;
    let gap: String = text
        .lines()
        .map(|l| {
            let mut f: Vec<&str> = l.split(',').collect();
            let in_gap = f.len() == 14
                && f[12] == "contact"
                && f[0].parse::<f64>().is_ok_and(|t| (18.0..=19.5).contains(&t));
            if in_gap {
                f[11] = "0.0";
                zeroed += 1;
            }
            f.join(",") + "\n"
        })
        .collect();
    assert!(zeroed > 10, "{zeroed}");
    let trajectory = dir.path().join("gap.csv");
    std::fs::write(&trajectory, gap).unwrap();
    let out = dir.path().join("o");
    let o = sim_on(
        &trajectory,
        &bottle_run().0.join("config.toml"),
        &out,
        &["--quiet"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let series = Series::read(&out);
    let (t, contact, set) = (
        series.values("t_s"),
        series.values("contact"),
        series.values("f_set_n"),
    );
    let first = contact.iter().position(|&c| c == 1.0).unwrap();
    let off: Vec<f64> = (first..t.len())
        .filter(|&i| contact[i] == 0.0 && series.rows[i][series.col("phase")] == "contact")
        .map(|i| set[i])
        .collect();
    assert!(off.len() > 20 && off.iter().all(|&f| f == 0.0), "{off:?}");
    let s = summary_in(&out);
    assert_eq!(s["contact_lost_s"].as_f64().unwrap(), 0.0, "{s}");
    assert!(
        (s["force_settled_error_mean_n"].as_f64().unwrap()).abs() < 3.0,
        "{s}"
    );
}

/// A force asked for and not held is a failed contact operation: on a surface ten times softer
/// than planned for (k = 1e3 N/m) the force loop's offset reaches its 5 cm limit at 50 N, and
/// the dwell waits its 10 s for a force that never settles (tried: settled at 49.3 N, exit 0
/// before). The message names the limit. A settling time that outlasts the contact phase
/// leaves no settled force to measure: bad input, not a summary of NaNs.
#[test]
fn a_force_not_held_is_a_failed_run() {
    let dir = tempfile::tempdir().unwrap();
    let p = bottle_on_stiffness(dir.path(), "1e3");
    let s = run_pipeline(&p, &dir.path().join("soft"));
    let sim = &s["sim"];
    let failure = sim["failure"].as_str().unwrap_or_default();
    assert!(
        failure.contains("the force along k settled at")
            && failure.contains("sim.force.max_offset_m = 0.05 m")
            && failure.contains("sim.dwell.max_wait_s"),
        "{sim}"
    );
    let (mean, offset) = (
        sim["force_settled_mean_n"].as_f64().unwrap(),
        sim["force_offset_max_m"].as_f64().unwrap(),
    );
    assert!(mean < 57.0 && (offset - 0.05).abs() < 1e-9, "{sim}");
    // The committed run holds its force well inside the limit.
    let committed = &bottle_run().1["sim"];
    assert!(
        committed["force_offset_max_m"].as_f64().unwrap() < 0.025,
        "{committed}"
    );
    let config = dir.path().join("late.toml");
    let resolved = std::fs::read_to_string(bottle_run().0.join("config.toml")).unwrap();
    assert!(resolved.contains("settle_time_s = 1.5"));
    std::fs::write(
        &config,
        resolved.replace("settle_time_s = 1.5", "settle_time_s = 100.0"),
    )
    .unwrap();
    let o = sim_bottle_trajectory(&config, &dir.path().join("late"), &["--quiet"]);
    let err = refused_output(&o, 2);
    assert!(
        err.contains("sim.settle_time_s: 100 s from the first contact"),
        "{err}"
    );
}

/// A ring of four passes 1 cm apart (`[plan.ring] width_m = 0.03`, a steady tool): between
/// passes the path turns, and the station the search chose checking 60 of its samples flipped
/// the wrist between two of them (exit 1, "check more samples"); the search runs again checking
/// twice as many and the run cleans the band at the bottle's figures.
#[test]
fn a_multi_pass_ring_is_searched_again_with_more_samples() {
    let dir = tempfile::tempdir().unwrap();
    let (ring, force) = ("pattern = \"ring\"", "force_n = 60.0");
    let steady = format!("{ring}\n\n[plan.tool]\nx_axis = \"steady\"");
    let wide = format!("{force}\nwidth_m = 0.03");
    let p = pipeline_with(
        "bottle_cleaning",
        dir.path(),
        "wide.toml",
        &[(ring, &steady), (force, &wide)],
    );
    let s = run_pipeline(&p, &dir.path().join("o"));
    let sim = &s["sim"];
    let f = |key: &str| sim[key].as_f64().unwrap();
    assert!(sim["failure"].is_null() && f("contact_lost_s") == 0.0, "{sim}");
    assert!((f("force_settled_mean_n") - 60.0).abs() <= 1.0, "{sim}");
    assert!(f("force_overshoot_n") <= 85.0, "{sim}");
    assert!(f("tool_deviation_max_m") <= 0.006, "{sim}");
    assert!(f("auv_deviation_max_m") <= 0.04, "{sim}");
}

/// A raster on the bottle: each row's end reverses the path. With the tool's `x_G` following the
/// travel the tool must turn half round about `k` there, and no hover point follows it (exit 1
/// at the hover point); with a tool symmetric about its axis (`[plan.tool] x_axis = "steady"`)
/// the whole raster (86 s in contact, 1708 samples) is cleaned at the bottle's figures.
#[test]
fn a_raster_on_the_bottle_with_a_symmetric_tool() {
    let (ring, raster) = ("pattern = \"ring\"", "pattern = \"raster\"");
    let dir = tempfile::tempdir().unwrap();
    let travel = pipeline_with("bottle_cleaning", dir.path(), "travel.toml", &[(ring, raster)]);
    let t = dir.path().join("t");
    let err = refused(
        &["run", travel.to_str().unwrap(), "--out", t.to_str().unwrap()],
        1,
    );
    assert!(err.contains("hover: no hover point reaches"), "{err}");
    let steady_tool = format!("{raster}\n\n[plan.tool]\nx_axis = \"steady\"");
    let steady = pipeline_with(
        "bottle_cleaning",
        dir.path(),
        "steady.toml",
        &[(ring, &steady_tool)],
    );
    let s = run_pipeline(&steady, &dir.path().join("s"));
    let sim = &s["sim"];
    let f = |key: &str| sim[key].as_f64().unwrap();
    assert!(sim["failure"].is_null() && f("contact_lost_s") == 0.0, "{sim}");
    assert!((f("force_settled_mean_n") - 60.0).abs() <= 1.0, "{sim}");
    assert!(f("force_max_n") <= 85.0, "{sim}");
    assert!(f("tool_deviation_max_m") <= 0.006, "{sim}");
    assert!(f("auv_deviation_max_m") <= 0.04, "{sim}");
    assert!(f("simulated_s") > 100.0, "{sim}");
}
