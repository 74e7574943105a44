//! The dynamic test of a ride (seed §5.4, §8): log pair → θ, γ → the free motion's window →
//! the experimental weave eigenvalue with its standard errors → beside the model's at the
//! ride's speed, the difference in standard errors.
//!
//! In: a ride's angles file (its `_cal` file beside it), the bicycle's parametrized model, the
//! speed (the speedometer's noted reading, or the reed switch's `Sync` column). Out:
//! [`DynamicTest`]. A campaign ([`RideManifest`], `rides.toml`) runs ride by ride in parallel.
//!
//! Every way a ride can be unusable is named: no kick, a recording too short for an eigenvalue,
//! a sensor that did not move, the two sensors swapped.

use super::modal::{
    fit_modes, refit_as, Eigenvalue, Estimator, ModalError, ModalFit, ModalOptions, Start,
    Structure, MAX_REAL_MODES,
};
use super::model_weave::{model_weave_at, ModelWeave};
use super::read::{read_ride, RideError, RideSignals};
pub use super::speed::SpeedSource;
use super::speed::{Geometry, GivenSpeed, NotedReading, SpeedSources};
use crate::model::uncertain::Parametrized;
use crate::model::weave::{weave_near, LinearWeave};
use crate::model::Canonical;
use crate::read::manifest::ManifestError;
use crate::read::rides::{RideEntry, RideManifest};
use nalgebra::Complex;
use std::path::{Path, PathBuf};

/// The window starts this long after the kick's peak (s): past the pulse (it ends 0.05 s after
/// the peak), the tyres' lag and the castor transient. The castor mode (about −7 /s at 4.4 m/s)
/// keeps 7 % of its amplitude 0.4 s after the kick, under the sensors' noise for the
/// information criterion but not for σ: starting at 0.4 s, σ came out 0.6 standard errors low
/// on average over 40 simulated rides with all effects off; at 0.8 s, within 0.1.
const AFTER_KICK_S: f64 = 0.8;
/// Beyond this roll (rad) the motion is no longer small: the window ends there (a fall).
const MAX_ROLL_RAD: f64 = 0.2;
/// A weave that grows (below the weave speed), or one too slow for [`MIN_CYCLES`] after
/// [`AFTER_KICK_S`], is fitted from this long after the kick's peak (s), the castor mode and
/// what is left of the kick fitted as real modes: waiting out 0.8 s left no cycle below the
/// roll limit on 26 of 30 rides released at 3.0–3.5 m/s (the weave speed is 3.1 m/s).
const EARLY_AFTER_KICK_S: f64 = 0.3;
/// … while the roll stays within this (rad; its nonlinearity is in the errors,
/// [`NONLINEAR_SE_PER_RAD2`]) …
const EARLY_MAX_ROLL_RAD: f64 = 0.25;
/// … and at least this many weave cycles.
const EARLY_MIN_CYCLES: f64 = 1.0;
/// At most this long a window (s), unless two weave cycles take longer: the coasting bicycle
/// slows down (0.05–0.15 m/s²) and its eigenvalue drifts, by more the longer the window.
const MAX_WINDOW_S: f64 = 2.5;
/// At least this long a free motion (s) …
const MIN_WINDOW_S: f64 = 1.0;
/// … and this many weave cycles.
const MIN_CYCLES: f64 = 1.5;

/// The speed at which the eigenvalue applies (at the fit's amplitude-weighted time), from the
/// best source the ride offers, and every source beside it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Speed {
    pub speed_mps: f64,
    /// Standard error (m/s) of the chosen source.
    pub speed_se_mps: f64,
    pub source: SpeedSource,
    /// Every source (and the slowing over the window), their disagreements beyond 3 combined
    /// standard errors.
    pub sources: SpeedSources,
}

/// Options of [`dynamic_test`].
#[derive(Debug, Clone, Default)]
pub struct DynamicOptions {
    /// The speedometer's reading at the release, with its resolution and error; without it
    /// the `Sync` column is used, or else the kinematic speed.
    pub noted: Option<NotedReading>,
    /// Use the `Sync` column when the log has it, the noted reading otherwise (campaigns).
    pub prefer_sync: bool,
    pub modal: ModalOptions,
}

/// A ride's dynamic test.
#[derive(Debug, Clone)]
pub struct DynamicTest {
    pub path: PathBuf,
    pub speed: Speed,
    pub kick_s: f64,
    pub catch_s: f64,
    /// The end of the push (s), when found.
    pub release_s: Option<f64>,
    /// The fit's weave and mode shape, corrected by [`replay_coasting`].
    pub fit: ModalFit,
    /// What was taken off the fit for the coasting ([`CoastingCorrection::taken_off`]: the
    /// mode shape's replay and the slowing bicycle's own change of its shape; nothing off the
    /// eigenvalue): `[re (1/s), im (1/s), |γ/θ|, arg γ/θ (rad)]`, zeros on a ride at constant
    /// speed.
    pub coasting_bias: [f64; 4],
    /// The size the coasting correction's error is counted in
    /// ([`CoastingCorrection::error_scale`]), in the same layout: the fit's standard errors
    /// hold [`COASTING_RIDE_SE_FRACTION`] of it.
    pub coasting_error_scale: [f64; 4],
    /// On a ride whose speed changes over the window: the window as it was replayed for
    /// `coasting_bias` (the gap stage replays each candidate's bicycle on it).
    pub coasting: Option<CoastingWindow>,
    pub model: ModelWeave,
    /// θ and γ from half a second before the kick to half a second after the window (for
    /// plots): time (s), roll (rad), steer (rad).
    pub trace: Vec<[f64; 3]>,
    /// What the log reader found in the angles file and kept as gaps (dropped packets,
    /// corrupt rows), each naming the file and line.
    pub warnings: Vec<String>,
}

fn ride_err(path: &Path, message: impl Into<String>) -> RideError {
    RideError::Ride {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// Runs the dynamic test of the ride whose angles file is `path` against `model`.
pub fn dynamic_test(
    path: &Path,
    model: &Parametrized,
    options: &DynamicOptions,
) -> Result<DynamicTest, RideError> {
    let nominal = model.nominal();
    let mut signals = read_ride(path, nominal.lambda, 1.5)?;
    let bike = crate::model::nonlinear::NonlinearBicycle::new(&nominal);
    super::speed::remove_pitch_gravity(&mut signals, |roll, steer| bike.pitch(roll, steer));
    let fit = fit_window(path, &signals, &options.modal)?;
    check_sensor_roles(path, &signals, &fit)?;
    let geometry = Geometry {
        wheelbase_m: nominal.w,
        trail_m: nominal.c,
        steer_axis_tilt_rad: nominal.lambda,
    };
    let sources = SpeedSources::collect(&signals, &fit, options.noted, geometry);
    if let Some(why) = sources.contradicted_reading() {
        return Err(ride_err(path, why));
    }
    let Some((source, best)) = sources.best(options.prefer_sync) else {
        return Err(ride_err(
            path,
            "no speed: the log has no `Sync` pulses (or no `Wheel circumference` in its \
             header) over the free motion, and the steer and yaw rate give none; give the \
             speedometer's reading at the release with --speed",
        ));
    };
    let accel = sources.window_accel_mps2;
    let speed = Speed {
        speed_mps: best.speed_mps,
        speed_se_mps: best.se_mps,
        source,
        sources,
    };
    let mut fit = fit;
    let canonical = Canonical::from_benchmark(&nominal).with_control(model.control);
    let window = CoastingWindow::of(&fit, signals.sample_rate_hz, speed.speed_mps, accel);
    let correction = coasting_correction(&canonical, &window).unwrap_or_default();
    let through_speed = correction_through_speed(&canonical, &window, speed.speed_se_mps);
    if fit.drift.is_none() {
        // The drift's fit failed: its error is taken from the model's slope dλ/dv times the
        // speed's change over half the window (what a constant fit can be off by at most).
        let (h, v) = (0.05, speed.speed_mps);
        let measured = Complex::new(fit.weave.re, fit.weave.im);
        if let (Some(a), Some(b)) = (
            weave_near(&canonical, v + h, measured),
            weave_near(&canonical, v - h, measured),
        ) {
            let change = (a - b) / (2.0 * h) * (accel * 0.5 * (fit.end_s - fit.start_s));
            let w = &mut fit.weave;
            w.re_se_drift = change.re.abs();
            w.im_se_drift = change.im.abs();
            w.re_se = w.re_se.hypot(w.re_se_drift);
            w.im_se = w.im_se.hypot(w.im_se_drift);
        }
    }
    let rate = signals.sample_rate_hz;
    // From before the kick to past the window, and the catch when it follows within 5 s.
    let to = (fit.end_s + 0.5).max((signals.catch_s + 0.3).min(fit.end_s + 5.0));
    let (from, to) = (signals.kick_s - 0.5, to);
    let trace = signals
        .index
        .iter()
        .enumerate()
        .map(|(k, &i)| (k, i as f64 / rate))
        .filter(|&(_, t)| t >= from && t <= to)
        .map(|(k, t)| [t, signals.roll_rad[k], signals.steer_rad[k]])
        .collect::<Vec<_>>();
    // The motion's size: the linear model's eigenvalue and mode shape are the small motion's.
    let motion = motion_size_rad2(trace.iter().copied(), fit.start_s, fit.end_s);
    let [re_nl, im_nl, ratio_nl, phase_nl] = nonlinear_se(motion, fit.shape.ratio.value);
    let w = &mut fit.weave;
    w.re_se = w.re_se.hypot(re_nl);
    w.im_se = w.im_se.hypot(im_nl);
    fit.shape.ratio.se = fit.shape.ratio.se.hypot(ratio_nl);
    fit.shape.phase_rad.se = fit.shape.phase_rad.se.hypot(phase_nl);
    // The correction taken off, its own error (see COASTING_BIAS_ERROR_SCALE) and the speed's
    // through it added to each part's.
    let w = &mut fit.weave;
    let sh = &mut fit.shape;
    let parts = [
        (&mut w.re, &mut w.re_se),
        (&mut w.im, &mut w.im_se),
        (&mut sh.ratio.value, &mut sh.ratio.se),
        (&mut sh.phase_rad.value, &mut sh.phase_rad.se),
    ];
    for (k, (value, se)) in parts.into_iter().enumerate() {
        *value -= correction.taken_off[k];
        *se = se
            .hypot(COASTING_RIDE_SE_FRACTION[k] * correction.error_scale[k])
            .hypot(through_speed[k]);
    }
    let model = model_weave(path, model, &speed, &fit.weave)?;
    Ok(DynamicTest {
        path: path.to_path_buf(),
        speed,
        kick_s: signals.kick_s,
        release_s: signals.release_s,
        catch_s: signals.catch_s,
        fit,
        coasting_bias: correction.taken_off,
        coasting_error_scale: correction.error_scale,
        coasting: (accel != 0.0 && correction != CoastingCorrection::default()).then_some(window),
        model,
        trace,
        warnings: signals.log.warnings.clone(),
    })
}

/// The free motion's window and its modal fit: from just after the kick to the catch, the
/// first roll beyond [`MAX_ROLL_RAD`], or where the fitted curve's envelope ([`lost_in_noise`])
/// sinks below three times the residual noise in both signals, whichever comes first. A weave
/// that grows, or a window too short after the castor's tail, gets [`early_window`]'s. A
/// window that ends at the catch runs on past it when the weave had already sunk into the
/// noise there (a quiet bicycle still rolling): the catch is found where the gyros go quiet.
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#fit_window).
fn fit_window(path: &Path, s: &RideSignals, options: &ModalOptions) -> Result<ModalFit, RideError> {
    let rate = s.sample_rate_hz;
    let start = s.kick_s + AFTER_KICK_S;
    let last_sample_s = s.index.last().map_or(0.0, |&i| i as f64 / rate);
    // The last sample before the catch, and whether a window ends there.
    let before_catch = s.catch_s - 0.05;
    let ends_at_catch = |end: f64| (before_catch - end).abs() < 1e-9;
    let mut end = before_catch;
    let mut limit = end;
    end = end.min(start + MAX_WINDOW_S);
    let roll_limit = first_roll_beyond(s, start, MAX_ROLL_RAD).map_or(f64::INFINITY, |t| t - 0.05);
    end = end.min(roll_limit);
    let mut run_on = None;
    let beyond = last_sample_s.min(roll_limit);
    let longest = beyond.min(start + MAX_WINDOW_S);
    if ends_at_catch(end) && longest > end + 0.1 {
        // Whether the weave had died by the catch, from the motion before it alone (from just
        // after the kick, as the early window takes it: a fit that ran on past a hand's catch
        // would bend to the held samples).
        let check = ModalOptions {
            resamples: 0,
            ..*options
        };
        let died = fit_span(s, &check, s.kick_s + EARLY_AFTER_KICK_S, before_catch)
            .is_ok_and(|f| weave_in_noise_at(&f, s.catch_s));
        run_on = died
            .then(|| fit_span(s, options, start, longest).ok())
            .flatten()
            .filter(|f| f.weave.re < 0.0);
        if run_on.is_some() {
            (end, limit) = (longest, beyond);
        }
    }
    let ending = |end: f64| -> String {
        if last_sample_s - end < 0.5 {
            format!("the log ends (at {last_sample_s:.2} s)")
        } else if ends_at_catch(end) {
            format!("the motion stops (caught at {:.2} s)", s.catch_s)
        } else {
            format!("the roll passes {MAX_ROLL_RAD} rad")
        }
    };
    let fit_between =
        |a: f64, b: f64| fit_span(s, options, a, b).map_err(|e| ride_err(path, e.to_string()));
    // What the window after the castor's tail cannot give (`why`), a window from just after
    // the kick may: a weave that grows, or a slow one, has its cycle there.
    let early = |why: String| {
        early_window(s, options)
            .map_err(|early| ride_err(path, format!("{why} (from just after the kick, {early})")))
    };
    if end - start < MIN_WINDOW_S {
        return early(format!(
            "too short: the free motion after the kick (at {:.2} s) lasts {:.2} s before {}; \
             an eigenvalue needs at least {MIN_WINDOW_S} s and {MIN_CYCLES} weave cycles",
            s.kick_s,
            (end - start).max(0.0),
            ending(end),
        ));
    }
    let mut fit = match run_on.map_or_else(|| fit_span(s, options, start, end), Ok) {
        Ok(fit) => fit,
        Err(no_weave) => return early(no_weave.to_string()),
    };
    // A slow weave gets two cycles, even if that takes longer than MAX_WINDOW_S (when they
    // fit).
    (fit, end) = two_cycles(s, options, fit, end, limit);
    if fit.weave.re > 0.0 {
        return early(format!(
            "too short: the weave grows (σ {:+.2} /s, below the weave speed) out of the linear \
             range",
            fit.weave.re
        ));
    }
    let lost = lost_in_noise(&fit);
    if lost < end - 0.3 {
        end = lost.max(start + MIN_WINDOW_S);
        fit = fit_between(start, end)?;
    }
    let cycles = (end - start) * fit.weave.im / std::f64::consts::TAU;
    if cycles < MIN_CYCLES {
        return early(format!(
            "too short: the free motion after the kick (at {:.2} s) holds {cycles:.1} weave \
             cycles ({:.2} s at {:.2} rad/s); an eigenvalue needs at least {MIN_CYCLES}",
            s.kick_s,
            end - start,
            fit.weave.im
        ));
    }
    Ok(fit)
}

/// A weave is lost in the noise where its envelope is within this many times the fit's
/// residual noise ([`lost_in_noise`], [`weave_in_noise_at`]).
const IN_NOISE: f64 = 3.0;

/// Where the fit `fit` sinks into the noise (s): where the envelope of its whole curve (the
/// weave's, taken from the curve's extremes over a quarter period at the reference time, so
/// with the offsets, trends and real modes at that time), decaying at the weave's σ, falls
/// below [`IN_NOISE`] times the residual noise in both signals.
fn lost_in_noise(fit: &ModalFit) -> f64 {
    let at_ref = fit.eval(fit.t_ref_s);
    let quarter = std::f64::consts::FRAC_PI_2 / fit.weave.im;
    let amplitude = [0, 1].map(|c| {
        (0..8)
            .map(|k| fit.eval(fit.t_ref_s + k as f64 * quarter / 4.0)[c].abs())
            .fold(at_ref[c].abs(), f64::max)
    });
    (0..2)
        .map(|c| {
            let ratio = amplitude[c] / (IN_NOISE * fit.residual_rms_rad[c]).max(1e-12);
            fit.t_ref_s + ratio.max(1.0).ln() / -fit.weave.re
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Whether the weave of `fit` alone (not its offsets, trends or real modes) is within
/// [`IN_NOISE`] times the residual noise at `t` (s) in both signals.
fn weave_in_noise_at(fit: &ModalFit, t: f64) -> bool {
    let roll = fit.weave_roll_phasor(t).norm();
    let steer = roll * fit.shape.ratio.value;
    roll < IN_NOISE * fit.residual_rms_rad[0] && steer < IN_NOISE * fit.residual_rms_rad[1]
}

/// The window of a weave that grows or is slow: from [`EARLY_AFTER_KICK_S`] after the kick
/// (the castor mode and the kick's tail fitted as real modes rather than waited out) until the roll
/// passes [`EARLY_MAX_ROLL_RAD`], the catch, or two weave cycles; at least
/// [`EARLY_MIN_CYCLES`] cycles. `Err` says, for the caller's message, why there is no such
/// window. At least one real mode is fitted, where that fit succeeds: under a faint weave the
/// information criterion would leave the castor's tail out (30 rides at 4.5 m/s kicked at 15 N
/// and caught 1.6 s later: ω's mean normalized error −0.80 with the criterion's choice, −0.25
/// with a real mode; σ's +0.77 and +0.69).
fn early_window(s: &RideSignals, options: &ModalOptions) -> Result<ModalFit, WindowError> {
    let start = s.kick_s + EARLY_AFTER_KICK_S;
    let limit = first_roll_beyond(s, start, EARLY_MAX_ROLL_RAD)
        .map_or(s.catch_s, |t| t.min(s.catch_s))
        - 0.05;
    let end = limit.min(start + MAX_WINDOW_S);
    let short = |end: f64, omega: Option<f64>| WindowError::EarlyTooShort {
        span_s: (end - start).max(0.0),
        cycles: omega.map(|w| (end - start).max(0.0) * w / std::f64::consts::TAU),
    };
    if end - start < MIN_WINDOW_S {
        return Err(short(end, None));
    }
    // The castor's tail is in this window whether or not the noise lets the information
    // criterion see it (a faint weave's): at least one real mode, or none where that fails.
    let with_castor = ModalOptions {
        min_real_modes: 1,
        ..*options
    };
    let (fit, used) = fit_span(s, &with_castor, start, end)
        .map(|f| (f, &with_castor))
        .or_else(|_| fit_span(s, options, start, end).map(|f| (f, options)))?;
    let (fit, end) = two_cycles(s, used, fit, end, limit);
    if (end - start) * fit.weave.im / std::f64::consts::TAU < EARLY_MIN_CYCLES {
        return Err(short(end, Some(fit.weave.im)));
    }
    Ok(fit)
}

/// `fit` (of a window ending at `end`) refitted over two weave cycles, up to `limit` (s), when
/// two cycles take longer and their fit succeeds; the fit and its window's end.
fn two_cycles(
    s: &RideSignals,
    options: &ModalOptions,
    fit: ModalFit,
    end: f64,
    limit: f64,
) -> (ModalFit, f64) {
    let two = fit.start_s + 2.0 * std::f64::consts::TAU / fit.weave.im;
    if two > end && limit > end + 0.1 {
        let longer = two.min(limit);
        if let Ok(f) = fit_span(s, options, fit.start_s, longer) {
            return (f, longer);
        }
    }
    (fit, end)
}

/// The modal fit of θ and γ between `a` and `b` (s); `Err` says why there is none.
fn fit_span(
    s: &RideSignals,
    options: &ModalOptions,
    a: f64,
    b: f64,
) -> Result<ModalFit, WindowError> {
    let rate = s.sample_rate_hz;
    let (mut t, mut roll, mut steer) = (Vec::new(), Vec::new(), Vec::new());
    for (k, &i) in s.index.iter().enumerate() {
        let ti = i as f64 / rate;
        if ti >= a && ti <= b {
            t.push(ti);
            roll.push(s.roll_rad[k]);
            steer.push(s.steer_rad[k]);
        }
    }
    fit_modes(&t, &roll, &steer, options).map_err(|e| match e {
        ModalError::TooShort(samples) => WindowError::TooFewSamples {
            samples,
            from_s: a,
            to_s: b,
        },
        ModalError::NoWeave => WindowError::NoWeave { from_s: a, to_s: b },
    })
}

/// Why a window of a ride gives no fit: said in the ride's error.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
enum WindowError {
    #[error(
        "too short: only {samples} samples between {from_s:.2} and {to_s:.2} s after the gaps"
    )]
    TooFewSamples {
        samples: usize,
        from_s: f64,
        to_s: f64,
    },
    #[error(
        "no weave: roll and steer between {from_s:.2} and {to_s:.2} s show no oscillation that \
         fits"
    )]
    NoWeave { from_s: f64, to_s: f64 },
    /// The early window ([`early_window`]): its length (s) and, where a fit gave ω, its
    /// weave cycles.
    #[error(
        "its roll passes {EARLY_MAX_ROLL_RAD} rad, where the linear model no longer holds, \
         {span_s:.2} s after the kick's tail{}; that window needs at least {MIN_WINDOW_S} s \
         and {EARLY_MIN_CYCLES} cycle",
        cycles.map_or(String::new(), |c| format!(" ({c:.1} weave cycles)"))
    )]
    EarlyTooShort { span_s: f64, cycles: Option<f64> },
}

/// What the speed's own error `speed_se_mps` makes of a coasting ride's correction
/// ([`coasting_correction`], made at the reported speed): its change between the speed ± that
/// error, halved, `[re, im, |γ/θ|, arg]`; zeros where either fails. Near the weave speed the
/// correction is erratic in the speed, and a correction taken at a speed off by its error is
/// off by this: the ride's error carries it beside the correction's own
/// ([`COASTING_RIDE_SE_FRACTION`]).
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#correction_through_speed).
pub fn correction_through_speed(
    model: &impl LinearWeave,
    window: &CoastingWindow,
    speed_se_mps: f64,
) -> [f64; 4] {
    let at = |dv: f64| {
        let mut w = *window;
        w.speed_mps += dv;
        coasting_correction(model, &w).map(|c| c.taken_off)
    };
    if !(speed_se_mps.is_finite() && speed_se_mps > 0.0) {
        return [0.0; 4];
    }
    match (at(speed_se_mps), at(-speed_se_mps)) {
        (Some(a), Some(b)) => std::array::from_fn(|k| {
            let d = 0.5 * (a[k] - b[k]).abs();
            if d.is_finite() {
                d
            } else {
                0.0
            }
        }),
        _ => [0.0; 4],
    }
}

/// The standard errors a motion of size m puts on a ride's fit, per rad² of m
/// ([`motion_size_rad2`]): `[σ (1/s), ω (1/s), |γ/θ| (a fraction of it), arg γ/θ (rad)]`.
/// The Whipple bicycle's equations are odd in lean and steer, so a large motion's eigenvalue
/// and shape differ from the small motion's by about κ m; these are a ride's own share of κ
/// (its scatter from ride to ride), the nonlinear bicycle's as simulated. The part a
/// campaign's rides share is the gap stage's ([`crate::gap::NONLINEAR_COMMON_FACTOR`]).
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#nonlinear_se_per_rad2).
pub const NONLINEAR_SE_PER_RAD2: [f64; 4] = [0.5, 0.5, 0.05, 0.03];

/// The motion's size over `[from_s, to_s]` of samples `[t (s), roll (rad), steer (rad)]`: the
/// largest roll squared plus the largest steer squared (rad²).
pub fn motion_size_rad2(samples: impl Iterator<Item = [f64; 3]>, from_s: f64, to_s: f64) -> f64 {
    let [roll, steer] = samples
        .filter(|r| (from_s..=to_s).contains(&r[0]))
        .fold([0.0f64; 2], |m, r| {
            [m[0].max(r[1].abs()), m[1].max(r[2].abs())]
        });
    roll * roll + steer * steer
}

/// The standard errors of a fit's `[σ, ω, |γ/θ|, arg γ/θ]` from the motion's size `m` (rad²)
/// ([`NONLINEAR_SE_PER_RAD2`]), the mode shape's ratio being `ratio`.
pub fn nonlinear_se(m: f64, ratio: f64) -> [f64; 4] {
    let k = NONLINEAR_SE_PER_RAD2;
    [k[0] * m, k[1] * m, k[2] * m * ratio.abs(), k[3] * m]
}

/// The roll (rad) with its time (s), sample by sample.
fn roll_series(s: &RideSignals) -> impl Iterator<Item = (f64, f64)> + '_ {
    let rate = s.sample_rate_hz;
    s.index
        .iter()
        .zip(&s.roll_rad)
        .map(move |(&i, &r)| (i as f64 / rate, r))
}

/// When the roll first exceeds `limit_rad` in size after `start_s` (s), if it does.
fn first_roll_beyond(s: &RideSignals, start_s: f64, limit_rad: f64) -> Option<f64> {
    roll_series(s)
        .find(|&(t, r)| t > start_s && r.abs() > limit_rad)
        .map(|(t, _)| t)
}

/// The size a coasting ride's eigenvalue bias is counted in, as a fraction of
/// [`replay_coasting`]'s `[re, im]`; none of the replay is taken off the eigenvalue. The rigid-wheeled
/// replay overstates the bias on tyres (the true one was half of it on knife edges, a tenth of the
/// opposite sign with tyres and damping), and the ride stage cannot know which bicycle it has: a
/// quarter, carried as error, leaves both kinds of ride within their errors. The fit's standard
/// error holds the whole of it ([`COASTING_RIDE_SE_FRACTION`]). The rides and campaigns behind it:
/// [docs/decisions/constants.md](../../docs/decisions/constants.md#coasting_bias_error_scale).
pub const COASTING_BIAS_ERROR_SCALE: f64 = 0.25;
/// The standard error of a correction the ride stage takes, as a fraction of it: the mode
/// shape's (its replay taken off in full), and the gap stage's shifts of a candidate's
/// replay ([`crate::gap::coasting`]).
pub const COASTING_BIAS_SE_FRACTION: f64 = 0.5;
/// The standard error a ride keeps for its coasting correction (`bikeproc dynamic`), per part
/// `[re, im, |γ/θ|, arg]`, as a fraction of its error scale
/// ([`CoastingCorrection::error_scale`]): the whole scale for the eigenvalue, of which nothing
/// is taken off (its bias lies from about −0.1 to +0.54 of the replay, tyres to knife-edge
/// wheels); [`COASTING_BIAS_SE_FRACTION`] of what is taken off for the shape. The gap stage
/// replaces it by a part common to a campaign's rides ([`COASTING_BIAS_COMMON_FRACTION`]) and
/// a part each keeps ([`COASTING_BIAS_OWN_FRACTION`]).
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#coasting_ride_se_fraction).
pub const COASTING_RIDE_SE_FRACTION: [f64; 4] = [
    1.0,
    1.0,
    COASTING_BIAS_SE_FRACTION,
    COASTING_BIAS_SE_FRACTION,
];
/// The common part of the coasting correction's error across one campaign's rides, as a
/// fraction of each ride's correction: the tyres and damping the rides share decide the bias,
/// which lies at about +1.2 and −1.4 of the correction at the two ends simulated (knife-edge
/// wheels; tyres and damping): 0.7 holds both within two of its standard deviations and keeps
/// the effect-free campaigns quiet.
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#coasting_bias_common_fraction).
pub const COASTING_BIAS_COMMON_FRACTION: f64 = 0.7;
/// The part of the coasting correction's error each ride keeps as its own beside the common
/// one, as a fraction of its correction: near the weave speed the correction is erratic in the
/// speed and the bicycle, so a large correction there is not one error shared with the other
/// rides. None kept tied the slow rides' phases and raised the effect-free campaigns' false
/// alarms; 0.3 left their p-values flat.
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#coasting_bias_own_fraction).
pub const COASTING_BIAS_OWN_FRACTION: f64 = 0.3;

/// How much of [`replay_coasting`]'s mode-shape part is taken off the fitted shape. The fit holds
/// the shape constant over a window in which the slowing bicycle's shape changes; the replay
/// gives what that does. On 10 effect-free noted campaigns (140 coasting rides at 0.05–0.24
/// m/s², knife-edge wheels) the shape's residual |γ/θ| was −0.0100 ± 0.0030 and the replay's
/// −0.0100 on average: fitted to such campaigns, a sensor clock came out 1.25 of its standard
/// errors low (median of 12), the front frame's I_xx 0.6 low.
pub const COASTING_SHAPE_APPLIED: f64 = 1.0;
/// A coasting ride's correction ([`coasting_correction`]): what is taken off its fit, and the
/// size its error is counted in, each `[re (1/s), im (1/s), |γ/θ|, arg γ/θ (rad)]`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CoastingCorrection {
    /// Taken off: the mode shape's part of the replay ([`COASTING_SHAPE_APPLIED`]) and the
    /// slowing bicycle's own change of its shape ([`accel_shape_shift`]); zero in the
    /// eigenvalue.
    pub taken_off: [f64; 4],
    /// The eigenvalue's part: [`COASTING_BIAS_ERROR_SCALE`] of the replay; the shape's: what is
    /// taken off. The ride's standard errors hold [`COASTING_RIDE_SE_FRACTION`] of it; the gap
    /// stage's common and own parts are fractions of it too.
    pub error_scale: [f64; 4],
}

/// A coasting ride's fit as its replay needs it ([`replay_coasting`]): the window (s), the
/// time the fit's eigenvalue applies at, the sampling rate, the fit's structure, the speed at
/// `t_ref_s` (m/s) and the forward acceleration (m/s²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoastingWindow {
    pub start_s: f64,
    pub end_s: f64,
    pub t_ref_s: f64,
    pub rate_hz: f64,
    pub structure: Structure,
    /// The fit's model and solver, which its replay's fit repeats.
    pub estimator: Estimator,
    pub speed_mps: f64,
    pub accel_mps2: f64,
    /// The measured weave (1/s), which picks the model's branch.
    pub measured: Complex<f64>,
    /// The fit's weave in θ at the window's start as a phasor (rad, [`ModalFit::weave_roll_phasor`])
    /// and its real modes there (`[θ, γ, θ̇, γ̇]`, [`ModalFit::real_modes_state`]): where
    /// [`ReplayStart::Fitted`] starts.
    pub weave_start: Complex<f64>,
    pub real_start: [f64; 4],
    /// The fit's real modes' rates (1/s; 0 beyond its count): where the replay's fit starts.
    pub real_rates: [f64; MAX_REAL_MODES],
}

/// About this many samples over the window in a [`ReplayStart::Fitted`] replay.
const REPLAY_SAMPLES: f64 = 80.0;

/// Where a replay ([`replay_coasting`]) starts its free motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReplayStart {
    /// On the model's weave alone: the ride stage's correction, whose error's size
    /// ([`COASTING_BIAS_ERROR_SCALE`]) was measured with this start.
    Weave,
    /// Where the ride's fit says the motion began: its weave (the model's mode shape, the
    /// fit's amplitude and phase in θ) and its real modes as fitted. On a damped bicycle's
    /// coasting rides whose fit holds real modes, σ is read 0.13–0.15 1/s too damped, and only
    /// a replay that carries those modes shows it (issue 29; [`crate::gap::coasting`]).
    Fitted,
}

impl CoastingWindow {
    /// The window of `fit` on a ride sampled at `rate_hz` whose speed at the fit's reference
    /// time is `speed_mps`, changing at `accel_mps2`.
    pub fn of(fit: &ModalFit, rate_hz: f64, speed_mps: f64, accel_mps2: f64) -> CoastingWindow {
        CoastingWindow {
            start_s: fit.start_s,
            end_s: fit.end_s,
            t_ref_s: fit.t_ref_s,
            rate_hz,
            structure: fit.structure,
            estimator: fit.estimator,
            speed_mps,
            accel_mps2,
            measured: Complex::new(fit.weave.re, fit.weave.im),
            weave_start: fit.weave_roll_phasor(fit.start_s),
            real_start: fit.real_modes_state(fit.start_s),
            real_rates: std::array::from_fn(|k| fit.real_modes.get(k).map_or(0.0, |r| r.value)),
        }
    }
}

/// A coasting ride's correction on `model` ([`CoastingCorrection`]), from its replay from the
/// model's weave ([`replay_coasting`], [`ReplayStart::Weave`]) and the slowing bicycle's own
/// mode shape less the one at constant speed ([`accel_shape_shift`]). What is left once
/// `taken_off` is off the fit is to be compared with the model at constant speed. `None` when
/// the model has no weave there; a replay that fails leaves the shift alone.
pub fn coasting_correction(
    model: &impl LinearWeave,
    w: &CoastingWindow,
) -> Option<CoastingCorrection> {
    let shift = accel_shape_shift(model, w)?;
    let replay = replay_coasting(model, w, ReplayStart::Weave).unwrap_or([0.0; 4]);
    let shape = |a: usize| COASTING_SHAPE_APPLIED * replay[a] + shift[a];
    Some(CoastingCorrection {
        taken_off: [0.0, 0.0, shape(2), shape(3)],
        error_scale: [
            COASTING_BIAS_ERROR_SCALE * replay[0],
            COASTING_BIAS_ERROR_SCALE * replay[1],
            shape(2),
            shape(3),
        ],
    })
}

/// What the window's acceleration does to `model`'s mode shape at the window's speed: the
/// shape of the bicycle slowing at v̇ (its stiffness `g K₀ + v² K₂ + v̇ K_a`,
/// [`Canonical::ka`]) less the one at constant speed, as `[0, 0, |γ/θ|, arg γ/θ]` (the
/// corrections' layout). Only the shape's part is taken: the eigenvalue's part of the same
/// `v̇ K_a` overstates what the lab's resistances do to σ and ω, whose lateral forces take part
/// of it back. `None` when the model has no weave there.
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#accel_shape_shift).
pub fn accel_shape_shift<M: LinearWeave>(model: &M, w: &CoastingWindow) -> Option<[f64; 4]> {
    let shape = |m: M| Some(m.weave_shape(w.speed_mps, w.measured)?.1);
    let still = shape(model.accelerating(0.0))?;
    let slowing = shape(model.accelerating(w.accel_mps2))?;
    let d = [
        0.0,
        0.0,
        slowing.norm() - still.norm(),
        crate::signal::wrap_pi(slowing.arg() - still.arg()),
    ];
    d.iter().all(|x| x.is_finite()).then_some(d)
}

/// What a coasting bicycle's changing speed does to the fitted eigenvalue, beyond the drift
/// the fit reads at `t_ref`: the mode shape changes with the speed, and the slow (adiabatic)
/// change of the mode's amplitude in θ and in γ, `ċ/c = −wᵀ(∂v/∂t)/(wᵀv)` (w, v the left and
/// right eigenvectors), reads as a shift of σ and ω that the frozen eigenvalue does not have.
/// Measured on the model: the linear bicycle `ẋ = A(v(t)) x` (Meijaard et al. 2007, eq. 59 of
/// the seed, the speed `v(t) = v_ref + a (t − t_ref)`), started on its weave, integrated (RK4)
/// over the fit's window and fitted by the same modal fit (the ride's structure: the same real
/// modes and trends); the fitted eigenvalue less the
/// frozen one at the speed where that fit applies is the bias (1/s, `[re, im]`), and the
/// fitted mode shape less the frozen one's (`[|γ/θ|, arg γ/θ (rad)]`). Both the run and the
/// frozen weave are the slowing bicycle's (`A(v, v̇)`, [`Canonical::ka`]): what v̇ does to the
/// frozen mode shape itself is [`accel_shape_shift`]. `None` when the model has no weave there or
/// the fit fails. `model` is any linear bicycle: the gap stage replays each candidate's.
pub fn replay_coasting(
    model: &impl LinearWeave,
    w: &CoastingWindow,
    from: ReplayStart,
) -> Option<[f64; 4]> {
    let model = &model.accelerating(w.accel_mps2);
    let speed_at = |t: f64| w.speed_mps + w.accel_mps2 * (t - w.t_ref_s);
    let (start_weave, start) = model.weave_mode(speed_at(w.start_s), w.measured)?;
    let states = model.angle_states();
    let [roll_state, steer_state, ..] = states;
    let mut x = match from {
        ReplayStart::Weave => start.map(|z| z.re),
        ReplayStart::Fitted => {
            let scale = w.weave_start / start[roll_state];
            let mut x = start.map(|z| (z * scale).re);
            for (&s, r) in states.iter().zip(w.real_start) {
                x[s] += r;
            }
            x
        }
    };
    if x.iter().any(|v| !v.is_finite()) {
        return None;
    }
    // The state matrix at a time; each RK4 step needs it at its start, middle and end, and the
    // end's is the next step's start: two matrices a step instead of four (the same values).
    let a_at = |t: f64| model.state_matrix_at(speed_at(t));
    // The gap stage's replays (many per campaign) are sampled more sparsely, at about
    // REPLAY_SAMPLES over the window: the least-squares fit of a smooth, noise-free motion
    // hardly depends on it.
    let rate_hz = match from {
        ReplayStart::Weave => w.rate_hz,
        ReplayStart::Fitted => {
            let every = ((w.end_s - w.start_s) * w.rate_hz / REPLAY_SAMPLES)
                .floor()
                .max(1.0);
            w.rate_hz / every
        }
    };
    let sub = 4;
    let h = 1.0 / (rate_hz * sub as f64);
    let n = ((w.end_s - w.start_s) * rate_hz).floor() as usize + 1;
    let (mut ts, mut roll, mut steer) = (Vec::new(), Vec::new(), Vec::new());
    // A whisper of noise keeps the fit's noise levels and information criterion finite:
    // uniform, seeded, of standard deviation 1e-7 rad.
    let mut rng = <rand_xoshiro::Xoshiro256StarStar as rand::SeedableRng>::seed_from_u64(17);
    let mut whisper = || {
        let u: f64 = rand::RngExt::random(&mut rng);
        1e-7 * 12f64.sqrt() * (u - 0.5)
    };
    let mut t = w.start_s;
    let mut a_start = a_at(t)?;
    for k in 0..n {
        if k > 0 {
            for _ in 0..sub {
                let a_mid = a_at(t + 0.5 * h)?;
                let a_end = a_at(t + h)?;
                let k1 = &a_start * &x;
                let k2 = &a_mid * &(&x + &k1 * (0.5 * h));
                let k3 = &a_mid * &(&x + &k2 * (0.5 * h));
                let k4 = &a_end * &(&x + &k3 * h);
                x += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
                t += h;
                a_start = a_end;
            }
        }
        ts.push(w.start_s + k as f64 / rate_hz);
        roll.push(x[roll_state] + whisper());
        steer.push(x[steer_state] + whisper());
    }
    // The ride's structure first; the model's weave alone excites no real mode, so where the
    // ride's real modes make that fit fail (a fifth of coasting rides at 4–4.5 m/s, whose σ
    // then went uncorrected and came out 2–4 standard errors high), the weave alone.
    let start = (from == ReplayStart::Fitted).then_some(Start {
        weave: [start_weave.re, start_weave.im],
        real_rates: w.real_rates,
    });
    let sim = refit_as(&ts, &roll, &steer, w.structure, start, w.estimator)?;
    let v_ref = speed_at(sim.t_ref_s);
    let (frozen, ratio) = model.weave_shape(v_ref, w.measured)?;
    Some([
        sim.weave.re - frozen.re,
        sim.weave.im - frozen.im,
        sim.shape.ratio.value - ratio.norm(),
        crate::signal::wrap_pi(sim.shape.phase_rad.value - ratio.arg()),
    ])
}

/// Which sensor is where, from kinematics alone: rolling without (much) slip, the frame turns
/// at ψ̇ = (v γ + c γ̇) cos λ / w, so its heading rate follows γ with a small γ̇ part
/// (c/w ≈ 0.05); the handlebar turns at that plus γ̇ cos λ. Regressing the "frame" sensor's
/// heading rate on γ and γ̇ gives a γ̇ coefficient near 0 when the labels are right and near
/// ±1 when they are exchanged (γ then comes out with its sign flipped; the heading's sign
/// depends on the sensors' axis convention, hence the magnitude). Measured: 0.04 on a correct
/// ride, 0.86 on the swapped fixture.
fn check_sensor_roles(path: &Path, s: &RideSignals, fit: &ModalFit) -> Result<(), RideError> {
    let rate = s.sample_rate_hz;
    let idx: Vec<usize> = (2..s.index.len().saturating_sub(2))
        .filter(|&k| {
            let t = s.index[k] as f64 / rate;
            t >= fit.start_s && t <= fit.end_s && s.index[k + 2] - s.index[k - 2] == 4
        })
        .collect();
    if idx.len() < 20 {
        return Ok(());
    }
    let smooth = |x: &[f64], k: usize| (x[k - 1] + x[k] + x[k + 1]) / 3.0;
    let rate_of = |x: &[f64], k: usize| (smooth(x, k + 1) - smooth(x, k - 1)) * rate / 2.0;
    let mut ata = nalgebra::Matrix3::<f64>::zeros();
    let mut atb = nalgebra::Vector3::<f64>::zeros();
    for &k in &idx {
        let row = nalgebra::Vector3::new(1.0, smooth(&s.steer_rad, k), rate_of(&s.steer_rad, k));
        ata += row * row.transpose();
        atb += row * rate_of(&s.heading_rad, k);
    }
    let Some(sol) = ata.cholesky().map(|c| c.solve(&atb)) else {
        return Ok(());
    };
    if sol[2].abs() > 0.5 {
        return Err(ride_err(
            path,
            format!(
                "sensors swapped: the sensor labelled `frame` turns with the steer rate \
                 (heading rate = {:.2}·γ {:+.2}·γ̇; the frame's own has a γ̇ part near 0, the \
                 handlebar's near ±1); exchange the `frame` and `handlebar` labels in the header",
                sol[1], sol[2]
            ),
        ));
    }
    Ok(())
}

/// The model's weave at the ride's speed, its standard error (parameters, and the speed's
/// through dλ/dv), and the experiment's distance from it in combined standard errors.
fn model_weave(
    path: &Path,
    model: &Parametrized,
    speed: &Speed,
    exp: &Eigenvalue,
) -> Result<ModelWeave, RideError> {
    model_weave_at(path, model, speed.speed_mps, speed.speed_se_mps, exp)
}

/// What a campaign's ride gave: a log's dynamic test, or one free decay of a CSV ride.
#[derive(Debug, Clone)]
pub enum Analysed {
    Log(Box<DynamicTest>),
    Csv(Box<super::csv::DecaySummary>),
}

/// One ride of a campaign, analysed: a CSV ride with several kicks gives one per kick, named
/// `name#k`.
#[derive(Debug)]
pub struct CampaignRide {
    pub name: String,
    pub result: Result<Analysed, RideError>,
}

impl CampaignRide {
    /// The log's dynamic test, when this is a log ride that gave one.
    pub fn test(&self) -> Option<&DynamicTest> {
        match &self.result {
            Ok(Analysed::Log(t)) => Some(t),
            _ => None,
        }
    }
}

/// A campaign's rides as `bikeproc dynamic rides.toml` gives them: each ride's summary and the
/// rides that gave none with the reason. Its JSON is the command's `--json`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CampaignSummary {
    /// The bicycle file the rides were compared with.
    pub bike: String,
    pub rides: Vec<RideSummary>,
    /// `ride: reason` of each ride that gave no eigenvalue.
    pub failures: Vec<String>,
}

/// One ride's summary in a campaign: a log's dynamic test or a CSV ride's free decay.
#[derive(Debug, Clone, serde::Serialize)]
#[serde(untagged)]
pub enum RideSummary {
    Log(Box<Summary>),
    Csv(Box<super::csv::DecaySummary>),
}

impl CampaignSummary {
    /// The summaries of a campaign's analysed rides ([`run_campaign`]) against `bike`.
    pub fn new(bike: &Path, results: &[CampaignRide]) -> Self {
        let mut rides = Vec::new();
        let mut failures = Vec::new();
        for r in results {
            match &r.result {
                Ok(Analysed::Log(t)) => rides.push(RideSummary::Log(Box::new(t.summary()))),
                Ok(Analysed::Csv(d)) => rides.push(RideSummary::Csv(d.clone())),
                Err(e) => failures.push(format!("{}: {e}", r.name)),
            }
        }
        CampaignSummary {
            bike: bike.display().to_string(),
            rides,
            failures,
        }
    }

    /// Every ride's summary, then the rides not analysed.
    pub fn to_text(&self) -> String {
        let mut text: String = self
            .rides
            .iter()
            .map(|r| match r {
                RideSummary::Log(s) => s.to_text() + "\n",
                RideSummary::Csv(d) => d.to_text() + "\n",
            })
            .collect();
        for f in &self.failures {
            text += &format!("not analysed: {f}\n");
        }
        text
    }
}

/// The bicycle of a ride given without one: the `lab_bike.toml` beside its log, or the bicycle
/// of the campaign manifest (`rides.toml`) beside it.
pub fn bike_beside(ride: &Path) -> Result<PathBuf, ManifestError> {
    // A ride that cannot be read is that, not a missing bicycle.
    if let Err(e) = std::fs::metadata(ride) {
        return Err(ManifestError {
            path: ride.to_path_buf(),
            line: None,
            message: format!("cannot read: {e}"),
        });
    }
    let dir = ride.parent().unwrap_or(Path::new(""));
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let lab = dir.join("lab_bike.toml");
    if lab.is_file() {
        return Ok(lab);
    }
    let manifest = dir.join("rides.toml");
    if manifest.is_file() {
        return Ok(RideManifest::load(&manifest)?.bike_path());
    }
    Err(ManifestError {
        path: ride.to_path_buf(),
        line: None,
        message: format!(
            "no bicycle to compare with: give --bike (there is no lab_bike.toml or rides.toml in {})",
            dir.display()
        ),
    })
}

/// `bikeproc dynamic rides.toml`: every ride of `manifest` analysed against the bicycle file
/// `bike` (with the manifest's controller), summarized; `progress(done, total)` after each.
pub fn campaign_summary(
    manifest: &RideManifest,
    bike: &Path,
    modal: &ModalOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<CampaignSummary, crate::model::ParamError> {
    let model = manifest.model(Some(bike))?;
    let results = run_campaign(manifest, &model, modal, progress);
    Ok(CampaignSummary::new(bike, &results))
}

/// Runs every ride of a campaign in parallel (rayon's threads), calling `progress` with
/// the number done after each; results in the manifest's order (a CSV ride's kicks in time
/// order).
pub fn run_campaign(
    manifest: &RideManifest,
    model: &Parametrized,
    modal: &ModalOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Vec<CampaignRide> {
    let run = |i: usize| -> Vec<CampaignRide> {
        let ride = &manifest.rides[i];
        let given = ride.given_speed(manifest);
        let path = manifest.dir.join(&ride.log);
        let name = ride.name();
        if ride.is_csv(&manifest.dir) {
            return csv_campaign_ride(&path, &name, ride, given, model, modal);
        }
        // An IMU log's ride has its noted reading (the manifest's reader requires it).
        let options = DynamicOptions {
            noted: given.map(|g| g.reading),
            prefer_sync: true,
            modal: *modal,
        };
        vec![CampaignRide {
            name,
            result: dynamic_test(&path, model, &options).map(|t| Analysed::Log(Box::new(t))),
        }]
    };
    use rayon::prelude::*;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let n = manifest.rides.len();
    let per_ride: Vec<Option<Vec<CampaignRide>>> = (0..n)
        .into_par_iter()
        .map(|i| {
            // A ride whose analysis panics (a defect) is reported as failed; the others stand.
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run(i))).ok();
            progress(
                done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1,
                n,
            );
            r
        })
        .collect();
    per_ride
        .into_iter()
        .enumerate()
        .flat_map(|(i, r)| {
            r.unwrap_or_else(|| {
                vec![CampaignRide {
                    name: manifest.rides[i].name(),
                    result: Err(ride_err(
                        &manifest.rides[i].log,
                        "the analysis thread stopped before this ride",
                    )),
                }]
            })
        })
        .collect()
}

/// A campaign's CSV ride: its decay, or one per kick of a long recording.
fn csv_campaign_ride(
    path: &Path,
    name: &str,
    ride: &RideEntry,
    given: Option<GivenSpeed>,
    model: &Parametrized,
    modal: &ModalOptions,
) -> Vec<CampaignRide> {
    let columns = ride
        .columns
        .as_deref()
        .map_or(Ok(Default::default()), str::parse::<super::csv::Columns>)
        .map_err(|e| ride_err(path, format!("columns: {e}")));
    let decays = columns.and_then(|c| {
        super::csv::ride_decays_file(
            path,
            &c,
            ride.rate_hz,
            ride.window_s.map(|[a, b]| (a, b)),
            given,
            Some(model),
            modal,
        )
    });
    match decays {
        Err(e) => vec![CampaignRide {
            name: name.to_string(),
            result: Err(e),
        }],
        Ok(list) => {
            let several = list.len() > 1;
            list.into_iter()
                .enumerate()
                .map(|(k, d)| CampaignRide {
                    name: if several {
                        format!("{name}#{}", k + 1)
                    } else {
                        name.to_string()
                    },
                    result: match (d.decay, d.not_fitted) {
                        (Some(s), _) => Ok(Analysed::Csv(Box::new(s))),
                        (None, why) => Err(ride_err(
                            path,
                            format!("kick at {:.2} s: {}", d.kick.at_s, why.unwrap_or_default()),
                        )),
                    },
                })
                .collect()
        }
    }
}

/// What `bikeproc dynamic` prints for one ride (`--json`), in SI units.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Summary {
    pub file: String,
    pub speed_mps: f64,
    pub speed_se_mps: f64,
    pub speed_source: SpeedSource,
    /// Every source of the speed, and where they disagree.
    pub speed_sources: SpeedSources,
    /// Where the eigenvalue applies (s, in the log): the window's amplitude-weighted time
    /// (see [`super::modal`]).
    pub applies_at_s: f64,
    /// The kick's peak and the window fitted (s, in the log).
    pub kick_s: f64,
    pub window_s: [f64; 2],
    pub weave: Eigenvalue,
    /// The eigenvalue's drift over the window (`None`: its fit failed).
    pub weave_drift: Option<super::modal::Drift>,
    /// Real modes beside the weave (1/s).
    pub real_modes: Vec<crate::fit::Estimate>,
    pub mode_shape: super::modal::ModeShape,
    /// Variance accounted for, roll and steer (0–1).
    pub vaf: Vaf,
    pub residual_rms_rad: [f64; 2],
    pub model_weave: ModelWeave,
}

/// Variance accounted for by the fit, per signal.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Vaf {
    pub roll: f64,
    pub steer: f64,
}

impl DynamicTest {
    pub fn summary(&self) -> Summary {
        let f = &self.fit;
        Summary {
            file: self.path.display().to_string(),
            speed_mps: self.speed.speed_mps,
            speed_se_mps: self.speed.speed_se_mps,
            speed_source: self.speed.source,
            speed_sources: self.speed.sources.clone(),
            applies_at_s: f.t_ref_s,
            kick_s: self.kick_s,
            window_s: [f.start_s, f.end_s],
            weave: f.weave,
            weave_drift: f.drift,
            real_modes: f.real_modes.clone(),
            mode_shape: f.shape,
            vaf: Vaf {
                roll: f.vaf[0],
                steer: f.vaf[1],
            },
            residual_rms_rad: f.residual_rms_rad,
            model_weave: self.model,
        }
    }
}

impl Summary {
    /// The human-readable form.
    pub fn to_text(&self) -> String {
        let w = &self.weave;
        let m = &self.model_weave;
        let mut out = format!("{}\n", self.file);
        let source = match self.speed_source {
            SpeedSource::Noted => "the noted reading carried to it",
            SpeedSource::Sync => "the reed switch",
            SpeedSource::Kinematic => "the yaw rate against the steer",
            SpeedSource::WheelSpeed => "the wheel-speed column",
            SpeedSource::Set => "the speed the lab set",
        };
        out += &format!(
            "  speed            {:.3} ± {:.3} m/s at t = {:.2} s, from {source}\n",
            self.speed_mps, self.speed_se_mps, self.applies_at_s
        );
        out += &self.speed_sources.to_text();
        out += &format!(
            "  window           {:.2} – {:.2} s (the kick at {:.2} s)\n",
            self.window_s[0], self.window_s[1], self.kick_s
        );
        out += &format!(
            "  weave            {:.4} ± {:.4} {:+.4} ± {:.4} i  1/s\n",
            w.re, w.re_se, w.im, w.im_se
        );
        out += &format!(
            "    its errors     noise {:.4}, {:.4} (resampled {:.4}, {:.4}); drift {:.4}, {:.4}\n",
            w.re_se_noise,
            w.im_se_noise,
            w.re_se_resampled,
            w.im_se_resampled,
            w.re_se_drift,
            w.im_se_drift
        );
        match &self.weave_drift {
            Some(d) => {
                out += &format!(
                    "    drift          dσ/dt {:.3} ± {:.3}, dω/dt {:.3} ± {:.3}  1/s²\n",
                    d.sigma_rate.value, d.sigma_rate.se, d.omega_rate.value, d.omega_rate.se
                )
            }
            None => out += "    drift          not measured (its fit failed)\n",
        }
        for r in &self.real_modes {
            out += &format!("  real mode        {:.3} ± {:.3}  1/s\n", r.value, r.se);
        }
        out += &format!(
            "  mode shape γ/θ   |{:.3} ± {:.3}|, phase {:.1} ± {:.1}°  (model {:.3}, {:.1}°)\n",
            self.mode_shape.ratio.value,
            self.mode_shape.ratio.se,
            self.mode_shape.phase_rad.value.to_degrees(),
            self.mode_shape.phase_rad.se.to_degrees(),
            m.shape_ratio,
            m.shape_phase_rad.to_degrees()
        );
        out += &format!(
            "  fit              VAF roll {:.2} %, steer {:.2} %; residual RMS {:.2} / {:.2} mrad\n",
            100.0 * self.vaf.roll,
            100.0 * self.vaf.steer,
            1e3 * self.residual_rms_rad[0],
            1e3 * self.residual_rms_rad[1]
        );
        out += &format!(
            "  model {:<11}{:.4} ± {:.4} {:+.4} ± {:.4} i  1/s\n",
            m.mode.label(),
            m.re,
            m.re_se,
            m.im,
            m.im_se
        );
        if let Some(note) = m.comparable_text() {
            out += &format!("                   {note}\n");
        }
        out += &format!(
            "  difference       real {:+.1} SE, imaginary {:+.1} SE (combined)\n",
            m.re_z, m.im_z
        );
        out
    }
}
