//! Analytic inverse kinematics of the PUMA class: a waist joint, a planar shoulder–elbow pair
//! with a lateral offset, and a spherical wrist (Paul & Zhang 1986; Craig, *Introduction to
//! Robotics*, §4.7, here in standard DH). No Jacobian inverse, no iteration.
//!
//! The wrist centre `p_w = o_5` is where the three wrist axes meet; it depends on `q1..q3` only:
//!
//! ```text
//! p_w − d1 z0 = a2 (c1 c2, s1 c2, s2) + D (s1, −c1, 0) + a3 (c1 c23, s1 c23, s23) + d4 (−c1 s23, −s1 s23, c23)
//! ```
//!
//! with `D = d2 + d3` the lateral offset. So `q1` solves `s1 x − c1 y = D` (two solutions:
//! shoulder left/right), `q2, q3` a planar two-link problem (two: elbow up/down), and the wrist
//! `R_3_6 = Rz(q4) Ry(−q5) Rz(q6)` a ZYZ Euler decomposition (two: wrist flipped or not): eight
//! solutions. Each is then moved by multiples of 2π into the joint limits, choosing the angle
//! nearest the current configuration, dropped if no multiple fits, and checked by forward
//! kinematics. At the wrist singularity (`q5 = 0`) only `q4 + q6` is defined; `q4` is kept at its
//! current value.
//!
//! Requirements on the DH table (checked): `a1 = 0`, `α = (+90°, 0, −90°, +90°, −90°, any)`,
//! `a4 = a5 = d5 = 0`. `d6`, `a6`, `α6`, the tool and all `θ` offsets are free.

use super::{Arm, JointVector};
use crate::error::{Error, Result};
use crate::model::N_JOINTS;
use nalgebra::{Isometry3, Matrix3, Vector3};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Up to eight IK solutions, sorted nearest to the current configuration first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkSolutions {
    solutions: [JointVector; 8],
    len: usize,
    /// How many analytic solutions the pose has before the joint limits are applied (0 when the
    /// pose is out of reach).
    pub analytic: usize,
}

impl IkSolutions {
    /// The solutions within the joint limits, nearest to the current configuration first.
    pub fn as_slice(&self) -> &[JointVector] {
        &self.solutions[..self.len]
    }

    /// The solution nearest to the current configuration, if any.
    pub fn nearest(&self) -> Option<&JointVector> {
        self.as_slice().first()
    }

    /// Whether no solution was found.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Number of solutions within the limits.
    pub fn len(&self) -> usize {
        self.len
    }
}

/// The shoulder and elbow of a PUMA-class arm: the wrist centre's offset from the arm's plane
/// `d2 + d3`, the upper arm `a2`, the forearm to the wrist centre `l3 = √(a3² + d4²)` and its
/// angle `ψ = atan2(d4, a3)` from link 3's x axis.
struct Elbow {
    lateral: f64,
    a2: f64,
    l3: f64,
    psi: f64,
}

/// Tolerance on the angles of the DH table (rad) and on the lengths that must be zero (m).
const STRUCTURE_TOL: f64 = 1e-9;
/// Largest position error (m) and rotation error (rad) of a returned solution.
const CHECK_TOL: f64 = 1e-7;

impl Arm {
    /// All inverse-kinematics solutions for the tool pose `t_base_tool` within the joint limits,
    /// nearest (Euclidean in joint space) to `q_now` first.
    ///
    /// # Errors
    /// [`Error::Input`] if the arm's DH table is not of the PUMA class (see the module docs) or
    /// the pose is not finite. An unreachable pose is not an error: the result is empty.
    pub fn ik(&self, t_base_tool: &Isometry3<f64>, q_now: &JointVector) -> Result<IkSolutions> {
        self.solve_ik(t_base_tool, q_now, false)
    }

    /// The inverse-kinematics solution nearest to `q_now` within the joint limits (what
    /// [`Arm::ik`]'s [`IkSolutions::nearest`] gives), checking only the candidates up to it.
    ///
    /// # Errors
    /// As [`Arm::ik`].
    pub fn ik_nearest(
        &self,
        t_base_tool: &Isometry3<f64>,
        q_now: &JointVector,
    ) -> Result<Option<JointVector>> {
        Ok(self.solve_ik(t_base_tool, q_now, true)?.nearest().copied())
    }

    /// The solutions, nearest to `q_now` first: every analytic solution moved into the limits,
    /// sorted by distance (stable), and checked by forward kinematics. With `nearest_only` the
    /// search is pruned (see below), the result is the nearest alone and `analytic` is not
    /// counted. Inline: [`Arm::ik_nearest`]'s copy keeps only the pruned search.
    #[inline]
    fn solve_ik(
        &self,
        t_base_tool: &Isometry3<f64>,
        q_now: &JointVector,
        nearest_only: bool,
    ) -> Result<IkSolutions> {
        self.check_puma_structure()?;
        if !t_base_tool.to_homogeneous().iter().all(|v| v.is_finite()) || !q_now.iter().all(|v| v.is_finite())
        {
            return Err(Error::input(
                "ik",
                "target pose or current configuration is not finite",
            ));
        }
        let l = &self.links;
        let off = |i: usize| l[i].dh().theta_offset;
        let (r06, pw) = self.wrist_centre(t_base_tool);
        let (px, py, pz) = (pw.x, pw.y, pw.z);
        let Elbow { lateral, a2, l3, psi } = self.elbow();

        let mut out = IkSolutions {
            solutions: [JointVector::zeros(); 8],
            len: 0,
            analytic: 0,
        };
        let rho = px.hypot(py);
        if rho < lateral.abs() - 1e-12 || rho < 1e-12 {
            return Ok(out);
        }
        let phi = py.atan2(px);
        let asn = (lateral / rho).clamp(-1.0, 1.0).asin();
        // Rx(−α6), from the link's own sine and cosine.
        let (sa6, ca6) = (l[5].sin_alpha, l[5].cos_alpha);
        let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, ca6, sa6, 0.0, -sa6, ca6);
        // The shoulder solutions θ1 with the wrist centre's reach `r` in the arm's plane and the
        // elbow's cosine, and where each one's shoulder–elbow pairs (raw q1..q3) go in the order
        // of the analytic solutions (none for a shoulder the elbow cannot reach).
        let shoulders = [phi + asn, phi + PI - asn].map(|theta1| {
            let (s1, c1) = theta1.sin_cos();
            let r = c1 * px + s1 * py;
            let cos_beta = (r * r + pz * pz - a2 * a2 - l3 * l3) / (2.0 * a2 * l3);
            (theta1, r, cos_beta)
        });
        let unreachable = |cos_beta: f64| cos_beta.abs() > 1.0 + 1e-9;
        let first_pair = [0, if unreachable(shoulders[0].2) { 0 } else { 2 }];
        let n_pairs = first_pair[1] + if unreachable(shoulders[1].2) { 0 } else { 2 };
        // The two elbow solutions of a shoulder solution.
        let elbows = |(theta1, r, cos_beta): (f64, f64, f64)| {
            let beta0 = cos_beta.clamp(-1.0, 1.0).acos();
            let elevation = pz.atan2(r);
            // sin is odd and cos even, exactly so in floating point too.
            let (sin0, cos0) = beta0.sin_cos();
            [(beta0, sin0), (-beta0, -sin0)].map(|(beta, sin_beta)| {
                let theta2 = elevation - (l3 * sin_beta).atan2(a2 + l3 * cos0);
                let theta3 = beta - psi;
                [theta1 - off(0), theta2 - off(1), theta3 - off(2)]
            })
        };
        let mut pairs = [[0.0; 3]; 4];
        // For the nearest alone, the pairs nearest to `q_now` in q1..q3 first, and a pair whose
        // q1..q3 alone are already farther than the best checked solution is skipped (the
        // margin covers the summation's round-off; ties keep the analytic order); a shoulder
        // solution whose q1 alone is farther is not solved for its elbows at all. What is
        // skipped cannot be the nearest, so the result is the search's without skipping.
        let mut order: [usize; 4] = std::array::from_fn(|i| i);
        let mut partial = [f64::INFINITY; 4];
        // ...and their q1..q3 fitted into the limits.
        let mut fitted = [[0.0; 3]; 4];
        let mut q1_distance = [f64::INFINITY; 2];
        let mut shoulder_order = [0, 1];
        if nearest_only {
            for (k, d) in q1_distance.iter_mut().enumerate() {
                if !unreachable(shoulders[k].2)
                    && let Some([q1]) = self.fit_joints(&[shoulders[k].0 - off(0)], 0, q_now)
                {
                    *d = (q1 - q_now[0]).powi(2);
                }
            }
            shoulder_order.sort_by(|&a, &b| q1_distance[a].total_cmp(&q1_distance[b]));
        } else {
            for k in 0..2 {
                if !unreachable(shoulders[k].2) {
                    pairs[first_pair[k]..first_pair[k] + 2].copy_from_slice(&elbows(shoulders[k]));
                }
            }
        }
        let dist = |q: &JointVector| (q - q_now).norm_squared();
        let mut best: Option<(f64, usize, JointVector)> = None;
        // Frame 3 (rotation, origin) of each pair, and each candidate's pair and raw wrist
        // angles, for the forward-kinematics check.
        let mut frame3 = [(Matrix3::<f64>::identity(), Vector3::<f64>::zeros()); 4];
        let mut wrist_of = [(0usize, [0.0; 3]); 8];
        let farther = |best: &Option<(f64, usize, JointVector)>, partial: f64| {
            partial.is_infinite() || best.is_some_and(|(d, _, _)| partial > d * (1.0 + 1e-9))
        };
        // A solution `d` away, `rank` in the analytic order, is nearer than the best so far (of
        // two equally near, the earlier in that order).
        let beats = |best: &Option<(f64, usize, JointVector)>, d: f64, rank: usize| {
            best.is_none_or(|(bd, br, _)| (d, rank) < (bd, br))
        };
        // The pairs in groups: each shoulder solution's (nearest in q1 first) for the nearest
        // alone, all of them at once otherwise.
        let groups: &[(usize, usize, usize)] = if nearest_only {
            &shoulder_order.map(|k| (k, first_pair[k], 2))
        } else {
            &[(0, 0, n_pairs)]
        };
        for &(k, group, n_group) in groups {
            let visit = &mut order[group..group + n_group];
            if nearest_only {
                if farther(&best, q1_distance[k]) {
                    continue;
                }
                pairs[group..group + 2].copy_from_slice(&elbows(shoulders[k]));
                for i in group..group + 2 {
                    if let Some(q) = self.fit_joints(&pairs[i], 0, q_now) {
                        partial[i] = (0..3).map(|j| (q[j] - q_now[j]).powi(2)).sum();
                        fitted[i] = q;
                    }
                }
                visit.sort_by(|&a, &b| partial[a].total_cmp(&partial[b]));
            }
            for &pair in &*visit {
                if nearest_only && farther(&best, partial[pair]) {
                    continue;
                }
                let q123 = pairs[pair];
                let (mut r03, mut p03) = (Matrix3::identity(), Vector3::zeros());
                self.advance(&mut r03, &mut p03, 0, &q123);
                frame3[pair] = (r03, p03);
                // R_3_6 Rx(−α6) = Rz(θ4) Ry(−θ5) Rz(θ6).
                let m: Matrix3<f64> = r03.transpose() * r06 * rx;
                let sb = m[(0, 2)].hypot(m[(1, 2)]);
                // The wrist's angles (θ4, θ5, θ6) with sin θ5 of the sign `sg`; at the
                // singularity (θ5 = 0 or π) one solution, with q4 kept.
                let wrist = |sg: f64| {
                    let b = (sg * sb).atan2(m[(2, 2)]);
                    let theta4 = (sg * m[(1, 2)]).atan2(sg * m[(0, 2)]);
                    let theta6 = (sg * m[(2, 1)]).atan2(-sg * m[(2, 0)]);
                    (theta4, b, theta6)
                };
                let raw_wrist =
                    |(theta4, b, theta6): (f64, f64, f64)| [theta4 - off(3), -b - off(4), theta6 - off(5)];
                let singular = sb < 1e-10;
                // For the nearest alone the wrist with θ5 on `q_now`'s side first (the other
                // is then seldom needed, see below): the sign of sin θ5, θ5 = −(q5 + θ5 offset).
                let side = if nearest_only && wrapped_signed(q_now[4] + off(4)) > 0.0 {
                    -1.0
                } else {
                    1.0
                };
                let first = if singular {
                    let theta4 = q_now[3] + off(3);
                    let (b, sum_or_diff) = if m[(2, 2)] > 0.0 {
                        (0.0, m[(1, 0)].atan2(m[(0, 0)]))
                    } else {
                        (PI, (-m[(1, 0)]).atan2(m[(1, 1)]))
                    };
                    let theta6 = if b == 0.0 {
                        sum_or_diff - theta4
                    } else {
                        theta4 - sum_or_diff
                    };
                    (theta4, b, theta6)
                } else {
                    wrist(side)
                };
                // Their ranks in the analytic order: two wrists per pair, sin θ5 ≥ 0 first.
                let (first_rank, other_rank) = if side > 0.0 || singular {
                    (2 * pair, 2 * pair + 1)
                } else {
                    (2 * pair + 1, 2 * pair)
                };
                if !nearest_only {
                    let second = (!singular).then(|| wrist(-1.0));
                    for angles in std::iter::once(first).chain(second) {
                        out.analytic += 1;
                        let w = raw_wrist(angles);
                        let raw = [q123[0], q123[1], q123[2], w[0], w[1], w[2]];
                        if let Some(q) = self.fit_limits(&raw, q_now) {
                            out.solutions[out.len] = q;
                            wrist_of[out.len] = (pair, w);
                            out.len += 1;
                        }
                    }
                    continue;
                }
                // For the nearest alone: a candidate is the pair's joints as fitted above and
                // the wrist's, ranked in the analytic order (two wrists per pair).
                let candidate = |w: [f64; 3], rank: usize| {
                    let [q1, q2, q3] = fitted[pair];
                    let [q4, q5, q6] = self.fit_joints(&w, 3, q_now)?;
                    let q = JointVector::new(q1, q2, q3, q4, q5, q6);
                    Some((dist(&q), rank, q, w))
                };
                let a = candidate(raw_wrist(first), first_rank);
                // The other wrist is (θ4 ± π, −θ5, θ6 ± π): its distance bounded below from the
                // first's angles, which are within round-off of those (1e-9 rad covers that and
                // the limits' tolerance), so that it is computed only when it may be nearer
                // than the best so far, and checked first when it may be nearer than the first.
                let bound = if singular {
                    f64::INFINITY
                } else {
                    let (theta4, b, theta6) = first;
                    let near = raw_wrist((theta4 + PI, -b, theta6 + PI));
                    partial[pair]
                        + (0..3)
                            .map(|j| (wrapped(near[j] - q_now[3 + j]) - 1e-9).max(0.0).powi(2))
                            .sum::<f64>()
                };
                let mut candidates = [a, None];
                let may_beat_first = a.is_none_or(|(d, rank, q, _)| !farther(&Some((d, rank, q)), bound));
                if may_beat_first && !farther(&best, bound) {
                    candidates[1] = candidate(raw_wrist(wrist(-side)), other_rank);
                    if let [Some(x), Some(y)] = &candidates
                        && (y.0, y.1) < (x.0, x.1)
                    {
                        candidates.swap(0, 1);
                    }
                }
                // Nearest first: once one passes the check the other is not looked at.
                for (d, rank, q, w) in candidates.into_iter().flatten() {
                    if beats(&best, d, rank) && self.wrist_matches(&r03, &p03, &w, t_base_tool) {
                        best = Some((d, rank, q));
                    }
                }
                // The first failed its check: the other may still be the nearest.
                if !may_beat_first
                    && !farther(&best, bound)
                    && let Some((d, rank, q, w)) = candidate(raw_wrist(wrist(-side)), other_rank)
                    && beats(&best, d, rank)
                    && self.wrist_matches(&r03, &p03, &w, t_base_tool)
                {
                    best = Some((d, rank, q));
                }
            }
        }
        if nearest_only {
            if let Some((_, _, q)) = best {
                out.solutions[0] = q;
                out.len = 1;
            }
            return Ok(out);
        }
        let candidates = out.len;
        let d: [f64; 8] = std::array::from_fn(|i| dist(&out.solutions[i]));
        let mut by_distance: [usize; 8] = std::array::from_fn(|i| i);
        by_distance[..candidates].sort_by(|&a, &b| d[a].total_cmp(&d[b]));
        let found = out.solutions;
        out.len = 0;
        for &i in &by_distance[..candidates] {
            let (pair, wrist) = &wrist_of[i];
            let (r03, p03) = &frame3[*pair];
            if self.wrist_matches(r03, p03, wrist, t_base_tool) {
                out.solutions[out.len] = found[i];
                out.len += 1;
            }
        }
        Ok(out)
    }

    /// The rotation of frame 6 and the wrist centre `o5 = o6 − d6 z5 − a6 x6`
    /// (`z5 = R06 Rx(−α6) e_z`) for the tool pose `t_base_tool`, its z taken from the
    /// shoulder's height `d1`: what the IK's position part solves for.
    fn wrist_centre(&self, t_base_tool: &Isometry3<f64>) -> (Matrix3<f64>, Vector3<f64>) {
        let dh = |i: usize| *self.links[i].dh();
        let t06 = t_base_tool * self.t_flange_tool.inverse();
        let r06 = t06.rotation.to_rotation_matrix().into_inner();
        let l6 = &self.links[5];
        let z5 = r06 * Vector3::new(0.0, l6.sin_alpha, l6.cos_alpha);
        let pw = t06.translation.vector - z5 * dh(5).d - r06.column(0) * dh(5).a;
        (r06, Vector3::new(pw.x, pw.y, pw.z - dh(0).d))
    }

    /// Whether the wrist centre of the tool pose `t_base_tool` is within the reach of the
    /// shoulder and elbow, a necessary condition for an inverse-kinematics solution with a
    /// margin over the IK's round-off: `false` means [`Arm::ik`] has none (the joint limits
    /// may still exclude every one when `true`). An arm not of the PUMA class, whose IK is
    /// an error, is always within reach here.
    pub fn within_reach(&self, t_base_tool: &Isometry3<f64>) -> bool {
        if self.check_puma_structure().is_err() {
            return true;
        }
        let (_, p) = self.wrist_centre(t_base_tool);
        let Elbow { lateral, a2, l3, .. } = self.elbow();
        let rho2 = p.x * p.x + p.y * p.y;
        if rho2.sqrt() < lateral.abs() - 1e-9 {
            return false;
        }
        // Both shoulder solutions put the wrist centre at `r = ±√(ρ² − lateral²)` in the arm's
        // plane: the elbow's cosine is the same for both.
        let r2 = (rho2 - lateral * lateral).max(0.0);
        let cos_beta = (r2 + p.z * p.z - a2 * a2 - l3 * l3) / (2.0 * a2 * l3);
        cos_beta.abs() <= 1.0 + 1e-6
    }

    /// `|det J|` (Yoshikawa's manipulability) of the tool point at `q`, whose tool pose is
    /// `t_base_tool`, for an arm of the PUMA class, without the Jacobian: about the wrist centre
    /// (the reference point does not change the determinant) the wrist's joints do not move
    /// the centre, so `det J` is the position block's times the wrist's. The first is the
    /// shoulder's lever times the planar elbow's, `r · a2 l3 sin β` (`r` the wrist centre's
    /// distance from the first axis in the arm's plane, `√(ρ² − lateral²)`; `β = θ3 + ψ` the
    /// elbow's bend from straight, `ψ = atan2(d4, a3)`, as in the IK); the second `sin θ5`.
    ///
    /// # Errors
    /// [`Error::Input`] if the arm is not of the PUMA class (as [`Arm::ik`]).
    pub fn manipulability_at(&self, t_base_tool: &Isometry3<f64>, q: &JointVector) -> Result<f64> {
        self.check_puma_structure()?;
        let off = |i: usize| self.links[i].dh().theta_offset;
        let (_, p) = self.wrist_centre(t_base_tool);
        let Elbow { lateral, a2, l3, psi } = self.elbow();
        let r = (p.x * p.x + p.y * p.y - lateral * lateral).max(0.0).sqrt();
        let beta = q[2] + off(2) + psi;
        let theta5 = q[4] + off(4);
        Ok((r * a2 * l3 * beta.sin() * theta5.sin()).abs())
    }

    /// Whether `a` and `b` are the same posture of a PUMA-class arm: the wrist centre on the
    /// same side of the first axis in the arm's plane (shoulder left or right: `r` of the IK's
    /// two shoulder solutions is `±√(ρ² − lateral²)`), the elbow bent the same way (`sin β`,
    /// `β = θ3 + ψ`, of the IK's two elbow solutions `±β₀`) and the wrist too (`sin θ5`, of
    /// its two solutions). Where two postures meet (one of these zero within `1e-9`: a
    /// singularity) either counts as the same. Only the joint angles are read.
    pub fn same_posture(&self, a: &JointVector, b: &JointVector) -> bool {
        let off = |i: usize| self.links[i].dh().theta_offset;
        let Elbow { a2, l3, psi, .. } = self.elbow();
        let posture = |q: &JointVector| {
            let beta = q[2] + off(2) + psi;
            // The wrist centre's elevation in the arm's plane, as the IK's θ2 = elevation −
            // atan2(l3 sin β, a2 + l3 cos β): `r` has the sign of its cosine.
            let elevation = q[1] + off(1) + (l3 * beta.sin()).atan2(a2 + l3 * beta.cos());
            [elevation.cos(), beta.sin(), (q[4] + off(4)).sin()]
        };
        let (pa, pb) = (posture(a), posture(b));
        pa.iter()
            .zip(&pb)
            .all(|(x, y)| x * y >= 0.0 || x.abs().min(y.abs()) < 1e-9)
    }

    /// The shoulder and elbow of a PUMA-class arm, from its DH table.
    fn elbow(&self) -> Elbow {
        let dh = |i: usize| *self.links[i].dh();
        let (a3, d4) = (dh(2).a, dh(3).d);
        Elbow {
            lateral: dh(1).d + dh(2).d,
            a2: dh(1).a,
            l3: a3.hypot(d4),
            psi: d4.atan2(a3),
        }
    }

    /// Checks that the DH table is of the PUMA class this IK solves.
    ///
    /// # Errors
    /// [`Error::Input`] (`ik`) saying what the class needs.
    pub fn check_puma_structure(&self) -> Result<()> {
        let want_alpha = [FRAC_PI_2, 0.0, -FRAC_PI_2, FRAC_PI_2, -FRAC_PI_2];
        let l = &self.links;
        let ok = want_alpha
            .iter()
            .enumerate()
            .all(|(i, a)| (l[i].dh().alpha - a).abs() < STRUCTURE_TOL)
            && l[0].dh().a.abs() < STRUCTURE_TOL
            && l[3].dh().a.abs() < STRUCTURE_TOL
            && l[4].dh().a.abs() < STRUCTURE_TOL
            && l[4].dh().d.abs() < STRUCTURE_TOL
            && l[1].dh().a.abs() > STRUCTURE_TOL
            && l[2].dh().a.hypot(l[3].dh().d) > STRUCTURE_TOL;
        if ok {
            Ok(())
        } else {
            Err(Error::input(
                "ik",
                "the arm is not of the PUMA class (need a1 = 0, alpha = (90, 0, -90, 90, -90, any) deg, a4 = a5 = d5 = 0, a2 > 0)",
            ))
        }
    }

    /// Moves each angle by a multiple of 2π into its limits, nearest to `q_now`; `None` if an
    /// angle cannot be placed within its limits.
    fn fit_limits(&self, raw: &[f64; N_JOINTS], q_now: &JointVector) -> Option<JointVector> {
        Some(JointVector::from(self.fit_joints(raw, 0, q_now)?))
    }

    /// [`Arm::fit_limits`] of the joints `first..first + N` alone.
    fn fit_joints<const N: usize>(
        &self,
        raw: &[f64; N],
        first: usize,
        q_now: &JointVector,
    ) -> Option<[f64; N]> {
        let mut q = [0.0; N];
        for (j, qj) in q.iter_mut().enumerate() {
            let (i, raw) = (first + j, raw[j]);
            let [lo, hi] = self.links[i].limits;
            // Candidates raw + 2πk inside [lo, hi]; the one nearest to q_now. That one is
            // raw + 2πk for the k nearest q_now when this lies inside the limits by more than the
            // round-off of the bounds on k below: then it is within them, and clamped to itself.
            let k_near = round_i64((q_now[i] - raw) / TAU);
            let nearest = raw + TAU * k_near as f64;
            if nearest >= lo + 1e-9 && nearest <= hi - 1e-9 {
                *qj = nearest;
                continue;
            }
            let k_lo = ceil_i64((lo - raw) / TAU);
            let k_hi = floor_i64((hi - raw) / TAU);
            if k_lo > k_hi {
                // Tolerate round-off at a limit.
                let clamped = raw - TAU * round_i64((raw - 0.5 * (lo + hi)) / TAU) as f64;
                if clamped >= lo - 1e-12 && clamped <= hi + 1e-12 {
                    *qj = clamped.clamp(lo, hi);
                    continue;
                }
                return None;
            }
            let k = k_near.clamp(k_lo, k_hi);
            *qj = raw + TAU * k as f64;
        }
        Some(q)
    }

    /// Whether the tool pose at `q` is `target` to [`CHECK_TOL`].
    #[cfg(test)]
    fn pose_matches(&self, q: &JointVector, target: &Isometry3<f64>) -> bool {
        let (mut r03, mut p03) = (Matrix3::identity(), Vector3::zeros());
        self.advance(&mut r03, &mut p03, 0, &[q[0], q[1], q[2]]);
        self.wrist_matches(&r03, &p03, &[q[3], q[4], q[5]], target)
    }

    /// Whether the tool pose with frame 3 at (`r03`, `p03`) and the wrist at `wrist` is `target`
    /// to [`CHECK_TOL`]: forward kinematics by the link rotation matrices, the rotation error the
    /// angle of `R_toolᵀ R_target` from its skew part and trace (accurate near zero).
    fn wrist_matches(
        &self,
        r03: &Matrix3<f64>,
        p03: &Vector3<f64>,
        wrist: &[f64; 3],
        target: &Isometry3<f64>,
    ) -> bool {
        let (mut r6, mut p6) = (*r03, *p03);
        self.advance(&mut r6, &mut p6, 3, wrist);
        let tool = &self.t_flange_tool;
        let p = p6 + r6 * tool.translation.vector;
        if (p - target.translation.vector).norm() >= CHECK_TOL {
            return false;
        }
        let r_tool = r6 * tool.rotation.to_rotation_matrix().into_inner();
        let e = r_tool.tr_mul(&target.rotation.to_rotation_matrix().into_inner());
        let sin = 0.5
            * Vector3::new(
                e[(2, 1)] - e[(1, 2)],
                e[(0, 2)] - e[(2, 0)],
                e[(1, 0)] - e[(0, 1)],
            )
            .norm();
        let cos = 0.5 * (e.trace() - 1.0);
        // The angle is at most sin/cos for cos > 0: within half the tolerance it passes without
        // the arc tangent (whose answer would be the same).
        (cos > 0.0 && sin < 0.5 * CHECK_TOL * cos) || sin.atan2(cos) < CHECK_TOL
    }
}

// `f64::floor`, `ceil` and `round` as integers, inline: the target's baseline (x86-64 without
// SSE4.1) has no rounding instruction and the library's are software routines, a good part of
// the IK's time. The same values as `x.floor() as i64` etc. (`as` saturates, NaN gives 0); `x`
// minus its truncation is exact.

fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x { t - 1 } else { t }
}

fn ceil_i64(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) < x { t + 1 } else { t }
}

/// The angle `x` less the nearest multiple of 2π, in [−π, π] (within its round-off).
fn wrapped_signed(x: f64) -> f64 {
    x - TAU * round_i64(x / TAU) as f64
}

/// The distance of the angle `x` from the nearest multiple of 2π (within its round-off).
fn wrapped(x: f64) -> f64 {
    wrapped_signed(x).abs()
}

/// Halves away from zero, as `f64::round`.
fn round_i64(x: f64) -> i64 {
    let t = x as i64;
    let frac = x - t as f64;
    if frac >= 0.5 {
        t + 1
    } else if frac <= -0.5 {
        t - 1
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::ChaCha8Rng;
    use rand::{RngExt, SeedableRng};

    use crate::arm::test_arm as arm;

    #[test]
    fn integer_rounding_is_the_library_s() {
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            -1.5,
            2.5,
            -2.5,
            0.49999999999999994,
            -0.49999999999999994,
        ];
        values.extend([
            1.0 - f64::EPSILON / 2.0,
            -1.0 + f64::EPSILON / 2.0,
            3.0,
            -3.0,
            1e6 + 0.5,
            f64::NAN,
        ]);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        values.extend((0..10_000).map(|_| rng.random_range(-10.0..10.0)));
        for x in values {
            assert_eq!(floor_i64(x), x.floor() as i64, "{x}");
            assert_eq!(ceil_i64(x), x.ceil() as i64, "{x}");
            assert_eq!(round_i64(x), x.round() as i64, "{x}");
        }
    }

    fn random_q(arm: &Arm, rng: &mut ChaCha8Rng) -> JointVector {
        JointVector::from_fn(|i, _| {
            let [lo, hi] = arm.links[i].limits;
            rng.random_range(lo..hi)
        })
    }

    /// The eight solutions of a generic pose are the arm's eight postures, each its own and
    /// no other's; a configuration nudged along any joint keeps its posture, and one through
    /// the wrist's singularity (`q5` across 0) meets both.
    #[test]
    fn the_eight_solutions_are_eight_postures() {
        let mut arm = arm();
        for l in &mut arm.links {
            l.limits = [-PI, PI];
        }
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for q in [
            JointVector::new(0.4, 0.6, -2.0, 0.5, 0.8, -0.3),
            random_q(&arm, &mut rng),
        ] {
            let sols = arm.ik(&arm.t_base_tool(&q), &q).unwrap();
            assert_eq!(sols.len(), 8, "{q}");
            for (i, a) in sols.as_slice().iter().enumerate() {
                for (j, b) in sols.as_slice().iter().enumerate() {
                    assert_eq!(arm.same_posture(a, b), i == j, "{a} {b}");
                }
                for k in 0..6 {
                    let mut nudged = *a;
                    nudged[k] += 1e-3;
                    assert!(arm.same_posture(a, &nudged), "{a} joint {k}");
                }
            }
        }
        let off = arm.links[4].dh().theta_offset;
        let at = JointVector::new(0.4, 0.6, -2.0, 0.5, -off, -0.3);
        let mut bent = at;
        bent[4] += 0.3;
        let mut other = at;
        other[4] -= 0.3;
        assert!(!arm.same_posture(&bent, &other));
        assert!(arm.same_posture(&at, &bent) && arm.same_posture(&at, &other));
    }

    #[test]
    fn a_generic_pose_has_eight_distinct_solutions_with_wide_limits() {
        let mut arm = arm();
        for l in &mut arm.links {
            l.limits = [-PI, PI];
        }
        let q = JointVector::new(0.4, 0.6, -2.0, 0.5, 0.8, -0.3);
        let sols = arm.ik(&arm.t_base_tool(&q), &q).unwrap();
        assert_eq!(sols.analytic, 8);
        assert_eq!(sols.len(), 8);
        assert!((sols.nearest().unwrap() - q).norm() < 1e-9);
        for (i, a) in sols.as_slice().iter().enumerate() {
            for b in &sols.as_slice()[i + 1..] {
                assert!((a - b).norm() > 1e-3, "duplicate solutions");
            }
        }
    }

    /// The closed-form manipulability equals `|det J|` of the Jacobian (LU) over random
    /// configurations, and `within_reach` holds wherever the IK has a solution and fails
    /// wherever the wrist centre is moved out of the elbow's reach.
    #[test]
    fn manipulability_and_reach_agree_with_the_jacobian_and_the_ik() {
        let arm = arm();
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let mut far = 0;
        for _ in 0..2_000 {
            let q = random_q(&arm, &mut rng);
            let target = arm.t_base_tool(&q);
            let lu = arm.jacobian(&q).determinant().abs();
            let closed = arm.manipulability_at(&target, &q).unwrap();
            assert!(
                (closed - lu).abs() <= 1e-9 * lu.max(1e-3),
                "{closed} vs {lu} at {q:?}"
            );
            assert!(arm.within_reach(&target));
            // Moved 2 m along the base's x: out of reach, and the IK agrees.
            let moved = Isometry3::translation(2.0, 0.0, 0.0) * target;
            assert!(arm.ik(&moved, &q).unwrap().is_empty());
            if !arm.within_reach(&moved) {
                far += 1;
            }
        }
        assert_eq!(far, 2_000);
        // At the wrist singularity and with the elbow straight the determinant vanishes.
        let mut q = JointVector::new(0.3, -0.4, 0.2, 0.1, 0.0, 0.5);
        assert!(arm.manipulability_at(&arm.t_base_tool(&q), &q).unwrap() < 1e-12);
        let dh2 = *arm.links[2].dh();
        q[4] = 0.7;
        q[2] = -dh2.theta_offset - arm.links[3].dh().d.atan2(dh2.a);
        assert!(arm.manipulability_at(&arm.t_base_tool(&q), &q).unwrap() < 1e-12);
        assert!(arm.jacobian(&q).determinant().abs() < 1e-9);
    }

    #[test]
    fn unreachable_pose_gives_no_solution() {
        let arm = arm();
        let far = Isometry3::translation(3.0, 0.0, 0.0);
        let sols = arm.ik(&far, &JointVector::zeros()).unwrap();
        assert!(sols.is_empty());
        assert_eq!(sols.analytic, 0);
    }

    #[test]
    fn ik_of_fk_is_identity_over_random_configurations() {
        // Property test: 10 000 random configurations within the limits (seeded).
        let arm = arm();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut exact = 0;
        for _ in 0..10_000 {
            let q = random_q(&arm, &mut rng);
            let target = arm.t_base_tool(&q);
            let sols = arm.ik(&target, &q).unwrap();
            assert!(!sols.is_empty(), "no solution for q = {q:?}");
            for s in sols.as_slice() {
                assert!(arm.within_limits(s), "solution out of limits: {s:?}");
                assert!(arm.pose_matches(s, &target));
            }
            // Away from the wrist singularity the nearest solution is q itself.
            if q[4].sin().abs() > 1e-3 {
                let near = sols.nearest().unwrap();
                assert!((near - q).norm() < 1e-6, "nearest {near:?} vs {q:?}");
                exact += 1;
            }
        }
        assert!(exact > 9_900);
    }

    #[test]
    fn nearest_alone_is_the_nearest_of_all() {
        let arm = arm();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for k in 0..4_000 {
            let q = random_q(&arm, &mut rng);
            let target = arm.t_base_tool(&q);
            // A far configuration, one near the solution (as when following a path), or one
            // near the solution with the wrist flipped (θ4 + π, −θ5, θ6 + π).
            let near = JointVector::from_fn(|_, _| rng.random_range(-0.05..0.05));
            let q_now = match k % 3 {
                0 => random_q(&arm, &mut rng),
                1 => q + near,
                _ => {
                    let o = |i: usize| arm.links[i].dh().theta_offset;
                    let mut flipped = q;
                    flipped[3] += PI;
                    flipped[4] = -(q[4] + o(4)) - o(4);
                    flipped[5] += PI;
                    flipped + near
                }
            };
            let all = arm.ik(&target, &q_now).unwrap();
            assert_eq!(arm.ik_nearest(&target, &q_now).unwrap().as_ref(), all.nearest());
        }
    }

    #[test]
    fn wrist_singularity_keeps_q4() {
        let arm = arm();
        let q = JointVector::new(0.2, 0.5, -1.5, 0.7, 0.0, 0.4);
        let q_now = JointVector::new(0.2, 0.5, -1.5, 0.3, 0.0, 0.8);
        let sols = arm.ik(&arm.t_base_tool(&q), &q_now).unwrap();
        let near = sols.nearest().unwrap();
        assert!(
            (near[3] - 0.3).abs() < 1e-9 && (near[5] - 0.8).abs() < 1e-9,
            "{near:?}"
        );
    }

    #[test]
    fn non_puma_arm_is_refused() {
        let mut arm = arm();
        let dh = crate::model::Dh {
            a: 0.1,
            ..*arm.links[3].dh()
        };
        arm.links[3].set_dh(dh);
        assert_eq!(
            arm.ik(&Isometry3::identity(), &JointVector::zeros())
                .unwrap_err()
                .exit_code(),
            2
        );
    }
}
