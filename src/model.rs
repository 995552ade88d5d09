//! The model file: every parameter of the vehicle, its thrusters, the arm and the water.
//!
//! A model is a TOML file (`data/models/*.toml`) read into [`UvmsModel`]. Missing sections and
//! keys take the defaults, which are the AUV300 + PUMA 560 set of the research notes
//! (`../shared/research/parameters.json`) and are exactly `data/models/auv300_puma560.toml` (a
//! test checks it). A link
//! of the arm, a thruster and a link's hydrodynamic cylinder must be given in full when given.
//!
//! Units are SI (m, kg, s, N, rad). Frames (DESIGN.md): world `W` NED (z down); vehicle body `C`
//! (x forward, y starboard, z down, origin at the centre of buoyancy); arm base `0` at
//! `arm.mount_position` in `C`; links `1..6` by standard Denavit–Hartenberg,
//! `T_i = Rz(q_i + theta_offset) Tz(d) Tx(a) Rx(alpha)`; tool `G` at `arm.tool` in frame 6.
//! Matrices are written as rows. Spatial 6-vectors and 6×6 matrices are ordered
//! [linear; angular] as in Fossen.

use crate::config;
use crate::error::{Error, Result};
use nalgebra::{Matrix3, Matrix6, Rotation3, Vector3};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Number of joints of the arm (the PUMA class).
pub const N_JOINTS: usize = 6;

/// The whole model: water, vehicle, thrusters and arm.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct UvmsModel {
    /// The water and gravity.
    pub environment: Environment,
    /// The vehicle's rigid body and hydrodynamics.
    pub vehicle: VehicleModel,
    /// The thrusters.
    pub thrusters: ThrustersModel,
    /// The manipulator.
    pub arm: ArmModel,
}

/// Water and gravity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Environment {
    /// Water density, kg/m³.
    pub water_density: f64,
    /// Gravitational acceleration, m/s², along +z of the world (NED).
    pub gravity: f64,
    /// Velocity of the water in the world frame (constant, irrotational current), m/s.
    pub current: [f64; 3],
}

/// The vehicle as a 6-DOF rigid body with Fossen hydrodynamics, all in the body frame `C`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VehicleModel {
    /// Dry mass without the arm links, kg.
    pub mass: f64,
    /// Inertia about the centre of gravity in `C` axes, kg·m² (rows).
    pub inertia: [[f64; 3]; 3],
    /// Centre of gravity in `C`, m.
    pub center_of_gravity: [f64; 3],
    /// Centre of buoyancy in `C`, m (the origin of `C` by DESIGN.md).
    pub center_of_buoyancy: [f64; 3],
    /// Displaced volume of the hull, m³.
    pub displaced_volume: f64,
    /// The point in `C` about which `added_mass` and the damping are given, m.
    pub hydrodynamic_origin: [f64; 3],
    /// Added mass 6×6 (positive magnitudes, symmetric), [linear; angular], `C` axes at
    /// `hydrodynamic_origin`; kg, kg·m, kg·m².
    pub added_mass: [[f64; 6]; 6],
    /// Linear damping D_L (diagonal), N·s/m and N·m·s.
    pub linear_damping: [f64; 6],
    /// Quadratic damping (diagonal, times |ν|), N·s²/m² and N·m·s².
    pub quadratic_damping: [f64; 6],
}

/// The thruster set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ThrustersModel {
    /// How thrust follows the lagged rotor state.
    pub static_characteristic: StaticCharacteristic,
    /// The thrusters, in allocation order.
    pub units: Vec<ThrusterModel>,
}

/// A thruster's static characteristic: thrust as a function of its lagged rotor state `s`
/// (`-1 ≤ s ≤ 1`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StaticCharacteristic {
    /// `T = T_max s`: the thrust itself follows the command with a first-order lag.
    Linear,
    /// `T = T_max s|s|` (a propeller: thrust ∝ n|n|), `s` the rotor speed ratio, lagged.
    Quadratic,
}

/// One thruster, in `C`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThrusterModel {
    /// Position in `C`, m.
    pub position: [f64; 3],
    /// Direction of positive thrust in `C` (normalised on use).
    pub direction: [f64; 3],
    /// Largest thrust either way, N.
    pub max_thrust: f64,
    /// Time constant of the first-order lag of the rotor, s.
    pub time_constant: f64,
}

/// The manipulator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ArmModel {
    /// Origin of the base frame 0 in `C` (the paper's `d0`), m.
    pub mount_position: [f64; 3],
    /// Rotation `R_C_0` (rows; columns are the base axes in `C`).
    pub mount_rotation: [[f64; 3]; 3],
    /// Velocity scale of the smoothed Coulomb friction `Tc·tanh(q̇/ε)` in the simulated plant,
    /// rad/s (inverse dynamics uses the exact sign rule).
    pub coulomb_smoothing: f64,
    /// Number of strips along each link cylinder for the cross-flow drag integral.
    pub drag_strips: usize,
    /// The tool frame `G` in DH frame 6.
    pub tool: ToolModel,
    /// The six links, base to tip.
    pub links: [LinkModel; N_JOINTS],
}

/// The tool frame `G` in DH frame 6.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ToolModel {
    /// Origin of `G` in frame 6, m.
    pub position: [f64; 3],
    /// Rotation `R_6_G` (rows).
    pub rotation: [[f64; 3]; 3],
}

/// Standard Denavit–Hartenberg parameters of one revolute joint:
/// `T = Rz(q + theta_offset) Tz(d) Tx(a) Rx(alpha)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Dh {
    /// Joint angle offset, rad.
    pub theta_offset: f64,
    /// Offset along the previous z, m.
    pub d: f64,
    /// Length along the new x, m.
    pub a: f64,
    /// Twist about the new x, rad.
    pub alpha: f64,
}

/// One link with its joint and drive. Friction and rotor inertia are motor-side, as in the
/// Robotics Toolbox: on the link side the drive adds `G² Jm q̈ + |G|(|G| B q̇ + Tc)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkModel {
    /// The joint's DH parameters.
    pub dh: Dh,
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass in the link's DH frame, m.
    pub center_of_mass: [f64; 3],
    /// Inertia about the centre of mass, DH-frame axes, kg·m² (rows).
    pub inertia: [[f64; 3]; 3],
    /// Motor rotor inertia `Jm`, kg·m² (motor side).
    pub motor_inertia: f64,
    /// Gear ratio `G` (motor turns per joint turn; the sign is the motor's direction).
    pub gear_ratio: f64,
    /// Viscous friction `B`, N·m·s/rad (motor side).
    pub viscous_friction: f64,
    /// Coulomb friction `Tc` for q̇ > 0 and for q̇ < 0 (N·m, motor side; the second is ≤ 0).
    pub coulomb_friction: [f64; 2],
    /// Joint limits [lower, upper], rad.
    pub joint_limits: [f64; 2],
    /// Largest drive torque either way, link side, N·m.
    pub torque_limit: f64,
    /// The link's hydrodynamic body, if it has one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hydro: Option<CylinderModel>,
}

/// A link's hydrodynamic body: a circular cylinder in the link's DH frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderModel {
    /// Radius, m.
    pub radius: f64,
    /// Length, m.
    pub length: f64,
    /// Axis direction in the DH frame (normalised on use).
    pub axis: [f64; 3],
    /// Centre in the DH frame (also the centre of buoyancy), m.
    pub center: [f64; 3],
    /// The volume is already counted in the vehicle's displaced volume (no separate buoyancy).
    #[serde(default)]
    pub volume_in_hull: bool,
    /// Cross-flow drag coefficient C_d (DNV-RP-C205 App. E).
    #[serde(default = "default_cd_cross")]
    pub drag_cross: f64,
    /// Axial drag coefficient, on the end area π r².
    #[serde(default = "default_cd_axial")]
    pub drag_axial: f64,
    /// Transverse added-mass coefficient C_a (DNV-RP-C205 App. D: 1 for a circular cylinder).
    #[serde(default = "default_ca")]
    pub added_mass_coefficient: f64,
    /// Linear damping (diagonal) on the velocity of the centre, [vx vy vz wx wy wz] in DH-frame
    /// axes, N·s/m and N·m·s.
    #[serde(default)]
    pub linear_damping: [f64; 6],
}

fn default_cd_cross() -> f64 {
    1.1
}
fn default_cd_axial() -> f64 {
    0.9
}
fn default_ca() -> f64 {
    1.0
}

impl Default for Environment {
    /// Standard sea water, still.
    fn default() -> Self {
        Environment {
            water_density: 1025.0,
            gravity: 9.81,
            current: [0.0; 3],
        }
    }
}

/// Depth of the AUV300's centre of gravity below its centre of buoyancy, m.
const AUV300_BG: f64 = 0.16321778883335006;

impl Default for VehicleModel {
    /// AUV300: the RexROV Fossen model (Berg 2012, uuv_simulator) Froude-scaled to 300 kg.
    fn default() -> Self {
        VehicleModel {
            mass: 300.0,
            inertia: [
                [25.0445353652983, -0.06864259107716088, -1.592603449922184],
                [-0.06864259107716088, 37.85829571769526, 0.12393801166709605],
                [-1.592603449922184, 0.12393801166709605, 32.949873771018],
            ],
            center_of_gravity: [0.0, 0.0, AUV300_BG],
            center_of_buoyancy: [0.0; 3],
            displaced_volume: 0.3002441406271791,
            hydrodynamic_origin: [0.0, 0.0, AUV300_BG],
            added_mass: [
                [
                    125.57881118918661,
                    1.107533000155674,
                    16.638842216579796,
                    0.7484710596487015,
                    14.504003373006583,
                    0.6836963242755967,
                ],
                [
                    1.107533000155674,
                    196.79312029288147,
                    8.259835629968814,
                    -35.87362052098475,
                    -0.512450253280421,
                    5.495820439623118,
                ],
                [
                    16.638842216579796,
                    8.259835629968814,
                    589.397005695513,
                    -0.5354407720980902,
                    -33.856693146050524,
                    0.9440218940585927,
                ],
                [
                    0.7484710596487015,
                    -35.87362052098475,
                    -0.5354407720980902,
                    25.497862477203714,
                    0.47797170884075835,
                    -1.0019434873964197,
                ],
                [
                    14.504003373006583,
                    -0.512450253280421,
                    -33.856693146050524,
                    0.47797170884075835,
                    40.1697396352866,
                    -0.053207541778004845,
                ],
                [
                    0.6836963242755967,
                    5.495820439623118,
                    0.9440218940585927,
                    -1.0019434873964197,
                    -0.053207541778004845,
                    10.692990298908837,
                ],
            ],
            linear_damping: [
                16.335532353454603,
                15.169644318605,
                159.03236789971044,
                17.371500103532156,
                20.019232094758763,
                6.785742227942249,
            ],
            quadratic_damping: [
                221.47350734225452,
                293.7893938178716,
                539.0199027095225,
                32.033209169341745,
                36.916366829025336,
                24.943478217323594,
            ],
        }
    }
}

impl Default for ThrustersModel {
    /// Six thrusters (h = 0.30, l = 0.55, k = 0.55 m) in the plane of the centre of gravity,
    /// 150 N, 0.2 s (Girona 500 UWSim), propeller characteristic.
    fn default() -> Self {
        let (h, l, k) = (0.3, 0.55, 0.55);
        let unit = |x: f64, y: f64, d: [f64; 3]| ThrusterModel {
            position: [x, y, AUV300_BG],
            direction: d,
            max_thrust: 150.0,
            time_constant: 0.2,
        };
        let (ex, ey, ez) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
        ThrustersModel {
            static_characteristic: StaticCharacteristic::Quadratic,
            units: vec![
                unit(-l, h, ex),
                unit(-l, -h, ex),
                unit(k, 0.0, ey),
                unit(l, 0.0, ez),
                unit(-l, h, ez),
                unit(-l, -h, ez),
            ],
        }
    }
}

const IDENTITY3: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

impl Default for ArmModel {
    /// The PUMA 560 hanging under the hull at d0 = (0, 0, 0.35) m, a 0.10 m tool along z6.
    fn default() -> Self {
        ArmModel {
            mount_position: [0.0, 0.0, 0.35],
            mount_rotation: IDENTITY3,
            coulomb_smoothing: 0.02,
            drag_strips: 8,
            tool: ToolModel::default(),
            links: puma560_links(),
        }
    }
}

impl Default for ToolModel {
    /// 0.10 m along z6.
    fn default() -> Self {
        ToolModel {
            position: [0.0, 0.0, 0.1],
            rotation: IDENTITY3,
        }
    }
}

/// The PUMA 560 (roboticstoolbox-python `Puma560`, d1 = 0) with torque limits (Armstrong,
/// Khatib & Burdick 1986, Table 7) and link cylinders (parameters.md §6).
fn puma560_links() -> [LinkModel; N_JOINTS] {
    use std::f64::consts::FRAC_PI_2;
    let deg = |d: f64| d.to_radians();
    let cyl = |radius: f64, length: f64, axis: [f64; 3], center: [f64; 3]| CylinderModel {
        radius,
        length,
        axis,
        center,
        volume_in_hull: false,
        drag_cross: default_cd_cross(),
        drag_axial: default_cd_axial(),
        added_mass_coefficient: default_ca(),
        linear_damping: [0.0; 6],
    };
    let diag = |a: f64, b: f64, c: f64| [[a, 0.0, 0.0], [0.0, b, 0.0], [0.0, 0.0, c]];
    #[allow(clippy::too_many_arguments)]
    let link = |d: f64,
                a: f64,
                alpha: f64,
                mass: f64,
                com: [f64; 3],
                inertia: [[f64; 3]; 3],
                jm: f64,
                g: f64,
                b: f64,
                tc: [f64; 2],
                lim: [f64; 2],
                tmax: f64,
                hydro: CylinderModel| LinkModel {
        dh: Dh {
            theta_offset: 0.0,
            d,
            a,
            alpha,
        },
        mass,
        center_of_mass: com,
        inertia,
        motor_inertia: jm,
        gear_ratio: g,
        viscous_friction: b,
        coulomb_friction: tc,
        joint_limits: lim,
        torque_limit: tmax,
        hydro: Some(hydro),
    };
    let mut housing = cyl(0.1, 0.25, [0.0, 1.0, 0.0], [0.0; 3]);
    housing.volume_in_hull = true;
    [
        link(
            0.0,
            0.0,
            FRAC_PI_2,
            0.0,
            [0.0; 3],
            diag(0.0, 0.35, 0.0),
            200e-6,
            -62.6111,
            1.48e-3,
            [0.395, -0.435],
            [deg(-160.0), deg(160.0)],
            97.6,
            housing,
        ),
        link(
            0.0,
            0.4318,
            0.0,
            17.4,
            [-0.3638, 0.006, 0.2275],
            diag(0.13, 0.524, 0.539),
            200e-6,
            107.815,
            0.817e-3,
            [0.126, -0.071],
            [deg(-45.0), deg(225.0)],
            186.4,
            cyl(0.075, 0.55, [1.0, 0.0, 0.0], [-0.2159, 0.0, 0.2275]),
        ),
        link(
            0.15005,
            0.0203,
            -FRAC_PI_2,
            4.8,
            [-0.0203, -0.0141, 0.070],
            diag(0.066, 0.086, 0.0125),
            200e-6,
            -53.7063,
            1.38e-3,
            [0.132, -0.105],
            [deg(-225.0), deg(45.0)],
            89.4,
            cyl(0.055, 0.45, [0.0, 0.0, 1.0], [0.0, 0.0, 0.2]),
        ),
        link(
            0.4318,
            0.0,
            FRAC_PI_2,
            0.82,
            [0.0, 0.019, 0.0],
            diag(1.8e-3, 1.3e-3, 1.8e-3),
            33e-6,
            76.0364,
            71.2e-6,
            [11.2e-3, -16.9e-3],
            [deg(-110.0), deg(170.0)],
            24.2,
            cyl(0.045, 0.1, [0.0, 1.0, 0.0], [0.0; 3]),
        ),
        link(
            0.0,
            0.0,
            -FRAC_PI_2,
            0.34,
            [0.0; 3],
            diag(0.3e-3, 0.4e-3, 0.3e-3),
            33e-6,
            71.923,
            82.6e-6,
            [9.26e-3, -14.5e-3],
            [deg(-100.0), deg(100.0)],
            20.1,
            cyl(0.04, 0.08, [0.0, 0.0, 1.0], [0.0; 3]),
        ),
        link(
            0.0,
            0.0,
            0.0,
            0.09,
            [0.0, 0.0, 0.032],
            diag(0.15e-3, 0.15e-3, 0.04e-3),
            33e-6,
            76.686,
            36.7e-6,
            [3.96e-3, -10.5e-3],
            [deg(-266.0), deg(266.0)],
            21.3,
            cyl(0.03, 0.1, [0.0, 0.0, 1.0], [0.0, 0.0, 0.05]),
        ),
    ]
}

/// Loads a model file (or the default model when `path` is `None`) and checks it.
///
/// # Errors
/// [`Error::Input`] naming the file and the field when the file cannot be read, does not parse
/// or holds an impossible value (negative mass, a non-rotation, an empty thruster set...).
pub fn load(path: Option<&Path>) -> Result<UvmsModel> {
    let model: UvmsModel = config::load(path)?;
    model.validate(&origin(path))?;
    Ok(model)
}

/// How errors name a model: its file, or `default model`.
pub fn origin(path: Option<&Path>) -> String {
    path.map_or_else(|| "default model".to_string(), |p| p.display().to_string())
}

/// The 3×3 matrix of `rows`.
pub fn matrix3(rows: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|r, c| rows[r][c])
}

/// The 6×6 matrix of `rows`.
pub fn matrix6(rows: &[[f64; 6]; 6]) -> Matrix6<f64> {
    Matrix6::from_fn(|r, c| rows[r][c])
}

/// The vector of `v`.
pub fn vector3(v: &[f64; 3]) -> Vector3<f64> {
    Vector3::new(v[0], v[1], v[2])
}

/// A rotation from rows that must be orthonormal with determinant +1 (to 1e-6); the result is
/// the nearest exact rotation. `what` names the field in errors.
///
/// # Errors
/// [`Error::Input`] naming `what` when the matrix is not a rotation.
pub fn rotation(rows: &[[f64; 3]; 3], what: &str) -> Result<Rotation3<f64>> {
    let m = matrix3(rows);
    if m.iter().any(|v| !v.is_finite())
        || (m.transpose() * m - Matrix3::identity()).abs().max() > 1e-6
        || (m.determinant() - 1.0).abs() > 1e-6
    {
        return Err(Error::input(
            what,
            "is not a rotation matrix (orthonormal, determinant +1)",
        ));
    }
    if (m.transpose() * m - Matrix3::identity()).abs().max() < 1e-15 {
        return Ok(Rotation3::from_matrix_unchecked(m));
    }
    // The nearest rotation (polar decomposition): U Vᵀ of the SVD.
    let svd = m.svd(true, true);
    match (svd.u, svd.v_t) {
        (Some(u), Some(v_t)) => Ok(Rotation3::from_matrix_unchecked(u * v_t)),
        _ => Err(Error::input(what, "cannot be orthonormalised")),
    }
}

impl UvmsModel {
    /// Checks every value for physical sense; `origin` names the file in errors.
    ///
    /// # Errors
    /// [`Error::Input`] naming `origin` and the field at fault.
    pub fn validate(&self, origin: &str) -> Result<()> {
        let bad = |field: &str, why: &str| Error::input(format!("{origin}: {field}"), why);
        let finite = |field: &str, vals: &[f64]| -> Result<()> {
            if vals.iter().all(|v| v.is_finite()) {
                Ok(())
            } else {
                Err(bad(field, "must be finite numbers"))
            }
        };
        crate::config::within_range(self, &format!("{origin}: "))?;
        let e = &self.environment;
        finite(
            "environment",
            &[
                e.water_density,
                e.gravity,
                e.current[0],
                e.current[1],
                e.current[2],
            ],
        )?;
        if e.water_density < 0.0 || e.gravity < 0.0 {
            return Err(bad("environment", "water_density and gravity must be >= 0"));
        }
        let v = &self.vehicle;
        finite("vehicle.mass", &[v.mass, v.displaced_volume])?;
        if v.mass <= 0.0 || v.displaced_volume < 0.0 {
            return Err(bad("vehicle.mass", "mass must be > 0 and displaced_volume >= 0"));
        }
        check_inertia(&matrix3(&v.inertia)).map_err(|why| bad("vehicle.inertia", why))?;
        let ma = matrix6(&v.added_mass);
        finite("vehicle.added_mass", ma.as_slice())?;
        if (ma - ma.transpose()).abs().max() > 1e-9 * ma.abs().max().max(1.0) {
            return Err(bad("vehicle.added_mass", "must be symmetric"));
        }
        if ma.symmetric_eigenvalues().min() < -1e-9 * ma.abs().max().max(1.0) {
            return Err(bad("vehicle.added_mass", "must be positive semi-definite"));
        }
        for (field, d) in [
            ("vehicle.linear_damping", &v.linear_damping),
            ("vehicle.quadratic_damping", &v.quadratic_damping),
        ] {
            finite(field, d)?;
            if d.iter().any(|x| *x < 0.0) {
                return Err(bad(field, "damping magnitudes must be >= 0"));
            }
        }
        finite(
            "vehicle centres",
            &[v.center_of_gravity, v.center_of_buoyancy, v.hydrodynamic_origin].concat(),
        )?;
        if self.thrusters.units.is_empty() {
            return Err(bad("thrusters.units", "at least one thruster is needed"));
        }
        for (i, t) in self.thrusters.units.iter().enumerate() {
            let field = format!("thrusters.units[{}]", i + 1);
            finite(&field, &[t.position, t.direction].concat())?;
            if vector3(&t.direction).norm() < 1e-9 {
                return Err(bad(&field, "direction must be a non-zero vector"));
            }
            let positive = |x: f64| x > 0.0 && x.is_finite();
            if !(positive(t.max_thrust) && positive(t.time_constant)) {
                return Err(bad(&field, "max_thrust and time_constant must be > 0"));
            }
        }
        let a = &self.arm;
        finite("arm.mount_position", &a.mount_position)?;
        rotation(&a.mount_rotation, &format!("{origin}: arm.mount_rotation"))?;
        finite("arm.tool.position", &a.tool.position)?;
        rotation(&a.tool.rotation, &format!("{origin}: arm.tool.rotation"))?;
        if !(a.coulomb_smoothing > 0.0 && a.coulomb_smoothing.is_finite()) {
            return Err(bad("arm.coulomb_smoothing", "must be > 0 rad/s"));
        }
        if a.drag_strips == 0 || a.drag_strips > 64 {
            return Err(bad("arm.drag_strips", "must be between 1 and 64"));
        }
        for (i, l) in a.links.iter().enumerate() {
            let field = |f: &str| format!("arm.links[{}].{f}", i + 1);
            finite(&field("dh"), &[l.dh.theta_offset, l.dh.d, l.dh.a, l.dh.alpha])?;
            // Each drive value finite, and those that are magnitudes not negative.
            for (name, v, magnitude) in [
                ("mass", l.mass, true),
                ("motor_inertia", l.motor_inertia, true),
                ("gear_ratio", l.gear_ratio, false),
                ("viscous_friction", l.viscous_friction, true),
                ("torque_limit", l.torque_limit, false),
            ] {
                finite(&field(name), &[v])?;
                if magnitude && v < 0.0 {
                    return Err(bad(&field(name), "must be >= 0"));
                }
            }
            finite(&field("coulomb_friction"), &l.coulomb_friction)?;
            finite(&field("center_of_mass"), &l.center_of_mass)?;
            if l.coulomb_friction[0] < 0.0 || l.coulomb_friction[1] > 0.0 {
                return Err(bad(
                    &field("coulomb_friction"),
                    "expected [>= 0 for qd > 0, <= 0 for qd < 0]",
                ));
            }
            if l.torque_limit <= 0.0 {
                return Err(bad(&field("torque_limit"), "must be > 0"));
            }
            if l.gear_ratio == 0.0 {
                return Err(bad(
                    &field("gear_ratio"),
                    "must not be 0 (motor turns per joint turn: 1 for a direct drive, negative for a reversed motor)",
                ));
            }
            check_inertia(&matrix3(&l.inertia)).map_err(|why| bad(&field("inertia"), why))?;
            let [lo, hi] = l.joint_limits;
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(bad(
                    &field("joint_limits"),
                    "expected finite [lower, upper] with lower < upper",
                ));
            }
            if let Some(c) = &l.hydro {
                finite(
                    &field("hydro"),
                    &[
                        c.radius,
                        c.length,
                        c.drag_cross,
                        c.drag_axial,
                        c.added_mass_coefficient,
                    ],
                )?;
                finite(&field("hydro"), &[c.axis, c.center].concat())?;
                finite(&field("hydro.linear_damping"), &c.linear_damping)?;
                if c.radius <= 0.0 || c.length <= 0.0 {
                    return Err(bad(&field("hydro"), "radius and length must be > 0"));
                }
                if c.drag_cross < 0.0 || c.drag_axial < 0.0 || c.added_mass_coefficient < 0.0 {
                    return Err(bad(&field("hydro"), "coefficients must be >= 0"));
                }
                if c.linear_damping.iter().any(|x| *x < 0.0) {
                    return Err(bad(&field("hydro.linear_damping"), "must be >= 0"));
                }
                if vector3(&c.axis).norm() < 1e-9 {
                    return Err(bad(&field("hydro.axis"), "must be a non-zero vector"));
                }
            }
        }
        Ok(())
    }
}

/// A rotational inertia must be finite, symmetric and positive semi-definite. (The triangle
/// inequality of the principal moments is not required: the published PUMA 560 link 3 violates
/// it, and link 1 gives only the moment about its joint axis.)
fn check_inertia(i: &Matrix3<f64>) -> std::result::Result<(), &'static str> {
    if i.iter().any(|v| !v.is_finite()) {
        return Err("must be finite numbers");
    }
    let scale = i.abs().max().max(1e-12);
    if (i - i.transpose()).abs().max() > 1e-9 * scale {
        return Err("must be symmetric");
    }
    if i.symmetric_eigenvalues().min() < -1e-12 * scale {
        return Err("must be positive semi-definite");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_file_parses_to_the_default() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/data/models/auv300_puma560.toml"
        ))
        .unwrap();
        let m: UvmsModel = config::from_toml_str(&text, "auv300_puma560.toml").unwrap();
        assert_eq!(m, UvmsModel::default());
        m.validate("default").unwrap();
    }

    #[test]
    fn default_is_the_research_set() {
        // Spot values of ../shared/research/parameters.json (AUV300, PUMA 560, d0).
        let m = UvmsModel::default();
        assert_eq!(m.vehicle.mass, 300.0);
        assert_eq!(m.vehicle.added_mass[2][2], 589.397005695513);
        assert_eq!(m.arm.mount_position, [0.0, 0.0, 0.35]);
        assert_eq!(m.arm.links[1].mass, 17.4);
        assert_eq!(m.arm.links[2].dh.d, 0.15005);
        assert_eq!(m.thrusters.units.len(), 6);
        // Vehicle + links 2..6 neutrally buoyant (link 1's housing counted in the hull).
        let dry: f64 = m.vehicle.mass + m.arm.links.iter().map(|l| l.mass).sum::<f64>();
        let wet: f64 = m.vehicle.displaced_volume
            + m.arm
                .links
                .iter()
                .filter_map(|l| l.hydro.as_ref())
                .filter(|c| !c.volume_in_hull)
                .map(|c| std::f64::consts::PI * c.radius * c.radius * c.length)
                .sum::<f64>();
        assert!(
            (dry - m.environment.water_density * wet).abs() < 1e-6,
            "{dry} vs {}",
            1025.0 * wet
        );
    }

    #[test]
    fn rtb_model_parses() {
        let p = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/data/models/puma560_rtb.toml"
        ));
        let m = load(Some(p)).unwrap();
        assert_eq!(m.arm.links[0].dh.d, 0.67183);
        assert!(m.arm.links.iter().all(|l| l.hydro.is_none()));
    }

    #[test]
    fn partial_file_takes_defaults_and_typos_fail() {
        let m: UvmsModel = config::from_toml_str("[environment]\ngravity = 0.0\n", "x.toml").unwrap();
        assert_eq!(m.environment.gravity, 0.0);
        assert_eq!(m.vehicle, VehicleModel::default());
        let err = config::from_toml_str::<UvmsModel>("[vehicle]\nmas = 3.0\n", "x.toml").unwrap_err();
        assert!(err.to_string().contains("mas"), "{err}");
    }

    #[test]
    fn wrong_link_count_is_an_input_error() {
        let mut text = String::from("[arm]\n");
        for _ in 0..5 {
            text.push_str(
                "[[arm.links]]\ndh = { theta_offset = 0.0, d = 0.0, a = 0.0, alpha = 0.0 }\nmass = 1.0\n\
                 center_of_mass = [0.0, 0.0, 0.0]\ninertia = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]\n\
                 motor_inertia = 0.0\ngear_ratio = 1.0\nviscous_friction = 0.0\ncoulomb_friction = [0.0, 0.0]\n\
                 joint_limits = [-1.0, 1.0]\ntorque_limit = 1.0\n",
            );
        }
        let err = config::from_toml_str::<UvmsModel>(&text, "five.toml").unwrap_err();
        assert_eq!(err.exit_code(), 2);
        assert!(err.to_string().contains("five.toml"), "{err}");
    }

    #[test]
    fn impossible_values_are_rejected() {
        let mut m = UvmsModel::default();
        m.arm.links[3].joint_limits = [1.0, -1.0];
        let msg = m.validate("m.toml").unwrap_err().to_string();
        assert!(msg.contains("arm.links[4].joint_limits"), "{msg}");
        // Each drive value named by its own key (all three were named `mass`).
        let mut m = UvmsModel::default();
        m.arm.links[1].motor_inertia = -2e-4;
        let msg = m.validate("m.toml").unwrap_err().to_string();
        assert!(
            msg.contains("m.toml: arm.links[2].motor_inertia: must be >= 0"),
            "{msg}"
        );
        // A drive without gearing would lose its rotor's inertia and friction unnoticed.
        let mut m = UvmsModel::default();
        m.arm.links[0].gear_ratio = 0.0;
        let msg = m.validate("m.toml").unwrap_err().to_string();
        assert!(
            msg.contains("m.toml: arm.links[1].gear_ratio: must not be 0"),
            "{msg}"
        );
        let mut m = UvmsModel::default();
        m.arm.mount_rotation[0][0] = 2.0;
        assert!(
            m.validate("m.toml")
                .unwrap_err()
                .to_string()
                .contains("mount_rotation")
        );
        let mut m = UvmsModel::default();
        m.vehicle.added_mass[0][1] = 5.0;
        assert!(
            m.validate("m.toml")
                .unwrap_err()
                .to_string()
                .contains("symmetric")
        );
        let mut m = UvmsModel::default();
        m.thrusters.units.clear();
        assert!(m.validate("m.toml").is_err());
        // Finite but past any vehicle, named with its key (it failed in the simulation, after
        // the plan's products, as a mass matrix not positive definite or a thrust not finite).
        let mut m = UvmsModel::default();
        m.environment.water_density = 1e300;
        let msg = m.validate("m.toml").unwrap_err().to_string();
        assert!(
            msg.contains("m.toml: environment.water_density: 1e300 is beyond"),
            "{msg}"
        );
        let mut m = UvmsModel::default();
        m.vehicle.inertia[2][2] = -2e9;
        let msg = m.validate("m.toml").unwrap_err().to_string();
        assert!(msg.contains("vehicle.inertia[3][3]: -2e9"), "{msg}");
    }
}
