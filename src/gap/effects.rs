//! The library of candidate effects: each an extension of the linear model with physical
//! parameters, bounds, the value that means "no effect" and a plausible range. In: the
//! measured bicycle's benchmark parameters and an effect's parameter values. Out: the extended
//! linear bicycle, and the weave it predicts for a ride (at the ride's speed as the ride
//! reported it). Each effect's definition is in [`library`]: one place per effect.

pub mod library;

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

    /// How far `p` lies outside the plausible range (0 inside it; NaN for a NaN).
    pub fn outside_plausible(&self, p: f64) -> f64 {
        let (lo, hi) = self.plausible;
        if p.is_nan() {
            return f64::NAN;
        }
        (lo - p).max(p - hi).max(0.0)
    }

    /// The plausibility prior's penalty on a fitted value `p` with standard error `se`, in the
    /// units of χ² (−2 ln of the prior's density there against its plateau): 0 inside the
    /// plausible range, `d² / (s² + se²)` at a distance `d` outside it. The prior is flat over
    /// the plausible range (its source, in each effect's doc, names no value inside it above
    /// another) and falls beyond it as a Gaussian of scale `s` = [`PRIOR_TAIL_FRACTION`] of the
    /// range's width; the fit's own Gaussian of width `se` convolved with that tail gives the
    /// quadratic form (its normalising log-ratio, under ln 2 where `se ≤ s`, left out). A value
    /// one tail scale out costs 1, as much as one standard error of the fit to every ride.
    /// Without a finite error, the prior's tail alone. The record:
    /// [docs/decisions/2026-12-06-plausibility-prior.md](../../docs/decisions/2026-12-06-plausibility-prior.md).
    pub fn prior_penalty(&self, p: f64, se: f64) -> f64 {
        let d = self.outside_plausible(p);
        if d.is_nan() || d == 0.0 {
            return 0.0;
        }
        let s = PRIOR_TAIL_FRACTION * (self.plausible.1 - self.plausible.0);
        let var = s * s + if se.is_finite() { se * se } else { 0.0 };
        d * d / var
    }
}

/// The scale of the plausibility prior's Gaussian tails beyond the plausible range, as a
/// fraction of the range's width ([`ParamSpec::prior_penalty`]): a quarter, the margin the
/// plausible flag already grants a fit that barely tells its value
/// (`gap::rank::plausible`). For the head angle (±2° plausible) a fit at 3° costs 1 in χ²,
/// at 4° 4; for an inertia factor (0.6–1.5) one at 2.0 costs 4.9.
pub const PRIOR_TAIL_FRACTION: f64 = 0.25;

/// An effect the Whipple model of the measured bicycle leaves out: its identity. What it is
/// and does is its [`Definition`], in [`library`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    SteerDamping,
    FrontMass,
    FrameMass,
    FrameIxx,
    FrameIzz,
    FrameIxz,
    FrontIxx,
    FrontIzz,
    Trail,
    WheelSpin,
    FrameCgHeight,
    FrameCgX,
    SpeedScale,
    TimeScale,
    Tyres,
    ActuatorGain,
    SteerInertia,
    ControllerSpeedScale,
    ActuatorLag,
    HeadAngle,
    FrameInertia,
    FrontInertia,
    SteerFriction,
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

/// Everything the diagnosis knows of one effect ([`Effect::definition`]; each is written in
/// [`library`]).
#[derive(Debug, Clone, Copy)]
pub struct Definition {
    /// The name used in reports and JSON.
    pub name: &'static str,
    /// What it is, in words.
    pub describe: &'static str,
    /// Its parameters, in order.
    pub params: &'static [ParamSpec],
    /// How it changes the linear model or the rides' readings.
    pub change: Change,
    /// Which conditions' rides it acts on.
    pub acts: Acts,
    /// It belongs to a condition's own equipment (a controller's actuator, a speedometer, a
    /// clock) and is fitted per condition in a study; otherwise it is the bicycle's, shared.
    pub per_condition: bool,
    /// It belongs to a steer motor: in the library only for a bicycle that carries one.
    pub needs_controller: bool,
    /// Its parameters where a manifest declares the bicycle's steer motor (`[steer_motor]`),
    /// for an effect of the motor itself: their ranges follow from it, and the effect is in
    /// the library with or without a controller ([`super::conditions::specs_of`]).
    pub of_declared_motor:
        Option<fn(ParamSpec, &crate::model::control::SteerMotorSpec) -> ParamSpec>,
    /// The measured quantity a factor multiplies and its unit, for detection limits in that
    /// unit; `None` for an effect that is not a factor on one.
    pub measured: Option<Quantity>,
}

/// A measured quantity of the bicycle: how to read it off the parameters, and its unit.
#[derive(Debug, Clone, Copy)]
pub struct Quantity {
    pub of: fn(&Benchmark) -> f64,
    pub unit: &'static str,
}

/// How an effect at parameters `p` changes the model ([`linear_bike`]) or what the rides
/// report ([`true_speed`], [`predict_weave`]).
#[derive(Debug, Clone, Copy)]
pub enum Change {
    /// The bicycle's parameters, by its one parameter.
    Bicycle(fn(&mut Benchmark, f64)),
    /// The controller, by its one parameter.
    Control(fn(&mut SteerControl, f64)),
    /// Viscous steer damping added (N·m·s/rad).
    SteerDamping,
    /// Dry (Coulomb) friction in the steering head (N·m), acting on each ride as the viscous
    /// damping of its swing's size ([`for_ride`]).
    SteerFriction,
    /// A first-order lag (s) between a controller's command and the steer torque
    /// ([`LinearBike::actuator_lag_s`]).
    ActuatorLag,
    /// Compliant tyres (cornering stiffness, relaxation length).
    Tyres,
    /// A speed read off an instrument is its scale times the true one.
    Speedometer,
    /// The sensors' clock runs at a scale of the nominal.
    Clock,
}

/// Which conditions' rides an effect acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Acts {
    /// Every ride.
    Always,
    /// Rides whose bicycle carries a controller.
    WithController,
    /// Rides whose speed is a reading or another instrument's wheel speed.
    OnReadSpeeds,
}

impl Effect {
    /// Every candidate, in a fixed order.
    pub const ALL: [Effect; 23] = [
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
        Effect::ControllerSpeedScale,
        Effect::ActuatorLag,
        Effect::HeadAngle,
        Effect::FrameInertia,
        Effect::FrontInertia,
        Effect::SteerFriction,
    ];

    /// The candidates for a bicycle with or without a controller: a steer motor's effects
    /// only with one, but those of the motor itself also where a motor is declared (`motor`;
    /// [`Definition::of_declared_motor`]): powered or not, its rotor turns with the steer.
    pub fn library(controlled: bool, motor: bool) -> Vec<Effect> {
        Effect::ALL
            .into_iter()
            .filter(|&e| {
                let d = e.definition();
                controlled || !d.needs_controller || (motor && d.of_declared_motor.is_some())
            })
            .collect()
    }

    /// Whether the effect belongs to a condition's own equipment rather than to the bicycle:
    /// in a study of several conditions ([`super::conditions`]) the actuator's gain (per
    /// controller), the speedometer's scale and the sensors' clock are fitted per condition;
    /// the bicycle's effects are shared by all.
    pub fn per_condition(self) -> bool {
        self.definition().per_condition
    }

    /// The name used in reports and JSON.
    pub fn name(self) -> &'static str {
        self.definition().name
    }

    /// What it is, in words.
    pub fn describe(self) -> &'static str {
        self.definition().describe
    }

    /// Its parameters, in order.
    pub fn params(self) -> &'static [ParamSpec] {
        self.definition().params
    }

    /// How it changes the model or the rides' readings.
    pub fn change(self) -> Change {
        self.definition().change
    }
}

/// Whether any of `effects` changes the model by `kind`.
pub fn any_change(effects: &[Effect], kind: fn(Change) -> bool) -> bool {
    effects.iter().any(|e| kind(e.change()))
}

/// The parameters of several effects, in order.
pub fn specs(effects: &[Effect]) -> Vec<ParamSpec> {
    effects.iter().flat_map(|e| e.params()).copied().collect()
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
    let mut lag = 0.0;
    let mut tyres = None;
    for (e, ps) in split(effects, params) {
        match (e.change(), ps) {
            (Change::Tyres, &[cornering, relaxation]) => {
                tyres = Some(LinearTyres {
                    cornering_per_rad: cornering,
                    camber_per_rad: assumed.camber_per_rad,
                    relaxation_length_m: relaxation,
                });
            }
            (Change::Bicycle(change), &[p, ..]) => change(&mut b, p),
            (Change::Control(change), &[p, ..]) => change(&mut control, p),
            (Change::SteerDamping, &[p, ..]) => damping += p,
            (Change::ActuatorLag, &[p, ..]) => lag += p,
            _ => {}
        }
    }
    LinearBike {
        steer_damping_nms_per_rad: damping,
        actuator_lag_s: lag,
        tyres,
        ..LinearBike::whipple(&b).with_control(control)
    }
}

/// The viscous damping (N·m·s/rad) that takes from a steer swing γ = A sin ωt as much energy
/// per cycle as a dry friction torque of `friction_nm` opposing the steer rate: its first
/// harmonic, c = 4F/(π ω A) (the describing function of dry friction: Den Hartog 1931, "Forced
/// vibrations with combined Coulomb and viscous friction", Trans. ASME 53; Gelb & Vander Velde
/// 1968, ch. 2). `omega` in rad/s, `amplitude_rad` in rad; 0 where either is not positive.
pub fn coulomb_damping_nms_per_rad(friction_nm: f64, omega: f64, amplitude_rad: f64) -> f64 {
    if omega > 0.0 && amplitude_rad > 0.0 && friction_nm.is_finite() {
        4.0 * friction_nm / (std::f64::consts::PI * omega * amplitude_rad)
    } else {
        0.0
    }
}

/// The dry steer friction (N·m) among `effects` at `params`, 0 without one.
pub fn steer_friction_nm(effects: &[Effect], params: &[f64]) -> f64 {
    first_param(effects, params, |c| matches!(c, Change::SteerFriction)).unwrap_or(0.0)
}

/// `bike` as it acts on ride `o`: with a dry steer friction among `effects`, its equivalent
/// damping ([`coulomb_damping_nms_per_rad`]) added at the weave's frequency `guess.im` (the
/// measured bicycle's at the ride's speed) and the weave's steer amplitude where the ride's
/// eigenvalue applies ([`Observation::steer_amplitude_rad`], at the window's amplitude-weighted
/// time). A swing slowed by dry friction loses a constant step of amplitude a cycle, so its
/// decay rate grows as it shrinks; the fit reports the rate where it applies. On nine blind
/// campaigns the friction came out 0.91 of its truth (mean), 1.2 taken at the envelope's mean
/// over the window instead: docs/decisions/2026-12-03-steer-friction.md. A ride without a
/// steer amplitude (a decay fitted from its roll rate alone) gets none. Without friction,
/// `bike` itself.
pub fn for_ride(
    bike: &LinearBike,
    effects: &[Effect],
    params: &[f64],
    o: &Observation,
    guess: Complex<f64>,
) -> LinearBike {
    let friction = steer_friction_nm(effects, params);
    let mut b = *bike;
    if let Some(a) = o.steer_amplitude_rad.filter(|_| friction != 0.0) {
        b.steer_damping_nms_per_rad += coulomb_damping_nms_per_rad(friction, guess.im, a);
    }
    b
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
            let k =
                first_param(effects, params, |c| matches!(c, Change::Speedometer)).unwrap_or(1.0);
            (obs.speed_mps - obs.speed_correction_mps) / k + obs.speed_correction_mps / s
        }
        SpeedSource::Sync | SpeedSource::Kinematic => obs.speed_mps * s,
    }
}

/// The sensors' clock scale under `effects` (1 without a clock's effect, [`Change::Clock`]).
pub fn clock(effects: &[Effect], params: &[f64]) -> f64 {
    first_param(effects, params, |c| matches!(c, Change::Clock)).unwrap_or(1.0)
}

/// The first parameter of the first effect among `effects` whose change is of the kind
/// `kind` picks, at `params`; `None` when there is none.
fn first_param(effects: &[Effect], params: &[f64], kind: fn(Change) -> bool) -> Option<f64> {
    split(effects, params)
        .into_iter()
        .find(|(e, _)| kind(e.change()))
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
    let bike = for_ride(bike, effects, params, obs, guess);
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
