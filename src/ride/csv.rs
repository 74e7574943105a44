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

    /// The column names recognised without `--columns`, each with its factor to SI.
    fn names(self) -> &'static [(&'static str, f64)] {
        const DEG: f64 = std::f64::consts::PI / 180.0;
        match self {
            Quantity::Time => &[("time_s", 1.0), ("time", 1.0), ("t", 1.0)],
            Quantity::Roll => &[("roll_rad", 1.0), ("roll_deg", DEG)],
            Quantity::RollRate => &[("roll_rate_rad_per_s", 1.0), ("roll_rate_deg_per_s", DEG)],
            Quantity::Steer => &[("steer_rad", 1.0), ("steer_deg", DEG)],
            Quantity::SteerRate => &[("steer_rate_rad_per_s", 1.0), ("steer_rate_deg_per_s", DEG)],
            Quantity::WheelSpeed => &[
                ("rear_wheel_speed_m_per_s", 1.0),
                ("wheel_speed_m_per_s", 1.0),
                ("speed_m_per_s", 1.0),
            ],
        }
    }
}

/// Column names given for quantities (`--columns roll_rate=gyro_x,time=time`); a name ending
/// in `_deg` or `_deg_per_s` is read as degrees, any other as SI.
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
            out.push((q, name.trim().to_string()));
        }
        Ok(Columns(out))
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
/// A time column is required and must advance; a named column that is missing is an error, an
/// unnamed quantity without a recognised column is simply absent.
pub fn read_csv_ride(path: &Path, given: &Columns) -> Result<CsvRide, RideError> {
    let file = std::fs::File::open(path).map_err(|e| err(path, format!("cannot read: {e}")))?;
    let table = CsvTable::read(file, path)?;
    let mut found: Vec<(Quantity, usize, f64, String)> = Vec::new();
    for q in Quantity::ALL {
        let pick = match given.0.iter().find(|(g, _)| *g == q) {
            Some((_, name)) => {
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
                Some((
                    k,
                    if deg {
                        std::f64::consts::PI / 180.0
                    } else {
                        1.0
                    },
                ))
            }
            None => q
                .names()
                .iter()
                .find_map(|(n, f)| table.find(&[n]).map(|k| (k, *f))),
        };
        if let Some((k, factor)) = pick {
            found.push((q, k, factor, table.headers[k].clone()));
        }
    }
    if !found.iter().any(|f| f.0 == Quantity::Time) {
        return Err(err(
            path,
            format!(
                "no time column (time_s, or --columns time=NAME); the columns: {}",
                table.headers.join(", ")
            ),
        ));
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
    for ((q, _, factor, _), v) in found.iter().zip(values) {
        let v: Vec<f64> = v.into_iter().map(|x| x * factor).collect();
        match q {
            Quantity::Time => ride.time_s = v,
            Quantity::Roll => ride.roll_rad = Some(v),
            Quantity::RollRate => ride.roll_rate_rad_per_s = Some(v),
            Quantity::Steer => ride.steer_rad = Some(v),
            Quantity::SteerRate => ride.steer_rate_rad_per_s = Some(v),
            Quantity::WheelSpeed => ride.wheel_speed_mps = Some(v),
        }
    }
    table.advancing(&ride.time_s)?;
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
                     (finding every kick of a long recording is not implemented yet)",
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

/// Where a CSV decay's speed comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CsvSpeedSource {
    /// The wheel-speed column over the window.
    WheelSpeed,
    /// Given on the command line (`--speed`).
    Given,
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
    pub speed_source: Option<CsvSpeedSource>,
    /// The model's weave at that speed, when a bicycle was given.
    pub model: Option<super::dynamic::ModelWeave>,
}

impl DecaySummary {
    pub fn new(
        ride: &CsvRide,
        decay: CsvDecay,
        speed: Option<(Measured, CsvSpeedSource)>,
        model: Option<super::dynamic::ModelWeave>,
    ) -> DecaySummary {
        DecaySummary {
            file: ride.path.display().to_string(),
            columns: ride.columns.clone(),
            decay,
            speed_mps: speed.map(|s| s.0),
            speed_source: speed.map(|s| s.1),
            model,
        }
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
                        CsvSpeedSource::WheelSpeed => "the wheel-speed column over the window",
                        CsvSpeedSource::Given => "given",
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
                "model weave      {:.3} ± {:.3} + {:.3} ± {:.3}i 1/s: experiment − model {:+.1} σ (real), {:+.1} σ (imaginary)",
                m.re, m.re_se, m.im, m.im_se, m.re_z, m.im_z
            );
        }
        out
    }
}
