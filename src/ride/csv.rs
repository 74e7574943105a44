//! Rides from other instruments, fitted (issue 13): a CSV's free decays, each fitted.
//!
//! In: a CSV ride ([`CsvRide`], read in [`crate::read::ride_csv`]) and the window of one free
//! decay, or a long recording's file. Out: [`CsvDecay`]: the weave's eigenvalue and mode shape
//! from roll and steer ([`super::modal::fit_modes`]), and the speed where it applies from the
//! wheel-speed column; for a long recording, every kick ([`find_kicks`]: where each push ends
//! and its free decay ends, and why) and its decay.
//!
//! What is missing narrows what can be fitted: roll and steer give the eigenvalue and the mode
//! shape; without a wheel-speed column the speed must be given.

use super::kicks::{
    find_kicks_in, DecayEnd, DecayStart, Kick, KickSeries, DECAY_MIN_S, KICK_OVER_BACKGROUND,
    MOVING_MPS,
};
use super::modal::{fit_modes, Eigenvalue, ModalFit, ModalOptions, ModeShape};
use super::read::{err, RideError};
use super::speed::{GivenSpeed, SpeedBeside, SpeedSource};
use crate::model::uncertain::Parametrized;
pub use crate::read::ride_csv::{
    check_rate_hz, read_csv_ride, read_csv_ride_within, Columns, ColumnsError, CsvRide, Quantity,
    RATE_RANGE_HZ,
};
use crate::read::ride_csv::{file_stamp, read_marked_windows, FirstPass, RowMark};
use crate::stats::number_text;
use crate::uncertainty::Measured;
use std::path::Path;

/// What a CSV decay's eigenvalue was fitted from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FittedFrom {
    /// Roll and steer angles together ([`fit_modes`]): the eigenvalue and the mode shape; the
    /// files without a roll-rate column.
    RollAndSteer,
    /// The roll rate alone ([`crate::fit::fit_short_decay`]), wherever the file has one: the
    /// eigenvalue; the mode shape, when the file has both angles too, from their fit.
    RollRate,
}

/// One free decay of a CSV ride, fitted.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CsvDecay {
    /// The window fitted (s) and the samples in it: the one asked for, cut to the recording.
    pub window_s: (f64, f64),
    /// The window asked for, where it reached beyond the recording (and `window_s` is cut).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub window_asked_s: Option<(f64, f64)>,
    pub samples: usize,
    pub fitted_from: FittedFrom,
    pub weave: Eigenvalue,
    /// The mode shape, from the roll-and-steer fit: where the eigenvalue is the roll rate's,
    /// only when that fit's eigenvalue agrees with it (a shape is the ratio of two amplitudes
    /// at the fit's own eigenvalue; at one the roll rate contradicts, it is not this mode's).
    pub shape: Option<ModeShape>,
    /// The real modes fitted beside the weave (1/s; by the roll-and-steer fit, when it gives
    /// the eigenvalue).
    pub real_modes: Vec<crate::fit::Estimate>,
    /// Variance accounted for (θ and γ by the roll-and-steer fit, or the roll rate twice).
    pub vaf: [f64; 2],
    /// The rear wheel's speed over the window (m/s): its mean, with the larger of the standard
    /// error of that mean and the change over the window over √12 (a drift, uniform over it).
    pub wheel_speed_mps: Option<Measured>,
    /// Where the file has roll and steer angles beside its roll rate: the same window fitted
    /// from the two angles, shown beside the roll rate's eigenvalue. An IMU's roll angle is its
    /// fusion filter's output, which the weave's lateral accelerations pull toward the apparent
    /// vertical; its gyro's rate is measured. On simulated treadmill recordings (`tests/real.rs`,
    /// `the_roll_rates_fit_is_the_calibrated_one`) the roll rate's σ and ω lay within two of
    /// their standard errors for 37 and 39 of 40 kicks, the roll-and-steer fit's for 36 and 33
    /// once its roll came through a complementary filter (19 and 18 with errors of white
    /// residuals, before the AR(1) sandwich). Shown together so that a disagreement is seen
    /// ([`CsvDecay::fits_disagree`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub roll_and_steer_weave: Option<Eigenvalue>,
    /// The weave's steer amplitude where its eigenvalue applies (rad), from the roll-and-steer
    /// fit whose shape the decay carries ([`ModalFit::weave_steer_amplitude_rad`]).
    #[serde(skip)]
    pub steer_amplitude_rad: Option<f64>,
}

impl CsvDecay {
    /// The roll-rate and the roll-and-steer fits of the window differ by more than two combined
    /// standard errors in σ or ω.
    pub fn fits_disagree(&self) -> bool {
        self.roll_and_steer_weave.is_some_and(|r| {
            let w = &self.weave;
            (w.re - r.re).abs() > 2.0 * w.re_se.hypot(r.re_se)
                || (w.im - r.im).abs() > 2.0 * w.im_se.hypot(r.im_se)
        })
    }

    /// The variance accounted for, as the fit that gave the eigenvalue has it: `θ 0.998, γ
    /// 0.995` or `roll rate 0.990`.
    pub fn vaf_text(&self) -> String {
        match self.fitted_from {
            FittedFrom::RollAndSteer => format!("θ {:.3}, γ {:.3}", self.vaf[0], self.vaf[1]),
            FittedFrom::RollRate => format!("roll rate {:.3}", self.vaf[0]),
        }
    }

    /// Whether the fit resolved an oscillation: ω's standard error below ω. A window that is
    /// no free decay (the roll wandering under a hand) gives a fit whose ω could be zero.
    pub fn resolves_weave(&self) -> bool {
        self.weave.im_se < self.weave.im.abs()
    }
}

/// At least this many samples in a window.
const MIN_WINDOW_SAMPLES: usize = super::modal::MIN_SAMPLES;

/// A record shorter than this (s) is one free decay when no window is given.
pub const WHOLE_RECORD_MAX_S: f64 = 10.0;

/// The weave is looked for between these angular frequencies (rad/s) in a roll-rate record.
const ROLL_RATE_OMEGA_RANGE: (f64, f64) = (1.0, 20.0);

/// Fits the free decay in `window_s` of `ride` (the whole record when `None` and it is shorter
/// than [`WHOLE_RECORD_MAX_S`]): the eigenvalue from the roll rate wherever the file has one
/// (else from roll and steer), the mode shape from roll and steer ([`CsvDecay`]).
pub fn fit_decay(
    ride: &CsvRide,
    window_s: Option<(f64, f64)>,
    options: &ModalOptions,
) -> Result<CsvDecay, RideError> {
    let path = &ride.path;
    let (first, last) = match (ride.time_s.first(), ride.time_s.last()) {
        (Some(&a), Some(&b)) => (a, b),
        _ => {
            return Err(err(
                path,
                match window_s {
                    Some((a, b)) => format!(
                        "the window {}–{} s holds no sample of the recording",
                        number_text(a),
                        number_text(b)
                    ),
                    None => "no samples".to_string(),
                },
            ))
        }
    };
    let (a, b) = match window_s {
        Some(w) => w,
        None if last - first <= WHOLE_RECORD_MAX_S => (first, last),
        None => {
            return Err(err(
                path,
                format!(
                "the record is {:.1} s long: give the free decay to fit with --window START:END \
                     (ride_decays finds every kick of a long recording)",
                last - first
            ),
            ))
        }
    };
    // A window reaching beyond the recording is the part of it the recording holds, and is
    // said so (a window given as 145.5–150 s of a file ending at 146 s is not 145.5–150 s).
    let asked = (a, b);
    let (a, b) = (a.max(first), b.min(last));
    let window_asked_s = (asked != (a, b)).then_some(asked);
    let idx: Vec<usize> = within(&ride.time_s, (a, b)).collect();
    if idx.len() < MIN_WINDOW_SAMPLES {
        return Err(err(
            path,
            format!(
                "the window {}–{} s holds {} samples: too few to fit (at least \
                 {MIN_WINDOW_SAMPLES}; the recording spans {first:.2}–{last:.2} s)",
                number_text(asked.0),
                number_text(asked.1),
                idx.len()
            ),
        ));
    }
    let pick = |x: &[f64]| -> Vec<f64> { idx.iter().map(|&i| x[i]).collect() };
    let t = pick(&ride.time_s);
    let wheel_speed_mps = ride.wheel_speed_mps.as_ref().map(|w| {
        let v = pick(w);
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let change = (v[v.len() - 1] - v[0]).abs();
        Measured::new(mean, (sd / n.sqrt()).max(change / 12f64.sqrt()))
    });
    let roll_rate_fit = |rate: &[f64]| roll_rate_weave(&t, &pick(rate), path, (a, b));
    // The same fit and settings as an IMU log's window (issue 75: one estimator for every
    // instrument).
    let angles_fit = |roll: &[f64], steer: &[f64]| {
        fit_modes(&t, &pick(roll), &pick(steer), options)
            .map_err(|e| err(path, format!("window {a}–{b} s: {e}")))
    };
    let rate_decay = |(weave, vaf): (Eigenvalue, f64)| CsvDecay {
        window_s: (a, b),
        window_asked_s,
        samples: idx.len(),
        fitted_from: FittedFrom::RollRate,
        weave,
        shape: None,
        real_modes: Vec::new(),
        vaf: [vaf, vaf],
        wheel_speed_mps,
        roll_and_steer_weave: None,
        steer_amplitude_rad: None,
    };
    let angles_decay = |fit: ModalFit| CsvDecay {
        window_s: (a, b),
        window_asked_s,
        samples: idx.len(),
        fitted_from: FittedFrom::RollAndSteer,
        weave: fit.weave,
        shape: Some(fit.shape),
        steer_amplitude_rad: Some(fit.weave_steer_amplitude_rad()),
        real_modes: fit.real_modes,
        vaf: fit.vaf,
        wheel_speed_mps,
        roll_and_steer_weave: None,
    };
    match (&ride.roll_rad, &ride.steer_rad, &ride.roll_rate_rad_per_s) {
        (Some(roll), Some(steer), Some(rate)) => match roll_rate_fit(rate) {
            // The roll rate's eigenvalue (calibrated, see `roll_and_steer_weave`), the angles'
            // beside it, and their shape where the two agree.
            Ok(r) => {
                let mut d = rate_decay(r);
                if let Ok(fit) = angles_fit(roll, steer) {
                    d.roll_and_steer_weave = Some(fit.weave);
                    if !d.fits_disagree() {
                        d.shape = Some(fit.shape);
                        d.steer_amplitude_rad = Some(fit.weave_steer_amplitude_rad());
                    }
                }
                Ok(d)
            }
            Err(_) => Ok(angles_decay(angles_fit(roll, steer)?)),
        },
        (Some(roll), Some(steer), None) => Ok(angles_decay(angles_fit(roll, steer)?)),
        (_, _, Some(rate)) => Ok(rate_decay(roll_rate_fit(rate)?)),
        _ => Err(err(
            path,
            "a free decay is fitted from roll and steer angles (roll_rad/roll_deg and \
             steer_rad/steer_deg) or from the roll rate (roll_rate_rad_per_s): the file has neither \
             (name other columns with --columns roll=…,steer=… or roll_rate=…)",
        )),
    }
}

/// An eigenvalue with its standard errors as the text output writes it: `-1.437 ± 0.061 + 4.925
/// ± 0.078i 1/s`.
fn eigenvalue_text(e: &Eigenvalue) -> String {
    format!(
        "{:.3} ± {:.3} {} {:.3} ± {:.3}i 1/s",
        e.re,
        e.re_se,
        if e.im < 0.0 { "-" } else { "+" },
        e.im.abs(),
        e.im_se
    )
}

/// The weave of a window `(a, b)` from its roll rate `x` at times `t` alone (one damped
/// sinusoid on an offset, [`crate::fit::fit_short_decay`]), and the variance it accounts for.
fn roll_rate_weave(
    t: &[f64],
    x: &[f64],
    path: &Path,
    (a, b): (f64, f64),
) -> Result<(Eigenvalue, f64), RideError> {
    let f = crate::fit::fit_short_decay(t, x, ROLL_RATE_OMEGA_RANGE)
        .map_err(|e| err(path, format!("window {a}–{b} s: {e}")))?;
    let (sg, om) = (f.sigma(), f.omega_d());
    // The fit's errors assume white residuals; a short record's are correlated (the sensor's
    // filter, the modes the one sinusoid leaves out), and n samples then hold fewer
    // independent ones: the errors are those of AR(1) residuals, as every ride fit's
    // ([`crate::fit::ar1_sandwich`]).
    let cov = f
        .correlated_covariance(t, x)
        .unwrap_or_else(|| f.covariance.clone());
    let (re_se, im_se) = (cov[(3, 3)].max(0.0).sqrt(), cov[(4, 4)].max(0.0).sqrt());
    let corr = cov[(3, 4)] / (re_se * im_se).max(1e-300);
    let inflation = [re_se / sg.se.max(1e-300), im_se / om.se.max(1e-300)];
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
    let vaf = 1.0 - f.residual_rms.powi(2) * (x.len() - f.params.len()) as f64 / var;
    Ok((
        Eigenvalue {
            re: -sg.value,
            im: om.value,
            re_se,
            im_se,
            re_se_noise: sg.se,
            im_se_noise: om.se,
            noise_inflation: inflation,
            re_im_corr: -corr,
            re_se_resampled: f64::NAN,
            im_se_resampled: f64::NAN,
            re_se_drift: 0.0,
            im_se_drift: 0.0,
        },
        vaf,
    ))
}

/// The speed where a decay applies: its wheel-speed column over the window when the file has
/// one, else the speed `given` (a set speed or a reading: uniform within half its display step,
/// with its own error).
pub fn decay_speed(decay: &CsvDecay, given: Option<GivenSpeed>) -> Option<(Measured, SpeedSource)> {
    match (decay.wheel_speed_mps, given) {
        (Some(v), _) => Some((v, SpeedSource::WheelSpeed)),
        (None, Some(g)) => Some((g.measured(), g.source())),
        (None, None) => None,
    }
}

/// Every kick of a long recording: the first peak of |roll rate| over [`KICK_OVER_BACKGROUND`]
/// times the background where none was in the [`super::kicks::KICK_SEPARATION_S`] before it, on a bicycle
/// not already swinging at its size, and its free decay: from the push's peak, or the swing
/// back where the push lasted through its swing ([`DecayStart`]), to where the free motion ends
/// ([`DecayEnd`]). Errors when the file has neither roll rate nor roll.
pub fn find_kicks(ride: &CsvRide) -> Result<Vec<Kick>, RideError> {
    let series = KickSeries::of_ride(ride).ok_or_else(|| no_roll(&ride.path))?;
    Ok(find_kicks_in(&series))
}

/// The error of a ride in memory without roll rate or roll, where kicks are looked for (a file
/// is refused where its columns are read, [`plan`]).
fn no_roll(path: &Path) -> RideError {
    err(
        path,
        "kicks are found in the roll rate or the roll angle: the file has neither",
    )
}

/// One kick of a long recording and its decay, or why it was not fitted.
#[derive(Debug, Clone, serde::Serialize)]
pub struct KickDecay {
    pub kick: Kick,
    #[serde(flatten)]
    pub decay: Option<DecaySummary>,
    /// Why the kick gave no decay (`None` when it did).
    pub not_fitted: Option<String>,
}

/// The kicks of a long CSV recording and each one's free decay, as `bikeproc dynamic FILE.csv`
/// gives them. Its JSON is the command's `--json`.
#[derive(Debug, Clone, serde::Serialize)]
pub struct KickReport {
    pub file: String,
    pub kicks: Vec<KickDecay>,
}

impl KickReport {
    /// The kicks found, each with its window and its decay or why it gave none.
    pub fn to_text(&self) -> String {
        let n = self.kicks.len();
        let plural = if n == 1 { "" } else { "s" };
        let mut text = format!("{}: {n} kick{plural} found\n", self.file);
        for (k, d) in self.kicks.iter().enumerate() {
            text += &format!(
                "\nkick {} at {:.2} s (roll rate {:+.3} rad/s), free decay {:.2} – {:.2} s: starts {}, ends {}\n",
                k + 1,
                d.kick.at_s,
                d.kick.peak_roll_rate_rad_per_s,
                d.kick.window_s.0,
                d.kick.window_s.1,
                d.kick.starts.words(),
                d.kick.ends.words()
            );
            match (&d.decay, &d.not_fitted) {
                (Some(s), _) => text += &s.to_text(),
                (None, Some(why)) => text += &format!("not fitted: {why}\n"),
                (None, None) => {}
            }
        }
        text
    }
}

/// The free decays of `ride`: the one in `window_s`, the whole record when it is at most
/// [`WHOLE_RECORD_MAX_S`] long, else one after every kick [`find_kicks`] finds (a kick whose
/// window the wheel turns through at under [`MOVING_MPS`], or whose speed changes by more than
/// a fifth, is listed as not fitted). `given` is the speed reading where there is no wheel-speed
/// column; with `model`, each decay's model weave.
pub fn ride_decays(
    ride: &CsvRide,
    window_s: Option<(f64, f64)>,
    given: Option<GivenSpeed>,
    model: Option<&Parametrized>,
    options: &ModalOptions,
) -> Result<Vec<KickDecay>, RideError> {
    let (first, last) = match (ride.time_s.first(), ride.time_s.last()) {
        (Some(&a), Some(&b)) => (a, b),
        // The window's own message (a window beyond the recording reads no rows).
        _ if window_s.is_some() => (f64::NAN, f64::NAN),
        _ => return Err(err(&ride.path, "no samples")),
    };
    if window_s.is_some() || last - first <= WHOLE_RECORD_MAX_S {
        let decay = fit_decay(ride, window_s, options)?;
        let window = decay.window_s;
        return Ok(vec![KickDecay {
            kick: Kick {
                at_s: window.0,
                peak_roll_rate_rad_per_s: f64::NAN,
                window_s: window,
                starts: DecayStart::Given,
                ends: DecayEnd::Given,
            },
            decay: Some(DecaySummary::new(ride, decay, given, model)?),
            not_fitted: None,
        }]);
    }
    let kicks = find_kicks(ride)?;
    if kicks.is_empty() {
        return Err(no_kick(&ride.path, last - first));
    }
    Ok(decays_of(ride, kicks, given, model, options))
}

/// The error of a long recording without a kick.
fn no_kick(path: &Path, span_s: f64) -> RideError {
    err(
        path,
        format!(
            "no kick found in {span_s:.1} s: no roll-rate peak over {KICK_OVER_BACKGROUND} times \
             the background with {DECAY_MIN_S} s of free decay after it (give one with --window \
             START:END)"
        ),
    )
}

/// [`ride_decays`] of a ride's CSV file, read in bounded memory: with a window, only its rows are
/// kept; without, a first pass finds the kicks in the compact [`KickSeries`] (9 bytes a row),
/// checking every row and marking where they start, and a second reads only the rows of
/// their windows.
pub fn ride_decays_file(
    path: &Path,
    columns: &Columns,
    rate_hz: Option<f64>,
    window_s: Option<(f64, f64)>,
    given: Option<GivenSpeed>,
    model: Option<&Parametrized>,
    options: &ModalOptions,
) -> Result<Vec<KickDecay>, RideError> {
    if let Some(w) = window_s {
        let ride = read_csv_ride_within(path, columns, rate_hz, Some(&[w]))?;
        return ride_decays(&ride, window_s, given, model, options);
    }
    let stamp = file_stamp(path);
    let (kicks, span_s, marks) = find_kicks_marked(path, columns, rate_hz)?;
    if span_s <= WHOLE_RECORD_MAX_S {
        let ride = read_csv_ride(path, columns, rate_hz)?;
        return ride_decays(&ride, None, given, model, options);
    }
    if kicks.is_empty() {
        return Err(no_kick(path, span_s));
    }
    let windows: Vec<(f64, f64)> = kicks.iter().map(|k| k.window_s).collect();
    let ride = read_marked_windows(path, columns, rate_hz, &windows, &marks, stamp)?;
    Ok(decays_of(&ride, kicks, given, model, options))
}

/// The kicks of a ride's CSV file ([`find_kicks`]) found in one pass over it in 9 bytes a row
/// ([`KickSeries`]), and the span of its times (s).
pub fn find_kicks_file(
    path: &Path,
    columns: &Columns,
    rate_hz: Option<f64>,
) -> Result<(Vec<Kick>, f64), RideError> {
    find_kicks_marked(path, columns, rate_hz).map(|(kicks, span_s, _)| (kicks, span_s))
}

/// [`find_kicks_file`] with the pass's [`RowMark`]s.
fn find_kicks_marked(
    path: &Path,
    columns: &Columns,
    rate_hz: Option<f64>,
) -> Result<(Vec<Kick>, f64, Vec<RowMark>), RideError> {
    let FirstPass { series, marks } = KickSeries::read(path, columns, rate_hz)?;
    let n = series.len();
    let span_s = if n > 0 {
        series.t(n - 1) - series.t(0)
    } else {
        0.0
    };
    Ok((find_kicks_in(&series), span_s, marks))
}

/// The samples whose times (strictly increasing, as the reader keeps them) lie in `[a, b]`.
fn within(time_s: &[f64], (a, b): (f64, f64)) -> std::ops::Range<usize> {
    let start = time_s.partition_point(|&t| t < a);
    start..start.max(time_s.partition_point(|&t| t <= b))
}

/// Each of `kicks` fitted on `ride` (which holds at least their windows' rows).
fn decays_of(
    ride: &CsvRide,
    kicks: Vec<Kick>,
    given: Option<GivenSpeed>,
    model: Option<&Parametrized>,
    options: &ModalOptions,
) -> Vec<KickDecay> {
    use rayon::prelude::*;
    // Each kick's fits are its own (the bootstrap seeded by `options`): in parallel, in order.
    kicks
        .into_par_iter()
        .map(|kick| {
            let fitted = fit_decay(ride, Some(kick.window_s), options).and_then(|d| {
                if let Some(w) = &ride.wheel_speed_mps {
                    let (a, b) = kick.window_s;
                    let v: Vec<f64> = within(&ride.time_s, (a, b)).map(|i| w[i]).collect();
                    let (lo, hi) = v
                        .iter()
                        .fold((f64::INFINITY, 0.0f64), |(l, h), &x| (l.min(x), h.max(x)));
                    let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
                    if mean < MOVING_MPS {
                        return Err(err(
                            &ride.path,
                            format!("the wheel turns at {mean:.2} m/s: not riding"),
                        ));
                    }
                    if hi - lo > 0.2 * mean {
                        return Err(err(
                            &ride.path,
                            format!(
                                "the speed changes from {lo:.2} to {hi:.2} m/s over the window"
                            ),
                        ));
                    }
                }
                DecaySummary::new(ride, d, given, model)
            });
            match fitted {
                Ok(d) => KickDecay {
                    kick,
                    decay: Some(d),
                    not_fitted: None,
                },
                Err(e) => KickDecay {
                    kick,
                    decay: None,
                    not_fitted: Some(e.to_string()),
                },
            }
        })
        .collect()
}

/// A CSV decay as reported (text and JSON).
#[derive(Debug, Clone, serde::Serialize)]
pub struct DecaySummary {
    pub file: String,
    /// Which column gave which quantity.
    pub columns: Vec<(Quantity, String)>,
    #[serde(flatten)]
    pub decay: CsvDecay,
    /// The speed where the eigenvalue applies (m/s) and where it comes from.
    pub speed_mps: Option<Measured>,
    pub speed_source: Option<SpeedSource>,
    /// The model's weave at that speed, when a bicycle was given.
    pub model: Option<super::model_weave::ModelWeave>,
    /// The speed the lab set or noted for the ride (a treadmill's setting), when given: rides
    /// of one given speed are repeats of one set-up.
    #[serde(skip)]
    pub set_speed_mps: Option<f64>,
    /// The speed given for the ride where the wheel-speed column's is used instead, with how
    /// far the wheel reads from it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub given_beside: Option<SpeedBeside>,
}

impl DecaySummary {
    /// The decay of `ride` with its speed (the wheel-speed column, else `given`) and, with a
    /// `model`, the model's weave there.
    pub fn new(
        ride: &CsvRide,
        decay: CsvDecay,
        given: Option<GivenSpeed>,
        model: Option<&Parametrized>,
    ) -> Result<DecaySummary, RideError> {
        let speed = decay_speed(&decay, given);
        if let Some((v, SpeedSource::WheelSpeed)) = speed {
            // A wheel column's noise may dip below zero at a standstill (the reader takes
            // down to −1 m/s); a window's mean below a riding speed is no ride to compare.
            super::speed::check_reading_mps(v.value).map_err(|e| {
                err(
                    &ride.path,
                    format!(
                        "window {:.2}–{:.2} s, the wheel-speed column's mean over it: {e} (a \
                         sign reversed, or the bicycle standing? map another column, or leave \
                         the column out and give --speed)",
                        decay.window_s.0, decay.window_s.1
                    ),
                )
            })?;
        }
        let model = match (model, speed) {
            (Some(m), Some((v, _))) => Some(super::model_weave::model_weave_at(
                &ride.path,
                m,
                v.value,
                v.se,
                &decay.weave,
            )?),
            _ => None,
        };
        Ok(DecaySummary {
            file: ride.path.display().to_string(),
            columns: ride.columns.clone(),
            decay,
            speed_mps: speed.map(|s| s.0),
            speed_source: speed.map(|s| s.1),
            model,
            set_speed_mps: given.map(|g| g.reading.speed_mps),
            given_beside: match (speed, given) {
                (Some((v, SpeedSource::WheelSpeed)), Some(g)) => Some(SpeedBeside::of(g, v)),
                _ => None,
            },
        })
    }

    /// The human-readable form.
    pub fn to_text(&self) -> String {
        use std::fmt::Write as _;
        let mut out = String::new();
        let cols: Vec<String> = self
            .columns
            .iter()
            .map(|(q, c)| format!("{}={c}", q.key()))
            .collect();
        let _ = writeln!(out, "{} ({})", self.file, cols.join(", "));
        let d = &self.decay;
        let w = &d.weave;
        let _ = writeln!(
            out,
            "window           {:.2} – {:.2} s ({} samples)",
            d.window_s.0, d.window_s.1, d.samples
        );
        if let Some((a, b)) = d.window_asked_s {
            let _ = writeln!(
                out,
                "                 of {} – {} s asked: the recording holds only this part",
                number_text(a),
                number_text(b)
            );
        }
        let _ = writeln!(out, "weave            {}", eigenvalue_text(w));
        if !d.resolves_weave() {
            let _ = writeln!(
                out,
                "                 no weave resolved: ω's standard error exceeds ω (no free decay here?)"
            );
        }
        let _ = writeln!(
            out,
            "                 from {}",
            match d.fitted_from {
                FittedFrom::RollRate => "the roll rate",
                FittedFrom::RollAndSteer => "the roll and steer angles",
            }
        );
        if let Some(r) = &d.roll_and_steer_weave {
            let _ = writeln!(
                out,
                "  roll and steer {}{}",
                eigenvalue_text(r),
                if d.fits_disagree() {
                    ": the two fits disagree beyond two combined standard errors (the roll \
                     rate's is the calibrated one: a fused roll angle carries its filter's \
                     dynamics)"
                } else {
                    ""
                }
            );
        }
        match &d.shape {
            Some(s) => {
                let _ = writeln!(
                    out,
                    "mode shape       |γ/θ| {:.3} ± {:.3} rad/rad at {:.1} ± {:.1}° (roll and steer)",
                    s.ratio.value,
                    s.ratio.se,
                    s.phase_rad.value.to_degrees(),
                    s.phase_rad.se.to_degrees()
                );
            }
            None if d.roll_and_steer_weave.is_some() => {
                let _ = writeln!(
                    out,
                    "mode shape       left out: the roll-and-steer fit it comes from disagrees with \
                     the roll rate's eigenvalue"
                );
            }
            None => {
                let _ = writeln!(
                    out,
                    "mode shape       not measured (the file has no roll and steer angles)"
                );
            }
        }
        let _ = writeln!(out, "VAF              {}", d.vaf_text());
        match (&self.speed_mps, self.speed_source) {
            (Some(v), Some(src)) => {
                let _ = writeln!(
                    out,
                    "speed            {:.3} ± {:.3} m/s ({})",
                    v.value,
                    v.se,
                    match src {
                        SpeedSource::WheelSpeed => "the wheel-speed column over the window",
                        other => super::speed::given_words(other),
                    }
                );
                if let Some(b) = &self.given_beside {
                    let _ = writeln!(out, "                 not used: {}", b.text());
                }
            }
            _ => {
                let _ = writeln!(
                    out,
                    "speed            unknown (no wheel-speed column; give --speed)"
                );
            }
        }
        if let Some(m) = &self.model {
            let _ = writeln!(
                out,
                "model {:<11}{:.3} ± {:.3} + {:.3} ± {:.3}i 1/s: experiment − model {:+.1} σ (real), {:+.1} σ (imaginary)",
                m.mode.label(), m.re, m.re_se, m.im, m.im_se, m.re_z, m.im_z
            );
            if let Some(note) = m.comparable_text() {
                let _ = writeln!(out, "                 {note}");
            }
        }
        out
    }
}
