//! Rides from other instruments (issue 13): a CSV of time series whose columns are recognised
//! by name, one free decay of it fitted.
//!
//! In: the CSV (`time_s`, `roll_rad`, `roll_rate_rad_per_s`, `steer_deg` or `steer_rad`,
//! `steer_rate_*`, `rear_wheel_speed_m_per_s`, …; other names through [`Columns`]) and the
//! window of one free decay. Out: [`CsvRide`], every quantity in SI units on the file's own
//! time stamps (a receiver's jitter is kept, not gridded), and [`CsvDecay`]: the weave's
//! eigenvalue and mode shape from roll and steer ([`super::modal::fit_modes`]), and the speed
//! where it applies from the wheel-speed column.
//!
//! What is missing narrows what can be fitted: roll and steer give the eigenvalue and the mode
//! shape; without a wheel-speed column the speed must be given.

use super::modal::{fit_modes, Eigenvalue, ModalFit, ModalOptions, ModeShape};
use super::read::RideError;
use super::speed::{NotedReading, SpeedSource};
use crate::model::uncertain::Parametrized;
use crate::signal::CsvTable;
use crate::uncertainty::Measured;
use std::path::{Path, PathBuf};

/// The quantities a ride's CSV may carry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantity {
    Time,
    Roll,
    RollRate,
    Steer,
    SteerRate,
    WheelSpeed,
}

impl Quantity {
    pub const ALL: [Quantity; 6] = [
        Quantity::Time,
        Quantity::Roll,
        Quantity::RollRate,
        Quantity::Steer,
        Quantity::SteerRate,
        Quantity::WheelSpeed,
    ];

    /// The key of `--columns` (`roll_rate=gyro_x`).
    pub fn key(self) -> &'static str {
        match self {
            Quantity::Time => "time",
            Quantity::Roll => "roll",
            Quantity::RollRate => "roll_rate",
            Quantity::Steer => "steer",
            Quantity::SteerRate => "steer_rate",
            Quantity::WheelSpeed => "wheel_speed",
        }
    }

    /// The column names recognised without `--columns`, each with its factor to SI: every
    /// common name of the quantity with each of its units as a suffix (`roll_rad`,
    /// `lean_angle_deg`, `speed_km_per_h`), in order of preference; a time also bare (`time`).
    fn names(self) -> Vec<(String, f64)> {
        let bases: &[&str] = match self {
            Quantity::Time => &["time", "t"],
            Quantity::Roll => &["roll", "lean", "lean_angle"],
            Quantity::RollRate => &["roll_rate", "lean_rate"],
            Quantity::Steer => &["steer", "steer_angle", "fork", "handlebar"],
            Quantity::SteerRate => &["steer_rate", "fork_rate"],
            Quantity::WheelSpeed => &["rear_wheel_speed", "wheel_speed", "speed"],
        };
        let mut out = Vec::new();
        for base in bases {
            out.extend(
                self.units()
                    .iter()
                    .map(|(u, f)| (format!("{base}_{u}"), *f)),
            );
            if self == Quantity::Time {
                out.push((base.to_string(), 1.0));
            }
        }
        out
    }

    /// Its units as written after a name, each with its factor to SI.
    fn units(self) -> &'static [(&'static str, f64)] {
        const DEG: f64 = std::f64::consts::PI / 180.0;
        match self {
            Quantity::Time => &[("s", 1.0), ("ms", 1e-3)],
            Quantity::Roll | Quantity::Steer => &[("rad", 1.0), ("deg", DEG)],
            Quantity::RollRate | Quantity::SteerRate => &[("rad_per_s", 1.0), ("deg_per_s", DEG)],
            Quantity::WheelSpeed => &[("m_per_s", 1.0), ("km_per_h", 1.0 / 3.6)],
        }
    }
}

/// Column names given for quantities (`--columns roll_rate=gyro_x,time=time`); a name ending
/// in `_deg` or `_deg_per_s` is read as degrees, any other as SI, unless a unit follows it
/// after a colon ([`Unit`]: `roll=lean_angle:deg`, `wheel_speed=v:km_per_h`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Columns(pub Vec<(Quantity, String)>);

impl std::str::FromStr for Columns {
    type Err = String;

    fn from_str(spec: &str) -> Result<Columns, String> {
        let mut out = Vec::new();
        for part in spec.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            let (key, name) = part
                .split_once('=')
                .ok_or_else(|| format!("`{part}`: expected QUANTITY=COLUMN"))?;
            let q = Quantity::ALL
                .into_iter()
                .find(|q| q.key() == key.trim())
                .ok_or_else(|| {
                    format!(
                        "`{key}`: not a quantity (one of {})",
                        Quantity::ALL.map(Quantity::key).join(", ")
                    )
                })?;
            let name = name.trim();
            if let Some((_, unit)) = name.rsplit_once(':') {
                unit_factor(q, unit)?;
            }
            out.push((q, name.to_string()));
        }
        Ok(Columns(out))
    }
}

/// The factor to SI of `unit` written after a column's name for quantity `q`
/// (`roll=lean_angle:deg`): [`Quantity::units`].
fn unit_factor(q: Quantity, unit: &str) -> Result<f64, String> {
    let units = q.units();
    units
        .iter()
        .find(|(u, _)| *u == unit.trim())
        .map(|(_, f)| *f)
        .ok_or_else(|| {
            format!(
                "`{unit}`: not a unit of {} (one of {})",
                q.key(),
                units.iter().map(|(u, _)| *u).collect::<Vec<_>>().join(", ")
            )
        })
}

/// The slowest and fastest sampling rates `--rate` takes (Hz).
pub const RATE_RANGE_HZ: (f64, f64) = (1.0, 100_000.0);

/// Checks a sampling rate given for a table without a time column (`--rate`, `rate_hz`).
pub fn check_rate_hz(rate: f64) -> Result<f64, String> {
    let (lo, hi) = RATE_RANGE_HZ;
    if rate.is_finite() && (lo..=hi).contains(&rate) {
        Ok(rate)
    } else {
        Err(format!(
            "{} Hz is not a sampling rate (expected from {lo} to {hi} Hz)",
            crate::inertia::manifest::number_text(rate)
        ))
    }
}

/// A ride read from a CSV: the time stamps (s) and whichever quantities the file has, in SI
/// units (rad, rad/s, m/s).
#[derive(Debug, Clone)]
pub struct CsvRide {
    pub path: PathBuf,
    pub time_s: Vec<f64>,
    pub roll_rad: Option<Vec<f64>>,
    pub roll_rate_rad_per_s: Option<Vec<f64>>,
    pub steer_rad: Option<Vec<f64>>,
    pub steer_rate_rad_per_s: Option<Vec<f64>>,
    pub wheel_speed_mps: Option<Vec<f64>>,
    /// Which column gave which quantity.
    pub columns: Vec<(Quantity, String)>,
}

fn err(path: &Path, message: impl Into<String>) -> RideError {
    RideError::Ride {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// Reads a ride's CSV: the columns of [`Quantity`] by their recognised names or by `given`.
/// Time comes from a time column, which must advance, or, for a table without one (a
/// microcontroller's line per control step), from the row's number at `rate_hz`; a rate for a
/// table that has a time column is refused (two clocks for one table). A named column that
/// is missing is an error, an unnamed quantity without a recognised column is simply absent.
pub fn read_csv_ride(
    path: &Path,
    given: &Columns,
    rate_hz: Option<f64>,
) -> Result<CsvRide, RideError> {
    if let Some(rate) = rate_hz {
        check_rate_hz(rate).map_err(|e| err(path, format!("--rate: {e}")))?;
    }
    let file = crate::kind::open_text(path).map_err(|e| {
        let at = e.line.map_or(String::new(), |l| format!("line {l}: "));
        err(path, format!("{at}{}", e.message))
    })?;
    let table = CsvTable::read(file, path)?;
    let mut found: Vec<(Quantity, usize, f64, String)> = Vec::new();
    for q in Quantity::ALL {
        let pick = match given.0.iter().find(|(g, _)| *g == q) {
            Some((_, given_name)) => {
                let (name, unit) = match given_name.rsplit_once(':') {
                    Some((n, u)) => (n.trim(), Some(u)),
                    None => (given_name.as_str(), None),
                };
                let k = table.find(&[name]).ok_or_else(|| {
                    err(
                        path,
                        format!(
                            "no column `{name}` for {} (the columns: {})",
                            q.key(),
                            table.headers.join(", ")
                        ),
                    )
                })?;
                let lower = name.to_ascii_lowercase();
                let deg = lower.ends_with("_deg") || lower.ends_with("_deg_per_s");
                let factor = match unit {
                    Some(u) => unit_factor(q, u).map_err(|e| err(path, e))?,
                    None if deg => std::f64::consts::PI / 180.0,
                    None => 1.0,
                };
                Some((k, factor))
            }
            None => q
                .names()
                .iter()
                .find_map(|(n, f)| table.find(&[n.as_str()]).map(|k| (k, *f))),
        };
        if let Some((k, factor)) = pick {
            found.push((q, k, factor, table.headers[k].clone()));
        }
    }
    let time_column = found
        .iter()
        .find(|f| f.0 == Quantity::Time)
        .map(|f| f.3.clone());
    match (&time_column, rate_hz) {
        (None, None) => {
            return Err(err(
                path,
                format!(
                    "no time column (time_s, or --columns time=NAME; a table sampled at a fixed \
                     rate without one: --rate HZ, or rate_hz in a manifest); the columns: {}",
                    table.headers.join(", ")
                ),
            ))
        }
        (Some(name), Some(rate)) => {
            return Err(err(
                path,
                format!(
                    "it has a time column (`{name}`): a rate ({rate} Hz) is for a table without \
                     one"
                ),
            ))
        }
        _ => {}
    }
    let which: Vec<usize> = found.iter().map(|f| f.1).collect();
    let values = table.columns(&which)?;
    let mut ride = CsvRide {
        path: path.to_path_buf(),
        time_s: Vec::new(),
        roll_rad: None,
        roll_rate_rad_per_s: None,
        steer_rad: None,
        steer_rate_rad_per_s: None,
        wheel_speed_mps: None,
        columns: found.iter().map(|f| (f.0, f.3.clone())).collect(),
    };
    let lines = table.lines();
    for ((q, k, factor, name), v) in found.iter().zip(values) {
        let v: Vec<f64> = v.into_iter().map(|x| x * factor).collect();
        // Each quantity in its physical range where it is read: a wheel speed from −1 m/s (an
        // encoder's noise at a standstill) to a riding speed's most (−5 gave "speed −5.000",
        // 1e9 a weave of −4.9e9); an angle within ±π, a rate within ±100 rad/s.
        let range = match q {
            Quantity::Time => None,
            Quantity::WheelSpeed => Some((-1.0, super::speed::MAX_READING_MPS, "m/s")),
            Quantity::Roll | Quantity::Steer => {
                Some((-std::f64::consts::PI, std::f64::consts::PI, "rad"))
            }
            Quantity::RollRate | Quantity::SteerRate => Some((-100.0, 100.0, "rad/s")),
        };
        if let Some((lo, hi, unit)) = range {
            if let Some(i) = v.iter().position(|x| !(lo..=hi).contains(x)) {
                return Err(table
                    .error(
                        lines.get(i).copied().unwrap_or(0),
                        k + 1,
                        format!(
                            "{} `{name}` = {} {unit}: expected from {lo:.4} to {hi} {unit}",
                            q.key(),
                            v[i]
                        ),
                    )
                    .into());
            }
        }
        if matches!(q, Quantity::Roll | Quantity::RollRate)
            && v.len() > 1
            && v.iter().all(|x| *x == v[0])
        {
            return Err(err(
                path,
                format!(
                    "{} `{name}` is {} in every row: no motion was recorded",
                    q.key(),
                    v[0]
                ),
            ));
        }
        match q {
            Quantity::Time => ride.time_s = v,
            Quantity::Roll => ride.roll_rad = Some(v),
            Quantity::RollRate => ride.roll_rate_rad_per_s = Some(v),
            Quantity::Steer => ride.steer_rad = Some(v),
            Quantity::SteerRate => ride.steer_rate_rad_per_s = Some(v),
            Quantity::WheelSpeed => ride.wheel_speed_mps = Some(v),
        }
    }
    match rate_hz {
        Some(rate) => {
            ride.time_s = (0..table.lines().len()).map(|i| i as f64 / rate).collect();
            ride.columns
                .push((Quantity::Time, format!("row number at {rate} Hz")));
        }
        None => table.advancing(&ride.time_s)?,
    }
    Ok(ride)
}

/// What a CSV decay was fitted from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FittedFrom {
    /// Roll and steer angles together ([`fit_modes`]): the eigenvalue and the mode shape.
    RollAndSteer,
    /// The roll rate alone ([`crate::fit::fit_short_decay`]): the eigenvalue, no mode shape.
    RollRate,
}

/// One free decay of a CSV ride, fitted.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CsvDecay {
    /// The window fitted (s) and the samples in it.
    pub window_s: (f64, f64),
    pub samples: usize,
    pub fitted_from: FittedFrom,
    pub weave: Eigenvalue,
    /// The mode shape, from roll and steer only.
    pub shape: Option<ModeShape>,
    /// The real modes fitted beside the weave (1/s; roll and steer only).
    pub real_modes: Vec<crate::fit::Estimate>,
    /// Variance accounted for (θ and γ, or the roll rate twice).
    pub vaf: [f64; 2],
    /// The rear wheel's speed over the window (m/s): its mean, with the larger of the standard
    /// error of that mean and the change over the window over √12 (a drift, uniform over it).
    pub wheel_speed_mps: Option<Measured>,
}

impl CsvDecay {
    /// Whether the fit resolved an oscillation: ω's standard error below ω. A window that is
    /// no free decay (the roll wandering under a hand) gives a fit whose ω could be zero.
    pub fn resolves_weave(&self) -> bool {
        self.weave.im_se < self.weave.im.abs()
    }
}

/// At least this many samples in a window.
const MIN_WINDOW_SAMPLES: usize = 40;

/// A record shorter than this (s) is one free decay when no window is given.
pub const WHOLE_RECORD_MAX_S: f64 = 10.0;

/// The weave is looked for between these angular frequencies (rad/s) in a roll-rate record.
const ROLL_RATE_OMEGA_RANGE: (f64, f64) = (1.0, 20.0);

/// Fits the free decay in `window_s` of `ride` (the whole record when `None` and it is shorter
/// than [`WHOLE_RECORD_MAX_S`]): from roll and steer angles when the file has both, else from
/// the roll rate alone.
pub fn fit_decay(
    ride: &CsvRide,
    window_s: Option<(f64, f64)>,
    options: &ModalOptions,
) -> Result<CsvDecay, RideError> {
    let path = &ride.path;
    let (first, last) = match (ride.time_s.first(), ride.time_s.last()) {
        (Some(&a), Some(&b)) => (a, b),
        _ => return Err(err(path, "no samples")),
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
    let idx: Vec<usize> = (0..ride.time_s.len())
        .filter(|&i| ride.time_s[i] >= a && ride.time_s[i] <= b)
        .collect();
    if idx.len() < MIN_WINDOW_SAMPLES {
        return Err(err(
            path,
            format!(
                "the window {a}–{b} s holds {} samples: too few to fit (at least {MIN_WINDOW_SAMPLES})",
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
    let decay = |fitted_from, weave, shape, real_modes, vaf| CsvDecay {
        window_s: (a, b),
        samples: idx.len(),
        fitted_from,
        weave,
        shape,
        real_modes,
        vaf,
        wheel_speed_mps,
    };
    match (&ride.roll_rad, &ride.steer_rad, &ride.roll_rate_rad_per_s) {
        (Some(roll), Some(steer), _) => {
            let fit: ModalFit = fit_modes(&t, &pick(roll), &pick(steer), options)
                .map_err(|e| err(path, format!("window {a}–{b} s: {e}")))?;
            Ok(decay(
                FittedFrom::RollAndSteer,
                fit.weave,
                Some(fit.shape),
                fit.real_modes.clone(),
                fit.vaf,
            ))
        }
        (_, _, Some(rate)) => {
            let x = pick(rate);
            let f = crate::fit::fit_short_decay(&t, &x, ROLL_RATE_OMEGA_RANGE)
                .map_err(|e| err(path, format!("window {a}–{b} s: {e}")))?;
            let (sg, om) = (f.sigma(), f.omega_d());
            let corr = f.covariance[(3, 4)] / (sg.se * om.se);
            // The fit's errors assume white residuals; a short record's are correlated (the
            // sensor's filter, the modes the one sinusoid leaves out), and n samples then hold
            // fewer independent ones: the errors grow by √((1 + ρ)/(1 − ρ)), ρ the residuals'
            // lag-one autocorrelation (an AR(1) noise's variance inflation).
            let resid: Vec<f64> = t.iter().zip(&x).map(|(&ti, &xi)| xi - f.eval(ti)).collect();
            let inflation = ar1_inflation(&resid);
            let (sg, om) = (
                crate::fit::Estimate {
                    value: sg.value,
                    se: sg.se * inflation,
                },
                crate::fit::Estimate {
                    value: om.value,
                    se: om.se * inflation,
                },
            );
            let mean = x.iter().sum::<f64>() / x.len() as f64;
            let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>();
            let vaf = 1.0 - f.residual_rms.powi(2) * (x.len() - f.params.len()) as f64 / var;
            Ok(decay(
                FittedFrom::RollRate,
                Eigenvalue {
                    re: -sg.value,
                    im: om.value,
                    re_se: sg.se,
                    im_se: om.se,
                    re_se_noise: sg.se / inflation,
                    im_se_noise: om.se / inflation,
                    re_im_corr: -corr,
                    re_se_resampled: f64::NAN,
                    im_se_resampled: f64::NAN,
                    re_se_drift: 0.0,
                    im_se_drift: 0.0,
                },
                None,
                Vec::new(),
                [vaf, vaf],
            ))
        }
        _ => Err(err(
            path,
            "a free decay is fitted from roll and steer angles (roll_rad/roll_deg and \
             steer_rad/steer_deg) or from the roll rate (roll_rate_rad_per_s): the file has neither \
             (name other columns with --columns roll=…,steer=… or roll_rate=…)",
        )),
    }
}

/// The speed where a decay applies: its wheel-speed column over the window when the file has
/// one, else the reading `given` (uniform within half its display step, with its own error).
pub fn decay_speed(
    decay: &CsvDecay,
    given: Option<NotedReading>,
) -> Option<(Measured, SpeedSource)> {
    match (decay.wheel_speed_mps, given) {
        (Some(v), _) => Some((v, SpeedSource::WheelSpeed)),
        (None, Some(r)) => Some((Measured::new(r.speed_mps, r.se_mps()), SpeedSource::Noted)),
        (None, None) => None,
    }
}

/// A kick found in a long recording, and the free decay after it.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Kick {
    /// The roll rate's peak (s): where the kick's push has ended.
    pub at_s: f64,
    pub peak_roll_rate_rad_per_s: f64,
    /// The free decay: from the peak until a swing grows again (a hand, the harness, the next
    /// kick) or [`DECAY_MAX_S`] after it.
    pub window_s: (f64, f64),
}

/// A kick's peak roll rate is at least this many times the recording's background (the
/// median |roll rate| while the wheel turns at over [`MOVING_MPS`], or over the whole record
/// without a wheel-speed column): a riderless bicycle on a treadmill sways at the background
/// level, a kick stands out by an order of magnitude.
pub const KICK_OVER_BACKGROUND: f64 = 8.0;
/// Two peaks closer than this (s) are one kick (the larger).
pub const KICK_SEPARATION_S: f64 = 1.5;
/// A kick's peak is more than this many times the largest swing of the second before its push.
pub const KICK_OVER_SWING: f64 = 2.0;
/// How long before its roll-rate peak a kick's motion may start (s): a hand's push lasts
/// 0.1–0.5 s and may swing the bicycle one way before the largest swing back (the real
/// recording's kicks at 141.3 and 154.0 s: a half-swing of 0.6 rad/s, then the peak 0.4 s on).
const PUSH_S: f64 = 1.0;
/// The longest free decay taken after a kick (s).
pub const DECAY_MAX_S: f64 = 2.5;
/// The shortest (s): less is not a decay to fit.
pub const DECAY_MIN_S: f64 = 0.8;
/// A half-swing larger than this times the one before it is a new disturbance: a stable free
/// decay's swings shrink. (An unstable weave's grow from the start: give its window with
/// `--window`.)
const SWING_GROWTH: f64 = 1.0;
/// Below this wheel speed (m/s) the bicycle is not riding.
pub const MOVING_MPS: f64 = 0.5;

/// The roll rate of a ride: its column, or the roll's central difference.
fn roll_rate_series(ride: &CsvRide) -> Option<Vec<f64>> {
    if let Some(r) = &ride.roll_rate_rad_per_s {
        return Some(r.clone());
    }
    let roll = ride.roll_rad.as_ref()?;
    let t = &ride.time_s;
    let n = t.len();
    Some(
        (0..n)
            .map(|i| {
                let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
                if b > a && t[b] > t[a] {
                    (roll[b] - roll[a]) / (t[b] - t[a])
                } else {
                    0.0
                }
            })
            .collect(),
    )
}

/// Every kick of a long recording: peaks of |roll rate| over [`KICK_OVER_BACKGROUND`] times
/// the background, at least [`KICK_SEPARATION_S`] apart, each with its free decay (see
/// [`Kick::window_s`]). Errors when the file has neither roll rate nor roll.
pub fn find_kicks(ride: &CsvRide) -> Result<Vec<Kick>, RideError> {
    let rate = roll_rate_series(ride).ok_or_else(|| {
        err(
            &ride.path,
            "kicks are found in the roll rate or the roll angle: the file has neither",
        )
    })?;
    let t = &ride.time_s;
    let n = t.len();
    let moving: Vec<f64> = match &ride.wheel_speed_mps {
        Some(v) => (0..n)
            .filter(|&i| v[i] > MOVING_MPS)
            .map(|i| rate[i].abs())
            .collect(),
        None => rate.iter().map(|r| r.abs()).collect(),
    };
    if moving.len() < MIN_WINDOW_SAMPLES {
        return Ok(Vec::new());
    }
    let background = crate::signal::median(&moving);
    let threshold = KICK_OVER_BACKGROUND * background.max(f64::MIN_POSITIVE);
    // Peaks over the threshold, the larger of two close ones kept.
    let mut peaks: Vec<usize> = Vec::new();
    for i in 1..n.saturating_sub(1) {
        let a = rate[i].abs();
        if a <= threshold || a < rate[i - 1].abs() || a < rate[i + 1].abs() {
            continue;
        }
        match peaks.last_mut() {
            Some(p) if t[i] - t[*p] < KICK_SEPARATION_S => {
                if a > rate[*p].abs() {
                    *p = i;
                }
            }
            _ => peaks.push(i),
        }
    }
    // The swings' amplitudes from the rate's moving mean over about 0.1 s (a sensor's spikes
    // are no swing).
    let dt = (t[n - 1] - t[0]) / (n - 1) as f64;
    let half = ((0.05 / dt).round() as usize).max(1);
    let smooth = |i: usize| -> f64 {
        let (a, b) = (i.saturating_sub(half), (i + half + 1).min(n));
        rate[a..b].iter().sum::<f64>() / (b - a) as f64
    };
    // A kick arrives on a bicycle that is not already swinging at its size: a peak no more
    // than KICK_OVER_SWING times the largest swing of the second before the kick's motion
    // began is part of a motion under way (a decay's late swings, the capsize's drift).
    peaks.retain(|&p| {
        let before = (0..p)
            .rev()
            .take_while(|&i| t[p] - t[i] <= 1.0 + PUSH_S)
            .filter(|&i| t[p] - t[i] >= PUSH_S)
            .map(|i| smooth(i).abs())
            .fold(0.0f64, f64::max);
        rate[p].abs() > KICK_OVER_SWING * before
    });
    let mut kicks = Vec::new();
    for (k, &p) in peaks.iter().enumerate() {
        let limit = peaks
            .get(k + 1)
            .map_or(t[n - 1], |&q| t[q])
            .min(t[p] + DECAY_MAX_S);
        // Half-swings after the peak: the decay ends where one grows. A swing changes sides
        // when the rate passes a level beyond zero on the other side (the larger of twice the
        // background and a tenth of the peak), so that noise about a crossing is no swing.
        let level = (2.0 * background).max(0.1 * rate[p].abs());
        let mut end = limit;
        let mut side = rate[p].signum();
        let (mut start, mut amplitude, mut previous) = (t[p], 0.0f64, f64::INFINITY);
        for (i, &ti) in t.iter().enumerate().skip(p) {
            if ti > limit {
                break;
            }
            let r = smooth(i);
            if r * side < -level {
                if amplitude > SWING_GROWTH * previous {
                    end = start;
                    break;
                }
                previous = amplitude;
                side = -side;
                start = ti;
                amplitude = 0.0;
            }
            amplitude = amplitude.max(r.abs());
        }
        if end == limit && amplitude > SWING_GROWTH * previous {
            end = start;
        }
        if end - t[p] >= DECAY_MIN_S {
            kicks.push(Kick {
                at_s: t[p],
                peak_roll_rate_rad_per_s: rate[p],
                window_s: (t[p], end),
            });
        }
    }
    Ok(kicks)
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
        let mut text = format!("{}: {} kicks found\n", self.file, self.kicks.len());
        for (k, d) in self.kicks.iter().enumerate() {
            text += &format!(
                "\nkick {} at {:.2} s (roll rate {:+.3} rad/s), free decay {:.2} – {:.2} s\n",
                k + 1,
                d.kick.at_s,
                d.kick.peak_roll_rate_rad_per_s,
                d.kick.window_s.0,
                d.kick.window_s.1
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
    given: Option<NotedReading>,
    model: Option<&Parametrized>,
    options: &ModalOptions,
) -> Result<Vec<KickDecay>, RideError> {
    let (first, last) = match (ride.time_s.first(), ride.time_s.last()) {
        (Some(&a), Some(&b)) => (a, b),
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
            },
            decay: Some(DecaySummary::new(ride, decay, given, model)?),
            not_fitted: None,
        }]);
    }
    let kicks = find_kicks(ride)?;
    if kicks.is_empty() {
        return Err(err(
            &ride.path,
            format!(
                "no kick found in {:.1} s: no roll-rate peak over {KICK_OVER_BACKGROUND} times the                  background with {DECAY_MIN_S} s of free decay after it (give one with --window START:END)",
                last - first
            ),
        ));
    }
    Ok(kicks
        .into_iter()
        .map(|kick| {
            let fitted = fit_decay(ride, Some(kick.window_s), options).and_then(|d| {
                if let Some(w) = &ride.wheel_speed_mps {
                    let (a, b) = kick.window_s;
                    let v: Vec<f64> = (0..ride.time_s.len())
                        .filter(|&i| ride.time_s[i] >= a && ride.time_s[i] <= b)
                        .map(|i| w[i])
                        .collect();
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
        .collect())
}

/// √((1 + ρ)/(1 − ρ)) for the residuals' lag-one autocorrelation ρ (1 when ρ ≤ 0; ρ capped at
/// 0.95).
fn ar1_inflation(resid: &[f64]) -> f64 {
    let n = resid.len();
    if n < 3 {
        return 1.0;
    }
    let mean = resid.iter().sum::<f64>() / n as f64;
    let var: f64 = resid.iter().map(|r| (r - mean).powi(2)).sum();
    if var <= 0.0 {
        return 1.0;
    }
    let lag: f64 = resid
        .windows(2)
        .map(|w| (w[0] - mean) * (w[1] - mean))
        .sum();
    let rho = (lag / var).clamp(0.0, 0.95);
    ((1.0 + rho) / (1.0 - rho)).sqrt()
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
    pub model: Option<super::dynamic::ModelWeave>,
    /// The speed the lab set or noted for the ride (a treadmill's setting), when given: rides
    /// of one set speed are repeats of one set-up.
    #[serde(skip)]
    pub set_speed_mps: Option<f64>,
}

impl DecaySummary {
    /// The decay of `ride` with its speed (the wheel-speed column, else `given`) and, with a
    /// `model`, the model's weave there.
    pub fn new(
        ride: &CsvRide,
        decay: CsvDecay,
        given: Option<NotedReading>,
        model: Option<&Parametrized>,
    ) -> Result<DecaySummary, RideError> {
        let speed = decay_speed(&decay, given);
        let model = match (model, speed) {
            (Some(m), Some((v, _))) => Some(super::dynamic::model_weave_at(
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
            set_speed_mps: given.map(|g| g.speed_mps),
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
        let _ = writeln!(
            out,
            "weave            {:.3} ± {:.3} {} {:.3} ± {:.3}i 1/s",
            w.re,
            w.re_se,
            if w.im < 0.0 { "-" } else { "+" },
            w.im.abs(),
            w.im_se
        );
        if !d.resolves_weave() {
            let _ = writeln!(
                out,
                "                 no weave resolved: ω's standard error exceeds ω (no free decay here?)"
            );
        }
        match &d.shape {
            Some(s) => {
                let _ = writeln!(
                    out,
                    "mode shape       |γ/θ| {:.3} ± {:.3} rad/rad at {:.1} ± {:.1}°",
                    s.ratio.value,
                    s.ratio.se,
                    s.phase_rad.value.to_degrees(),
                    s.phase_rad.se.to_degrees()
                );
                let _ = writeln!(out, "VAF              θ {:.3}, γ {:.3}", d.vaf[0], d.vaf[1]);
            }
            None => {
                let _ = writeln!(
                    out,
                    "mode shape       not measured (fitted from the roll rate alone)"
                );
                let _ = writeln!(out, "VAF              roll rate {:.3}", d.vaf[0]);
            }
        }
        match (&self.speed_mps, self.speed_source) {
            (Some(v), Some(src)) => {
                let _ = writeln!(
                    out,
                    "speed            {:.3} ± {:.3} m/s ({})",
                    v.value,
                    v.se,
                    match src {
                        SpeedSource::WheelSpeed => "the wheel-speed column over the window",
                        _ => "the reading given",
                    }
                );
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
