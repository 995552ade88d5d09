//! A global initial guess for ICP that the object's symmetries cannot fool.
//!
//! Principal axes alone are ambiguous: every axis has two signs, a body of revolution has no
//! defined second axis, and a single-view scan sees half the object, so its minor axes need not
//! match the model's. So candidates are enumerated and each is judged on the data:
//! 1. each of the model's three axes is laid along the scan's major axis, both ways round (both
//!    end-to-end orientations), and turned about it in `rotation_steps` equal steps — `3 × 2 ×
//!    rotation_steps` rotations, which include the sign flips of the aligned PCA frames — except
//!    the axes along which the model is shorter than the scan (`span_tolerance`);
//! 2. each candidate's translation puts the centroids together and is then corrected by a few
//!    trimmed mean-offset steps on a few scan points against a sparse sample of the model (the
//!    scan sees the near side only, so its centroid is biased);
//! 3. each gets a short, coarse point-to-plane ICP from a few hundred scan points to the model
//!    (scan → model, since every scanned point must lie on the model while most model points are
//!    unseen) and is scored by the truncated RMS distance of the scan's points to the model,
//!    `√mean(min(d², τ²))`. The coarse ICPs run in lockstep, a few iterations at a time; between
//!    blocks a run stops when it has come within 0.1 τ of a run ahead of it (it would end where
//!    that one ends) or when its score is out of contention (step 4's bound) with the best so far —
//!    a bound that only bites once some run fits to near the noise floor — or has reached that
//!    floor, 0.1 τ (the refinement takes it on from there). The last two tests also run before the
//!    first block, on the start scores: a candidate that already fits to the floor spares every
//!    other candidate out of contention with it its coarse ICP;
//! 4. the `refine` best distinct candidates (laying the model's major axis differently, or turned
//!    by more than 90° — so both end-to-end orientations of a bottle get there) that are still in
//!    contention (`refine_within`) get a longer ICP on more points and are scored again; the best
//!    wins.
//!
//! Frames: poses map reference-model coordinates into scan coordinates (`t_scan_reference`).

use crate::cloud::pca::PrincipalAxes;
use crate::error::{Error, Result};
use crate::frames::Pose;
use crate::register::ReferenceModel;
use crate::register::icp::{IcpConfig, MAX_ITERATIONS, Surfel, icp_point_to_plane};
use crate::spatial::KdIndex;
use nalgebra::{Matrix3, Point3, Rotation3, Translation3, Unit, UnitQuaternion, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Configuration of the global initial guess.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InitConfig {
    /// Turns about the scan's major axis tried per axis pairing (8: every 45°; 1 to
    /// [`MAX_ROTATION_STEPS`]).
    pub rotation_steps: usize,
    /// Scan points (evenly strided) for the coarse ICP every candidate gets.
    pub coarse_points: usize,
    /// Scan points (evenly strided) for the trimmed mean-offset steps that correct each
    /// candidate's translation before its coarse ICP (far from the model, these queries cost the
    /// most, and a mean needs fewer points than a fit).
    pub offset_points: usize,
    /// Model points (evenly strided) for the coarse ICP.
    pub coarse_model_points: usize,
    /// Model points (evenly strided) for the mean-offset steps. Their pairs reach out to the
    /// gate, far beyond the model's point spacing, where a nearest-point query costs about as
    /// many point visits as the model has points within that distance; a mean over
    /// `offset_points` pairs needs the model only a few times denser than those scan points.
    pub offset_model_points: usize,
    /// Iterations of the coarse ICP (1 to [`MAX_ITERATIONS`]).
    pub coarse_iterations: usize,
    /// Best candidates refined further (1 to [`MAX_REFINE`]).
    pub refine: usize,
    /// Only candidates whose coarse score is within this factor of the best one's (plus 0.1 τ,
    /// the floor of a score at the noise level) are refined: the others cannot win.
    pub refine_within: f64,
    /// Scan points (evenly strided) for the refinement.
    pub sample_points: usize,
    /// Iterations of the refinement (1 to [`MAX_ITERATIONS`]).
    pub icp_iterations: usize,
    /// Gate of the short ICP as a fraction of the model's largest span, in (0, 1] and at least
    /// 0.1 × `score_fraction` (the noise floor of a score, the smallest gate a refinement uses).
    pub gate_fraction: f64,
    /// Truncation `τ` of the score as a fraction of the model's largest span, in (0, 1].
    pub score_fraction: f64,
    /// A model axis is laid along the scan's major axis only if the model's span along it is at
    /// least this fraction of the scan's major span (below 1: noise, fouling, a model that is not
    /// quite the object; 0 tries every axis).
    pub span_tolerance: f64,
}

impl Default for InitConfig {
    fn default() -> Self {
        InitConfig {
            rotation_steps: 8,
            coarse_points: 150,
            offset_points: 50,
            coarse_model_points: 4000,
            offset_model_points: 500,
            coarse_iterations: 12,
            refine: 4,
            refine_within: 3.0,
            sample_points: 500,
            icp_iterations: 20,
            gate_fraction: 0.2,
            score_fraction: 0.05,
            span_tolerance: 0.8,
        }
    }
}

/// Most turns about the scan's major axis: 1° steps, 45 times the default (`6 × 360`
/// candidates, each with its own coarse ICP).
pub const MAX_ROTATION_STEPS: usize = 360;

/// Most candidates refined: 25 times the default (the distinct candidates in contention are
/// rarely more than the few orientations a symmetric object allows).
pub const MAX_REFINE: usize = 100;

/// The floor of a score at the noise level, as a fraction of its truncation `τ`: the smallest
/// gate a refinement starts with.
const NOISE_FLOOR: f64 = 0.1;

impl InitConfig {
    /// Checks every value.
    ///
    /// # Errors
    /// [`Error::Input`] naming the field (`register.init.…`).
    pub fn validate(&self) -> Result<()> {
        use crate::config::{count_between, require};
        let key = |f: &str| format!("register.init.{f}");
        count_between(key("rotation_steps"), self.rotation_steps, 1, MAX_ROTATION_STEPS)?;
        count_between(key("refine"), self.refine, 1, MAX_REFINE)?;
        count_between(
            key("coarse_iterations"),
            self.coarse_iterations,
            1,
            MAX_ITERATIONS,
        )?;
        count_between(key("icp_iterations"), self.icp_iterations, 1, MAX_ITERATIONS)?;
        require(
            self.sample_points >= 10,
            key("sample_points"),
            format!("must be ≥ 10, got {}", self.sample_points),
        )?;
        require(
            self.refine_within >= 1.0 && self.refine_within.is_finite(),
            key("refine_within"),
            format!(
                "must be a finite number ≥ 1, got {}",
                crate::config::shown(self.refine_within)
            ),
        )?;
        for (f, v) in [
            ("gate_fraction", self.gate_fraction),
            ("score_fraction", self.score_fraction),
        ] {
            require(
                v > 0.0 && v <= 1.0,
                key(f),
                format!(
                    "must be in (0, 1] (a fraction of the model's largest span), got {}",
                    crate::config::shown(v)
                ),
            )?;
        }
        // (The relative margin takes the product's rounding: 0.1 × 0.05 is 0.005000000000000001.)
        require(
            self.gate_fraction >= NOISE_FLOOR * self.score_fraction * (1.0 - 1e-12),
            key("gate_fraction"),
            format!(
                "must be at least {NOISE_FLOOR} × register.init.score_fraction ({}): the gate cannot \
                 be narrower than the score's noise floor, got {}",
                crate::config::shown(self.score_fraction),
                crate::config::shown(self.gate_fraction)
            ),
        )?;
        crate::config::non_negative(key("span_tolerance"), self.span_tolerance)
    }
}

/// Iterations the coarse ICPs run between two checks for runs that have met.
const COARSE_BLOCK: usize = 2;

/// One candidate's coarse ICP (scan → decimated model) as it goes.
struct CoarseRun {
    /// The candidate after its centroid and offset steps (`t_scan_reference`).
    start: Pose,
    /// Its score there.
    start_score: f64,
    /// Where the ICP is (`t_model_scan`), `None` once it has failed.
    t_model_scan: Option<Pose>,
    /// The gate its next iteration uses.
    gate: f64,
    /// Iterations left.
    left: usize,
    /// Neither converged, failed, out of iterations, nor redundant.
    running: bool,
    /// It met a run ahead of it and was dropped.
    redundant: bool,
    /// Once it has stopped (and is not redundant): its pose and score, or its start's when the
    /// start scored better.
    done: Option<(Pose, f64)>,
}

/// Every `stride`-th model point, with its normal, an index and their spacing.
struct Decimated {
    points: Vec<Point3<f64>>,
    normals: Vec<Vector3<f64>>,
    index: KdIndex,
    spacing: f64,
}

impl Decimated {
    /// About `n` (at least 100) of the model's points.
    fn new(model: &ReferenceModel, n: usize) -> Result<Self> {
        let stride = model.points.len().div_ceil(n.max(100)).max(1);
        let points: Vec<Point3<f64>> = model.points.iter().step_by(stride).copied().collect();
        Ok(Decimated {
            normals: model.normals.iter().step_by(stride).copied().collect(),
            index: KdIndex::new(&points)?,
            points,
            spacing: model.spacing_m * (stride as f64).sqrt(),
        })
    }

    fn surfel(&self) -> Surfel<'_> {
        Surfel {
            points: &self.points,
            normals: &self.normals,
            index: &self.index,
        }
    }
}

/// The chosen initial guess.
#[derive(Debug, Clone, PartialEq)]
pub struct InitOutcome {
    /// Maps reference coordinates into scan coordinates.
    pub t_scan_reference: Pose,
    /// Candidates scored.
    pub candidates: usize,
    /// Truncated RMS scan → model distance of the winner, metres.
    pub score_m: f64,
    /// The same for the best candidate that lays the model's major axis more than 30° from the
    /// winner's (e.g. the other end-to-end orientation), metres: how clearly the winner won. Its
    /// refined score, or its coarse one (where its coarse ICP stopped) when it was not in
    /// contention. `None` if every candidate lays the axis as the winner does.
    pub runner_up_score_m: Option<f64>,
}

/// The candidate rotations (model frame → scan frame) for the model's and the scan's principal
/// axes: each model axis `i` with `pairable[i]` along the scan's major axis, both ways, turned in
/// `steps` steps.
pub fn candidate_rotations(
    model: &Matrix3<f64>,
    scan: &Matrix3<f64>,
    steps: usize,
    pairable: [bool; 3],
) -> Vec<Rotation3<f64>> {
    let s1 = Unit::new_normalize(scan.column(0).into_owned());
    let mut out = Vec::with_capacity(6 * steps.max(1));
    for i in (0..3).filter(|&i| pairable[i]) {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        let a = Matrix3::from_columns(&[model.column(i), model.column(j), model.column(k)]);
        for sign in [1.0, -1.0] {
            let mut b = Matrix3::from_columns(&[
                scan.column(0) * sign,
                scan.column(1).into_owned(),
                scan.column(2).into_owned(),
            ]);
            if (b * a.transpose()).determinant() < 0.0 {
                let c = -b.column(2);
                b.set_column(2, &c);
            }
            let r0 = Rotation3::from_matrix_unchecked(b * a.transpose());
            for s in 0..steps.max(1) {
                let turn =
                    Rotation3::from_axis_angle(&s1, std::f64::consts::TAU * s as f64 / steps.max(1) as f64);
                out.push(turn * r0);
            }
        }
    }
    out
}

/// Truncated RMS distance (metres) from `scan` points mapped into the model frame by `pose⁻¹` to
/// the model's surface, and the trimmed mean offset (model frame) of the pairs within `tau`. The
/// distance to the surface is measured along the nearest model point's normal, plus whatever the
/// in-plane offset exceeds the model's point `spacing` by, so that a sparse model does not raise
/// the floor of the score.
fn score(
    model: Surfel<'_>,
    spacing: f64,
    scan: &[Point3<f64>],
    pose: &Pose,
    tau: f64,
) -> (f64, Vector3<f64>) {
    let inv = pose.inverse();
    let (mut sum, mut off, mut n) = (0.0, Vector3::zeros(), 0usize);
    for s in scan {
        let x = inv * s;
        // Beyond τ + spacing the distance to the surface exceeds τ whatever the normal.
        let Some(nb) = model.index.nearest_within(&x, tau + spacing) else {
            sum += tau * tau;
            continue;
        };
        let v = model.points[nb.index] - x;
        let along = v.dot(&model.normals[nb.index]);
        let across = (v.norm_squared() - along * along).max(0.0).sqrt();
        let d2 = along * along + (across - spacing).max(0.0).powi(2);
        sum += d2.min(tau * tau);
        if nb.distance < tau {
            off += model.points[nb.index] - x;
            n += 1;
        }
    }
    let rms = (sum / scan.len().max(1) as f64).sqrt();
    (rms, if n > 0 { off / n as f64 } else { Vector3::zeros() })
}

/// Chooses an initial `t_scan_reference` for the scanned object `scan` (its principal axes
/// `scan_shape`) and the reference `model`.
///
/// # Errors
/// [`Error::Input`] for a configuration that cannot work; [`Error::Failed`] (stage `init`) when
/// the scan has too few points.
pub fn initial_guess(
    model: &ReferenceModel,
    scan: &[Point3<f64>],
    scan_shape: &PrincipalAxes,
    cfg: &InitConfig,
) -> Result<InitOutcome> {
    cfg.validate()?;
    if scan.len() < 10 {
        return Err(Error::failed(
            "init",
            format!("the scanned object has only {} points", scan.len()),
        ));
    }
    let strided = |n: usize| -> Vec<Point3<f64>> {
        scan.iter()
            .step_by(scan.len().div_ceil(n).max(1))
            .copied()
            .collect()
    };
    let coarse = strided(cfg.coarse_points.max(10));
    let sample = strided(cfg.sample_points);
    let few = strided(cfg.offset_points.max(10));
    let size = model.shape.spans.max().max(1e-6);
    let tau = cfg.score_fraction * size;
    let gate = cfg.gate_fraction * size;
    // The scan cannot be longer along its major axis than the model is along the axis laid
    // there: pairings that would need it are not tried (the model's longest axis always is).
    let longest = model.shape.spans.imax();
    let pairable =
        [0, 1, 2].map(|i| i == longest || model.shape.spans[i] >= cfg.span_tolerance * scan_shape.spans[0]);
    let rotations = candidate_rotations(&model.shape.axes, &scan_shape.axes, cfg.rotation_steps, pairable);
    let candidates = rotations.len();
    // Short ICP from scan to model (every scanned point lies on the model) and the score after it.
    // The coarse stage works on a decimated model: smaller tree, faster queries.
    let small_model = Decimated::new(model, cfg.coarse_model_points)?;
    let (small, small_spacing) = (small_model.surfel(), small_model.spacing);
    let sparse_model = Decimated::new(model, cfg.offset_model_points)?;
    let (sparse, sparse_spacing) = (sparse_model.surfel(), sparse_model.spacing);
    let full = model.surfel();
    let short = |iterations: usize| IcpConfig {
        max_iterations: iterations.max(1),
        min_gate_m: (0.1 * tau).max(1e-6),
        gate_shrink: 0.85,
        // A candidate only has to be ranked (and the best handed to the final ICP): steps below
        // a hundredth of τ no longer change that.
        rotation_tolerance_rad: 0.01 * tau / size,
        translation_tolerance_m: (0.01 * tau).max(1e-9),
        ..IcpConfig::default()
    };
    // The short ICP's pose if it scores no worse than where it started, else the start.
    let better = |(model, spacing): (Surfel<'_>, f64),
                  pts: &[Point3<f64>],
                  (start, s0): (&Pose, f64),
                  icp: Option<Pose>|
     -> (Pose, f64) {
        let Some(t_model_scan) = icp else {
            return (*start, s0);
        };
        let p = t_model_scan.inverse();
        let s = score(model, spacing, pts, &p, tau).0;
        if s <= s0 { (p, s) } else { (*start, s0) }
    };
    let refine = |(model, spacing): (Surfel<'_>, f64),
                  pts: &[Point3<f64>],
                  (pose, gate): (&Pose, f64),
                  iterations: usize|
     -> (Pose, f64) {
        let s0 = score(model, spacing, pts, pose, tau).0;
        let icp = icp_point_to_plane(pts, model, None, &pose.inverse(), gate, &short(iterations));
        better(
            (model, spacing),
            pts,
            (pose, s0),
            icp.ok().map(|o| o.t_target_source),
        )
    };
    let mut coarse_runs: Vec<CoarseRun> = rotations
        .par_iter()
        .map(|r| {
            let q = UnitQuaternion::from_rotation_matrix(r);
            let mut pose = Pose::from_parts(
                Translation3::from(scan_shape.centroid.coords - r * model.shape.centroid.coords),
                q,
            );
            for _ in 0..3 {
                // Moving the model by −off (model frame) moves it onto the scan's points.
                let (_, off) = score(sparse, sparse_spacing, &few, &pose, gate);
                pose *= Translation3::from(-off);
            }
            CoarseRun {
                start: pose,
                start_score: score(small, small_spacing, &coarse, &pose, tau).0,
                t_model_scan: Some(pose.inverse()),
                gate,
                left: cfg.coarse_iterations.max(1),
                running: true,
                redundant: false,
                done: None,
            }
        })
        .collect();
    // The coarse ICPs run in lockstep, a few iterations at a time; a run that has come within
    // 0.1 τ (the noise floor of a score) of a run ahead of it in the list would follow it to the
    // same pose and the same score, so it stops there and is dropped.
    let same = |a: &Pose, b: &Pose| {
        let (a, b) = (a.inverse(), b.inverse());
        let moved = (a * model.shape.centroid - b * model.shape.centroid).norm()
            + a.rotation.angle_to(&b.rotation) * size;
        moved < 0.1 * tau
    };
    // Candidates scoring above this, for the best score `best`, cannot win: they are not refined.
    let contention = |best: f64| cfg.refine_within * best + 0.1 * tau;
    let finish = |c: &CoarseRun| {
        better(
            (small, small_spacing),
            &coarse,
            (&c.start, c.start_score),
            c.t_model_scan,
        )
    };
    // Before every block (the first included, on the start scores): a run whose score is out of
    // contention with the best so far (the refinement's own bound, which is loose unless some run
    // already fits to within the noise floor) stops, as it will not be refined; and so does a run
    // that has reached the noise floor, 0.1 τ: further coarse steps could only reorder it among
    // scores the noise cannot tell apart, and its refinement starts with its gate at that floor.
    let floor = NOISE_FLOOR * tau;
    let settle = |runs: &mut [CoarseRun], now: Vec<Option<(Pose, f64)>>| {
        let best = runs
            .iter()
            .zip(&now)
            .filter_map(|(c, n)| c.done.or(*n).map(|d| d.1))
            .fold(f64::INFINITY, f64::min);
        let bound = contention(best);
        for (c, n) in runs.iter_mut().zip(now) {
            if let Some(n) = n.filter(|n| n.1 > bound || n.1 <= floor) {
                c.running = false;
                c.done = Some(n);
            }
        }
    };
    let starts = coarse_runs
        .iter()
        .map(|c| Some((c.start, c.start_score)))
        .collect();
    settle(&mut coarse_runs, starts);
    while coarse_runs.iter().any(|c| c.running) {
        coarse_runs.par_iter_mut().filter(|c| c.running).for_each(|c| {
            let run = short(c.left.min(COARSE_BLOCK));
            let pose = c.t_model_scan.unwrap_or(c.start.inverse());
            match icp_point_to_plane(&coarse, small, None, &pose, c.gate, &run) {
                Ok(o) => {
                    c.t_model_scan = Some(o.t_target_source);
                    c.gate = o.next_gate_m;
                    c.left = c.left.saturating_sub(o.iterations);
                    c.running = !o.converged && c.left > 0;
                }
                Err(_) => {
                    c.t_model_scan = None;
                    c.running = false;
                }
            }
            if !c.running {
                c.done = Some(finish(c));
            }
        });
        for i in 0..coarse_runs.len() {
            let Some(p) = coarse_runs[i].t_model_scan.filter(|_| coarse_runs[i].running) else {
                continue;
            };
            let ahead = &coarse_runs[..i];
            if ahead
                .iter()
                .any(|c| !c.redundant && c.t_model_scan.is_some_and(|q| same(&p, &q)))
            {
                coarse_runs[i].running = false;
                coarse_runs[i].redundant = true;
            }
        }
        if !coarse_runs.iter().any(|c| c.running) {
            break;
        }
        let now = coarse_runs
            .par_iter()
            .map(|c| c.running.then(|| finish(c)))
            .collect();
        settle(&mut coarse_runs, now);
    }
    let mut scored: Vec<(Pose, f64)> = coarse_runs
        .iter()
        .filter(|c| !c.redundant)
        .filter_map(|c| c.done)
        .collect();
    scored.sort_by(|a, b| a.1.total_cmp(&b.1));
    // The best `refine` that are distinct: they lay the model's major axis differently (> 30°,
    // e.g. the two end-to-end orientations of a bottle) or differ by more than 90° overall.
    let major = model.shape.axes.column(0).into_owned();
    let cut = contention(scored[0].1);
    let mut chosen: Vec<(Pose, f64)> = Vec::with_capacity(cfg.refine);
    for c in scored.iter().take_while(|c| c.1 <= cut) {
        let distinct = chosen.iter().all(|(p, _)| {
            let axes = (p.rotation * major).angle(&(c.0.rotation * major));
            axes > 30f64.to_radians() || (p.rotation.inverse() * c.0.rotation).angle() > 90f64.to_radians()
        });
        if distinct {
            chosen.push(*c);
            if chosen.len() == cfg.refine {
                break;
            }
        }
    }
    let mut refined: Vec<(Pose, f64)> = chosen
        .par_iter()
        .map(|(pose, s)| {
            // The coarse ICP left the candidate within a few of its truncated RMS distances.
            // (Not `clamp`: it panics on a NaN or when the floor exceeds the gate.)
            let near = (4.0 * s).max(floor).min(gate);
            refine((full, model.spacing_m), &sample, (pose, near), cfg.icp_iterations)
        })
        .collect();
    refined.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (best, best_s) = refined[0];
    let other_axis =
        |(p, _): &&(Pose, f64)| (best.rotation * major).angle(&(p.rotation * major)) > 30f64.to_radians();
    let runner_up = refined
        .iter()
        .skip(1)
        .find(other_axis)
        .or_else(|| scored.iter().find(other_axis))
        .map(|r| r.1);
    Ok(InitOutcome {
        t_scan_reference: best,
        candidates,
        score_m: best_s,
        runner_up_score_m: runner_up,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candidates_are_rotations_and_include_the_pca_alignment() {
        let m = *Rotation3::from_euler_angles(0.2, 0.4, -0.3).matrix();
        let s = *Rotation3::from_euler_angles(-1.0, 0.1, 0.7).matrix();
        let c = candidate_rotations(&m, &s, 8, [true; 3]);
        assert_eq!(c.len(), 48);
        for r in &c {
            assert!((r.matrix().determinant() - 1.0).abs() < 1e-9);
            assert!((r.matrix().transpose() * r.matrix() - Matrix3::identity()).norm() < 1e-9);
        }
        // The plain alignment s·mᵀ and its three sign-flipped variants are all among them.
        for flip in [
            [1.0, 1.0, 1.0],
            [1.0, -1.0, -1.0],
            [-1.0, 1.0, -1.0],
            [-1.0, -1.0, 1.0],
        ] {
            let r = s * Matrix3::from_diagonal(&Vector3::from(flip)) * m.transpose();
            assert!(c.iter().any(|x| (x.matrix() - r).norm() < 1e-9), "{flip:?}");
        }
    }

    #[test]
    fn fractions_that_panicked_the_refinement_are_input_errors() {
        use crate::perception::assert_bad_input;
        // Each made the refinement's gate clamp panic ("min > max, or either was NaN").
        for (gate, score, field) in [
            (0.004, 0.05, "register.init.gate_fraction"),
            (0.02, 0.5, "register.init.gate_fraction"),
            (0.2, f64::INFINITY, "register.init.score_fraction"),
            (0.2, 1e300, "register.init.score_fraction"),
            (f64::NAN, 0.05, "register.init.gate_fraction"),
        ] {
            let cfg = InitConfig {
                gate_fraction: gate,
                score_fraction: score,
                ..InitConfig::default()
            };
            assert_bad_input(cfg.validate(), field);
        }
        // Counts that exhausted memory (a candidate per turn, a refinement slot per `refine`).
        let cfg = InitConfig {
            rotation_steps: usize::MAX,
            ..InitConfig::default()
        };
        assert_bad_input(cfg.validate(), "register.init.rotation_steps");
        let cfg = InitConfig {
            refine: 1_000_000_000,
            ..InitConfig::default()
        };
        assert_bad_input(cfg.validate(), "register.init.refine");
        let cfg = InitConfig {
            refine_within: f64::INFINITY,
            ..InitConfig::default()
        };
        assert_bad_input(cfg.validate(), "register.init.refine_within");
        InitConfig::default().validate().unwrap();
    }

    #[test]
    fn initial_guess_returns_the_error_instead_of_panicking() {
        let (mp, mn) = crate::register::tests::bottle(3000, 1);
        let model = ReferenceModel::build(mp, mn, None, "model").unwrap();
        let truth = Pose::translation(0.0, 0.0, 1.0);
        let scan = crate::register::tests::scan_of(&truth, 0.0005, 2);
        let shape = crate::cloud::pca::principal_axes(&scan, 0.01).unwrap();
        let cfg = InitConfig {
            gate_fraction: 0.004,
            ..InitConfig::default()
        };
        crate::perception::assert_bad_input(
            initial_guess(&model, &scan, &shape, &cfg),
            "register.init.gate_fraction",
        );
    }
}
