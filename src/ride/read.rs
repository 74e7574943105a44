//! Ride stage (dynamic tests, seed §5.4): a ride's log pair → the frame's roll θ(t) and the
//! steer angle γ(t).
//!
//! In: the angles file (orientation of the frame and handlebar sensors) and its `_cal` file
//! (accelerations). Out: [`RideSignals`]: θ and γ on the 100 Hz grid (rad; roll positive leaning
//! right, steer positive turning right, as in the benchmark), with the mountings found.
//!
//! How each sensor sits is found from the ride itself, not from the lab's notes (known to a few
//! degrees): while the bicycle stands still and upright the accelerometers give "up" in each
//! sensor's frame; while it is pushed straight ahead the frame sensor's horizontal acceleration
//! gives "forward". Roll is then the frame's tilt about its forward axis relative to the
//! vertical, independent of the heading (so of the magnetometer's offset and drift); steer is the
//! handlebar sensor's rotation relative to the frame sensor, about the steer axis, measured from
//! its orientation at the standstill.

use crate::read::log::{Log, LogError, ReadOptions};
use nalgebra::{Rotation3, UnitQuaternion, Vector3};
use std::path::{Path, PathBuf};

/// Errors of the ride stage: what is wrong with a ride log, named.
#[derive(Debug, thiserror::Error)]
pub enum RideError {
    #[error(transparent)]
    Log(#[from] LogError),
    /// A CSV ride's table (its error names file, line and column).
    #[error(transparent)]
    Csv(#[from] crate::signal::SignalError),
    #[error("{path}: {message}")]
    Ride { path: PathBuf, message: String },
}

/// A ride's own error: `path` and what is wrong with it ([`RideError::Ride`]).
pub(crate) fn err(path: &Path, message: impl Into<String>) -> RideError {
    RideError::Ride {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// A ride's angles on the sample grid.
#[derive(Debug, Clone)]
pub struct RideSignals {
    /// Grid index of each sample (both sensors present).
    pub index: Vec<u64>,
    pub sample_rate_hz: f64,
    /// Roll of the frame (rad).
    pub roll_rad: Vec<f64>,
    /// Steer angle (rad).
    pub steer_rad: Vec<f64>,
    /// The frame's heading (rad, unwrapped; offset and drift of the magnetometer included): only
    /// its rate is used, to check which sensor is where.
    pub heading_rad: Vec<f64>,
    /// The mounting found for the frame sensor: rotation bicycle axes → sensor axes.
    pub frame_mounting: UnitQuaternion<f64>,
    /// The angles file as read (its `Sync` column gives the speed).
    pub log: Log,
    /// Grid index of each sample of the `_cal` file (the rows of the two series below).
    pub imu_index: Vec<u64>,
    /// How many of those samples fall in the standstill.
    pub standstill_samples: usize,
    /// The frame sensor's acceleration along the bicycle's forward axis less its standstill
    /// mean (m/s²): the forward acceleration, gravity and the accelerometer's bias removed
    /// (the forward axis is horizontal at the standstill, and stays so on level ground).
    pub forward_accel_mps2: Vec<f64>,
    /// The frame's yaw rate about the vertical (rad/s, positive turning right as in the
    /// benchmark): the frame gyro less its standstill bias, turned into earth axes by the
    /// sensor's orientation (its tilt only matters: no magnetometer in it); NaN where the
    /// angles file lacks the sample.
    pub yaw_rate_rad_per_s: Vec<f64>,
    /// Per `_cal` sample, the frame sensor's motion about the rear contact: what its lever arm
    /// adds to its acceleration along each bicycle axis, and its lateral and vertical
    /// accelerations, from which that arm is found ([`LeverSample`]).
    pub lever: Vec<LeverSample>,
    /// When the kick struck (s, the peak of the frame's lateral acceleration after the push).
    pub kick_s: f64,
    /// When the bicycle was caught or the motion was lost (s): the last moment the frame's
    /// gyro still shows motion above its noise.
    pub catch_s: f64,
    /// When the push ended (s): the last moment before the kick that the frame's forward
    /// acceleration (0.1 s mean) exceeded [`RELEASE_MPS2`]; `None` when it never did.
    pub release_s: Option<f64>,
}

/// One `_cal` sample of the frame sensor's motion about the rear frame's point at the rear
/// contact, which moves at the riding speed v along the bicycle's forward axis: with the
/// sensor at r from it (sensor axes), the sensor's acceleration along a bicycle axis e is that
/// point's, `(v̇, v ω_z, −v ω_y)` in the bicycle's axes (x forward, y left, z up, the rear
/// frame pitch-free), plus `e · (ω̇ × r + ω × (ω × r)) = c_e · r` with
/// `c_e = e × ω̇ + (e · ω) ω − |ω|² e` (ω the gyro less its standstill bias and ω̇, both from
/// `smoothed_rate`). [`LeverSample::MISSING`] near a gap and where the angles file lacks the
/// sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeverSample {
    /// `c_e` along the forward, left and up axes (1/s², per metre of r's sensor-axis
    /// components).
    pub forward: [f64; 3],
    pub lateral: [f64; 3],
    pub vertical: [f64; 3],
    /// The sensor's acceleration along the left and up axes (m/s²), gravity removed: the
    /// standstill's specific force turned by the sensor's orientation since then.
    pub lateral_accel_mps2: f64,
    pub vertical_accel_mps2: f64,
    /// The frame's rates about the up and left axes (rad/s, sensor's gyro in bicycle axes).
    pub up_rate_rad_per_s: f64,
    pub left_rate_rad_per_s: f64,
}

impl LeverSample {
    /// A sample without its terms: every one NaN.
    pub const MISSING: LeverSample = LeverSample {
        forward: [f64::NAN; 3],
        lateral: [f64::NAN; 3],
        vertical: [f64::NAN; 3],
        lateral_accel_mps2: f64::NAN,
        vertical_accel_mps2: f64::NAN,
        up_rate_rad_per_s: f64::NAN,
        left_rate_rad_per_s: f64::NAN,
    };
}

/// Half the width of the window (samples) over which [`smoothed_rate`] fits the gyro: 15
/// samples, 0.15 s at 100 Hz, pass a weave of up to 2 Hz unchanged (the quadratic's response
/// at 2 Hz: 0.98) and cut the angular acceleration's noise twelvefold against a central
/// difference.
const RATE_HALF_WIDTH: usize = 7;

/// The gyro's rate and its derivative at sample `k` (rad/s, rad/s²): a quadratic fitted by least
/// squares over the [`RATE_HALF_WIDTH`] samples either side (Savitzky and Golay 1964), `None`
/// where the window is not whole (a gap, the log's ends). A central difference of the raw rates
/// has noise σ·rate/√2 in ω̇, which, as a regressor, pulled a fitted lever arm toward zero:
/// 0.30–0.37 m for the simulated sensor's 0.71 m above the rear contact.
fn smoothed_rate(
    rates: &[Vector3<f64>],
    grid: &[u64],
    k: usize,
    rate_hz: f64,
) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let h = RATE_HALF_WIDTH;
    let (lo, hi) = (k.checked_sub(h)?, k + h);
    if hi >= rates.len() || grid[hi] - grid[lo] != 2 * h as u64 {
        return None;
    }
    // The quadratic's value at the centre: weights (3(3h² + 3h − 1) − 15 j²) / ((2h + 3)(2h + 1)(2h − 1));
    // its slope: j / Σ j².
    let hf = h as f64;
    let norm = (2.0 * hf + 3.0) * (2.0 * hf + 1.0) * (2.0 * hf - 1.0);
    let sum_j2 = hf * (hf + 1.0) * (2.0 * hf + 1.0) / 3.0;
    let (mut value, mut slope) = (Vector3::zeros(), Vector3::zeros());
    for (i, w) in rates[lo..=hi].iter().enumerate() {
        let j = i as f64 - hf;
        value += w * ((3.0 * (3.0 * hf * hf + 3.0 * hf - 1.0) - 15.0 * j * j) / norm);
        slope += w * (j / sum_j2);
    }
    Some((value, slope * rate_hz))
}

/// The forward acceleration (m/s²) below which the bicycle is coasting: a push accelerates
/// it by 1–3 m/s², coasting slows it by 0.05–0.2 m/s².
pub const RELEASE_MPS2: f64 = 0.3;

/// The shortest ride log (s): standstill, push, release, kick and a free motion of at least a
/// second take more.
const MIN_RIDE_S: f64 = 3.0;

/// The two files of a ride are one recording: written from the same packets, they start at the
/// same counter and span the same time (within a second); and a ride lasts at least
/// [`MIN_RIDE_S`].
fn check_pair(angles: &Path, log: &Log, cal: &Log) -> Result<(), RideError> {
    let span_s = |l: &Log| l.grid_len() as f64 / l.sample_rate_hz;
    let (a, c) = (span_s(log), span_s(cal));
    if a < MIN_RIDE_S {
        return Err(err(
            angles,
            format!(
                "the log holds {a:.2} s: a ride (standstill, push, release, kick, free motion) \
                 takes at least {MIN_RIDE_S} s"
            ),
        ));
    }
    if cal.first_counter != log.first_counter || (a - c).abs() > 1.0 {
        return Err(err(
            angles,
            format!(
                "its _cal file is not the same recording: the angles start at packet {} and span \
                 {a:.2} s, the _cal file starts at packet {} and spans {c:.2} s (the two files of a \
                 ride are written from the same packets)",
                log.first_counter, cal.first_counter
            ),
        ));
    }
    Ok(())
}

/// Reads a ride's log pair and extracts θ and γ; `steer_axis_tilt_rad` is λ of the bicycle.
/// The first `standstill_s` seconds must be the bicycle standing still and upright.
pub fn read_ride(
    angles: &Path,
    steer_axis_tilt_rad: f64,
    standstill_s: f64,
) -> Result<RideSignals, RideError> {
    let opts = ReadOptions::default();
    let log = Log::open(angles, &opts)?;
    let cal_path = Log::cal_path(angles);
    if !cal_path.exists() {
        return Err(err(angles, format!("the accelerations ({}) are needed to find how the sensors sit, and that file does not exist", cal_path.display())));
    }
    let cal = Log::open(&cal_path, &opts)?;
    check_pair(angles, &log, &cal)?;
    let find = |key: &str| {
        log.sensor(key).ok_or_else(|| {
            err(
                angles,
                format!(
                    "no `{key}` sensor (sensors: {})",
                    log.sensors
                        .iter()
                        .map(|s| s.label.clone())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
        })
    };
    let (frame, bar) = (find("frame")?, find("handlebar")?);
    let (frame_q, bar_q) = (log.orientation(frame), log.orientation(bar));
    let same = frame_q.len() == bar_q.len()
        && frame_q.iter().zip(bar_q).all(|(a, b)| a.angle_to(b) < 1e-9);
    if same {
        return Err(err(
            angles,
            format!(
                "the frame ({}) and handlebar ({}) sensors give the same orientations sample for \
                 sample: one sensor's data written twice, not two sensors",
                frame.id, bar.id
            ),
        ));
    }
    let vectors = |id: &str, what: &str| -> Result<Vec<Vector3<f64>>, RideError> {
        let col = |axis: &str| {
            cal.column_index(&format!("{id}_{what}_{axis}"))
                .ok_or_else(|| err(&cal_path, format!("no column {id}_{what}_{axis}")))
        };
        let (x, y, z) = (col("X")?, col("Y")?, col("Z")?);
        Ok((0..cal.grid_index.len())
            .map(|i| Vector3::new(cal.data[x][i], cal.data[y][i], cal.data[z][i]))
            .collect())
    };
    let accs = [vectors(&frame.id, "Acc")?, vectors(&bar.id, "Acc")?];
    let rate = log.sample_rate_hz;
    for ((sensor, label), a) in [(frame, "frame"), (bar, "handlebar")]
        .into_iter()
        .zip(&accs)
    {
        let first = log
            .orientation(sensor)
            .first()
            .ok_or_else(|| err(angles, format!("the {label} sensor has no samples")))?;
        let turned = log
            .orientation(sensor)
            .iter()
            .map(|q| q.angle_to(first))
            .fold(0.0, f64::max);
        let g0 = a.first().map_or(0.0, |v| v.norm());
        let shaken = a.iter().map(|v| (v.norm() - g0).abs()).fold(0.0, f64::max);
        if turned < 0.5f64.to_radians() && shaken < 0.3 {
            return Err(err(
                angles,
                format!(
                    "the {label} sensor ({}) did not move: it turned {:.2}° at most and its \
                     acceleration changed by {shaken:.2} m/s² at most over the whole ride; was it \
                     on the bicycle, and switched to this log?",
                    sensor.id,
                    turned.to_degrees()
                ),
            ));
        }
    }
    let [acc_frame, _] = accs;
    let gyro_frame = vectors(&frame.id, "Gyr")?;
    let still_end = (standstill_s * rate).round() as u64;
    // A series' sum and sample count over the standstill.
    let standstill_sum = |x: &[Vector3<f64>]| -> (Vector3<f64>, usize) {
        x.iter()
            .zip(&cal.grid_index)
            .filter(|(_, &i)| i < still_end)
            .fold((Vector3::zeros(), 0), |(s, n), (v, _)| (s + v, n + 1))
    };
    let standstill_mean = |x: &[Vector3<f64>]| -> Vector3<f64> {
        let (sum, n) = standstill_sum(x);
        sum / n.max(1) as f64
    };
    let (still_acc_sum, standstill_samples) = standstill_sum(&acc_frame);
    let up_frame = (still_acc_sum.norm() > 0.0)
        .then(|| still_acc_sum.normalize())
        .ok_or_else(|| err(angles, "no standstill at the start"))?;
    // Forward: the frame sensor's mean horizontal acceleration while pushed (after the standstill,
    // wherever it exceeds 0.5 m/s²).
    let g = acc_frame
        .iter()
        .zip(&cal.grid_index)
        .filter(|(_, &i)| i < still_end)
        .map(|(v, _)| v.norm())
        .sum::<f64>()
        / standstill_samples.max(1) as f64;
    let mut push = Vector3::zeros();
    for (a, &i) in acc_frame.iter().zip(&cal.grid_index) {
        if i >= still_end && i < still_end + (4.0 * rate) as u64 {
            let horizontal = a - up_frame * a.dot(&up_frame);
            if horizontal.norm() > 0.5 && (a.norm() - g).abs() < 5.0 {
                push += horizontal;
            }
        }
    }
    if push.norm() < 1e-6 {
        return Err(err(
            angles,
            "no push-off found after the standstill: the frame sensor never accelerated forward",
        ));
    }
    let forward = push.normalize();
    // Bicycle axes in the frame sensor's frame: x forward, y left, z up.
    let left = up_frame.cross(&forward);
    let mount = Rotation3::from_basis_unchecked(&[forward, left, up_frame]);
    let frame_mounting = UnitQuaternion::from_rotation_matrix(&mount);
    // Pair the two sensors' samples (both files share the grid).
    let (qf, qb) = (log.orientation(frame), log.orientation(bar));
    let rest_n = log
        .grid_index
        .iter()
        .filter(|&&i| i < still_end)
        .count()
        .max(1);
    let rest_rel = crate::signal::mean_rotation(
        &(0..rest_n)
            .map(|k| (qf[k] * frame_mounting).inverse() * qb[k])
            .collect::<Vec<_>>(),
    )
    .ok_or_else(|| err(angles, "cannot average the handlebar's rest orientation"))?;
    // The steer axis in the bicycle's axes (x forward, z up): up and backwards by λ.
    let (sl, cl) = steer_axis_tilt_rad.sin_cos();
    let axis = Vector3::new(-sl, 0.0, cl);
    let mut roll = Vec::with_capacity(qf.len());
    let mut steer = Vec::with_capacity(qf.len());
    let mut heading: Vec<f64> = Vec::with_capacity(qf.len());
    for k in 0..qf.len() {
        let body = qf[k] * frame_mounting;
        // Roll: the body's left axis against the vertical (Z up), heading-free.
        let left_g = body * Vector3::y();
        let fwd_g = body * Vector3::x();
        let up_g = Vector3::z();
        let level_left = up_g.cross(&fwd_g);
        let tilt = level_left
            .cross(&left_g)
            .dot(&fwd_g)
            .atan2(level_left.dot(&left_g));
        roll.push(tilt);
        let h = fwd_g.y.atan2(fwd_g.x);
        heading.push(match heading.last() {
            Some(&prev) => crate::signal::wrap_near(h, prev),
            None => h,
        });
        let rel = body.inverse() * qb[k] * rest_rel.inverse();
        steer.push(-rel.scaled_axis().dot(&axis));
    }
    // The kick comes before the bicycle leans far: search it before |roll| first exceeds 0.15 rad.
    let lean_limit = roll
        .iter()
        .position(|r| r.abs() > 0.15)
        .map_or(u64::MAX, |k| log.grid_index[k]);
    let still_acc = standstill_mean(&acc_frame);
    let forward_accel_mps2 = acc_frame
        .iter()
        .map(|a| (a - still_acc).dot(&forward))
        .collect();
    let gyro_bias = standstill_mean(&gyro_frame);
    let yaw_rate_rad_per_s = gyro_frame
        .iter()
        .zip(&cal.grid_index)
        .map(|(w, i)| match log.grid_index.binary_search(i) {
            // Earth's z is up: a left turn is positive there, the benchmark's yaw turns right.
            Ok(k) => -(qf[k] * (w - gyro_bias)).z,
            Err(_) => f64::NAN,
        })
        .collect();
    let rates: Vec<Vector3<f64>> = gyro_frame.iter().map(|w| w - gyro_bias).collect();
    // Gravity along the sensor's axes at each sample: the standstill's specific force turned
    // by the orientation the sensor has turned through since (its heading's drift is a turn
    // about the vertical and leaves gravity alone).
    let still_orientation = crate::signal::mean_rotation(&qf[..rest_n])
        .ok_or_else(|| err(angles, "cannot average the frame sensor's rest orientation"))?;
    let still_global = still_orientation * still_acc;
    let lever = (0..rates.len())
        .map(|k| {
            let at_log = log.grid_index.binary_search(&cal.grid_index[k]);
            match (smoothed_rate(&rates, &cal.grid_index, k, rate), at_log) {
                (Some((w, wd)), Ok(j)) => {
                    let c = |e: &Vector3<f64>| {
                        let c = e.cross(&wd) + w * e.dot(&w) - e * w.norm_squared();
                        [c.x, c.y, c.z]
                    };
                    let kinematic = acc_frame[k] - qf[j].inverse() * still_global;
                    LeverSample {
                        forward: c(&forward),
                        lateral: c(&left),
                        vertical: c(&up_frame),
                        lateral_accel_mps2: kinematic.dot(&left),
                        vertical_accel_mps2: kinematic.dot(&up_frame),
                        up_rate_rad_per_s: w.dot(&up_frame),
                        left_rate_rad_per_s: w.dot(&left),
                    }
                }
                _ => LeverSample::MISSING,
            }
        })
        .collect();
    let (kick_s, catch_s, release_s) = events(
        &cal.grid_index,
        &acc_frame,
        (&gyro_frame, gyro_bias),
        &mount,
        (still_end, lean_limit),
        rate,
    )
    .ok_or_else(|| {
        err(
            angles,
            "no kick found: the frame never accelerated sideways after the push",
        )
    })?;
    Ok(RideSignals {
        index: log.grid_index.clone(),
        sample_rate_hz: rate,
        roll_rad: roll,
        steer_rad: steer,
        heading_rad: heading,
        frame_mounting,
        kick_s,
        catch_s,
        release_s,
        standstill_samples,
        imu_index: cal.grid_index.clone(),
        forward_accel_mps2,
        yaw_rate_rad_per_s,
        lever,
        log,
    })
}

/// The smallest lateral-acceleration pulse taken for a kick (m/s², 0.1 s mean).
const KICK_MIN_MPS2: f64 = 0.2;

/// The kick and the catch from the frame sensor's `_cal` data: the kick is the first pulse of
/// lateral acceleration (in the bicycle's axes, 0.1 s moving mean, less its 1 s moving mean)
/// after the push's first second and before the bicycle leans past 0.15 rad; the catch is the
/// end of the last stretch where the gyro's rate less its standstill bias (magnitude, 0.1 s
/// moving mean) exceeds 3× its largest value during the standstill; the release is the last
/// moment before the kick that the forward acceleration (0.1 s moving mean, the bicycle's
/// forward axis) exceeds [`RELEASE_MPS2`].
fn events(
    grid_index: &[u64],
    acc: &[Vector3<f64>],
    (gyr, bias): (&[Vector3<f64>], Vector3<f64>),
    mount: &Rotation3<f64>,
    (still_end, lean_limit): (u64, u64),
    rate: f64,
) -> Option<(f64, f64, Option<f64>)> {
    let n = acc.len();
    let w = (0.1 * rate).round() as usize;
    let smooth = |x: &[f64]| -> Vec<f64> {
        (0..n)
            .map(|i| {
                let (lo, hi) = (i.saturating_sub(w / 2), (i + w / 2 + 1).min(n));
                x[lo..hi].iter().sum::<f64>() / (hi - lo) as f64
            })
            .collect()
    };
    // Lateral: the bicycle's left axis in sensor coordinates.
    let left = mount.matrix().column(1).into_owned();
    let lateral = smooth(&acc.iter().map(|a| a.dot(&left)).collect::<Vec<_>>());
    // The gyro's rate less its standstill bias (a few tenths of °/s), as a magnitude.
    let still: Vec<usize> = (0..n).filter(|&i| grid_index[i] < still_end).collect();
    let gyro = smooth(&gyr.iter().map(|w| (w - bias).norm()).collect::<Vec<_>>());
    let after_push = still_end + (1.0 * rate) as u64;
    // The kick is a short pulse: take the lateral acceleration less its 1 s moving mean (which
    // carries gravity once the bicycle leans), and its first excursion above half the largest.
    let slow = {
        let wide = (1.0 * rate).round() as usize;
        (0..n)
            .map(|i| {
                let (lo, hi) = (i.saturating_sub(wide / 2), (i + wide / 2 + 1).min(n));
                lateral[lo..hi].iter().sum::<f64>() / (hi - lo) as f64
            })
            .collect::<Vec<f64>>()
    };
    let pulse: Vec<f64> = (0..n).map(|i| (lateral[i] - slow[i]).abs()).collect();
    let candidates: Vec<usize> = (0..n)
        .filter(|&i| grid_index[i] > after_push && grid_index[i] < lean_limit)
        .collect();
    let top = candidates.iter().map(|&i| pulse[i]).fold(0.0, f64::max);
    // A 12–18 N kick on the lab's 14 kg bicycle gives ~0.6 m/s² here; the sensor's noise
    // ~0.01 m/s², a coast without a kick ~0.05 m/s².
    if top < KICK_MIN_MPS2 {
        return None;
    }
    let first = *candidates.iter().find(|&&i| pulse[i] > 0.5 * top)?;
    let kick = (first..(first + w * 3).min(n)).max_by(|&a, &b| pulse[a].total_cmp(&pulse[b]))?;
    let quiet = still.iter().map(|&i| gyro[i]).fold(0.0, f64::max).max(1e-4);
    let last_moving = (kick..n).rev().find(|&i| gyro[i] > 3.0 * quiet)?;
    let ahead = mount.matrix().column(0).into_owned();
    let forward = smooth(&acc.iter().map(|a| a.dot(&ahead)).collect::<Vec<_>>());
    let release = (0..kick)
        .rev()
        .find(|&i| grid_index[i] >= still_end && forward[i] > RELEASE_MPS2)
        .map(|i| grid_index[i] as f64 / rate);
    Some((
        grid_index[kick] as f64 / rate,
        grid_index[last_moving] as f64 / rate,
        release,
    ))
}

/// The speed from the reed switch: `Sync` pulses one wheel circumference apart (the header's
/// `Wheel circumference`), the distance rolled `C k` at the `k`-th pulse's time, and a parabola
/// `s(t)` fitted through them over `[t0_s, t1_s]`: its slope is the speed. The distance against
/// time, not each pair of pulses' `C/Δt`: a pulse is known to the sample, and `C/Δt` of a
/// quantized `Δt` is biased high.
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#syncspeed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyncSpeed {
    /// Speed at `at_s` (m/s) and its standard error from the parabola's fit.
    pub speed_mps: f64,
    pub speed_se_mps: f64,
    /// Its rate of change over the window (m/s²).
    pub accel_mps2: f64,
    pub at_s: f64,
    /// Pulses used.
    pub pulses: usize,
}

/// Reads the `Sync` column and fits the speed in `[t0_s, t1_s]`, evaluated at `at_s`. `None`
/// when the log has no `Sync` column or circumference, or fewer than four pulses there.
///
/// A pulse lost with its packet leaves a gap of two turns (or more): each pulse's count is
/// the turns since the first, an interval rounded to whole median intervals.
pub fn sync_speed(log: &Log, t0_s: f64, t1_s: f64, at_s: f64) -> Option<SyncSpeed> {
    let col = log.column_index("Sync")?;
    let circumference: f64 = log
        .metadata
        .iter()
        .find(|(k, _)| k.eq_ignore_ascii_case("Wheel circumference"))?
        .1
        .replace(',', ".")
        .trim_end_matches('m')
        .trim()
        .parse()
        .ok()?;
    let rate = log.sample_rate_hz;
    let pulses: Vec<f64> = log
        .grid_index
        .iter()
        .zip(&log.data[col])
        .filter(|(_, &v)| v > 0.5)
        .map(|(&i, _)| i as f64 / rate)
        .filter(|t| (t0_s..=t1_s).contains(t))
        .collect();
    speed_from_pulses(&pulses, circumference, rate, at_s)
}

/// The speed at `at_s` from reed-switch pulse times (s, ascending, each stamped at the first
/// sample of `rate_hz` after the switch closed) one `circumference_m` apart, as
/// [`sync_speed`] fits it. `None` with fewer than four pulses, times that do not increase, or
/// a fit that is not finite.
pub fn speed_from_pulses(
    pulses: &[f64],
    circumference_m: f64,
    rate_hz: f64,
    at_s: f64,
) -> Option<SyncSpeed> {
    if pulses.len() < 4 {
        return None;
    }
    let mut gaps: Vec<f64> = pulses.windows(2).map(|w| w[1] - w[0]).collect();
    if gaps.iter().any(|g| g.is_nan() || *g <= 0.0) {
        return None;
    }
    gaps.sort_by(f64::total_cmp);
    let median_gap = gaps[gaps.len() / 2];
    let mut turns = vec![0.0];
    for w in pulses.windows(2) {
        let k = ((w[1] - w[0]) / median_gap).round().max(1.0);
        turns.push(turns[turns.len() - 1] + k);
    }
    // s(t) = a + b u + c u², u = t − t̄, by least squares (the times' error, a sample's
    // quantization, enters as a distance error v·δt: the same for every pulse).
    let n = pulses.len() as f64;
    let tm = pulses.iter().sum::<f64>() / n;
    let x = nalgebra::DMatrix::from_fn(pulses.len(), 3, |i, j| (pulses[i] - tm).powi(j as i32));
    let y =
        nalgebra::DVector::from_iterator(pulses.len(), turns.iter().map(|k| circumference_m * k));
    let xtx_inv = (x.transpose() * &x).try_inverse()?;
    let coef = &xtx_inv * x.transpose() * &y;
    let residual = &y - &x * &coef;
    // A pulse is stamped at the first sample after the switch closed: on average half a
    // sample after it, which on a slowing bicycle reads the speed of half a sample later.
    let u = at_s - tm + 0.5 / rate_hz;
    let speed = coef[1] + 2.0 * coef[2] * u;
    // The residual scatter, and never less than a sample's quantization makes it (a uniform
    // error of one sample period, 1/√12 of it, times the speed): four pulses leave one
    // degree of freedom.
    let quantization = speed.abs() / (rate_hz * 12f64.sqrt());
    let sigma2 = (residual.norm_squared() / (n - 3.0)).max(quantization * quantization);
    let g = nalgebra::DVector::from_column_slice(&[0.0, 1.0, 2.0 * u]);
    let se = (sigma2 * (g.transpose() * &xtx_inv * &g)[(0, 0)]).sqrt();
    (speed.is_finite() && se.is_finite()).then_some(SyncSpeed {
        speed_mps: speed,
        speed_se_mps: se,
        accel_mps2: 2.0 * coef[2],
        at_s,
        pulses: pulses.len(),
    })
}

#[cfg(test)]
mod sync_tests {
    use super::*;
    use crate::sim::ride::{simulate_ride, Effects, RideSpec};

    /// On a coasting ride with the reed switch wired, the speed at the middle of the free motion
    /// is the truth's within 3 standard errors (pulses come every wheel turn, ~0.4 s at 4.5 m/s)
    /// and the deceleration has the truth's sign and size.
    #[test]
    fn the_reed_switch_gives_the_speed_and_its_decay() {
        let b = crate::model::lab::lab_to_benchmark(&crate::inertia::bike::LabBike::seed());
        let mut spec = RideSpec::lab(4.5, Effects::realistic());
        spec.sync = true;
        let ride = simulate_ride(&b, &spec, 21).unwrap();
        let log = Log::parse(
            ride.angles_log.as_bytes(),
            Path::new("ride.log"),
            &ReadOptions::default(),
        )
        .unwrap();
        let t = &ride.truth;
        let mid = 0.5 * (t.kick_s + t.catch_s);
        let s = sync_speed(&log, t.kick_s, t.catch_s, mid).unwrap();
        let truth = t.speed_mps[(mid * t.rate_hz).round() as usize];
        assert!(
            (s.speed_mps - truth).abs() < 3.0 * s.speed_se_mps.max(0.01),
            "{s:?} vs {truth}"
        );
        let truth_decel = (t.speed_mps[(t.kick_s * 100.0) as usize]
            - t.speed_mps[(t.catch_s * 100.0) as usize - 1])
            / (t.catch_s - t.kick_s - 0.01);
        assert!(
            (s.accel_mps2 + truth_decel).abs() < 0.05,
            "{} vs {}",
            s.accel_mps2,
            -truth_decel
        );
    }
    /// Pulses of a bicycle slowing at a known rate, each stamped at the next sample of 100 Hz
    /// (a random phase per ride), one in ten rides losing a pulse with its packet: over 400
    /// seeded rides the speed at the window's middle is unbiased (mean error below a tenth of
    /// its standard error, against the closed form v₀ + a t) and its standard error is honest
    /// (the errors' spread over their standard errors between 0.7 and 1.3; the quantization
    /// floor keeps it from promising more than the samples hold). The pairs' C/Δt line this
    /// replaced was high by 0.13 % on simulated rides.
    #[test]
    fn pulses_give_an_unbiased_speed_with_an_honest_error() {
        use crate::sim::draw::Draw;
        let mut rng = crate::sim::draw::seeded(77);
        let (c, rate) = (2.0 * std::f64::consts::PI * 0.3, 100.0);
        let mut z = Vec::new();
        for ride in 0..400 {
            let v0 = 3.5 + 3.0 * rng.uniform();
            let a = -0.2 * rng.uniform();
            let t_first = rng.uniform();
            let mut pulses = Vec::new();
            let mut k = 0.0;
            loop {
                // The time the wheel has rolled k turns: v0 t + a t²/2 = C k.
                let d = c * k;
                let t = (-v0 + (v0 * v0 + 2.0 * a * d).sqrt()) / a;
                let t = if a == 0.0 { d / v0 } else { t } + t_first;
                if t > t_first + 2.5 {
                    break;
                }
                pulses.push((t * rate).ceil() / rate);
                k += 1.0;
            }
            if ride % 10 == 0 {
                pulses.remove(pulses.len() / 2);
            }
            let at = t_first + 1.25;
            let s = speed_from_pulses(&pulses, c, rate, at).unwrap();
            let truth = v0 + a * (at - t_first);
            z.push((s.speed_mps - truth) / s.speed_se_mps);
        }
        let n = z.len() as f64;
        let mean = z.iter().sum::<f64>() / n;
        let sd = (z.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        println!("mean z {mean:.3}, sd z {sd:.3}");
        assert!(mean.abs() < 0.1, "mean z {mean}");
        assert!((0.7..=1.3).contains(&sd), "sd z {sd}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::ride::{simulate_ride, Effects, RideSpec};

    /// The release is found at the end of the push: within 0.3 s before the simulator's
    /// (the push's acceleration falls to 0.3 m/s² of its 2 m/s² peak 0.14 s early).
    #[test]
    fn the_release_is_the_end_of_the_push() {
        let b = crate::model::lab::lab_to_benchmark(&crate::inertia::bike::LabBike::seed());
        let ride = simulate_ride(&b, &RideSpec::lab(4.5, Effects::realistic()), 8).unwrap();
        let dir = std::env::temp_dir().join(format!("bikeproc_release_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("r.log"), &ride.angles_log).unwrap();
        std::fs::write(dir.join("r_cal.log"), &ride.cal_log).unwrap();
        let s = read_ride(&dir.join("r.log"), b.lambda, 1.5).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        let found = s.release_s.unwrap();
        let early = ride.truth.release_s - found;
        assert!(
            (0.0..0.3).contains(&early),
            "found {found}, released at {}",
            ride.truth.release_s
        );
    }

    /// Below the weave speed the bicycle falls after the kick and is caught: the kick is still
    /// found at the kick, not at the fall, and the catch at the catch.
    #[test]
    fn a_falling_ride_has_its_kick_and_catch_where_they_were() {
        let b = crate::model::lab::lab_to_benchmark(&crate::inertia::bike::LabBike::seed());
        let ride = simulate_ride(&b, &RideSpec::lab(2.6, Effects::default()), 5).unwrap();
        let dir = std::env::temp_dir().join(format!("bikeproc_fall_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("r.log"), &ride.angles_log).unwrap();
        std::fs::write(dir.join("r_cal.log"), &ride.cal_log).unwrap();
        let s = read_ride(&dir.join("r.log"), b.lambda, 1.5).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        let t = &ride.truth;
        assert!(
            t.catch_s < t.kick_s + 5.0,
            "it should have fallen: caught at {}",
            t.catch_s
        );
        assert!(
            (s.kick_s - (t.kick_s + 0.05)).abs() < 0.05,
            "kick at {} s, truth {}",
            s.kick_s,
            t.kick_s
        );
        assert!(
            (s.catch_s - t.catch_s).abs() < 0.1,
            "catch at {} s, truth {}",
            s.catch_s,
            t.catch_s
        );
    }

    /// The simulator's truth (roll q₄, steer q₇) is what comes out of the sensors, to the
    /// sensors' noise (RMS within 1.5× of it), for roughly mounted sensors and a drifting
    /// heading.
    #[test]
    fn roll_and_steer_come_back_from_the_sensors() {
        // The lab's light bicycle (the benchmark's 85 kg rider hardly moves under a 15 N kick).
        let b = crate::model::lab::lab_to_benchmark(&crate::inertia::bike::LabBike::seed());
        let ride = simulate_ride(&b, &RideSpec::lab(4.5, Effects::default()), 11).unwrap();
        let dir = std::env::temp_dir().join(format!("bikeproc_ride_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("r.log"), &ride.angles_log).unwrap();
        std::fs::write(dir.join("r_cal.log"), &ride.cal_log).unwrap();
        let s = read_ride(&dir.join("r.log"), b.lambda, 1.5).unwrap();
        let t = &ride.truth;
        let (mut sq_roll, mut sq_steer, mut n, mut peak) = (0.0f64, 0.0f64, 0usize, 0.0f64);
        for (k, &i) in s.index.iter().enumerate() {
            let i = i as usize;
            if (i as f64) < t.kick_s * 100.0 || (i as f64) > t.catch_s * 100.0 {
                continue;
            }
            sq_roll += (s.roll_rad[k] - t.roll_rad[i]).powi(2);
            sq_steer += (s.steer_rad[k] - t.steer_rad[i]).powi(2);
            n += 1;
            peak = peak.max(t.roll_rad[i].abs());
        }
        std::fs::remove_dir_all(&dir).ok();
        let (rms_roll, rms_steer) = ((sq_roll / n as f64).sqrt(), (sq_steer / n as f64).sqrt());
        assert!(peak > 0.02, "the kick moved it: {peak}");
        // The orientation noise is 0.05° = 0.87 mrad per axis (√2 of it for steer, two sensors).
        assert!(
            rms_roll < 1.5 * 0.87e-3 && rms_steer < 1.5 * 1.23e-3,
            "RMS roll error {rms_roll}, steer {rms_steer} rad"
        );
    }
}
