//! The library of candidate effects: each an extension of the linear model with physical
//! parameters, bounds, the value that means "no effect" and a plausible range. In: the
//! measured bicycle's benchmark parameters and an effect's parameter values. Out: the extended
//! linear bicycle, and the weave it predicts for a ride (at the ride's speed as the ride
//! reported it).

use super::linear::{LinearBike, LinearTyres};
use super::observe::Observation;
use crate::model::{Benchmark, SteerControl};
use crate::ride::dynamic::SpeedSource;
use nalgebra::Complex;

/// One physical parameter of an effect.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ParamSpec {
    pub name: &'static str,
    pub unit: &'static str,
    /// The search's bounds.
    pub lo: f64,
    pub hi: f64,
    /// The value at which the effect is absent.
    pub none: f64,
    /// The range a real bicycle and lab make plausible.
    pub plausible: (f64, f64),
}

impl ParamSpec {
    /// How far `p` lies from the nearer of the search's edges, and whether that is the lower
    /// (the lower when both are as near).
    pub fn nearest_edge(&self, p: f64) -> (f64, bool) {
        let (below, above) = (p - self.lo, self.hi - p);
        if below <= above {
            (below, true)
        } else {
            (above, false)
        }
    }
}

/// An effect the Whipple model of the measured bicycle leaves out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    /// Viscous friction in the steering head: a torque −c δ̇.
    SteerDamping,
    /// A point mass at the front frame's centre of mass (a lamp, a bag, a sensor box).
    FrontMass,
    /// A point mass at the rear frame's centre of mass.
    FrameMass,
    /// A measured parameter off by a factor.
    FrameIxx,
    FrameIzz,
    FrameIxz,
    FrontIxx,
    FrontIzz,
    Trail,
    /// Both wheels' spin inertias.
    WheelSpin,
    /// The rear frame's centre of mass height (−z_B).
    FrameCgHeight,
    /// The rear frame's centre of mass, x_B.
    FrameCgX,
    /// The speedometer (or a treadmill's display, another instrument's wheel sensor) reads `k`
    /// times the true speed (rides whose speed is a reading or such a column).
    SpeedScale,
    /// The sensors sample at `s` times the nominal rate: every rate read from the logs (the
    /// eigenvalue, the `Sync` speed) is the true one over `s`.
    TimeScale,
    /// Lateral tyre compliance with a relaxation length, in place of rolling without lateral
    /// slip (two parameters; the camber stiffness held at [`CAMBER_PER_RAD`]).
    Tyres,
    /// The steer motor delivers `a` times the torque its controller commands (campaigns whose
    /// bicycle carries a controller only).
    ActuatorGain,
    /// Inertia `J` added about the steer axis: a steer motor's rotor and gears, reflected
    /// through the gear ratio (campaigns whose bicycle carries a controller only).
    SteerInertia,
}

/// The tyres' camber stiffness per unit load (1/rad): a typical bicycle tyre's (0.5–1 /rad in
/// drum measurements); the weave data alone do not separate it from the cornering stiffness.
pub const CAMBER_PER_RAD: f64 = 0.7;

/// The standard deviation of [`CAMBER_PER_RAD`] over real tyres: the 0.5–1 /rad range taken as
/// uniform (0.5/√12). The tyres' fitted parameters carry it ([`super::fit::assumed_se`]): held
/// at 0.7 for tyres of 0.6 the cornering stiffness came out 1.45 of its own errors low (median,
/// 50 blind campaigns) and within 2 errors of its truth in 62 % of them.
pub const CAMBER_SE_PER_RAD: f64 = 0.144;

/// What the library assumes and does not fit: the tyres' camber stiffness (1/rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Assumed {
    pub camber_per_rad: f64,
}

impl Assumed {
    /// The library's values.
    pub const NOMINAL: Assumed = Assumed {
        camber_per_rad: CAMBER_PER_RAD,
    };
}

/// A measured parameter off by a factor: inertias (a component forgotten or counted twice, a
/// pendulum misread) plausibly by up to half. The search reaches well beyond that (0.25–2.2),
/// so that a fit of 0.5 ± 0.1 or 1.7 ± 0.12 is an estimate and not a bound at the search's
/// edge.
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#inertia_factor).
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

/// The trail, built from the head angle, the fork's offset and the wheel's radius: 1.5° of
/// head angle and 5 mm of offset already make 20 %.
const TRAIL_FACTOR: ParamSpec = ParamSpec {
    plausible: (0.8, 1.2),
    ..LENGTH_FACTOR
};

impl Effect {
    /// Every candidate, in a fixed order.
    pub const ALL: [Effect; 17] = [
        Effect::SteerDamping,
        Effect::FrontMass,
        Effect::FrameMass,
        Effect::FrameIxx,
        Effect::FrameIzz,
        Effect::FrameIxz,
        Effect::FrontIxx,
        Effect::FrontIzz,
        Effect::Trail,
        Effect::WheelSpin,
        Effect::FrameCgHeight,
        Effect::FrameCgX,
        Effect::SpeedScale,
        Effect::TimeScale,
        Effect::Tyres,
        Effect::ActuatorGain,
        Effect::SteerInertia,
    ];

    /// The candidates for a bicycle with or without a controller: the steer motor's gain and
    /// its inertia only with one.
    pub fn library(controlled: bool) -> Vec<Effect> {
        Effect::ALL
            .into_iter()
            .filter(|&e| controlled || !matches!(e, Effect::ActuatorGain | Effect::SteerInertia))
            .collect()
    }

    /// Whether the effect belongs to a condition's own equipment rather than to the bicycle:
    /// in a study of several conditions ([`super::conditions`]) the actuator's gain (per
    /// controller), the speedometer's scale and the sensors' clock are fitted per condition;
    /// the bicycle's effects are shared by all.
    pub fn per_condition(self) -> bool {
        matches!(
            self,
            Effect::ActuatorGain | Effect::SpeedScale | Effect::TimeScale
        )
    }

    /// The name used in reports and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Effect::SteerDamping => "steer_damping",
            Effect::FrontMass => "front_mass",
            Effect::FrameMass => "frame_mass",
            Effect::FrameIxx => "frame_ixx",
            Effect::FrameIzz => "frame_izz",
            Effect::FrameIxz => "frame_ixz",
            Effect::FrontIxx => "front_ixx",
            Effect::FrontIzz => "front_izz",
            Effect::Trail => "trail",
            Effect::WheelSpin => "wheel_spin",
            Effect::FrameCgHeight => "frame_cg_height",
            Effect::FrameCgX => "frame_cg_x",
            Effect::SpeedScale => "speed_scale",
            Effect::TimeScale => "time_scale",
            Effect::Tyres => "tyres",
            Effect::ActuatorGain => "actuator_gain",
            Effect::SteerInertia => "steer_inertia",
        }
    }

    /// What it is, in words.
    pub fn describe(self) -> &'static str {
        match self {
            Effect::SteerDamping => "viscous steer damping",
            Effect::FrontMass => "added mass on the front frame",
            Effect::FrameMass => "added mass on the rear frame",
            Effect::FrameIxx => "the rear frame's I_xx off by a factor",
            Effect::FrameIzz => "the rear frame's I_zz off by a factor",
            Effect::FrameIxz => "the rear frame's I_xz off by a factor",
            Effect::FrontIxx => "the front frame's I_xx off by a factor",
            Effect::FrontIzz => "the front frame's I_zz off by a factor",
            Effect::Trail => "the trail off by a factor",
            Effect::WheelSpin => "the wheels' spin inertia off by a factor",
            Effect::FrameCgHeight => "the rear frame's centre of mass height off by a factor",
            Effect::FrameCgX => "the rear frame's centre of mass x off by a factor",
            Effect::SpeedScale => "a speedometer scale error",
            Effect::TimeScale => "a sensor clock error (time scale)",
            Effect::Tyres => "lateral tyre compliance with a relaxation length",
            Effect::ActuatorGain => "the steer motor's torque off from the commanded one",
            Effect::SteerInertia => "inertia added about the steer axis (a steer motor's rotor)",
        }
    }

    /// Its parameters, in order.
    pub fn params(self) -> Vec<ParamSpec> {
        match self {
            Effect::Tyres => vec![
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
            e => vec![e.param()],
        }
    }

    /// The parameter of a one-parameter effect.
    fn param(self) -> ParamSpec {
        match self {
            Effect::SteerDamping => ParamSpec {
                name: "c",
                unit: "N·m·s/rad",
                lo: 0.0,
                hi: 3.0,
                none: 0.0,
                plausible: (0.0, 1.0),
            },
            Effect::FrontMass | Effect::FrameMass => ParamSpec {
                name: "mass",
                unit: "kg",
                lo: 0.0,
                hi: 8.0,
                none: 0.0,
                // A lock, a lamp, a bag, a sensor box: up to 5 kg.
                plausible: (0.0, 5.0),
            },
            Effect::SpeedScale => ParamSpec {
                name: "k",
                unit: "× nominal",
                lo: 0.8,
                hi: 1.25,
                none: 1.0,
                plausible: (0.9, 1.1),
            },
            Effect::TimeScale => ParamSpec {
                name: "s",
                unit: "× nominal",
                lo: 0.9,
                hi: 1.1,
                none: 1.0,
                // A logger that stamps samples by their count at a nominal rate inherits its
                // sensor's oscillator: a MEMS sensor's internal RC oscillator is specified
                // to a few per cent and drifts with temperature. At ±3 % a clock 1.04 slow,
                // fitted at 1.0415 ± 0.009 with the best χ² and held-out RMS of all
                // candidates, was ranked tenth behind the speedometer it mimics.
                plausible: (0.95, 1.05),
            },
            Effect::ActuatorGain => ParamSpec {
                name: "a",
                unit: "× nominal",
                lo: 0.1,
                hi: 3.0,
                none: 1.0,
                // A motor's torque constant, its driver's current loop and limit, and a
                // gearbox's losses (a worm or planetary stage passes 50–90 % of the torque):
                // from under a third of the nominal to half again.
                plausible: (0.3, 1.5),
            },
            Effect::SteerInertia => ParamSpec {
                name: "J",
                unit: "kg·m²",
                lo: 0.0,
                hi: 1.0,
                none: 0.0,
                // A motor's rotor (1e-4 to 5e-4 kg·m²) through a 10–50:1 gearbox: its inertia
                // times the ratio squared, up to ~0.5 kg·m², powered or not.
                plausible: (0.0, 0.5),
            },
            Effect::Trail => TRAIL_FACTOR,
            Effect::FrameCgHeight | Effect::FrameCgX => LENGTH_FACTOR,
            _ => INERTIA_FACTOR,
        }
    }
}

/// Adds a point mass `m` at the body's own centre of mass: the mass grows, the centre of mass
/// and the inertia about it stay.
fn add_mass(b: &mut Benchmark, front: bool, m: f64) {
    if front {
        b.m_h += m;
    } else {
        b.m_b += m;
    }
}

/// Adds inertia `j` about the steer axis to the front frame: `J d dᵀ` with the axis'
/// direction `d = (sin λ, 0, cos λ)` (x forward, z down; the axis tilted back by λ).
fn add_steer_inertia(b: &mut Benchmark, j: f64) {
    let (s, c) = b.lambda.sin_cos();
    b.i_hxx += j * s * s;
    b.i_hzz += j * c * c;
    b.i_hxz += j * s * c;
}

/// The parameters of several effects, in order.
pub fn specs(effects: &[Effect]) -> Vec<ParamSpec> {
    effects.iter().flat_map(|e| e.params()).collect()
}

/// Each effect with its slice of `params`.
fn split<'p>(effects: &[Effect], params: &'p [f64]) -> Vec<(Effect, &'p [f64])> {
    let mut out = Vec::with_capacity(effects.len());
    let mut at = 0;
    for &e in effects {
        let k = e.params().len();
        out.push((e, params.get(at..at + k).unwrap_or(&[])));
        at += k;
    }
    out
}

/// The measured bicycle with its controller (if any) and `effects` at `params` (their
/// parameters in order): its parameters changed, and its extra terms and states.
pub fn linear_bike(
    base: &Benchmark,
    control: &SteerControl,
    effects: &[Effect],
    params: &[f64],
) -> LinearBike {
    linear_bike_assuming(base, control, effects, params, Assumed::NOMINAL)
}

/// [`linear_bike`] with the library's assumed values replaced by `assumed`.
pub fn linear_bike_assuming(
    base: &Benchmark,
    control: &SteerControl,
    effects: &[Effect],
    params: &[f64],
    assumed: Assumed,
) -> LinearBike {
    let mut b = *base;
    let mut control = *control;
    let mut damping = 0.0;
    let mut tyres = None;
    for (e, ps) in split(effects, params) {
        if e == Effect::Tyres {
            if let [cornering, relaxation] = ps {
                tyres = Some(LinearTyres {
                    cornering_per_rad: *cornering,
                    camber_per_rad: assumed.camber_per_rad,
                    relaxation_length_m: *relaxation,
                });
            }
            continue;
        }
        let Some(&p) = ps.first() else { continue };
        match e {
            Effect::SteerDamping => damping += p,
            Effect::FrontMass => add_mass(&mut b, true, p),
            Effect::FrameMass => add_mass(&mut b, false, p),
            Effect::FrameIxx => b.i_bxx *= p,
            Effect::FrameIzz => b.i_bzz *= p,
            Effect::FrameIxz => b.i_bxz *= p,
            Effect::FrontIxx => b.i_hxx *= p,
            Effect::FrontIzz => b.i_hzz *= p,
            Effect::Trail => b.c *= p,
            Effect::WheelSpin => {
                b.i_ryy *= p;
                b.i_fyy *= p;
            }
            Effect::FrameCgHeight => b.z_b *= p,
            Effect::FrameCgX => b.x_b *= p,
            Effect::ActuatorGain => control.actuator_gain *= p,
            Effect::SteerInertia => add_steer_inertia(&mut b, p),
            Effect::SpeedScale | Effect::TimeScale | Effect::Tyres => {}
        }
    }
    LinearBike {
        steer_damping_nms_per_rad: damping,
        tyres,
        ..LinearBike::whipple(&b).with_control(control)
    }
}

/// The true speed behind a ride's reported one under `effects` (see `predict`).
///
/// - A noted reading (or another instrument's wheel speed) is the true speed times the
///   speedometer's scale; a noted reading is carried to the eigenvalue's time by the slowing,
///   the frame sensor's forward acceleration integrated over the sensors' clock, so a clock
///   running `s` times slow makes that slowing `s` times too large: the true speed is
///   `reading / k + slowing / s`. Left out, a clock's effect on a coasting campaign was half
///   taken up by the slowing's (50 noted campaigns: the clock fitted at a median 0.75 of its
///   deviation, median z −0.95).
/// - A `Sync` or kinematic speed is a distance (or a yaw rate's ratio) per clock second: the
///   true speed is `s` times it.
pub fn true_speed(effects: &[Effect], params: &[f64], obs: &Observation) -> f64 {
    let s = clock(effects, params);
    match obs.speed_source {
        SpeedSource::Noted | SpeedSource::WheelSpeed | SpeedSource::Set => {
            let k = first_param(effects, params, Effect::SpeedScale).unwrap_or(1.0);
            (obs.speed_mps - obs.speed_correction_mps) / k + obs.speed_correction_mps / s
        }
        SpeedSource::Sync | SpeedSource::Kinematic => obs.speed_mps * s,
    }
}

/// The sensors' clock scale under `effects` (1 without [`Effect::TimeScale`]).
pub fn clock(effects: &[Effect], params: &[f64]) -> f64 {
    first_param(effects, params, Effect::TimeScale).unwrap_or(1.0)
}

/// The first parameter of `effect` among `effects` at `params`; `None` when it is not there.
fn first_param(effects: &[Effect], params: &[f64], effect: Effect) -> Option<f64> {
    split(effects, params)
        .into_iter()
        .find(|(e, _)| *e == effect)
        .and_then(|(_, ps)| ps.first().copied())
}

/// The weave the extended model predicts for a ride, as the ride would report it: at the
/// true speed behind the reported one (a noted reading over the speedometer's scale; a `Sync`
/// speed times the clock's), the eigenvalue over the clock's scale; with `shape`, its mode
/// shape γ/θ there too (a clock's scale changes the eigenvalue the ride reports, not the
/// shape). `guess` picks the branch (the unextended model's weave at the ride's speed). `None`
/// when there is no weave there, or no shape when one is asked for.
pub fn predict_weave(
    bike: &LinearBike,
    effects: &[Effect],
    params: &[f64],
    obs: &Observation,
    guess: Complex<f64>,
    shape: bool,
) -> Option<(Complex<f64>, Option<Complex<f64>>)> {
    let v = true_speed(effects, params, obs);
    let (w, s) = bike.weave_and_shape(v, guess, shape)?;
    Some((w / clock(effects, params), s))
}

/// A parameter at its search's edge ([`super::rank::at_bound`]) as the bound the rides put on
/// it: at the lower edge `lo`, "≤ p + SE"; at the upper, "≥ p − SE" (neither past the other
/// edge); without a standard error, the edge alone. Never an estimate ± SE, which would read
/// as a measurement.
pub fn bound_text(spec: &ParamSpec, p: f64, se: f64) -> String {
    let unit = spaced(spec.unit);
    let (_, lower) = spec.nearest_edge(p);
    let edge = if lower { spec.lo } else { spec.hi };
    match (se.is_finite(), lower) {
        // One SE from the value, but never past the search's other edge (a value the rides
        // barely tell: frame_mass 8.0 ± 8.2 kg is "≥ 0.000", not "≥ −0.215").
        (true, true) => format!(
            "≤ {:.3}{unit} (at the search's edge {edge:.3} within its SE)",
            (p + se).min(spec.hi)
        ),
        (true, false) => format!(
            "≥ {:.3}{unit} (at the search's edge {edge:.3} within its SE)",
            (p - se).max(spec.lo)
        ),
        (false, true) => format!("≤ {edge:.3}{unit} (at the search's edge, no SE)"),
        (false, false) => format!("≥ {edge:.3}{unit} (at the search's edge, no SE)"),
    }
}

/// A fitted parameter with its standard error and unit, `0.092 ± 0.061 kg·m²`; one the fit
/// could not identify has no standard error, and says so.
pub fn param_text(value: f64, se: f64, unit: &str) -> String {
    let unit = spaced(unit);
    if se.is_finite() {
        format!("{value:.3} ± {se:.3}{unit}")
    } else {
        format!("{value:.3}{unit} (no standard error: not identified)")
    }
}

/// A unit with its leading space (`" kg"`), or nothing.
pub(super) fn spaced(unit: &str) -> String {
    if unit.is_empty() {
        String::new()
    } else {
        format!(" {unit}")
    }
}
