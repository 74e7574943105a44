//! The library's effects, one [`Definition`] each: its name, what it is, its parameters with
//! their search bounds and plausible ranges (and why), how it changes the linear model, where
//! it acts, and the measured quantity a factor multiplies. An effect is its variant of
//! [`Effect`] and its definition here; nothing else in `gap/` lists the effects.
//!
//! The simulator's counterpart of an effect is the variant of `sim::campaign::Withheld` whose
//! label is the effect's name (`blind::campaigns` pairs them by it). It stays in `sim/`: the
//! simulator builds its bicycle from the physics and never shares this model's code.

use super::{Acts, Change, Definition, Effect, ParamSpec, Quantity};
use crate::model::{trail_keeping_offset, Benchmark};

impl Effect {
    /// Everything the diagnosis knows of the effect.
    pub fn definition(self) -> &'static Definition {
        match self {
            Effect::SteerDamping => &STEER_DAMPING,
            Effect::FrontMass => &FRONT_MASS,
            Effect::FrameMass => &FRAME_MASS,
            Effect::FrameIxx => &FRAME_IXX,
            Effect::FrameIzz => &FRAME_IZZ,
            Effect::FrameIxz => &FRAME_IXZ,
            Effect::FrontIxx => &FRONT_IXX,
            Effect::FrontIzz => &FRONT_IZZ,
            Effect::Trail => &TRAIL,
            Effect::WheelSpin => &WHEEL_SPIN,
            Effect::FrameCgHeight => &FRAME_CG_HEIGHT,
            Effect::FrameCgX => &FRAME_CG_X,
            Effect::SpeedScale => &SPEED_SCALE,
            Effect::TimeScale => &TIME_SCALE,
            Effect::Tyres => &TYRES,
            Effect::ActuatorGain => &ACTUATOR_GAIN,
            Effect::SteerInertia => &STEER_INERTIA,
            Effect::ControllerSpeedScale => &CONTROLLER_SPEED_SCALE,
            Effect::ActuatorLag => &ACTUATOR_LAG,
            Effect::HeadAngle => &HEAD_ANGLE,
            Effect::FrameInertia => &FRAME_INERTIA,
            Effect::FrontInertia => &FRONT_INERTIA,
            Effect::SteerFriction => &STEER_FRICTION,
        }
    }
}

/// The definition of an effect of the bicycle itself, shared by every condition of a study,
/// acting on every ride, scaling no measured quantity: what each effect gives (its name, its
/// words, its parameters, its change of the model), the rest as defaults a definition may
/// override.
const fn bicycle(
    name: &'static str,
    describe: &'static str,
    params: &'static [ParamSpec],
    change: Change,
) -> Definition {
    Definition {
        name,
        describe,
        params,
        change,
        acts: Acts::Always,
        per_condition: false,
        needs_controller: false,
        of_declared_motor: None,
        measured: None,
    }
}

/// A measured parameter off by a factor: inertias (a component forgotten or counted twice, a
/// pendulum misread) plausibly by up to half. The search reaches well beyond that (0.25–2.2),
/// so that a fit of 0.5 ± 0.1 or 1.7 ± 0.12 is an estimate and not a bound at the search's
/// edge.
/// The measurements behind it: [docs/decisions/constants.md](../../../docs/decisions/constants.md#inertia_factor).
const INERTIA_FACTOR: ParamSpec = ParamSpec {
    name: "factor",
    unit: "× measured",
    lo: 0.25,
    hi: 2.2,
    none: 1.0,
    plausible: (0.6, 1.5),
};

/// Lengths measured with a tape and a plumb line (the trail, the centre of mass from hanging
/// tests): plausibly within 15 %.
const LENGTH_FACTOR: ParamSpec = ParamSpec {
    name: "factor",
    unit: "× measured",
    lo: 0.5,
    hi: 1.6,
    none: 1.0,
    plausible: (0.85, 1.15),
};

/// Viscous friction in the steering head: a torque −c δ̇.
const STEER_DAMPING: Definition = bicycle(
    "steer_damping",
    "viscous steer damping",
    &[ParamSpec {
        name: "c",
        unit: "N·m·s/rad",
        lo: 0.0,
        hi: 3.0,
        none: 0.0,
        plausible: (0.0, 1.0),
    }],
    Change::SteerDamping,
);

/// Dry (Coulomb) friction in the steering head: a torque −F sign(δ̇), whose damping of a swing
/// grows as the swing shrinks (a dead band), taken on each ride as the viscous damping of its
/// size ([`super::for_ride`]). Plausibly up to 0.15 N·m, a headset's friction on a riderless
/// bicycle with its bearings as built (the simulator's realistic value, `sim::ride`); the
/// search to 0.5 N·m, where a weave of a few hundredths of a radian would stick.
const STEER_FRICTION: Definition = bicycle(
    "steer_friction",
    "dry (Coulomb) steer friction",
    &[ParamSpec {
        name: "F",
        unit: "N·m",
        lo: 0.0,
        hi: 0.5,
        none: 0.0,
        plausible: (0.0, 0.15),
    }],
    Change::SteerFriction,
);

/// An added point mass (a lock, a lamp, a bag, a sensor box: up to 5 kg).
const ADDED_MASS: ParamSpec = ParamSpec {
    name: "mass",
    unit: "kg",
    lo: 0.0,
    hi: 8.0,
    none: 0.0,
    plausible: (0.0, 5.0),
};

/// A point mass at the front frame's centre of mass: the mass grows, the centre of mass and
/// the inertia about it stay.
const FRONT_MASS: Definition = bicycle(
    "front_mass",
    "added mass on the front frame",
    &[ADDED_MASS],
    Change::Bicycle(|b, m| b.m_h += m),
);

/// A point mass at the rear frame's centre of mass.
const FRAME_MASS: Definition = bicycle(
    "frame_mass",
    "added mass on the rear frame",
    &[ADDED_MASS],
    Change::Bicycle(|b, m| b.m_b += m),
);

/// A measured inertia off by a factor ([`INERTIA_FACTOR`]): `of` reads the measured quantity
/// (in `unit`) that detection limits are given in, `change` scales the moments the factor
/// multiplies.
const fn inertia_off(
    name: &'static str,
    describe: &'static str,
    of: fn(&Benchmark) -> f64,
    unit: &'static str,
    change: fn(&mut Benchmark, f64),
) -> Definition {
    Definition {
        measured: Some(Quantity { of, unit }),
        ..bicycle(name, describe, &[INERTIA_FACTOR], Change::Bicycle(change))
    }
}

const FRAME_IXX: Definition = inertia_off(
    "frame_ixx",
    "the rear frame's I_xx off by a factor",
    |b| b.i_bxx,
    "kg·m²",
    |b, k| b.i_bxx *= k,
);

const FRAME_IZZ: Definition = inertia_off(
    "frame_izz",
    "the rear frame's I_zz off by a factor",
    |b| b.i_bzz,
    "kg·m²",
    |b, k| b.i_bzz *= k,
);

const FRAME_IXZ: Definition = inertia_off(
    "frame_ixz",
    "the rear frame's I_xz off by a factor",
    |b| b.i_bxz,
    "kg·m²",
    |b, k| b.i_bxz *= k,
);

const FRONT_IXX: Definition = inertia_off(
    "front_ixx",
    "the front frame's I_xx off by a factor",
    |b| b.i_hxx,
    "kg·m²",
    |b, k| b.i_hxx *= k,
);

const FRONT_IZZ: Definition = inertia_off(
    "front_izz",
    "the front frame's I_zz off by a factor",
    |b| b.i_hzz,
    "kg·m²",
    |b, k| b.i_hzz *= k,
);

/// The rear frame's inertia tensor in the bicycle's plane (I_xx, I_zz, I_xz) off by one
/// factor, as a body re-measured (or a pendulum's stiffness misread) changes every moment it
/// gave at once.
const FRAME_INERTIA: Definition = inertia_off(
    "frame_inertia",
    "the rear frame's inertia (I_xx, I_zz, I_xz together) off by a factor",
    |b| b.i_bxx + b.i_bzz,
    "kg·m² (I_xx + I_zz)",
    |b, k| {
        b.i_bxx *= k;
        b.i_bzz *= k;
        b.i_bxz *= k;
    },
);

/// The front frame's inertia tensor in the bicycle's plane off by one factor ([`FRAME_INERTIA`]).
const FRONT_INERTIA: Definition = inertia_off(
    "front_inertia",
    "the front frame's inertia (I_xx, I_zz, I_xz together) off by a factor",
    |b| b.i_hxx + b.i_hzz,
    "kg·m² (I_xx + I_zz)",
    |b, k| {
        b.i_hxx *= k;
        b.i_hzz *= k;
        b.i_hxz *= k;
    },
);

/// The trail, built from the head angle, the fork's offset and the wheel's radius: 1.5° of
/// head angle and 5 mm of offset already make 20 %.
const TRAIL: Definition = Definition {
    measured: Some(Quantity {
        of: |b| b.c,
        unit: "m",
    }),
    ..bicycle(
        "trail",
        "the trail off by a factor",
        &[ParamSpec {
            plausible: (0.8, 1.2),
            ..LENGTH_FACTOR
        }],
        Change::Bicycle(|b, k| b.c *= k),
    )
};

/// The head angle: the steer axis tilted by `Δλ` (rad, positive slacker) with the fork's
/// offset kept — the front frame (fork and handlebar) turned about the front axle by `Δλ` in
/// the bicycle's plane, as a different headset or fork crown tilts it. Its centre of mass
/// turns about the axle and its inertia tensor with it; the wheels, the wheelbase and the rear
/// frame stay; the trail follows from the offset, `c = (r_F sin λ − d)/cos λ` (Meijaard et
/// al. 2007, Appendix A: the offset `d = r_F sin λ − c cos λ` is the axle's distance from the
/// steer axis). An inclinometer on a head tube reads to about 0.5°, a frame built to a
/// drawing is within about a degree of it: plausibly ±2°; the search reaches ±8.6°. On the
/// lab's bicycle 1° moves the weave by 0.2 1/s over 3.8–6.4 m/s, which a factor on the rear
/// frame's I_zz (1.17) follows to 0.03 1/s: named apart from it only by the rides' errors.
/// The measurements behind it:
/// [docs/decisions/2026-12-03-head-angle.md](../../../docs/decisions/2026-12-03-head-angle.md).
const HEAD_ANGLE: Definition = bicycle(
    "head_angle",
    "the steer axis tilted off the measured head angle (the fork's offset kept)",
    &[ParamSpec {
        name: "dlambda",
        unit: "rad (slacker +)",
        lo: -0.15,
        hi: 0.15,
        none: 0.0,
        plausible: (-0.035, 0.035),
    }],
    Change::Bicycle(tilt_steer_axis),
);

/// The front frame turned about the front axle by `d` (rad) in the bicycle's plane
/// ([`HEAD_ANGLE`]): `λ → λ + d`, the front frame's centre of mass and inertia tensor turned
/// with it (`I → R I Rᵀ`, R the turn about y, x forward and z down), the fork's offset kept.
fn tilt_steer_axis(b: &mut Benchmark, d: f64) {
    let (s, c) = d.sin_cos();
    // The centre of mass about the front axle at (w, −r_F).
    let (dx, dz) = (b.x_h - b.w, b.z_h + b.r_f);
    b.x_h = b.w + c * dx + s * dz;
    b.z_h = -b.r_f - s * dx + c * dz;
    let (ixx, ixz, izz) = (b.i_hxx, b.i_hxz, b.i_hzz);
    b.i_hxx = c * c * ixx + 2.0 * c * s * ixz + s * s * izz;
    b.i_hzz = s * s * ixx - 2.0 * c * s * ixz + c * c * izz;
    b.i_hxz = -c * s * ixx + (c * c - s * s) * ixz + c * s * izz;
    b.c = trail_keeping_offset(b.r_f, (b.lambda, b.c), b.lambda + d);
    b.lambda += d;
}

/// Both wheels' spin inertias.
const WHEEL_SPIN: Definition = Definition {
    measured: Some(Quantity {
        of: |b| b.i_ryy + b.i_fyy,
        unit: "kg·m² (both wheels)",
    }),
    ..bicycle(
        "wheel_spin",
        "the wheels' spin inertia off by a factor",
        &[INERTIA_FACTOR],
        Change::Bicycle(|b, k| {
            b.i_ryy *= k;
            b.i_fyy *= k;
        }),
    )
};

/// The rear frame's centre of mass height (−z_B).
const FRAME_CG_HEIGHT: Definition = Definition {
    measured: Some(Quantity {
        of: |b| b.z_b,
        unit: "m",
    }),
    ..bicycle(
        "frame_cg_height",
        "the rear frame's centre of mass height off by a factor",
        &[LENGTH_FACTOR],
        Change::Bicycle(|b, k| b.z_b *= k),
    )
};

/// The rear frame's centre of mass, x_B.
const FRAME_CG_X: Definition = Definition {
    measured: Some(Quantity {
        of: |b| b.x_b,
        unit: "m",
    }),
    ..bicycle(
        "frame_cg_x",
        "the rear frame's centre of mass x off by a factor",
        &[LENGTH_FACTOR],
        Change::Bicycle(|b, k| b.x_b *= k),
    )
};

/// The speedometer (or a treadmill's display, another instrument's wheel sensor) reads `k`
/// times the true speed (rides whose speed is a reading or such a column): a condition's own
/// instrument.
const SPEED_SCALE: Definition = Definition {
    acts: Acts::OnReadSpeeds,
    per_condition: true,
    ..bicycle(
        "speed_scale",
        "a speedometer scale error",
        &[ParamSpec {
            name: "k",
            unit: "× nominal",
            lo: 0.8,
            hi: 1.25,
            none: 1.0,
            plausible: (0.9, 1.1),
        }],
        Change::Speedometer,
    )
};

/// The sensors sample at `s` times the nominal rate: every rate read from the logs (the
/// eigenvalue, the `Sync` speed) is the true one over `s`. A condition's own instrument.
const TIME_SCALE: Definition = Definition {
    per_condition: true,
    ..bicycle(
        "time_scale",
        "a sensor clock error (time scale)",
        &[ParamSpec {
            name: "s",
            unit: "× nominal",
            lo: 0.9,
            hi: 1.1,
            none: 1.0,
            // A logger that stamps samples by their count at a nominal rate inherits its
            // sensor's oscillator: a MEMS sensor's internal RC oscillator is specified to a few
            // per cent and drifts with temperature. At ±3 % a clock 1.04 slow, fitted at 1.0415
            // ± 0.009 with the best χ² and held-out RMS of all candidates, was ranked tenth
            // behind the speedometer it mimics.
            plausible: (0.95, 1.05),
        }],
        Change::Clock,
    )
};

/// Lateral tyre compliance with a relaxation length, in place of rolling without lateral slip
/// (two parameters; the camber stiffness held at [`super::CAMBER_PER_RAD`]).
const TYRES: Definition = bicycle(
    "tyres",
    "lateral tyre compliance with a relaxation length",
    &[
        ParamSpec {
            name: "cornering",
            unit: "1/rad",
            lo: 3.0,
            hi: 40.0,
            none: f64::INFINITY,
            plausible: (5.0, 30.0),
        },
        ParamSpec {
            name: "relaxation",
            unit: "m",
            lo: 0.01,
            hi: 0.6,
            none: 0.0,
            plausible: (0.02, 0.4),
        },
    ],
    Change::Tyres,
);

/// The steer motor delivers `a` times the torque its controller commands: per controller,
/// where a condition carries one.
const ACTUATOR_GAIN: Definition = Definition {
    acts: Acts::WithController,
    per_condition: true,
    needs_controller: true,
    ..bicycle(
        "actuator_gain",
        "the steer motor's torque off from the commanded one",
        &[ParamSpec {
            name: "a",
            unit: "× nominal",
            lo: 0.1,
            hi: 3.0,
            none: 1.0,
            // A motor's torque constant, its driver's current loop and limit, and a gearbox's
            // losses (a worm or planetary stage passes 50–90 % of the torque): from under a third
            // of the nominal to half again.
            plausible: (0.3, 1.5),
        }],
        Change::Control(|c, a| c.actuator_gain *= a),
    )
};

/// Inertia `J` added about the steer axis: a steer motor's rotor and gears, reflected through
/// the gear ratio, powered or not (bicycles that carry a controller, or declare the motor:
/// then its range is the motor's, `steer_inertia_of`).
const STEER_INERTIA: Definition = Definition {
    needs_controller: true,
    of_declared_motor: Some(steer_inertia_of),
    ..bicycle(
        "steer_inertia",
        "inertia added about the steer axis (a steer motor's rotor)",
        &[ParamSpec {
            name: "J",
            unit: "kg·m²",
            lo: 0.0,
            hi: 1.0,
            none: 0.0,
            // A motor's rotor (1e-4 to 5e-4 kg·m²) through a 10–50:1 gearbox: its inertia times
            // the ratio squared, up to ~0.5 kg·m², powered or not.
            plausible: (0.0, 0.5),
        }],
        Change::Bicycle(add_steer_inertia),
    )
};

/// How far below the declared motor's reflected inertia (`J_r N²`, a fraction of it) the added
/// inertia is plausible: a rotor's data-sheet value is its nominal, made to within about
/// ten per cent, and a ratio may be given rounded.
pub const DECLARED_MOTOR_LOW: f64 = 0.8;

/// How far above the declared motor's reflected inertia (a multiple of it) the added inertia
/// is plausible: the gearbox's own stages, reflected to the steer, an encoder's disc, a brake
/// and the coupling add to the rotor's — planetary gearheads' catalogues list a few per cent
/// to about the whole of a small motor's rotor at their input — so up to as much again.
pub const DECLARED_MOTOR_HIGH: f64 = 2.0;

/// The `steer_inertia` parameter for a bicycle whose manifest declares its steer motor
/// (`[steer_motor]`): plausible from [`DECLARED_MOTOR_LOW`] to [`DECLARED_MOTOR_HIGH`] times the
/// rotor's inertia reflected through the ratio, `J_r N²` (the rotor turns N times as fast as
/// the steer: ½ J_r (N δ̇)² = ½ (J_r N²) δ̇²), in place of the catalogue-wide 0–0.5 kg·m²; the
/// search reaches at least twice the plausible range's top. Issue 76: "ranges belong to the
/// bicycle … a steer motor: gear ratio and rotor inertia … the ranges follow from the
/// physics".
fn steer_inertia_of(spec: ParamSpec, motor: &crate::model::control::SteerMotorSpec) -> ParamSpec {
    let j = motor.reflected_inertia_kg_m2();
    let plausible = (DECLARED_MOTOR_LOW * j, DECLARED_MOTOR_HIGH * j);
    ParamSpec {
        plausible,
        hi: spec.hi.max(2.0 * plausible.1),
        ..spec
    }
}

/// The speed a controller schedules its gains on is `k` times the bicycle's: its own speed
/// sensor (a wheel magnet's count or circumference set for another wheel, a hub motor's
/// estimate), apart from the speed the rides report (a treadmill's, a speedometer's). One
/// sensor on the bicycle: shared by every controlled condition.
const CONTROLLER_SPEED_SCALE: Definition = Definition {
    acts: Acts::WithController,
    needs_controller: true,
    ..bicycle(
        "controller_speed_scale",
        "the speed the controller schedules its gains on off by a factor",
        &[ParamSpec {
            name: "k",
            unit: "× true",
            lo: 0.6,
            hi: 1.6,
            none: 1.0,
            // A wheel's circumference set for another tyre (a 26-inch wheel's 2.07 m against a
            // 700C's 2.10 m, a worn or underinflated tyre: a few per cent), a magnet counted
            // twice or a hub motor's estimate from its back-EMF (10–15 %).
            plausible: (0.85, 1.15),
        }],
        Change::Control(|c, k| c.speed_sensor_scale *= k),
    )
};

/// Adds inertia `j` about the steer axis to the front frame: `J d dᵀ` with the axis'
/// direction `d = (sin λ, 0, cos λ)` (x forward, z down; the axis tilted back by λ).
fn add_steer_inertia(b: &mut Benchmark, j: f64) {
    let (s, c) = b.lambda.sin_cos();
    b.i_hxx += j * s * s;
    b.i_hzz += j * c * c;
    b.i_hxz += j * s * c;
}

/// A first-order lag `T` between the controller's command and the torque on the steer
/// (`T τ̇ = u − τ`): a motor driver's current loop (about a millisecond), the firmware's loop
/// and a filter on its command (one or two periods of a 100–500 Hz loop), a gearbox's
/// compliance. One motor and driver on the bicycle: shared by every controlled condition.
const ACTUATOR_LAG: Definition = Definition {
    acts: Acts::WithController,
    needs_controller: true,
    ..bicycle(
        "actuator_lag",
        "the steer motor's torque lagging its command (a first-order lag)",
        &[ParamSpec {
            name: "T",
            unit: "s",
            lo: 0.0,
            hi: 0.3,
            none: 0.0,
            // A current loop's millisecond, a 100 Hz firmware's period or two, a low-pass
            // filter on the command: up to about 50 ms; beyond, a loop a lab would retune.
            plausible: (0.0, 0.05),
        }],
        Change::ActuatorLag,
    )
};
