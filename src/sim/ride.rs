//! A dynamic test (seed §5.4) simulated: the bicycle held upright and still, pushed up to speed,
//! released, struck sideways at the saddle, and caught; the nonlinear Whipple bicycle
//! ([`super::whipple`]) in between, with the effects the linear model leaves out; a frame and a
//! handlebar sensor recording it all in the acquisition side's format.
//!
//! Effects (each off at zero): steering-head friction, viscous and Coulomb; lateral tyre
//! compliance (side slip with cornering and camber stiffness and a relaxation length, in place
//! of the lateral no-slip constraints); rolling resistance and aerodynamic drag (the coast slows
//! down); extra point masses on the frame or the fork (sensors, speedometer, polystyrene
//! protection); a truth bicycle whose parameters differ from the measured ones (pass it as the
//! bicycle); a speedometer reading off by a factor.

use super::draw::{seeded, Draw};
use super::imu::{self, BodySample, FileSpec, LinkModel, Locale, Precision, SensorModel};
use super::whipple::{self, Body, Load, RideState, WhippleParams};
use crate::jet::Jet;
use crate::model::Benchmark;
use crate::read::log::OutputMode;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// A point mass added to a body, at benchmark coordinates (x forward, z down from the rear
/// contact, upright bicycle).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointMass {
    pub body: Body,
    pub mass_kg: f64,
    pub x_m: f64,
    pub z_m: f64,
}

/// The physical effects of a ride, with documented sizes (issue 5's typical values).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Effects {
    /// Steering-head viscous friction (≈0.3 N·m·s/rad measured on an instrumented bicycle).
    pub steer_viscous_nms_per_rad: f64,
    /// Steering-head Coulomb friction (≈0.15 N·m).
    pub steer_coulomb_nm: f64,
    /// A spring on the steer (a stiff brake or gear cable, a bungee holding the handlebar):
    /// torque −k·δ (N·m/rad). Not among the gap stage's candidate effects.
    #[serde(skip_serializing_if = "is_zero")]
    pub steer_spring_nm_per_rad: f64,
    /// Rolling resistance coefficient: a force C_rr·N at each wheel centre against its motion.
    pub rolling_resistance_coeff: f64,
    /// Drag area C_d·A (m²) at the frame's centre of mass; air density 1.2 kg/m³.
    pub drag_area_m2: f64,
    pub extra_masses: Vec<PointMass>,
    /// Speedometer reading / true speed (a wrong wheel circumference).
    pub speedometer_scale: f64,
    /// Lateral tyre compliance in place of the lateral no-slip constraints (none: knife edges).
    pub tyres: Option<whipple::TyreModel>,
    /// The sensors' sample rate / the nominal 100 Hz (their clock running fast when above 1):
    /// the logs' time stamps stay at the nominal rate, so every rate read from them (the
    /// eigenvalues, the `Sync` speed) is the true one divided by this.
    pub clock_scale: f64,
    /// A geared steer motor on the head tube, powered or not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub steer_motor: Option<SteerMotor>,
}

/// A steer motor: its rotor turns with the fork through a gearbox, so that the fork carries the
/// rotor's inertia times the gear ratio squared about the steer axis whether the motor is
/// powered or not; powered, it applies the torque its controller commands, scaled by what the
/// driver and gearbox deliver.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SteerMotor {
    /// The rotor's inertia reflected to the steer axis (kg·m²): I_rotor · N².
    pub reflected_inertia_kgm2: f64,
    /// The controller, when powered.
    pub controller: Option<MotorController>,
}

/// A steer controller as the motor's firmware runs it: a steer torque (N·m, turning the fork
/// towards positive steer) of `Σ gains(v) · (roll, steer, roll rate, steer rate)` (rad, rad/s),
/// the gains linear between `speeds_mps` and constant beyond, v the speed the firmware's own
/// sensor reads (`speed_sensor_scale` times the rear wheel's); the motor delivers `delivered`
/// times it, through a first-order lag of `lag_s` (`T τ̇ = u − τ`; 0: at once).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotorController {
    pub speeds_mps: Vec<f64>,
    pub gains: Vec<[f64; 4]>,
    pub delivered: f64,
    /// The firmware's speed reading over the rear wheel's true speed (1: it reads true).
    #[serde(default = "one")]
    pub speed_sensor_scale: f64,
    /// The time constant (s) of the lag between the commanded torque and the delivered one (a
    /// motor driver's current loop, a filter on the command); 0 for none.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub lag_s: f64,
}

fn one() -> f64 {
    1.0
}

impl MotorController {
    /// The gains at speed `v` (m/s), as the firmware interpolates its table.
    fn gains_at(&self, v: f64) -> [f64; 4] {
        let s = &self.speeds_mps;
        let (Some(&first), Some(&last)) = (s.first(), s.last()) else {
            return [0.0; 4];
        };
        if v <= first {
            return self.gains[0];
        }
        if v >= last {
            return self.gains[s.len() - 1];
        }
        let k = s.iter().rposition(|&x| x <= v).unwrap_or(0);
        let f = (v - s[k]) / (s[k + 1] - s[k]);
        std::array::from_fn(|j| self.gains[k][j] + f * (self.gains[k + 1][j] - self.gains[k][j]))
    }

    /// The torque the motor is commanded to apply at the state `(q, q̇)`, times what it
    /// delivers (the rear wheel's radius `rr`): applied at once without a lag.
    fn torque_nm(&self, q: &[f64; 8], qd: &[f64; 8], rr: f64) -> f64 {
        let g = self.gains_at(self.speed_sensor_scale * -qd[5] * rr);
        let x = [q[3], q[6], qd[3], qd[6]];
        self.delivered * g.iter().zip(x).map(|(k, x)| k * x).sum::<f64>()
    }
}

/// The simulator's parameters of `bike` with a steer motor's reflected inertia on the fork,
/// about its own z axis (the steer axis).
pub fn params_with_motor(bike: &Benchmark, motor: Option<&SteerMotor>) -> WhippleParams {
    let mut p = WhippleParams::from_benchmark(bike);
    if let Some(m) = motor {
        p.ie[2][2] += m.reflected_inertia_kgm2;
    }
    p
}

pub(super) fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

impl Default for Effects {
    fn default() -> Self {
        Effects {
            steer_viscous_nms_per_rad: 0.0,
            steer_coulomb_nm: 0.0,
            steer_spring_nm_per_rad: 0.0,
            rolling_resistance_coeff: 0.0,
            drag_area_m2: 0.0,
            extra_masses: vec![],
            speedometer_scale: 1.0,
            tyres: None,
            clock_scale: 1.0,
            steer_motor: None,
        }
    }
}

impl Effects {
    /// A realistic mix for the lab's riderless bicycle: steer damping 0.3 N·m·s/rad, no Coulomb
    /// friction, C_rr 0.004, C_dA 0.08 m² (a bare bicycle: ≈0.1 m/s² at 5 m/s for the lab's
    /// 13 kg), two sensors and a speedometer (0.3 kg on the frame, 0.15 kg on the handlebar), a
    /// speedometer reading 3 % high, tyres with C_α = 11 /rad, C_γ = 0.6 /rad, σ = 0.18 m. No
    /// Coulomb friction: a riderless bicycle with good headset bearings follows the frictionless
    /// model (Kooijman, Schwab & Meijaard 2008), and friction has no linearization to state a
    /// true eigenvalue with (`steer_coulomb_nm` stays for robustness tests).
    /// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#effectsrealistic).
    pub fn realistic() -> Effects {
        Effects {
            steer_viscous_nms_per_rad: 0.3,
            steer_coulomb_nm: 0.0,
            steer_spring_nm_per_rad: 0.0,
            rolling_resistance_coeff: 0.004,
            drag_area_m2: 0.08,
            extra_masses: vec![
                PointMass {
                    body: Body::Frame,
                    mass_kg: 0.3,
                    x_m: 0.55,
                    z_m: -0.75,
                },
                PointMass {
                    body: Body::Fork,
                    mass_kg: 0.15,
                    x_m: 0.85,
                    z_m: -0.95,
                },
            ],
            speedometer_scale: 1.03,
            clock_scale: 1.0,
            steer_motor: None,
            tyres: Some(whipple::TyreModel {
                cornering_per_rad: 11.0,
                camber_per_rad: 0.6,
                relaxation_length_m: 0.18,
            }),
        }
    }
}

const AIR_DENSITY_KGPM3: f64 = 1.2;

/// Coulomb friction is smoothed as `F_c tanh(δ̇ / ε)`: ε = 0.01 rad/s is far below the steer
/// rates of a ride (0.1–1 rad/s) and keeps the equations from turning stiff at every reversal.
const COULOMB_SMOOTHING_RAD_PER_S: f64 = 0.01;

/// The bicycle with point masses added: each body's mass, centre and inertia (parallel axis).
pub fn with_point_masses(b: &Benchmark, masses: &[PointMass]) -> Benchmark {
    let mut out = *b;
    for pm in masses {
        let (m, x, z, ixx, iyy, izz, ixz) = match pm.body {
            Body::Frame => (
                &mut out.m_b,
                &mut out.x_b,
                &mut out.z_b,
                &mut out.i_bxx,
                &mut out.i_byy,
                &mut out.i_bzz,
                &mut out.i_bxz,
            ),
            _ => (
                &mut out.m_h,
                &mut out.x_h,
                &mut out.z_h,
                &mut out.i_hxx,
                &mut out.i_hyy,
                &mut out.i_hzz,
                &mut out.i_hxz,
            ),
        };
        let mt = *m + pm.mass_kg;
        let (xn, zn) = (
            (*m * *x + pm.mass_kg * pm.x_m) / mt,
            (*m * *z + pm.mass_kg * pm.z_m) / mt,
        );
        // Parallel axis for both parts about the new centre.
        let shift = |mass: f64, dx: f64, dz: f64| {
            (
                mass * dz * dz,
                mass * (dx * dx + dz * dz),
                mass * dx * dx,
                -mass * dx * dz,
            )
        };
        let (a1, b1, c1, d1) = shift(*m, *x - xn, *z - zn);
        let (a2, b2, c2, d2) = shift(pm.mass_kg, pm.x_m - xn, pm.z_m - zn);
        *ixx += a1 + a2;
        *iyy += b1 + b2;
        *izz += c1 + c2;
        *ixz += d1 + d2;
        *m = mt;
        *x = xn;
        *z = zn;
    }
    out
}

/// The kick at the saddle: a half-sine lateral force pulse.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Kick {
    /// After the release (s).
    pub after_release_s: f64,
    pub duration_s: f64,
    /// Peak force (N), positive to the right.
    pub peak_force_n: f64,
    /// Where the saddle is (benchmark coordinates, m).
    pub saddle_x_m: f64,
    pub saddle_z_m: f64,
}

/// Everything that defines a ride.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RideSpec {
    /// The speed at release (m/s).
    pub speed_mps: f64,
    pub standstill_s: f64,
    pub push_s: f64,
    /// From the release to the catch, at most (s); a fall over 0.5 rad of roll is caught earlier.
    pub coast_s: f64,
    pub kick: Kick,
    pub effects: Effects,
    /// Write the reed switch's `Sync` column and the wheel circumference.
    pub sync: bool,
    /// Coasting (the lab's rides) or the rear wheel's rate imposed.
    #[serde(default)]
    pub motion: whipple::Motion,
    pub mode: OutputMode,
    pub locale: Locale,
    /// Something gone wrong in the recording (for the analysis's diagnoses), or none.
    #[serde(default)]
    pub fault: Option<Fault>,
    /// Each sensor's mounting error (degrees, about a random axis); `None`: the lab's, a
    /// random rotation with 2° per axis.
    #[serde(default)]
    pub mounting_error_deg: Option<f64>,
    /// The magnetometer heading drifts (as the sensors do near steel, ~0.5°/min).
    #[serde(default = "yes")]
    pub heading_drift: bool,
    /// Bursts per minute in which the receiver stamps packets late ([`FileSpec`]); 0: none.
    #[serde(default)]
    pub receiver_late_bursts_per_minute: f64,
}

fn yes() -> bool {
    true
}

/// What can go wrong in a ride's recording.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Fault {
    /// The two sensors' labels exchanged in the files' headers.
    SensorsSwapped,
    /// The handlebar sensor lay still (off the bicycle) through the ride.
    HandlebarSensorStill,
    /// The recording stopped at this time (s).
    EndsAt(f64),
}

impl RideSpec {
    /// A ride at `speed_mps` with the lab's sequence and the given effects.
    pub fn lab(speed_mps: f64, effects: Effects) -> RideSpec {
        RideSpec {
            speed_mps,
            standstill_s: 2.0,
            push_s: 3.0,
            coast_s: 6.0,
            kick: Kick {
                after_release_s: 0.8,
                duration_s: 0.1,
                peak_force_n: 15.0,
                saddle_x_m: 0.35,
                saddle_z_m: -0.85,
            },
            effects,
            sync: false,
            motion: whipple::Motion::Free,
            mode: OutputMode::Euler,
            locale: Locale::Tab,
            fault: None,
            mounting_error_deg: None,
            heading_drift: true,
            receiver_late_bursts_per_minute: 0.0,
        }
    }
}

/// The truth of a simulated ride: never an input of the analysis.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RideTruth {
    /// Samples per second of the logs' time (per sample: the arrays below). Times are the
    /// logs' (the sensors' clock); speeds and eigenvalues are physical (true time).
    pub rate_hz: f64,
    pub release_s: f64,
    pub kick_s: f64,
    pub catch_s: f64,
    /// Forward speed of the rear contact (m/s), per sample.
    pub speed_mps: Vec<f64>,
    /// Roll of the frame (rad, positive to the right) and steer (rad), per sample.
    pub roll_rad: Vec<f64>,
    pub steer_rad: Vec<f64>,
    /// What the lab would write down: the speedometer's reading at release (m/s).
    pub noted_speed_mps: f64,
    pub effects: Effects,
    /// Mean speed over the free motion (kick to catch).
    pub mean_free_speed_mps: f64,
    /// The truth's weave and capsize eigenvalues over the free motion's speeds (every 0.05 m/s
    /// from below the slowest to above the fastest): the simulator's own equations, with the
    /// ride's smooth effects (steer viscous friction, tyres, drag, rolling resistance, masses),
    /// linearized at the upright straight run ([`super::linearize`]). Coulomb friction has no
    /// linearization and is left out.
    pub modes: Vec<TruthModes>,
}

/// The truth's eigenvalues at one speed (1/s): weave `[re, im]` with im > 0, capsize `[re, im]`.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct TruthModes {
    pub speed_mps: f64,
    pub weave: [f64; 2],
    pub capsize: [f64; 2],
}

impl RideTruth {
    /// The forward speed at time `t_s` (linear between samples; `None` outside the record).
    pub fn speed_at(&self, t_s: f64) -> Option<f64> {
        interpolate(&self.speed_mps, t_s * self.rate_hz)
    }

    /// The truth's weave eigenvalue at `speed_mps`, linear between the table's speeds; `None`
    /// outside the table.
    pub fn weave_at(&self, speed_mps: f64) -> Option<nalgebra::Complex<f64>> {
        let m = &self.modes;
        let k = m
            .windows(2)
            .position(|w| w[0].speed_mps <= speed_mps && speed_mps <= w[1].speed_mps)?;
        let (a, b) = (m[k], m[k + 1]);
        let u = (speed_mps - a.speed_mps) / (b.speed_mps - a.speed_mps);
        Some(nalgebra::Complex::new(
            a.weave[0] + u * (b.weave[0] - a.weave[0]),
            a.weave[1] + u * (b.weave[1] - a.weave[1]),
        ))
    }
}

fn interpolate(x: &[f64], at: f64) -> Option<f64> {
    if at.is_nan() || at < 0.0 || at > (x.len().checked_sub(1)?) as f64 {
        return None;
    }
    let k = (at.floor() as usize).min(x.len() - 1);
    let u = at - k as f64;
    Some(if u == 0.0 {
        x[k]
    } else {
        x[k] + u * (x[k + 1] - x[k])
    })
}

/// A simulated ride: the log pair's text and the truth.
#[derive(Debug, Clone)]
pub struct Ride {
    pub angles_log: String,
    pub cal_log: String,
    pub truth: RideTruth,
}

/// Why a ride could not be simulated (an analysed ride's errors are [`crate::ride::RideError`]).
#[derive(Debug, thiserror::Error)]
pub enum SimulationError {
    #[error("the bicycle has no upright configuration (pitch could not be solved)")]
    NoUpright,
    #[error(transparent)]
    Ode(#[from] super::ode::OdeError),
    #[error(
        "a steer motor whose torque lags its command is simulated on knife-edge wheels only \
         (not with compliant tyres)"
    )]
    LaggedMotorOnTyres,
}

/// The wheels' static normal loads (rear, front; N): the weight split by the centre of mass.
pub(super) fn static_normal_loads(b: &Benchmark) -> [f64; 2] {
    let mass = b.m_r + b.m_b + b.m_h + b.m_f;
    let weight = b.g * mass;
    let x_total = (b.x_b * b.m_b + b.x_h * b.m_h + b.w * b.m_f) / mass;
    let front = weight * x_total / b.w;
    [weight - front, front]
}

/// The loads of a ride beyond gravity and the contacts: steering-head friction, the kick at the
/// saddle (from `kick_s`), rolling resistance at each wheel and drag on the frame.
fn ride_loads(
    bike: &Benchmark,
    effects: &Effects,
    kick: &Kick,
    kick_s: f64,
) -> impl Fn(&whipple::LoadInput<'_>) -> Vec<Load> {
    let e = effects.clone();
    let kick = kick.clone();
    let normal = static_normal_loads(bike);
    let r_r = bike.r_r;
    let (sl, cl) = bike.lambda.sin_cos();
    // The saddle in the frame's axes relative to its centre of mass.
    let sx = kick.saddle_x_m - bike.x_b;
    let sz = kick.saddle_z_m - bike.z_b;
    let saddle = [sx * cl - sz * sl, 0.0, sx * sl + sz * cl];
    move |input: &whipple::LoadInput<'_>| -> Vec<Load> {
        let (t, q, qd) = (input.t, input.q, input.qd);
        let mut l = Vec::new();
        // A lagged motor's torque is a state of the coast's; otherwise the command, at once.
        let motor = input.actuator_torque_nm.unwrap_or_else(|| {
            e.steer_motor
                .as_ref()
                .and_then(|m| m.controller.as_ref())
                .map_or(0.0, |c| c.torque_nm(q, qd, r_r))
        });
        l.push(Load::Steer(
            motor
                - e.steer_viscous_nms_per_rad * qd[6]
                - e.steer_spring_nm_per_rad * q[6]
                - e.steer_coulomb_nm * (qd[6] / COULOMB_SMOOTHING_RAD_PER_S).tanh(),
        ));
        if t >= kick_s && t < kick_s + kick.duration_s {
            let f = kick.peak_force_n * (PI * (t - kick_s) / kick.duration_s).sin();
            let (s3, c3) = q[2].sin_cos();
            l.push(Load::Force {
                body: Body::Frame,
                offset_body_m: saddle,
                force_n: [-s3 * f, c3 * f, 0.0],
            });
        }
        for (k, body) in [Body::RearWheel, Body::FrontWheel].into_iter().enumerate() {
            let v = input.velocities[if body == Body::RearWheel { 1 } else { 3 }];
            let sp = (v[0] * v[0] + v[1] * v[1]).sqrt();
            if sp > 1e-6 && e.rolling_resistance_coeff > 0.0 {
                let f = e.rolling_resistance_coeff * normal[k] / sp;
                l.push(Load::Force {
                    body,
                    offset_body_m: [0.0; 3],
                    force_n: [-f * v[0], -f * v[1], 0.0],
                });
            }
        }
        if e.drag_area_m2 > 0.0 {
            let v = input.velocities[0];
            let sp = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            let k = 0.5 * AIR_DENSITY_KGPM3 * e.drag_area_m2 * sp;
            l.push(Load::Force {
                body: Body::Frame,
                offset_body_m: [0.0; 3],
                force_n: [-k * v[0], -k * v[1], -k * v[2]],
            });
        }
        l
    }
}

/// The ride's steer motor's command and lag (s) where its controller lags (`lag_s` > 0), for
/// [`whipple::Actuator`]: the torque the loads would apply at once without it.
fn lagged_motor(bike: &Benchmark, effects: &Effects) -> Option<(f64, MotorCommand)> {
    let c = effects.steer_motor.as_ref()?.controller.clone()?;
    let r_r = bike.r_r;
    (c.lag_s > 0.0).then(|| {
        let lag = c.lag_s;
        let command: MotorCommand =
            Box::new(move |i: &whipple::LoadInput<'_>| c.torque_nm(i.q, i.qd, r_r));
        (lag, command)
    })
}

/// A motor's command at a state (N·m).
type MotorCommand = Box<dyn Fn(&whipple::LoadInput<'_>) -> f64>;

/// Sensor outputs need positions, orientations, velocities and accelerations of two points:
/// kinematics along `(q, q̇, q̈)` as jets.
fn sample(
    p: &WhippleParams,
    q: &[f64; 8],
    qd: &[f64; 8],
    qdd: &[f64; 8],
    heading_rad: f64,
    frame_sensor: [f64; 3],
    bar_sensor: [f64; 3],
) -> [BodySample; 2] {
    let j: [Jet; 8] = std::array::from_fn(|i| Jet {
        v: q[i],
        d: qd[i],
        dd: qdd[i],
    });
    let to_g = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), heading_rad)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), PI);
    let out = |frame: &[[Jet; 3]; 3], origin: [Jet; 3], offset: [f64; 3]| -> BodySample {
        let r = Matrix3::from_fn(|i, k| frame[k][i].v);
        let rd = Matrix3::from_fn(|i, k| frame[k][i].d);
        let rdd = Matrix3::from_fn(|i, k| frame[k][i].dd);
        let w_m = rd * r.transpose();
        let w = Vector3::new(
            0.5 * (w_m[(2, 1)] - w_m[(1, 2)]),
            0.5 * (w_m[(0, 2)] - w_m[(2, 0)]),
            0.5 * (w_m[(1, 0)] - w_m[(0, 1)]),
        );
        let off = Vector3::from(offset);
        let a = Vector3::new(origin[0].dd, origin[1].dd, origin[2].dd) + rdd * off;
        let rot = UnitQuaternion::from_matrix(&r);
        BodySample {
            orientation: to_g * rot,
            omega_global: to_g * w,
            accel_global: to_g * a,
        }
    };
    let k = whipple::kinematics_jets(p, &j);
    [out(&k.0, k.1, frame_sensor), out(&k.2, k.3, bar_sensor)]
}

/// Simulates one ride of `bike` (the truth bicycle), deterministic for a seed.
pub fn simulate_ride(
    bike: &Benchmark,
    spec: &RideSpec,
    seed: u64,
) -> Result<Ride, SimulationError> {
    let mut rng = seeded(seed);
    let truth_bike = with_point_masses(bike, &spec.effects.extra_masses);
    let p = params_with_motor(&truth_bike, spec.effects.steer_motor.as_ref());
    // The logs' nominal rate; the sensors sample every `dt` of true time.
    let rate = 100.0;
    let dt = 1.0 / (rate * spec.effects.clock_scale);
    let heading = rng.range(0.0, 2.0 * PI);
    let (frame_sensor, bar_sensor) = ([0.05, 0.0, -0.25], [0.0, 0.0, -0.45]);
    // Held phase: upright, straight, the speed ramping up (cosine) to the release speed.
    let release_s = spec.standstill_s + spec.push_s;
    let n_hold = (release_s / dt).round() as usize;
    let upright = whipple::upright_state(&p, 0.0, 0.0, 0.0, 0.0, 0.0)
        .ok_or(SimulationError::NoUpright)?
        .0;
    let mut motion: [Vec<BodySample>; 2] = [Vec::new(), Vec::new()];
    let (mut roll, mut steer, mut speed) = (Vec::new(), Vec::new(), Vec::new());
    let mut wheel_angle = Vec::new();
    let (mut x, mut wheel) = (0.0, 0.0);
    let v0 = spec.speed_mps;
    for k in 0..n_hold {
        let t = k as f64 * dt;
        let u = ((t - spec.standstill_s) / spec.push_s).clamp(0.0, 1.0);
        let (v, a) = if t < spec.standstill_s {
            (0.0, 0.0)
        } else {
            (
                v0 * 0.5 * (1.0 - (PI * u).cos()),
                v0 * 0.5 * PI / spec.push_s * (PI * u).sin(),
            )
        };
        let mut q = upright;
        q[0] = x;
        q[5] = wheel;
        let mut qd = [0.0; 8];
        qd[0] = v;
        qd[5] = -v / p.rr;
        let mut qdd = [0.0; 8];
        qdd[0] = a;
        qdd[5] = -a / p.rr;
        let s = sample(&p, &q, &qd, &qdd, heading, frame_sensor, bar_sensor);
        motion[0].push(s[0]);
        motion[1].push(s[1]);
        roll.push(0.0);
        steer.push(0.0);
        speed.push(v);
        wheel_angle.push(wheel);
        x += v * dt;
        wheel -= v / p.rr * dt;
    }
    // Release with the hand's small imperfection, then the coast with the kick and the effects.
    let (q, qd) =
        whipple::upright_state(&p, v0, 0.0, 0.0, 0.01 * rng.normal(), 0.02 * rng.normal())
            .ok_or(SimulationError::NoUpright)?;
    let mut y: RideState = whipple::ride_state(&q, &qd);
    y[0] = x;
    y[5] = wheel;
    let kick_s = release_s + spec.kick.after_release_s;
    let normal = static_normal_loads(&truth_bike);
    let loads = ride_loads(&truth_bike, &spec.effects, &spec.kick, kick_s);
    // Sensors write 3–5 decimals: 1e-8 relative is ample (the constraints are projected anyway).
    let tol = super::ode::Tolerance {
        rtol: 1e-8,
        atol: 1e-10,
        max_steps: 1_000_000,
    };
    let lagged = lagged_motor(&truth_bike, &spec.effects);
    let actuator = lagged.as_ref().map(|(lag_s, command)| whipple::Actuator {
        lag_s: *lag_s,
        command: command.as_ref(),
    });
    let drive = whipple::Drive {
        loads: &loads,
        motion: spec.motion,
        actuator,
    };
    let span = whipple::Span {
        t0_s: release_s,
        duration_s: spec.coast_s,
        dt_s: dt,
    };
    // The free motion as (q, q̇, q̈) per sample after the release.
    let free: Vec<([f64; 8], [f64; 8], [f64; 8])> = match &spec.effects.tyres {
        None => whipple::coast_actuated(&p, y, span, &tol, drive)?
            .iter()
            .enumerate()
            .map(|(i, (s, torque))| {
                let t = release_s + i as f64 * dt;
                let q: [f64; 8] = std::array::from_fn(|k| s[k]);
                let qd = whipple::full_rates(&p, s)?;
                let qdd = whipple::accelerations_loaded(
                    &p,
                    &q,
                    &qd,
                    &loads(&whipple::LoadInput {
                        t,
                        q: &q,
                        qd: &qd,
                        velocities: whipple::body_velocities(&p, &q, &qd),
                        actuator_torque_nm: actuator.map(|_| *torque),
                    }),
                    spec.motion,
                )?;
                Some((q, qd, qdd))
            })
            .collect::<Option<_>>()
            .ok_or(SimulationError::NoUpright)?,
        Some(_) if actuator.is_some() => return Err(SimulationError::LaggedMotorOnTyres),
        Some(tyre) => {
            let q0: [f64; 8] = std::array::from_fn(|k| y[k]);
            let qd0 = whipple::full_rates(&p, &y).ok_or(SimulationError::NoUpright)?;
            let tyres = whipple::Tyres {
                model: *tyre,
                normal_n: normal,
            };
            let states = whipple::coast_on_tyres(&p, &tyres, &q0, &qd0, span, &tol, drive)?;
            states
                .iter()
                .enumerate()
                .map(|(i, s)| {
                    let t = release_s + i as f64 * dt;
                    let (qd, qdd, _) = whipple::tyre_motion(&p, &tyres, t, s, drive)?;
                    Some((std::array::from_fn(|k| s[k]), qd, qdd))
                })
                .collect::<Option<_>>()
                .ok_or(SimulationError::NoUpright)?
        }
    };
    let mut catch_s = release_s + spec.coast_s;
    let mut free_speeds = Vec::new();
    for (i, (q, qd, qdd)) in free.iter().enumerate().skip(1) {
        let (q, qd, qdd) = (*q, *qd, *qdd);
        let t = release_s + i as f64 * dt;
        let smp = sample(&p, &q, &qd, &qdd, heading, frame_sensor, bar_sensor);
        motion[0].push(smp[0]);
        motion[1].push(smp[1]);
        roll.push(q[3]);
        steer.push(q[6]);
        let v = -qd[5] * p.rr;
        speed.push(v);
        wheel_angle.push(q[5]);
        if t >= kick_s {
            free_speeds.push(v);
        }
        if q[3].abs() > 0.5 {
            catch_s = t;
            break;
        }
    }
    // The catch: held where it was, for one more second.
    if let (Some(&last0), Some(&last1)) = (motion[0].last(), motion[1].last()) {
        for _ in 0..(rate as usize) {
            let hold = |b: BodySample| BodySample {
                omega_global: Vector3::zeros(),
                accel_global: Vector3::zeros(),
                ..b
            };
            motion[0].push(hold(last0));
            motion[1].push(hold(last1));
            roll.push(*roll.last().unwrap_or(&0.0));
            steer.push(*steer.last().unwrap_or(&0.0));
            speed.push(0.0);
            wheel_angle.push(*wheel_angle.last().unwrap_or(&0.0));
        }
    }
    match spec.fault {
        Some(Fault::HandlebarSensorStill) => {
            let still = BodySample {
                omega_global: Vector3::zeros(),
                accel_global: Vector3::zeros(),
                ..motion[1][0]
            };
            motion[1].iter_mut().for_each(|m| *m = still);
        }
        Some(Fault::EndsAt(t)) => {
            let n = ((t * rate).round() as usize).max(1);
            motion.iter_mut().for_each(|m| m.truncate(n));
            roll.truncate(n);
            steer.truncate(n);
            speed.truncate(n);
            wheel_angle.truncate(n);
            catch_s = catch_s.min(t);
        }
        _ => {}
    }
    // Sensors and receiver.
    let mut sensor_rng = rng.fork(1);
    let imus: Vec<Vec<imu::ImuSample>> = motion
        .iter()
        .map(|m| {
            let mut s = SensorModel::typical(&mut sensor_rng);
            if !spec.heading_drift {
                s.heading_drift_rad_per_s = 0.0;
            }
            // Mounted roughly level (z up ≈ −c₃), a few degrees off.
            let axis = Vector3::new(
                sensor_rng.normal(),
                sensor_rng.normal(),
                sensor_rng.normal(),
            );
            let error = match spec.mounting_error_deg {
                None => axis * 2f64.to_radians(),
                Some(deg) => axis.normalize() * deg.to_radians(),
            };
            s.mounting = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), PI)
                * UnitQuaternion::from_scaled_axis(error);
            s.measure(m, rate, &mut sensor_rng)
        })
        .collect();
    let packets = LinkModel::default().packets(imus[0].len(), rate, &mut rng.fork(2));
    let circumference = 2.0 * PI * p.rr;
    let mut file_rng = rng.fork(3);
    let mut cal_rng = rng.fork(4);
    // Where the wheel's magnet stands at the start: anywhere on the wheel. Always at the reed
    // switch, every ride at one speed had its pulses at the same samples, and their
    // quantization error was one and the same draw across 50 blind campaigns (the six `Sync`
    // rides' speeds 0.17 % high on average; speed_scale fitted 1 of its SEs low in 46 of 50).
    let magnet_rad = 2.0 * PI * rng.fork(5).uniform();
    let turn = |angle: f64| ((angle.abs() + magnet_rad) / (2.0 * PI)).floor();
    let sync: Vec<u8> = wheel_angle
        .windows(2)
        .map(|w| u8::from(turn(w[0]) != turn(w[1])))
        .collect();
    let sync: Vec<u8> = std::iter::once(0).chain(sync).collect();
    let mut fspec = FileSpec::single_sensor(
        spec.mode,
        spec.locale,
        Precision::Sensor,
        ("00300417", "frame"),
        (seed % 65_536) as u16,
    );
    fspec.sensors.push(("00300418".into(), "handlebar".into()));
    fspec.late_bursts_per_minute = spec.receiver_late_bursts_per_minute;
    if spec.fault == Some(Fault::SensorsSwapped) {
        fspec.sensors[0].1 = "handlebar".into();
        fspec.sensors[1].1 = "frame".into();
    }
    if spec.sync {
        fspec
            .extra_header
            .push(("Wheel circumference".into(), format!("{circumference:.4}")));
    }
    let angles_log = imu::write_log(
        &fspec,
        false,
        &imus,
        &packets,
        spec.sync.then_some(&sync[..]),
        &mut file_rng,
    );
    let cal_log = imu::write_log(&fspec, true, &imus, &packets, None, &mut cal_rng);
    let mean_free = if free_speeds.is_empty() {
        v0
    } else {
        free_speeds.iter().sum::<f64>() / free_speeds.len() as f64
    };
    // The sealed truth's eigenvalues (the analysis never reads this file), from the
    // simulator's own equations linearized with the smooth effects (no Coulomb, no kick).
    let (lo, hi) = free_speeds
        .iter()
        .fold((v0, v0), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    let smooth = Effects {
        steer_coulomb_nm: 0.0,
        ..spec.effects.clone()
    };
    let smooth_loads = ride_loads(&truth_bike, &smooth, &spec.kick, f64::INFINITY);
    let smooth_drive = whipple::Drive {
        loads: &smooth_loads,
        motion: spec.motion,
        actuator,
    };
    let grid: Vec<f64> = ((lo / 0.05).floor() as i64 - 1..=(hi / 0.05).ceil() as i64 + 1)
        .map(|k| k as f64 * 0.05)
        .filter(|&v| v > 0.2)
        .collect();
    let tyres = spec.effects.tyres.map(|model| whipple::Tyres {
        model,
        normal_n: normal,
    });
    let modes = super::linearize::weave_and_capsize(&p, tyres.as_ref(), smooth_drive, &grid)
        .map(|m| {
            grid.iter()
                .zip(m)
                .map(|(&speed_mps, (w, c))| TruthModes {
                    speed_mps,
                    weave: [w.re, w.im],
                    capsize: [c.re, c.im],
                })
                .collect()
        })
        .unwrap_or_default();
    Ok(Ride {
        angles_log,
        cal_log,
        truth: RideTruth {
            rate_hz: rate,
            // In the logs' time (the sensors' clock).
            release_s: release_s * spec.effects.clock_scale,
            kick_s: kick_s * spec.effects.clock_scale,
            catch_s: catch_s * spec.effects.clock_scale,
            speed_mps: speed,
            roll_rad: roll,
            steer_rad: steer,
            noted_speed_mps: v0 * spec.effects.speedometer_scale,
            effects: spec.effects.clone(),
            mean_free_speed_mps: mean_free,
            modes,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_masses_keep_the_total_mass_moment() {
        let b = Benchmark::meijaard_2007();
        let pm = [PointMass {
            body: Body::Frame,
            mass_kg: 2.0,
            x_m: 0.5,
            z_m: -1.0,
        }];
        let c = with_point_masses(&b, &pm);
        assert!((c.m_b - 87.0).abs() < 1e-12);
        assert!((c.m_b * c.x_b - (85.0 * 0.3 + 2.0 * 0.5)).abs() < 1e-12);
        // I_yy about the new centre = old about new + point about new.
        let d = |x: f64, z: f64| (x - c.x_b).powi(2) + (z - c.z_b).powi(2);
        assert!((c.i_byy - (11.0 + 85.0 * d(0.3, -0.9) + 2.0 * d(0.5, -1.0))).abs() < 1e-12);
    }

    #[test]
    fn a_ride_is_deterministic_and_reads_back() {
        let b = Benchmark::meijaard_2007();
        let spec = RideSpec::lab(5.0, Effects::realistic());
        let a = simulate_ride(&b, &spec, 7).unwrap();
        let c = simulate_ride(&b, &spec, 7).unwrap();
        assert!(a.angles_log == c.angles_log && a.cal_log == c.cal_log);
        let log = crate::read::log::Log::parse(
            a.angles_log.as_bytes(),
            std::path::Path::new("ride.log"),
            &Default::default(),
        )
        .unwrap();
        assert_eq!(log.sensors.len(), 2);
        // The coast slows down as the point mass of the closed form (within 20 %: the masses
        // added, the speed's own decay over the 2 s).
        let t = &a.truth;
        let i0 = (t.release_s * t.rate_hz) as usize + 1;
        let i1 = i0 + 200;
        let decel = (t.speed_mps[i0] - t.speed_mps[i1]) / 2.0;
        let e = Effects::realistic();
        let m = b.m_r + b.m_b + b.m_h + b.m_f;
        let inertial = m + b.i_ryy / b.r_r.powi(2) + b.i_fyy / b.r_f.powi(2);
        let want = (e.rolling_resistance_coeff * m * b.g
            + 0.5 * AIR_DENSITY_KGPM3 * e.drag_area_m2 * 25.0)
            / inertial;
        assert!(
            (decel / want - 1.0).abs() < 0.2,
            "deceleration {decel} m/s², closed form {want}"
        );
    }

    /// Upright and straight, rolling resistance and drag decelerate the bicycle as a point mass
    /// with its wheels' spin inertia: a = −(C_rr W + ½ρ C_dA v²) / (m + I_Ryy/r_R² + I_Fyy/r_F²).
    #[test]
    fn resistance_decelerates_as_the_closed_form_and_an_imposed_speed_holds() {
        let b = Benchmark::meijaard_2007();
        let p = WhippleParams::from_benchmark(&b);
        let (crr, cda, v) = (0.008, 0.4, 5.0);
        let m = b.m_r + b.m_b + b.m_h + b.m_f;
        let weight = b.g * m;
        let x_t = (b.x_b * b.m_b + b.x_h * b.m_h + b.w * b.m_f) / m;
        let nf = weight * x_t / b.w;
        let normal = [weight - nf, nf];
        let (q, qd) = whipple::upright_state(&p, v, 0.0, 0.0, 0.0, 0.0).unwrap();
        let mut loads = Vec::new();
        for (k, body) in [Body::RearWheel, Body::FrontWheel].into_iter().enumerate() {
            loads.push(Load::Force {
                body,
                offset_body_m: [0.0; 3],
                force_n: [-crr * normal[k], 0.0, 0.0],
            });
        }
        loads.push(Load::Force {
            body: Body::Frame,
            offset_body_m: [0.0; 3],
            force_n: [-0.5 * AIR_DENSITY_KGPM3 * cda * v * v, 0.0, 0.0],
        });
        let qdd =
            whipple::accelerations_loaded(&p, &q, &qd, &loads, whipple::Motion::Free).unwrap();
        let want = -(crr * weight + 0.5 * AIR_DENSITY_KGPM3 * cda * v * v)
            / (m + b.i_ryy / (b.r_r * b.r_r) + b.i_fyy / (b.r_f * b.r_f));
        let got = -qdd[5] * b.r_r;
        assert!((got / want - 1.0).abs() < 1e-10, "{got} vs {want}");
        // Held at its rate, the wheel does not slow down, and nothing else moves.
        let held =
            whipple::accelerations_loaded(&p, &q, &qd, &loads, whipple::Motion::ImposedSpeed)
                .unwrap();
        assert!(
            held[5].abs() < 1e-12 && held[3].abs() < 1e-12 && held[6].abs() < 1e-12,
            "{held:?}"
        );
    }
}
