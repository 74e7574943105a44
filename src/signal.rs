//! Signal: one scalar oscillation on a uniform sample grid, with its gaps.
//!
//! In: a [`Log`] (orientation or calibrated file) or a plain CSV `time_s,value` file, read by
//! [`crate::read`] (which the file is, its content says).
//! Out: a [`Signal`] — the rotation angle of a pendulum test about its own dominant axis (rad),
//! or a chosen channel as written (e.g. `Gyr_Z` in rad/s), or the CSV's values.
//!
//! The angle from orientations uses the rotation relative to the rest orientation, as a rotation
//! vector in the sensor frame, projected on the principal direction of its motion. A sensor
//! mounted with any rotation `M` on the body sees the rotation vector `Mᵀr`, whose projection on
//! its own principal direction is the same number: the signal does not depend on how the sensor
//! sits on the body, and it has no Euler singularity.

use crate::read::log::{Log, LogError, OutputMode, ReadOptions};
use nalgebra::{Matrix3, SymmetricEigen, UnitQuaternion, Vector3};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

/// A scalar signal sampled on a uniform grid; missing samples are absent.
#[derive(Debug, Clone, PartialEq)]
pub struct Signal {
    /// What the values are (`rotation about dominant axis`, a column name, …).
    pub name: String,
    /// Unit of the values (`rad`, `rad/s`, `V`, …).
    pub unit: String,
    pub sample_rate_hz: f64,
    /// Time of grid index 0, seconds.
    pub t0_s: f64,
    /// Grid position of each sample.
    pub index: Vec<u64>,
    pub values: Vec<f64>,
}

impl Signal {
    /// Samples `from..=to` of this signal with `values` in place of its own: the same name,
    /// unit and grid, the rest of its samples not copied (a struct update from a clone copied
    /// every sample, then dropped them).
    pub fn part(&self, from: usize, to: usize, values: Vec<f64>) -> Signal {
        Signal {
            name: self.name.clone(),
            unit: self.unit.clone(),
            sample_rate_hz: self.sample_rate_hz,
            t0_s: self.t0_s,
            index: self.index[from..=to].to_vec(),
            values,
        }
    }
}

/// Errors of signal extraction.
#[derive(Debug, thiserror::Error)]
pub enum SignalError {
    #[error(transparent)]
    Log(#[from] LogError),
    /// Samples given as arrays ([`Signal::from_samples`]): `sample` counts from 0.
    #[error("sample {sample}: {message}")]
    Samples { sample: usize, message: String },
    #[error("{path}:{line}: channel `{channel}` is not in this file (columns: {available})")]
    NoChannel {
        path: PathBuf,
        line: usize,
        channel: String,
        available: String,
    },
    #[error("{path}:{line}: channel `{channel}` is not in this file and needs the calibrated file {cal}, which does not exist")]
    MissingCal {
        path: PathBuf,
        line: usize,
        channel: String,
        cal: PathBuf,
    },
    #[error("{path}:{line}: sensor `{sensor}` is not in this file (sensors: {available})")]
    NoSensor {
        path: PathBuf,
        line: usize,
        sensor: String,
        available: String,
    },
    #[error("{path}:{line}: the file has {count} sensors; name one with --sensor ({available})")]
    WhichSensor {
        path: PathBuf,
        line: usize,
        count: usize,
        available: String,
    },
    #[error("{path}:{line}: a calibrated file has no orientation; name a channel (e.g. Gyr_Z)")]
    NoOrientation { path: PathBuf, line: usize },
    #[error("{path}:{line}:{column}: {message}")]
    Csv {
        path: PathBuf,
        line: u64,
        column: usize,
        message: String,
    },
    #[error("{path}:{line}: {message}")]
    Invalid {
        path: PathBuf,
        line: usize,
        message: String,
    },
}

impl Signal {
    /// Times of the samples, seconds.
    pub fn times_s(&self) -> Vec<f64> {
        let dt = 1.0 / self.sample_rate_hz;
        self.index
            .iter()
            .map(|&i| self.t0_s + i as f64 * dt)
            .collect()
    }

    pub fn len(&self) -> usize {
        self.values.len()
    }

    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// Duration spanned, seconds.
    pub fn duration_s(&self) -> f64 {
        match (self.index.first(), self.index.last()) {
            (Some(a), Some(b)) => (b - a) as f64 / self.sample_rate_hz,
            _ => 0.0,
        }
    }

    /// The samples whose time lies in `[start_s, end_s]`.
    pub fn slice_time(&self, start_s: f64, end_s: f64) -> Signal {
        let t = self.times_s();
        let keep: Vec<usize> = (0..t.len())
            .filter(|&i| t[i] >= start_s && t[i] <= end_s)
            .collect();
        Signal {
            name: self.name.clone(),
            unit: self.unit.clone(),
            sample_rate_hz: self.sample_rate_hz,
            t0_s: self.t0_s,
            index: keep.iter().map(|&i| self.index[i]).collect(),
            values: keep.iter().map(|&i| self.values[i]).collect(),
        }
    }

    /// A signal from its times `t` (s) and values `x`, gridded as a CSV's ([`sampling_grid`]):
    /// finite, as many of each, at least 8, times advancing.
    pub fn from_samples(name: &str, t: &[f64], x: &[f64]) -> Result<Signal, SignalError> {
        let bad = |sample: usize, message: String| SignalError::Samples { sample, message };
        if t.len() != x.len() {
            return Err(bad(
                t.len().min(x.len()),
                format!("{} times but {} values", t.len(), x.len()),
            ));
        }
        if t.len() < MIN_SAMPLES {
            return Err(bad(
                t.len(),
                format!("only {} samples: too few for a signal", t.len()),
            ));
        }
        if let Some(i) = (0..t.len()).find(|&i| !t[i].is_finite() || !x[i].is_finite()) {
            return Err(bad(
                i,
                format!("not a finite number (time {}, value {})", t[i], x[i]),
            ));
        }
        if let Some((i, message)) = not_advancing(t) {
            return Err(bad(i, message));
        }
        let (dt, index) = sampling_grid(t).map_err(|(i, message)| bad(i, message))?;
        Ok(Signal {
            name: name.to_string(),
            unit: String::new(),
            sample_rate_hz: 1.0 / dt,
            t0_s: t[0],
            index,
            values: x.to_vec(),
        })
    }
}

/// The first sample whose time `t` (s) does not advance from the one before it, with the
/// message saying so.
pub(crate) fn not_advancing(t: &[f64]) -> Option<(usize, String)> {
    t.windows(2).position(|w| w[1] <= w[0]).map(|i| {
        (
            i + 1,
            format!("time {} s does not advance from {} s", t[i + 1], t[i]),
        )
    })
}

/// The fewest samples a signal may have.
pub(crate) const MIN_SAMPLES: usize = 8;

/// The sampling grid of advancing times `t` (s, at least two): the median step and each
/// sample's grid index. Times must lie within a quarter step of the grid, and no hole may
/// exceed [`MAX_GAP_S`] or [`grid_span_limit`]; an error gives the offending sample's index.
pub fn sampling_grid(t: &[f64]) -> Result<(f64, Vec<u64>), (usize, String)> {
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let dt = steps[steps.len() / 2];
    let mut index = Vec::with_capacity(t.len());
    for (i, &ti) in t.iter().enumerate() {
        let k = (ti - t[0]) / dt;
        let r = k.round();
        let gap_s = i.checked_sub(1).map_or(0.0, |p| ti - t[p]);
        if gap_s > MAX_GAP_S || r > grid_span_limit(i, 1.0 / dt) as f64 {
            return Err((i, gap_too_long_message(gap_s)));
        }
        if (k - r).abs() > 0.25 {
            return Err((
                i,
                format!("time {ti} s is off the {:.6} s sampling grid", dt),
            ));
        }
        index.push(r as u64);
    }
    Ok((dt, index))
}

// The limits on a recording's holes are the log reader's ([`crate::read::log`]); a CSV's time
// column is held to the same.
pub use crate::read::log::{
    gap_too_long_message, grid_span_limit, MAX_GAP_S, MAX_HOLE_S, MAX_HOLE_SAMPLES,
};

/// Which signal to take from a log.
#[derive(Debug, Clone, Default)]
pub enum Extract {
    /// The rotation angle about the dominant axis of motion (orientation files).
    #[default]
    DominantRotation,
    /// A channel by column name (`Gyr_Z`, `00300417_Roll`); looked up in the `_cal` file when
    /// the orientation file does not have it.
    Channel(String),
}

/// A signal as [`load_signal`] read it, with what the reader noticed.
#[derive(Debug, Clone)]
pub struct LoadedSignal {
    pub signal: Signal,
    /// The reader's warnings (gaps, corrupt rows).
    pub warnings: Vec<String>,
    /// Rows whose receiver time was more than half a sample off the counter's (jitter, late
    /// delivery), placed by the counter: [`crate::read::log::GapReport::time_off_rows`], of the log
    /// the signal came from.
    pub time_off_rows: usize,
}

/// Opens a log or CSV file (by its content, [`crate::read::kind`]) and extracts one scalar
/// signal from it. `sensor` picks a sensor by id or label when the file has several.
pub fn load_signal(
    path: &Path,
    extract: &Extract,
    sensor: Option<&str>,
    options: &ReadOptions,
) -> Result<LoadedSignal, SignalError> {
    if crate::read::kind::recognise(path) == crate::read::kind::Kind::Table {
        return Ok(LoadedSignal {
            signal: Signal::from_csv(path)?,
            warnings: Vec::new(),
            time_off_rows: 0,
        });
    }
    let loaded = |signal: Signal, log: Log| LoadedSignal {
        signal,
        time_off_rows: log.gaps.time_off_rows,
        warnings: log.warnings,
    };
    match extract {
        Extract::DominantRotation => {
            // A log of several sensors without one named is refused from its header, before
            // its rows are read.
            if sensor.is_none() {
                let header_only = ReadOptions {
                    header_only: true,
                    ..options.clone()
                };
                let head = Log::open(path, &header_only)?;
                if head.sensors.len() > 1 {
                    pick_sensor(&head, None)?;
                }
            }
            // Only the sensor named is kept (a two-sensor log's other columns were half the
            // memory of a long recording's period).
            let options = ReadOptions {
                only_sensor: sensor.map(str::to_string),
                ..options.clone()
            };
            let log = Log::open(path, &options)?;
            let signal = dominant_rotation(&log, sensor)?;
            Ok(loaded(signal, log))
        }
        Extract::Channel(name) => {
            let log = Log::open(path, options)?;
            if let Some(s) = channel(&log, name, sensor) {
                return Ok(loaded(s, log));
            }
            if log.mode == OutputMode::Calibrated {
                return Err(no_channel(&log, name));
            }
            let cal = Log::cal_path(path);
            if !cal.exists() {
                return Err(SignalError::MissingCal {
                    path: path.to_path_buf(),
                    line: log.column_row_line,
                    channel: name.clone(),
                    cal,
                });
            }
            let cal_log = Log::open(&cal, options)?;
            let s = channel(&cal_log, name, sensor).ok_or_else(|| no_channel(&cal_log, name))?;
            let mut w = log.warnings;
            w.extend(cal_log.warnings);
            Ok(LoadedSignal {
                signal: s,
                warnings: w,
                time_off_rows: cal_log.gaps.time_off_rows,
            })
        }
    }
}

fn no_channel(log: &Log, name: &str) -> SignalError {
    SignalError::NoChannel {
        path: log.path.clone(),
        line: log.column_row_line,
        channel: name.to_string(),
        available: log.columns.join(", "),
    }
}

/// A column of the log as a signal, by full name or by short name within the chosen sensor.
pub fn channel(log: &Log, name: &str, sensor: Option<&str>) -> Option<Signal> {
    let idx = match sensor.and_then(|s| log.sensor(s)) {
        Some(s) if !s.id.is_empty() => log
            .column_index(&format!("{}_{name}", s.id))
            .or_else(|| log.column_index(name)),
        _ => log.column_index(name),
    }?;
    let unit = match log.mode {
        OutputMode::Euler => "deg",
        OutputMode::Calibrated if name.contains("Gyr") => "rad/s",
        OutputMode::Calibrated if name.contains("Acc") => "m/s²",
        _ => "",
    };
    Some(Signal {
        name: log.columns[idx].clone(),
        unit: unit.to_string(),
        sample_rate_hz: log.sample_rate_hz,
        t0_s: 0.0,
        index: log.grid_index.clone(),
        values: log.data[idx].clone(),
    })
}

/// Picks the sensor: by key, or the only one.
pub fn pick_sensor<'l>(
    log: &'l Log,
    key: Option<&str>,
) -> Result<&'l crate::read::log::Sensor, SignalError> {
    let available = || {
        log.sensors
            .iter()
            .map(|s| {
                if s.label.is_empty() {
                    s.id.clone()
                } else {
                    format!("{} ({})", s.id, s.label)
                }
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    match key {
        Some(k) => log.sensor(k).ok_or_else(|| SignalError::NoSensor {
            path: log.path.clone(),
            line: log.column_row_line,
            sensor: k.to_string(),
            available: available(),
        }),
        None if log.sensors.len() == 1 => Ok(&log.sensors[0]),
        None => Err(SignalError::WhichSensor {
            path: log.path.clone(),
            line: log.column_row_line,
            count: log.sensors.len(),
            available: available(),
        }),
    }
}

/// The median of `x` (the mean of the two middle values for an even count); NaN when empty.
/// By selection, O(n): the values a full sort would put in the middle.
pub fn median(x: &[f64]) -> f64 {
    let mut v = x.to_vec();
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    let (lower, &mut upper, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    if n % 2 == 1 {
        return upper;
    }
    // The largest of the lower half is the other middle value.
    let below = lower
        .iter()
        .copied()
        .max_by(f64::total_cmp)
        .unwrap_or(upper);
    0.5 * (below + upper)
}

/// `angle` (rad) moved by whole turns into [−π, π).
pub fn wrap_pi(angle: f64) -> f64 {
    (angle + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

/// `angle` (rad) moved by whole turns to within ±π of `near`.
pub fn wrap_near(angle: f64, near: f64) -> f64 {
    near + wrap_pi(angle - near)
}

/// The mean of a set of nearby rotations (normalised sum of sign-aligned quaternions).
pub fn mean_rotation(qs: &[UnitQuaternion<f64>]) -> Option<UnitQuaternion<f64>> {
    let first = qs.first()?;
    let mut sum = nalgebra::Vector4::zeros();
    for q in qs {
        let c = q.coords;
        sum += if c.dot(&first.coords) < 0.0 { -c } else { c };
    }
    let n = sum.norm();
    (n > 0.0).then(|| UnitQuaternion::from_quaternion(nalgebra::Quaternion::from(sum / n)))
}

/// Rotation of the sensor relative to its rest orientation, about the dominant axis of the motion (rad).
///
/// The rest orientation is the mean over the first second of the record (or its first tenth when
/// shorter); `r(t) = log(q_rest⁻¹ q(t))` is the rotation vector in the sensor frame; the axis is the
/// principal eigenvector of the covariance of `r`; the sign makes the axis, seen in the global
/// frame, point along its largest global component.
pub fn dominant_rotation(log: &Log, sensor: Option<&str>) -> Result<Signal, SignalError> {
    if log.mode == OutputMode::Calibrated {
        return Err(SignalError::NoOrientation {
            path: log.path.clone(),
            line: log.column_row_line,
        });
    }
    let s = pick_sensor(log, sensor)?;
    // The orientations are streamed in passes (the rest, the mean, the spread, the values),
    // never held (a 92 MB log's quaternions and rotation vectors were 140 MB): the same
    // numbers in the same order as held ones.
    let too_few = |n: usize| SignalError::Invalid {
        path: log.path.clone(),
        line: log.column_row_line,
        message: format!("only {n} samples: too few for a signal"),
    };
    let n = log
        .each_orientation(s, |_| ControlFlow::Break(()))
        .unwrap_or(0);
    if n < 8 {
        return Err(too_few(n));
    }
    let rest_n = (log.sample_rate_hz.round() as usize).min(n / 10).max(1);
    let mut head = Vec::with_capacity(rest_n);
    log.each_orientation(s, |q| {
        head.push(*q);
        if head.len() == rest_n {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })
    .ok_or_else(|| too_few(0))?;
    let rest = mean_rotation(&head).ok_or_else(|| SignalError::Invalid {
        path: log.path.clone(),
        line: log.column_row_line,
        message: "cannot average the rest orientation".into(),
    })?;
    let rest_inv = rest.inverse();
    // Each sample's rotation from the rest, in blocks made on rayon's threads and visited in
    // order (the sums below in the order of a sequential pass). The rotation vector of
    // `rest⁻¹ q` is that of `rest⁻¹ (−q)` bit for bit (nalgebra's axis and angle take |w|), so
    // the quaternions' signs need not be made continuous here.
    let each_r = |visit: &mut dyn FnMut(Vector3<f64>)| {
        use rayon::prelude::*;
        const BLOCK: usize = 1 << 14;
        let mut block = Vec::with_capacity(BLOCK.min(n));
        for start in (0..n).step_by(BLOCK) {
            (start..(start + BLOCK).min(n))
                .into_par_iter()
                .map(|i| {
                    log.orientation_at(s, i)
                        .map_or(Vector3::from_element(f64::NAN), |q| {
                            (rest_inv * q).scaled_axis()
                        })
                })
                .collect_into_vec(&mut block);
            block.iter().for_each(|r| visit(*r));
        }
    };
    let mut sum = Vector3::zeros();
    each_r(&mut |r| sum += r);
    let mean = sum / n as f64;
    let mut cov = Matrix3::zeros();
    each_r(&mut |r| {
        let d = r - mean;
        cov += d * d.transpose();
    });
    let eig = cov
        .iter()
        .all(|x| x.is_finite())
        .then(|| SymmetricEigen::try_new(cov, f64::EPSILON, crate::MAX_DECOMPOSITION_ITERATIONS))
        .flatten()
        .ok_or_else(|| SignalError::Invalid {
            path: log.path.clone(),
            line: log.column_row_line,
            message: "the rotations' spread has no axis (not a number)".into(),
        })?;
    let k = eig.eigenvalues.imax();
    let mut axis: Vector3<f64> = eig.eigenvectors.column(k).into_owned();
    let axis_global = rest * axis;
    if axis_global[axis_global.iamax()] < 0.0 {
        axis = -axis;
    }
    let mut values = Vec::with_capacity(n);
    each_r(&mut |r| values.push(r.dot(&axis)));
    let label = if s.label.is_empty() {
        s.id.clone()
    } else {
        s.label.clone()
    };
    Ok(Signal {
        name: format!("rotation of {label} about its dominant axis"),
        unit: "rad".into(),
        sample_rate_hz: log.sample_rate_hz,
        t0_s: 0.0,
        index: log.grid_index.clone(),
        values,
    })
}
