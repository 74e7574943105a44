//! The ride's speed where its eigenvalue applies, from every source the log offers, each with a
//! standard error, compared ride by ride.
//!
//! In: the ride's signals ([`RideSignals`]: the frame's forward acceleration and yaw rate, the
//! `Sync` column), its modal fit (the window, the time where the eigenvalue applies, the
//! fitted steer), the bicycle's geometry, and the speedometer's reading noted at the release
//! when there is one. Out: [`SpeedSources`], the speed chosen among them, and every
//! disagreement beyond [`DISAGREEMENT_SIGMAS`].
//!
//! - **Noted, carried**: the speedometer's reading at the release, carried to the eigenvalue's
//!   time by the slowing the frame sensor measures ([`slowing`]; the gravity its forward axis
//!   picks up as the frame pitches taken off first, [`remove_pitch_gravity`]). Its standard
//!   error holds the
//!   reading's resolution (a uniform rounding error, resolution/√12) and the speedometer's own
//!   error per reading (a fraction of the reading), and the integral's.
//! - **Sync**: the reed switch's pulses, a line over the window ([`super::read::sync_speed`]).
//! - **Kinematic**: rolling without slip, the rear frame yaws at
//!   `ψ̇ = (v δ + c δ̇) cos λ / w` (Meijaard et al. 2007, eq. A.40 linearized; the seed's
//!   kinematic relation for the rear frame), so the frame gyro's yaw rate against the fitted
//!   steer gives `v` ([`kinematic_speed`]). Tyres slip: the lateral slip angles (of the order of
//!   the lateral acceleration over the cornering stiffness, a few per cent of δ in a weave) enter
//!   the yaw rate in phase with the roll, not the steer, and bias `v` by up to a tenth; a
//!   systematic [`SLIP_FRACTION`] of `v` enters its standard error. It is a check, used as the
//!   speed only when no other source exists.
//!
//! `Sync` is the best source where present, the noted reading carried by the slowing next.

use super::modal::ModalFit;
use super::read::{sync_speed, LeverSample, RideSignals};
use crate::uncertainty::Measured;

/// Sources further apart than this many combined standard errors are reported.
pub const DISAGREEMENT_SIGMAS: f64 = 3.0;

/// A noted reading further than this many combined standard errors from every speed the log
/// itself measures (`Sync`, the kinematic speed) is refused: not a speedometer's error but a
/// reading in another unit or of another ride. The kinematic speed's error holds a tenth of
/// the speed for tyre slip ([`SLIP_FRACTION`]), so a reading 10 of them off is off by about
/// twice the speed.
pub const NOTED_CONTRADICTION_SIGMAS: f64 = 10.0;

/// The kinematic speed's systematic standard error from tyre slip, as a fraction of the speed.
/// Measured on 100 simulated coasting rides with compliant tyres (cornering 11 /rad, camber
/// 0.6 /rad, relaxation 0.18 m) and steer damping: the kinematic speed came out 9.9 % ± 4.1 %
/// high; with knife-edge wheels 0.5 % ± 1.4 % (tests/speed.rs).
pub const SLIP_FRACTION: f64 = 0.10;

/// How flat the floor is, as the rms change of its slope along the ride (rad): a change of the
/// slope under the bicycle between the standstill and the coast reads as a forward
/// acceleration g·Δβ. A sports-hall or lab floor: 0.5 mm per metre.
pub const FLOOR_SLOPE_CHANGE_RAD: f64 = 5e-4;

const GRAVITY_MPS2: f64 = 9.81;

/// The fastest speed reading bikeproc accepts (m/s): 30 m/s is 108 km/h, beyond any riderless
/// bicycle's test.
pub const MAX_READING_MPS: f64 = 30.0;

/// The slowest speed reading bikeproc accepts (m/s): a bicycle below 0.1 m/s stands (a reading
/// of 1e-300 gave "no weave at −0.202 m/s" once carried over the coast).
pub const MIN_READING_MPS: f64 = 0.1;

/// Checks a speedometer reading: a number from [`MIN_READING_MPS`] to [`MAX_READING_MPS`].
pub fn check_reading_mps(v: f64) -> Result<f64, super::OutOfRange> {
    super::OutOfRange::check(
        v,
        (MIN_READING_MPS, MAX_READING_MPS),
        "m/s",
        "a riding speed",
    )
}

/// The speedometer's reading as noted by the lab, with what limits it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct NotedReading {
    /// The reading at the release (m/s).
    pub speed_mps: f64,
    /// The display's step (m/s): a reading to 0.1 m/s is uniform within ±0.05 m/s.
    pub resolution_mps: f64,
    /// The speedometer's own random error per reading, as a fraction of the reading (its
    /// display lags and averages; a common scale error is the gap stage's `speed_scale`).
    pub se_fraction: f64,
}

impl NotedReading {
    /// The lab's speedometer: 0.1 m/s steps, 1 % per reading.
    pub fn lab(speed_mps: f64) -> NotedReading {
        NotedReading {
            speed_mps,
            resolution_mps: 0.1,
            se_fraction: 0.01,
        }
    }

    /// Standard error of the reading as the speed at the release (m/s).
    pub fn se_mps(&self) -> f64 {
        (self.resolution_mps.powi(2) / 12.0 + (self.se_fraction * self.speed_mps).powi(2)).sqrt()
    }
}

/// A speed the lab gives for another instrument's ride (a CSV), beside any wheel-speed column
/// the file has: a speedometer's reading ([`SpeedSource::Noted`]) or the speed the lab set, a
/// treadmill's setting ([`SpeedSource::Set`]). Either is a reading with a display step and an
/// error per reading ([`NotedReading`]); no slowing carries it (the window is the ride's own).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GivenSpeed {
    pub reading: NotedReading,
    /// The treadmill's setting (`true`) or a speedometer's reading.
    pub set: bool,
}

impl GivenSpeed {
    /// A speedometer's reading.
    pub fn noted(reading: NotedReading) -> GivenSpeed {
        GivenSpeed {
            reading,
            set: false,
        }
    }

    /// The speed the lab set (a treadmill's), its display step and error per setting.
    pub fn set(reading: NotedReading) -> GivenSpeed {
        GivenSpeed { reading, set: true }
    }

    /// Where the speed comes from when it is used.
    pub fn source(&self) -> SpeedSource {
        if self.set {
            SpeedSource::Set
        } else {
            SpeedSource::Noted
        }
    }

    /// The speed with its standard error (uniform within half the display step, with the
    /// error per reading).
    pub fn measured(&self) -> Measured {
        Measured::new(self.reading.speed_mps, self.reading.se_mps())
    }
}

/// A speed given for a CSV ride, in words, by where it comes from: `the set speed` for
/// [`SpeedSource::Set`], else `the reading given`.
pub fn given_words(source: SpeedSource) -> &'static str {
    match source {
        SpeedSource::Set => "the set speed",
        _ => "the reading given",
    }
}

/// A speed given for a ride (a treadmill's setting, a speedometer's reading) beside the
/// wheel-speed column whose speed is used: both shown, with their disagreement.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SpeedBeside {
    /// `set` or `noted`.
    pub source: SpeedSource,
    pub speed_mps: Measured,
    /// The wheel's speed less the given one (m/s).
    pub wheel_less_given_mps: f64,
    /// That difference in its combined standard error.
    pub z: f64,
}

impl SpeedBeside {
    /// `given` beside the `wheel`'s speed.
    pub fn of(given: GivenSpeed, wheel: Measured) -> SpeedBeside {
        let speed = given.measured();
        let d = wheel.value - speed.value;
        SpeedBeside {
            source: given.source(),
            speed_mps: speed,
            wheel_less_given_mps: d,
            z: d / wheel.se.hypot(speed.se),
        }
    }

    /// In words: `the set speed 5.000 ± 0.050 m/s: the wheel reads +0.031 m/s (+0.6σ) from it`.
    pub fn text(&self) -> String {
        format!(
            "{} {:.3} ± {:.3} m/s: the wheel reads {:+.3} m/s ({:+.1}σ) from it",
            given_words(self.source),
            self.speed_mps.value,
            self.speed_mps.se,
            self.wheel_less_given_mps,
            self.z
        )
    }
}

/// A speed with its standard error, where it applies.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SpeedEstimate {
    pub speed_mps: f64,
    pub se_mps: f64,
}

/// The change of the speed from the release (the speed's peak) to a later time, from the
/// frame sensor's forward acceleration.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Slowing {
    /// The speed's peak at the end of the push (s): where the integral starts.
    pub from_s: f64,
    pub to_s: f64,
    /// v(to) − v(from) (m/s) and its standard error.
    pub delta_mps: f64,
    pub se_mps: f64,
    /// The mean forward acceleration over the eigenvalue's window (m/s²).
    pub window_accel_mps2: f64,
}

/// The noted reading carried to the eigenvalue's time.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CarriedReading {
    pub reading: NotedReading,
    pub slowing: Slowing,
    pub estimate: SpeedEstimate,
}

/// Which source the ride's speed came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SpeedSource {
    /// The speedometer's reading noted at the release, carried by the measured slowing.
    Noted,
    /// The reed switch's pulses over the window.
    Sync,
    /// The frame's yaw rate against the steer (rolling without slip).
    Kinematic,
    /// Another instrument's wheel-speed column over the window (a CSV ride).
    WheelSpeed,
    /// The speed the lab set for the ride (a treadmill's setting; a CSV ride without a
    /// wheel-speed column).
    Set,
}

impl SpeedSource {
    /// Its name in the outputs (as in the JSON).
    pub fn name(self) -> &'static str {
        match self {
            SpeedSource::Noted => "noted",
            SpeedSource::Sync => "sync",
            SpeedSource::Kinematic => "kinematic",
            SpeedSource::WheelSpeed => "wheel_speed",
            SpeedSource::Set => "set",
        }
    }
}

/// Every source of the speed where the eigenvalue applies.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SpeedSources {
    /// Where the eigenvalue applies (s).
    pub at_s: f64,
    pub noted: Option<CarriedReading>,
    pub sync: Option<SpeedEstimate>,
    pub kinematic: Option<SpeedEstimate>,
    /// The mean forward acceleration over the eigenvalue's window (m/s², the frame sensor's;
    /// 0 when no release was found to measure the slowing from); the noted source prints it.
    #[serde(skip)]
    pub window_accel_mps2: f64,
    /// Pairs of sources more than [`DISAGREEMENT_SIGMAS`] apart, in words.
    pub disagreements: Vec<String>,
    /// A CSV ride's speed given (set or noted) where its wheel-speed column's is used.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub given_beside_wheel: Option<SpeedBeside>,
}

impl SpeedSources {
    /// Collects the sources of a ride: `noted` is the reading at the release, if any; `w`, `c`,
    /// `lambda` the bicycle's wheelbase (m), trail (m) and steer-axis tilt (rad).
    pub fn collect(
        s: &RideSignals,
        fit: &ModalFit,
        noted: Option<NotedReading>,
        geometry: Geometry,
    ) -> SpeedSources {
        let at_s = fit.t_ref_s;
        let slow = slowing(s, fit, at_s);
        let noted = match (noted, slow) {
            (Some(reading), Some(slowing)) => Some(CarriedReading {
                reading,
                slowing,
                estimate: SpeedEstimate {
                    speed_mps: reading.speed_mps + slowing.delta_mps,
                    se_mps: reading.se_mps().hypot(slowing.se_mps),
                },
            }),
            // No release found: the reading stands for the speed, the coast unmeasured. Its
            // error then holds a coast of up to 0.2 m/s² over the time since the log's
            // standstill ended, uniform.
            (Some(reading), None) => Some(CarriedReading {
                reading,
                slowing: Slowing {
                    from_s: at_s,
                    to_s: at_s,
                    delta_mps: 0.0,
                    se_mps: f64::NAN,
                    window_accel_mps2: 0.0,
                },
                estimate: SpeedEstimate {
                    speed_mps: reading.speed_mps,
                    se_mps: reading
                        .se_mps()
                        .hypot(0.2 * (at_s - s.kick_s + 1.0) / 12f64.sqrt()),
                },
            }),
            (None, _) => None,
        };
        // A measured speed that is no riding speed (a wheel pulse train or a fit gone wrong)
        // is no measurement: the source is left out, as when it is missing.
        let sync = sync_speed(&s.log, fit.start_s, fit.end_s, at_s)
            .map(|v| SpeedEstimate {
                speed_mps: v.speed_mps,
                se_mps: v.speed_se_mps,
            })
            .filter(|e| check_reading_mps(e.speed_mps).is_ok());
        let window_accel_mps2 = slow.map_or(0.0, |x| x.window_accel_mps2);
        let kinematic = kinematic_speed(s, fit, geometry, window_accel_mps2)
            .filter(|e| check_reading_mps(e.speed_mps).is_ok());
        let mut out = SpeedSources {
            given_beside_wheel: None,
            at_s,
            noted,
            sync,
            kinematic,
            window_accel_mps2,
            disagreements: Vec::new(),
        };
        let named = out.named();
        for (i, (a, x)) in named.iter().enumerate() {
            for (b, y) in &named[i + 1..] {
                let z = (x.speed_mps - y.speed_mps) / x.se_mps.hypot(y.se_mps);
                if z.abs() > DISAGREEMENT_SIGMAS {
                    out.disagreements.push(format!(
                        "{a} {:.3} ± {:.3} and {b} {:.3} ± {:.3} m/s differ by {z:+.1} SE",
                        x.speed_mps, x.se_mps, y.speed_mps, y.se_mps
                    ));
                }
            }
        }
        out
    }

    /// Why the noted reading cannot be this ride's speed in m/s: the log's own measure (the
    /// closest to it) lies more than [`NOTED_CONTRADICTION_SIGMAS`] combined standard errors
    /// away; with a hint (a reading in km/h, a ride mixed up). `None` when it agrees or nothing
    /// measures it.
    pub fn contradicted_reading(&self) -> Option<String> {
        let noted = self.noted?;
        let (name, measured, z) = [
            (SpeedSource::Sync, self.sync),
            (SpeedSource::Kinematic, self.kinematic),
        ]
        .into_iter()
        .filter_map(|(n, e)| {
            let e = e?;
            let z =
                (noted.estimate.speed_mps - e.speed_mps) / noted.estimate.se_mps.hypot(e.se_mps);
            Some((n.name(), e, z))
        })
        .min_by(|a, b| a.2.abs().total_cmp(&b.2.abs()))?;
        if z.abs() <= NOTED_CONTRADICTION_SIGMAS || !z.is_finite() {
            return None;
        }
        let reading = noted.reading.speed_mps;
        let ratio = noted.estimate.speed_mps / measured.speed_mps;
        let hint = if (ratio / 3.6 - 1.0).abs() < 0.2 {
            format!(
                "was the reading in km/h? {reading} km/h is {:.2} m/s; give --speed in m/s",
                reading / 3.6
            )
        } else {
            "is it this ride's reading (rides mixed up, or the speedometer's of another run)?"
                .to_string()
        };
        Some(format!(
            "the noted speed {reading} m/s (carried to the kick: {:.3} ± {:.3} m/s) is {z:+.1} \
             combined standard errors from the {name} speed the log measures, {:.3} ± {:.3} m/s: \
             {hint}",
            noted.estimate.speed_mps, noted.estimate.se_mps, measured.speed_mps, measured.se_mps
        ))
    }

    /// The sources present, by name, best first.
    pub fn named(&self) -> Vec<(&'static str, SpeedEstimate)> {
        [
            (SpeedSource::Sync, self.sync),
            (SpeedSource::Noted, self.noted.map(|n| n.estimate)),
            (SpeedSource::Kinematic, self.kinematic),
        ]
        .into_iter()
        .filter_map(|(n, e)| Some((n.name(), e?)))
        .collect()
    }

    /// The best source: `Sync` when `prefer_sync` (or no reading was noted), the noted reading
    /// carried next, the kinematic speed last.
    pub fn best(&self, prefer_sync: bool) -> Option<(SpeedSource, SpeedEstimate)> {
        let noted = self.noted.map(|n| (SpeedSource::Noted, n.estimate));
        let sync = self.sync.map(|e| (SpeedSource::Sync, e));
        let first = if prefer_sync || noted.is_none() {
            sync.or(noted)
        } else {
            noted
        };
        first.or(self.kinematic.map(|e| (SpeedSource::Kinematic, e)))
    }
}

impl SpeedSources {
    /// The sources, one line each, and the disagreements (the `dynamic` command's text).
    pub fn to_text(&self) -> String {
        let mut out = String::new();
        if let Some(n) = &self.noted {
            out += &format!(
                "    noted          {:.3} ± {:.3} m/s: the reading {:.2} m/s (step {:.2}, {:.1} %) at the release ({:.2} s), {:+.3} ± {:.3} m/s of coasting since\n",
                n.estimate.speed_mps,
                n.estimate.se_mps,
                n.reading.speed_mps,
                n.reading.resolution_mps,
                100.0 * n.reading.se_fraction,
                n.slowing.from_s,
                n.slowing.delta_mps,
                n.slowing.se_mps
            );
        }
        if let Some(e) = &self.sync {
            out += &format!(
                "    reed switch    {:.3} ± {:.3} m/s\n",
                e.speed_mps, e.se_mps
            );
        }
        if let Some(e) = &self.kinematic {
            out += &format!(
                "    kinematic      {:.3} ± {:.3} m/s (yaw rate against the steer; tyre slip {:.0} % included)\n",
                e.speed_mps,
                e.se_mps,
                100.0 * SLIP_FRACTION
            );
        }
        for d in &self.disagreements {
            out += &format!("    DISAGREE       {d}\n");
        }
        out
    }
}

/// The geometry the kinematic speed needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    pub wheelbase_m: f64,
    pub trail_m: f64,
    pub steer_axis_tilt_rad: f64,
}

/// The forward acceleration's samples in `[a, b]` (s): (time, value).
fn accel_between(s: &RideSignals, a: f64, b: f64) -> Vec<(f64, f64)> {
    accel_between_with(s, a, b, |x, _| x)
}

/// [`accel_between`] with each value mapped by `f(value, lever regressors)`.
fn accel_between_with(
    s: &RideSignals,
    a: f64,
    b: f64,
    f: impl Fn(f64, [f64; 3]) -> f64,
) -> Vec<(f64, f64)> {
    cal_samples(s, a, b)
        .map(|(t, x, c)| (t, f(x, c)))
        .filter(|&(_, x)| x.is_finite())
        .collect()
}

/// The `_cal` samples in `[a, b]` (s): (time, forward acceleration, its lever regressors).
fn cal_samples(s: &RideSignals, a: f64, b: f64) -> impl Iterator<Item = (f64, f64, [f64; 3])> + '_ {
    lever_samples(s, a, b).map(|(t, x, l)| (t, x, l.forward))
}

/// The `_cal` samples in `[a, b]` (s): (time, forward acceleration, the sample's lever terms).
fn lever_samples(
    s: &RideSignals,
    a: f64,
    b: f64,
) -> impl Iterator<Item = (f64, f64, &LeverSample)> + '_ {
    let rate = s.sample_rate_hz;
    s.imu_index
        .iter()
        .zip(&s.forward_accel_mps2)
        .zip(&s.lever)
        .map(move |((&i, &x), l)| (i as f64 / rate, x, l))
        .filter(move |&(t, _, _)| t >= a && t <= b)
}

/// The trapezoid integral of samples (time, value), gaps bridged linearly.
fn integral(samples: &[(f64, f64)]) -> f64 {
    samples
        .windows(2)
        .map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0))
        .sum()
}

/// Removes the gravity the frame sensor's forward axis picks up as the rear frame pitches
/// with lean and steer: the pitch p is a function of roll θ and steer δ (the Whipple bicycle's
/// holonomic constraint, `pitch_rad(θ, δ)`, [`crate::model::nonlinear`]), and the forward
/// specific force gains `g Δp cos θ`, which integrated reads as a change of speed that is not
/// there. Each `_cal` sample takes θ and δ at its grid index (linear between neighbours);
/// samples outside the angles' span, or where `pitch_rad` has no answer, are left as they are.
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#remove_pitch_gravity).
pub fn remove_pitch_gravity(s: &mut RideSignals, pitch_rad: impl Fn(f64, f64) -> Option<f64>) {
    let Some(upright) = pitch_rad(0.0, 0.0) else {
        return;
    };
    let angles_at = |i: u64| -> Option<(f64, f64)> {
        match s.index.binary_search(&i) {
            Ok(k) => Some((s.roll_rad[k], s.steer_rad[k])),
            Err(k) if k > 0 && k < s.index.len() => {
                let (a, b) = (s.index[k - 1], s.index[k]);
                let u = (i - a) as f64 / (b - a) as f64;
                let lerp = |x: &[f64]| x[k - 1] + u * (x[k] - x[k - 1]);
                Some((lerp(&s.roll_rad), lerp(&s.steer_rad)))
            }
            Err(_) => None,
        }
    };
    let leak: Vec<f64> = s
        .imu_index
        .iter()
        .map(|&i| {
            angles_at(i)
                .and_then(|(roll, steer)| {
                    let p = pitch_rad(roll, steer)?;
                    Some(GRAVITY_MPS2 * (p - upright) * roll.cos())
                })
                .filter(|x| x.is_finite())
                .unwrap_or(0.0)
        })
        .collect();
    for (a, l) in s.forward_accel_mps2.iter_mut().zip(leak) {
        *a -= l;
    }
}

/// The speed's change from its peak at the end of the push to `to_s`, from the frame sensor's
/// forward acceleration (gravity and bias removed at the standstill): `Δv = ∫ a dt`.
///
/// The peak is where the forward acceleration (0.1 s mean), falling after the detected release
/// (the last moment above [`super::read::RELEASE_MPS2`]), first reaches zero: the push ends
/// and the coast begins, and the speedometer's reading at the release is the speed there. A
/// timing error there matters to second order only (the acceleration is near zero).
///
/// Standard error, in quadrature: the sensor's white noise integrated (σₐ √N / rate, σₐ from
/// the first differences of the samples), the standstill's mean (σₐ/√N₀ times the duration),
/// and the floor's slope changing under the bicycle ([`FLOOR_SLOPE_CHANGE_RAD`] times g times
/// the duration). `None` when no release was found.
pub fn slowing(s: &RideSignals, fit: &ModalFit, to_s: f64) -> Option<Slowing> {
    let release = s.release_s?;
    let rate = s.sample_rate_hz;
    let after = accel_between(s, release, s.kick_s);
    let w = ((0.1 * rate).round() as usize).max(1);
    let mean_at = |k: usize| {
        let (lo, hi) = (k.saturating_sub(w / 2), (k + w / 2 + 1).min(after.len()));
        after[lo..hi].iter().map(|p| p.1).sum::<f64>() / (hi - lo) as f64
    };
    let from_s = (0..after.len())
        .find(|&k| mean_at(k) <= 0.0)
        .map_or(release, |k| after[k].0);
    if to_s <= from_s {
        return None;
    }
    let lever = LeverArm::fit(s, from_s, to_s.max(fit.end_s));
    let corrected = |a: f64, b: f64| -> Vec<(f64, f64)> {
        accel_between_with(s, a, b, |x, c| match &lever {
            Some(l) => x - l.term(c),
            None => x,
        })
    };
    let samples = corrected(from_s, to_s);
    if samples.len() < 2 {
        return None;
    }
    let delta = integral(&samples);
    // The white noise: from first differences over the coast (slow changes cancel).
    let coast = accel_between(s, from_s, fit.end_s);
    let diffs: Vec<f64> = coast
        .windows(2)
        .filter(|p| (p[1].0 - p[0].0) * rate < 1.5)
        .map(|p| p[1].1 - p[0].1)
        .collect();
    let sigma = (diffs.iter().map(|d| d * d).sum::<f64>() / (2 * diffs.len().max(1)) as f64).sqrt();
    let still_n = s.standstill_samples.max(1);
    let duration = to_s - from_s;
    let noise = sigma * (samples.len() as f64).sqrt() / rate;
    let zero = sigma / (still_n as f64).sqrt() * duration;
    let floor = GRAVITY_MPS2 * FLOOR_SLOPE_CHANGE_RAD * duration;
    let arm = lever
        .as_ref()
        .map_or(0.0, |l| l.se_of_integral(s, from_s, to_s));
    let window = corrected(fit.start_s, fit.end_s);
    let window_accel = if window.len() >= 2 {
        integral(&window) / (window[window.len() - 1].0 - window[0].0)
    } else {
        0.0
    };
    Some(Slowing {
        from_s,
        to_s,
        delta_mps: delta,
        se_mps: (noise * noise + zero * zero + floor * floor + arm * arm).sqrt(),
        window_accel_mps2: window_accel,
    })
}

/// The frame sensor's lever arm r (m, sensor axes) from the rear frame's point at the rear
/// contact, with its covariance: a large weave puts ω̇ × r and ω × (ω × r) into the sensor's
/// forward acceleration, which integrated would read as a slowing. It comes from the lateral
/// and vertical accelerations ([`LeverSample`]), where ω̇ × r is of first order in the motion
/// (least squares for r, the speed as a line in time and each axis's offset); on the forward
/// axis the arm's terms are of second order, as the weave's real exchange of energy is.
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#leverarm).
struct LeverArm {
    r: nalgebra::Vector3<f64>,
    cov: nalgebra::Matrix3<f64>,
}

impl LeverArm {
    /// The regression's unknowns: r (3), the speed and its slope, the two axes' offsets.
    const UNKNOWNS: usize = 7;

    /// `None` when fewer than 50 samples or the regression is singular.
    fn fit(s: &RideSignals, from_s: f64, to_s: f64) -> Option<LeverArm> {
        const P: usize = LeverArm::UNKNOWNS;
        // Two rows a sample, lateral (axis 0) and vertical (axis 1).
        let mut rows: Vec<([f64; P], f64, usize)> = Vec::new();
        for (t, _, l) in lever_samples(s, from_s, to_s) {
            let tau = t - from_s;
            let axes = [
                (l.lateral_accel_mps2, l.up_rate_rad_per_s, l.lateral),
                (l.vertical_accel_mps2, -l.left_rate_rad_per_s, l.vertical),
            ];
            for (axis, (y, speed_term, c)) in axes.into_iter().enumerate() {
                let x = [
                    c[0],
                    c[1],
                    c[2],
                    speed_term,
                    speed_term * tau,
                    f64::from(u8::from(axis == 0)),
                    f64::from(u8::from(axis == 1)),
                ];
                if y.is_finite() && x.iter().all(|v| v.is_finite()) {
                    rows.push((x, y, axis));
                }
            }
        }
        let n = rows.len();
        if n < 100 {
            return None;
        }
        // Least squares with each axis's rows weighted by `w`: (X'X)⁻¹ (scaled), β, residuals.
        let solve = |w: [f64; 2]| {
            let x = nalgebra::DMatrix::from_fn(n, P, |k, j| rows[k].0[j] * w[rows[k].2]);
            let y = nalgebra::DVector::from_fn(n, |k, _| rows[k].1 * w[rows[k].2]);
            let inv = (x.transpose() * &x).try_inverse()?;
            let beta = &inv * (x.transpose() * &y);
            let res = &y - &x * &beta;
            Some((inv, beta, res))
        };
        let (_, _, res) = solve([1.0, 1.0])?;
        let spread = |axis: usize| {
            let (sum, count) = res
                .iter()
                .zip(&rows)
                .filter(|(_, row)| row.2 == axis)
                .fold((0.0, 0usize), |(s, n), (r, _)| (s + r * r, n + 1));
            (sum / count.max(1) as f64).sqrt()
        };
        let (lateral, vertical) = (spread(0), spread(1));
        if !(lateral > 0.0 && vertical > 0.0) {
            return None;
        }
        let (inv, beta, res) = solve([1.0 / lateral, 1.0 / vertical])?;
        let var = res.norm_squared() / (n - P) as f64;
        // The residuals are correlated from sample to sample (an axis's rows are two apart):
        // the effective count shrinks.
        let lag: f64 = (2..n).map(|k| res[k] * res[k - 2]).sum();
        let rho = (lag / res.norm_squared()).clamp(0.0, 0.95);
        let inflate = (1.0 + rho) / (1.0 - rho);
        let cov = inv.fixed_view::<3, 3>(0, 0) * (var * inflate);
        let r = nalgebra::Vector3::new(beta[0], beta[1], beta[2]);
        (r.iter().all(|v| v.is_finite()) && cov.iter().all(|v| v.is_finite()))
            .then_some(LeverArm { r, cov })
    }

    /// What the lever arm adds to the forward acceleration at regressors `c`.
    fn term(&self, c: [f64; 3]) -> f64 {
        if c.iter().all(|x| x.is_finite()) {
            c[0] * self.r.x + c[1] * self.r.y + c[2] * self.r.z
        } else {
            0.0
        }
    }

    /// The standard error the arm's own uncertainty puts on ∫ c · r dt over `[a, b]`.
    fn se_of_integral(&self, s: &RideSignals, a: f64, b: f64) -> f64 {
        let rate = s.sample_rate_hz;
        let mut g = nalgebra::Vector3::zeros();
        for (_, _, c) in cal_samples(s, a, b) {
            if c.iter().all(|x| x.is_finite()) {
                g += nalgebra::Vector3::new(c[0], c[1], c[2]) / rate;
            }
        }
        (g.transpose() * self.cov * g)[(0, 0)].max(0.0).sqrt()
    }
}

/// The speed from the rolling bicycle's kinematics over the fit's window: the rear frame's yaw
/// rate `ψ̇ = (v δ + c δ̇) cos λ / w` (Meijaard et al. 2007, the rear frame's yaw linearized;
/// no slip), with the fitted steer δ(t) and its rate as regressors (free of the sensors' noise),
/// `v(t) = v(t_ref) + a (t − t_ref)` with the measured mean acceleration `a`, and an offset for
/// the gyro's remaining bias: least squares for `v(t_ref)`. Its standard error: the regression's,
/// with the residuals' lag-one correlation shrinking the sample count, and the tyres' slip,
/// [`SLIP_FRACTION`] of `v`. `None` when the window has too few samples or the steer too little
/// motion.
pub fn kinematic_speed(
    s: &RideSignals,
    fit: &ModalFit,
    g: Geometry,
    accel_mps2: f64,
) -> Option<SpeedEstimate> {
    let rate = s.sample_rate_hz;
    let k = g.steer_axis_tilt_rad.cos() / g.wheelbase_m;
    let h = 0.5 / rate;
    let rows: Vec<(f64, f64, f64)> = s
        .imu_index
        .iter()
        .zip(&s.yaw_rate_rad_per_s)
        .map(|(&i, &y)| (i as f64 / rate, y))
        .filter(|&(t, y)| t >= fit.start_s && t <= fit.end_s && y.is_finite())
        .map(|(t, y)| {
            let steer = fit.eval(t)[1];
            let steer_rate = (fit.eval(t + h)[1] - fit.eval(t - h)[1]) / (2.0 * h);
            let tau = t - fit.t_ref_s;
            let x = k * steer;
            (x, y - k * g.trail_m * steer_rate - accel_mps2 * tau * x, t)
        })
        .collect();
    let n = rows.len();
    if n < 20 {
        return None;
    }
    let nf = n as f64;
    let (mx, my) = (
        rows.iter().map(|r| r.0).sum::<f64>() / nf,
        rows.iter().map(|r| r.1).sum::<f64>() / nf,
    );
    let sxx: f64 = rows.iter().map(|r| (r.0 - mx).powi(2)).sum();
    let sxy: f64 = rows.iter().map(|r| (r.0 - mx) * (r.1 - my)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let v = sxy / sxx;
    let res: Vec<f64> = rows.iter().map(|r| r.1 - my - v * (r.0 - mx)).collect();
    let s2 = res.iter().map(|e| e * e).sum::<f64>() / (nf - 2.0);
    let rho = (res.windows(2).map(|w| w[0] * w[1]).sum::<f64>()
        / res.iter().map(|e| e * e).sum::<f64>().max(1e-300))
    .clamp(0.0, 0.99);
    let inflation = (1.0 + rho) / (1.0 - rho);
    let se_noise = (s2 / sxx * inflation).sqrt();
    (v.is_finite() && v > 0.0).then(|| SpeedEstimate {
        speed_mps: v,
        se_mps: se_noise.hypot(SLIP_FRACTION * v),
    })
}
