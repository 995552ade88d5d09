//! TCU, the trajectory correction unit of Figure 4: eq. (18).
//!
//! The desired tool pose (`P*`, `X*_G`, `Y*_G` in the world `W`, plus the FCU's `ΔP* = x̃ k`)
//! is expressed in the vehicle frame `C` with the vehicle's displacement `r` and attitude
//! `ᴼ_C R` as NS knows them:
//! `ᶜP* = ᴼ_C Rᵀ (P* − r)`, `ᶜX*_G = ᴼ_C Rᵀ X*_G`, `ᶜY*_G = ᴼ_C Rᵀ Y*_G`,
//! then in the arm's base frame, and the analytic inverse kinematics gives the joint set-points
//! (the solution nearest the previous set-point; no Jacobian inverse). The displacement is
//! NS's estimate of where the vehicle is now ([`super::navigation`]: the accelerometers
//! between the delayed fixes). With the correction switched off (an ablation) the vehicle is
//! assumed to sit at its stabilisation point.

use crate::arm::{Arm, JointVector};
use crate::error::Result;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// The desired tool pose in the arm's base frame (eq. 18), from the desired pose in the world
/// and the vehicle pose the controller believes (`t_world_body`).
pub fn tool_in_base(
    arm: &Arm,
    t_world_tool: &Isometry3<f64>,
    t_world_body: &Isometry3<f64>,
) -> Isometry3<f64> {
    (t_world_body * arm.t_body_base()).inverse() * t_world_tool
}

/// The vehicle pose from a position fix and an attitude.
pub fn vehicle_pose(position: &Vector3<f64>, attitude: &UnitQuaternion<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(*position), *attitude)
}

/// The largest step of a joint's set-point from one update to the next that is a motion
/// whatever the posture, rad. At the tool's centimetres a second the set-points move by under a
/// milliradian a control period (0.6 rad/s at most in both pipelines' runs); where two
/// postures meet (the wrist's, the elbow's or the shoulder's singularity) the nearest solution
/// passes from one to the other continuously, and elsewhere the other postures lie radians away
/// (the waist's other side, the wrist turned by π). Half a radian is above the 0.18 rad a
/// vehicle off its station by 2 cm and 30 mrad asks of the arm at once.
pub const POSTURE_STEP_RAD: f64 = 0.5;

/// Joint set-points for the tool pose `t_base_tool`: the IK solution nearest `q_prev` if it
/// steps by at most [`POSTURE_STEP_RAD`] or keeps the posture of `q_prev`
/// ([`Arm::same_posture`]), else the nearest that keeps it; `None` if the pose is out of reach
/// within the joint limits in that posture. Taking another posture swung the arm through the
/// workspace: in soil with the waist at its limit, its set-point turned by 2.4 rad within
/// 0.1 s and the sampler ploughed 15 cm off its path at 220 N. A set-point held meanwhile
/// catches up with the target once the posture reaches it again, however far it has moved.
///
/// # Errors
/// As [`Arm::ik`] (an arm not of the PUMA class, a non-finite pose).
pub fn set_point(
    arm: &Arm,
    t_base_tool: &Isometry3<f64>,
    q_prev: &JointVector,
) -> Result<Option<JointVector>> {
    let Some(q) = arm.ik_nearest(t_base_tool, q_prev)? else {
        return Ok(None);
    };
    if (q - q_prev).amax() <= POSTURE_STEP_RAD || arm.same_posture(&q, q_prev) {
        return Ok(Some(q));
    }
    Ok(arm
        .ik(t_base_tool, q_prev)?
        .as_slice()
        .iter()
        .find(|s| arm.same_posture(s, q_prev))
        .copied())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::UvmsModel;
    use crate::multibody::{Multibody, State};

    /// A vehicle displaced by r and turned by R: the corrected set-point puts the tool back on
    /// the same world pose, exactly.
    #[test]
    fn correction_keeps_the_tool_on_its_world_pose() {
        let mb = Multibody::new(&UvmsModel::default()).unwrap();
        let q0 = JointVector::new(0.1, 0.9, -2.0, 0.2, 0.6, -0.1);
        let home = Isometry3::identity();
        let target = mb.t_world_tool(&State::at_rest(home, q0));
        let moved = vehicle_pose(
            &Vector3::new(0.02, -0.015, 0.01),
            &UnitQuaternion::from_euler_angles(0.02, -0.01, 0.03),
        );
        let q = set_point(&mb.arm, &tool_in_base(&mb.arm, &target, &moved), &q0)
            .unwrap()
            .unwrap();
        let reached = mb.t_world_tool(&State::at_rest(moved, q));
        assert!((reached.translation.vector - target.translation.vector).norm() < 1e-9);
        assert!(reached.rotation.angle_to(&target.rotation) < 1e-9);
        // Without the correction the tool is off by about the displacement.
        let q_uncorrected = set_point(&mb.arm, &tool_in_base(&mb.arm, &target, &home), &q0)
            .unwrap()
            .unwrap();
        let off = mb.t_world_tool(&State::at_rest(moved, q_uncorrected));
        assert!((off.translation.vector - target.translation.vector).norm() > 0.02);
    }

    /// Past the waist's limit the nearest solution within the limits is the arm's other
    /// posture, 2.4 rad away: no set-point (held, counted out of reach); a step within the
    /// limit is one, and so is a long one in the posture.
    #[test]
    fn another_posture_is_no_set_point() {
        let mb = Multibody::new(&UvmsModel::default()).unwrap();
        let home = Isometry3::identity();
        let limit = mb.arm.links[0].limits[1];
        let q0 = JointVector::new(limit - 0.04, 0.9, -2.0, 0.2, 0.6, -0.1);
        let at = |q1: f64| {
            let mut q = q0;
            q[0] = q1;
            tool_in_base(&mb.arm, &mb.t_world_tool(&State::at_rest(home, q)), &home)
        };
        let beyond = at(limit + 0.06);
        let other = mb.arm.ik_nearest(&beyond, &q0).unwrap().unwrap();
        assert!((other - q0).amax() > 1.0, "{other}");
        assert_eq!(set_point(&mb.arm, &beyond, &q0).unwrap(), None);
        let q = set_point(&mb.arm, &at(limit - 0.03), &q0).unwrap().unwrap();
        assert!((q[0] - (limit - 0.03)).abs() < 1e-9, "{q}");
        // A set-point held while the target moved on catches up in its posture, 0.55 rad on.
        let held = JointVector::new(limit - 0.6, 0.9, -2.0, 0.2, 0.6, -0.1);
        let q = set_point(&mb.arm, &at(limit - 0.05), &held).unwrap().unwrap();
        assert!((q[0] - (limit - 0.05)).abs() < 1e-9, "{q}");
    }
}
