//! The simulated sensors and receiver: a body's true motion → what an MTx-class IMU reports
//! (orientation with noise and heading drift, gyro with a drifting bias, accelerometer,
//! magnetometer, all in the sensor frame of a roughly mounted sensor), and the receiver's text
//! files (`../shared/formats/imu-log.md`) with counter wrap, clock jitter, dropped packets and
//! corrupt rows.

use super::draw::{seeded, Draw, Rng};
use crate::read::log::OutputMode;
use nalgebra::{UnitQuaternion, Vector3};
use std::fmt::Write as _;

/// Standard gravity (m/s²) as the accelerometers see it.
pub const GRAVITY_MPS2: f64 = 9.81;

/// The true motion of the point where a sensor sits, at one sample.
#[derive(Debug, Clone, Copy)]
pub struct BodySample {
    /// Rotation body → global.
    pub orientation: UnitQuaternion<f64>,
    /// Angular velocity in the global frame (rad/s).
    pub omega_global: Vector3<f64>,
    /// Linear acceleration of the sensor's location in the global frame (m/s²).
    pub accel_global: Vector3<f64>,
}

/// What one sensor reports at one sample.
#[derive(Debug, Clone, Copy)]
pub struct ImuSample {
    /// The sensor's orientation output (sensor → global), with its errors.
    pub orientation: UnitQuaternion<f64>,
    pub acc: Vector3<f64>,
    pub gyr: Vector3<f64>,
    pub mag: Vector3<f64>,
}

/// How a sensor sits and how it errs. Angles in radians, rates in rad/s.
#[derive(Debug, Clone)]
pub struct SensorModel {
    /// Rotation sensor → body (the mounting; known to the lab only to a few degrees).
    pub mounting: UnitQuaternion<f64>,
    /// White noise of the orientation output, per axis (rad).
    pub orientation_noise_rad: f64,
    /// Linear drift of the heading output (rad/s), from steel and motors near the magnetometer.
    pub heading_drift_rad_per_s: f64,
    /// Random-walk part of the heading error (rad/√s).
    pub heading_walk_rad_per_sqrt_s: f64,
    pub gyro_noise_rad_per_s: f64,
    /// Gyro bias at the start (rad/s, sensor frame).
    pub gyro_bias_rad_per_s: Vector3<f64>,
    /// Linear drift of the gyro bias (rad/s²).
    pub gyro_bias_drift_rad_per_s2: Vector3<f64>,
    /// Random-walk part of the gyro bias (rad/s/√s).
    pub gyro_bias_walk: f64,
    pub acc_noise_mps2: f64,
    pub mag_noise: f64,
    /// Inclination of the magnetic field below the horizontal (rad).
    pub magnetic_dip_rad: f64,
}

impl SensorModel {
    /// A realistic sensor at a random mounting: orientation noise 0.05°, heading drift
    /// ~0.5°/min, gyro bias a few tenths of °/s drifting slowly.
    pub fn typical(rng: &mut Rng) -> SensorModel {
        let deg = std::f64::consts::PI / 180.0;
        SensorModel {
            mounting: rng.rotation(),
            orientation_noise_rad: 0.05 * deg,
            heading_drift_rad_per_s: rng.range(-0.5, 0.5) * deg / 60.0,
            heading_walk_rad_per_sqrt_s: 0.002 * deg,
            gyro_noise_rad_per_s: 0.005,
            gyro_bias_rad_per_s: Vector3::new(rng.normal(), rng.normal(), rng.normal()) * 0.3 * deg,
            gyro_bias_drift_rad_per_s2: Vector3::new(rng.normal(), rng.normal(), rng.normal())
                * 0.003
                * deg,
            gyro_bias_walk: 0.0005 * deg,
            acc_noise_mps2: 0.02,
            mag_noise: 0.003,
            magnetic_dip_rad: 57.0 * deg,
        }
    }

    /// What the sensor reports for a motion sampled at `rate_hz`.
    pub fn measure(&self, motion: &[BodySample], rate_hz: f64, rng: &mut Rng) -> Vec<ImuSample> {
        let dt = 1.0 / rate_hz;
        let up = Vector3::z();
        let field = Vector3::new(
            self.magnetic_dip_rad.cos(),
            0.0,
            -self.magnetic_dip_rad.sin(),
        );
        let mut heading_walk = 0.0;
        let mut bias_walk = Vector3::zeros();
        motion
            .iter()
            .enumerate()
            .map(|(n, b)| {
                let t = n as f64 * dt;
                let sensor = b.orientation * self.mounting;
                let inv = sensor.inverse();
                heading_walk += self.heading_walk_rad_per_sqrt_s * dt.sqrt() * rng.normal();
                bias_walk += Vector3::new(rng.normal(), rng.normal(), rng.normal())
                    * (self.gyro_bias_walk * dt.sqrt());
                let heading = UnitQuaternion::from_axis_angle(
                    &nalgebra::Vector3::z_axis(),
                    self.heading_drift_rad_per_s * t + heading_walk,
                );
                let orientation = heading * sensor * rng.small_rotation(self.orientation_noise_rad);
                let noise3 = |rng: &mut Rng, s: f64| {
                    Vector3::new(rng.normal(), rng.normal(), rng.normal()) * s
                };
                let bias =
                    self.gyro_bias_rad_per_s + self.gyro_bias_drift_rad_per_s2 * t + bias_walk;
                ImuSample {
                    orientation,
                    gyr: inv * b.omega_global + bias + noise3(rng, self.gyro_noise_rad_per_s),
                    acc: inv * (b.accel_global + up * GRAVITY_MPS2)
                        + noise3(rng, self.acc_noise_mps2),
                    mag: inv * field + noise3(rng, self.mag_noise),
                }
            })
            .collect()
    }

    /// A perfect sensor (no noise, drift or bias) at the given mounting.
    pub fn ideal(mounting: UnitQuaternion<f64>) -> SensorModel {
        SensorModel {
            mounting,
            orientation_noise_rad: 0.0,
            heading_drift_rad_per_s: 0.0,
            heading_walk_rad_per_sqrt_s: 0.0,
            gyro_noise_rad_per_s: 0.0,
            gyro_bias_rad_per_s: Vector3::zeros(),
            gyro_bias_drift_rad_per_s2: Vector3::zeros(),
            gyro_bias_walk: 0.0,
            acc_noise_mps2: 0.0,
            mag_noise: 0.0,
            magnetic_dip_rad: 1.0,
        }
    }
}

/// Field separator and decimal mark of the written files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Locale {
    /// Tab-separated, decimal point.
    #[default]
    Tab,
    /// A PC with a Spanish locale: `;` and decimal comma.
    Spanish,
}

/// How many digits the receiver writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Precision {
    /// What a real sensor writes: 3 decimals of degree, 5 of a quaternion, …
    #[default]
    Sensor,
    /// Shortest round-trip representation of every f64 (for exactness tests).
    Full,
}

/// What the Bluetooth link did to each sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Packet {
    Ok,
    Dropped,
    /// Arrived corrupted: a field reads NaN.
    Nan,
    /// Arrived cut short: the row ends early.
    Cut,
}

/// The link's behaviour over a recording.
#[derive(Debug, Clone, Copy)]
pub struct LinkModel {
    /// Probability that a single packet is lost.
    pub drop_probability: f64,
    /// Bursts of lost packets per minute (Bluetooth fades), each of 2–30 samples.
    pub bursts_per_minute: f64,
    /// Probability that a packet arrives corrupted (NaN or cut short).
    pub corrupt_probability: f64,
}

impl Default for LinkModel {
    fn default() -> Self {
        LinkModel {
            drop_probability: 0.003,
            bursts_per_minute: 0.5,
            corrupt_probability: 0.0005,
        }
    }
}

impl LinkModel {
    /// A perfect link.
    pub fn perfect() -> LinkModel {
        LinkModel {
            drop_probability: 0.0,
            bursts_per_minute: 0.0,
            corrupt_probability: 0.0,
        }
    }

    /// The fate of each of `n` packets at `rate_hz`. The first and last are always delivered.
    pub fn packets(&self, n: usize, rate_hz: f64, rng: &mut Rng) -> Vec<Packet> {
        let mut out = vec![Packet::Ok; n];
        let burst_p = self.bursts_per_minute / (60.0 * rate_hz);
        let mut i = 1;
        while i + 1 < n {
            let u = rng.uniform();
            if u < burst_p {
                let len = 2 + (rng.uniform() * 29.0) as usize;
                for p in out.iter_mut().skip(i).take(len.min(n - 1 - i)) {
                    *p = Packet::Dropped;
                }
                i += len;
                continue;
            }
            let v = rng.uniform();
            if v < self.drop_probability {
                out[i] = Packet::Dropped;
            } else if v < self.drop_probability + self.corrupt_probability {
                out[i] = if rng.uniform() < 0.5 {
                    Packet::Nan
                } else {
                    Packet::Cut
                };
            }
            i += 1;
        }
        out
    }
}

/// Everything about the files but the data.
#[derive(Debug, Clone)]
pub struct FileSpec {
    pub mode: OutputMode,
    pub locale: Locale,
    pub precision: Precision,
    pub rate_hz: f64,
    /// Sensor serials and where they are mounted.
    pub sensors: Vec<(String, String)>,
    /// The packet counter of the first row.
    pub first_counter: u16,
    /// `// Start:` stamp.
    pub start: String,
    /// Extra `// Key: value` lines.
    pub extra_header: Vec<(String, String)>,
    /// Whether to write `// Decimal separator: ,` in the Spanish locale (the reader copes without).
    pub declare_decimal: bool,
    /// The receiver stamps its own clock: time-stamp jitter, standard deviation (s), cut at 3σ.
    pub jitter_s: f64,
    /// Bursts per minute in which the receiver gets packets late, 2–5 at once (20–50 ms): the
    /// packets of a burst carry the stamp of its last one. Drawn from their own stream (the
    /// first counter's), the same in a pair's two files; 0 leaves the file as without.
    pub late_bursts_per_minute: f64,
}

impl FileSpec {
    /// One sensor at 100 Hz, counter starting at `first_counter`, ±0.5 ms of receiver jitter,
    /// no extra header lines.
    pub fn single_sensor(
        mode: OutputMode,
        locale: Locale,
        precision: Precision,
        sensor: (&str, &str),
        first_counter: u16,
    ) -> FileSpec {
        FileSpec {
            mode,
            locale,
            precision,
            rate_hz: 100.0,
            sensors: vec![(sensor.0.to_string(), sensor.1.to_string())],
            first_counter,
            start: "2009-03-12 11:42:07".into(),
            extra_header: vec![],
            declare_decimal: false,
            jitter_s: 0.0005,
            late_bursts_per_minute: 0.0,
        }
    }
}

fn fmt_num(out: &mut String, v: f64, decimals: usize, precision: Precision, comma: bool) {
    let start = out.len();
    match precision {
        Precision::Sensor => {
            let _ = write!(out, "{v:.decimals$}");
            // No "-0.000": a sensor writes 0.000.
            if out[start..].starts_with('-')
                && out[start + 1..].bytes().all(|b| b == b'0' || b == b'.')
            {
                out.remove(start);
            }
        }
        Precision::Full => {
            let _ = write!(out, "{v:?}");
        }
    }
    if comma {
        // Safe: only ASCII digits, sign, '.' and 'e' were written.
        let replaced = out[start..].replace('.', ",");
        out.truncate(start);
        out.push_str(&replaced);
    }
}

/// Writes one file (`mode` from `spec`, or Calibrated) for `data[sensor][sample]`.
///
/// `sync` adds the reed-switch column (one value per sample) to an orientation file.
pub fn write_log(
    spec: &FileSpec,
    calibrated: bool,
    data: &[Vec<ImuSample>],
    packets: &[Packet],
    sync: Option<&[u8]>,
    rng: &mut Rng,
) -> String {
    let mode = if calibrated {
        OutputMode::Calibrated
    } else {
        spec.mode
    };
    let spanish = spec.locale == Locale::Spanish;
    let sep = if spanish { ';' } else { '\t' };
    let mut out =
        String::with_capacity(packets.len() * 16 * (1 + data.len() * mode.channels().len()));
    let _ = writeln!(
        out,
        "// Receiver: Xbus Master, {} sensor{}, Bluetooth",
        data.len(),
        if data.len() == 1 { "" } else { "s" }
    );
    let _ = writeln!(out, "// Sample rate: {} Hz", spec.rate_hz);
    let _ = writeln!(out, "// Output mode: {}", mode.name());
    for (id, label) in &spec.sensors {
        let _ = writeln!(out, "// Sensor {id}: {label}");
    }
    let _ = writeln!(out, "// Start: {}", spec.start);
    if spanish && spec.declare_decimal {
        let _ = writeln!(out, "// Decimal separator: ,");
    }
    for (k, v) in &spec.extra_header {
        let _ = writeln!(out, "// {k}: {v}");
    }
    out.push_str("Counter");
    out.push(sep);
    out.push_str("Time");
    for (id, _) in &spec.sensors {
        for ch in mode.channels() {
            out.push(sep);
            let _ = write!(out, "{id}_{ch}");
        }
    }
    if sync.is_some() && !calibrated {
        out.push(sep);
        out.push_str("Sync");
    }
    out.push('\n');
    let decimals = match mode {
        OutputMode::Euler => 3,
        OutputMode::Quaternion | OutputMode::Matrix => 5,
        OutputMode::Calibrated => 4,
    };
    let deg = 180.0 / std::f64::consts::PI;
    let mut values: Vec<f64> = Vec::with_capacity(9);
    let mut late = (spec.late_bursts_per_minute > 0.0)
        .then(|| seeded(0x1A7E_5EED ^ ((spec.first_counter as u64) << 20)));
    let late_p = spec.late_bursts_per_minute / (60.0 * spec.rate_hz);
    let (mut burst_last, mut last_stamp) = (None::<usize>, 0.0_f64);
    for (n, &packet) in packets.iter().enumerate() {
        // Jitter is drawn for every sample so that the files do not depend on which are dropped.
        let jitter =
            (rng.normal() * spec.jitter_s).clamp(-3.0 * spec.jitter_s, 3.0 * spec.jitter_s);
        // A late burst: packets n … its last are stamped when the last arrives.
        if let Some(r) = late.as_mut() {
            if burst_last.is_none_or(|e| n > e) && r.uniform() < late_p {
                burst_last = Some(n + 1 + (r.uniform() * 4.0) as usize);
            }
        }
        let delivered = burst_last.filter(|&e| n <= e).unwrap_or(n);
        if packet == Packet::Dropped {
            continue;
        }
        let counter = (spec.first_counter as u64 + n as u64) % 65_536;
        let mut time = (delivered as f64 / spec.rate_hz + jitter).max(0.0);
        if late.is_some() {
            // The receiver's clock does not run backwards.
            time = time.max(last_stamp);
            last_stamp = time;
        }
        let _ = write!(out, "{counter}");
        out.push(sep);
        fmt_num(&mut out, time, 3, spec.precision, spanish);
        let total_fields = data.len() * mode.channels().len();
        // A cut row always ends before its last field, whatever the mode's width.
        let mut fields_left = match packet {
            Packet::Cut => ((rng.uniform() * total_fields as f64) as usize).min(total_fields - 1),
            _ => usize::MAX,
        };
        let nan_at = match packet {
            Packet::Nan => Some((rng.uniform() * total_fields as f64) as usize),
            _ => None,
        };
        let mut field = 0usize;
        'sensors: for sensor in data {
            let s = &sensor[n];
            values.clear();
            match mode {
                OutputMode::Euler => {
                    let (r, p, y) = s.orientation.euler_angles();
                    values.extend([r * deg, p * deg, y * deg]);
                }
                OutputMode::Quaternion => {
                    let q = s.orientation.quaternion();
                    // Scalar part non-negative, as the sensor writes it.
                    let sign = if q.w < 0.0 { -1.0 } else { 1.0 };
                    values.extend([q.w * sign, q.i * sign, q.j * sign, q.k * sign]);
                }
                OutputMode::Matrix => {
                    let m = s.orientation.to_rotation_matrix();
                    for r in 0..3 {
                        for c in 0..3 {
                            values.push(m[(r, c)]);
                        }
                    }
                }
                OutputMode::Calibrated => {
                    values.extend(s.acc.iter());
                    values.extend(s.gyr.iter());
                    values.extend(s.mag.iter());
                }
            }
            for (k, &v) in values.iter().enumerate() {
                if fields_left == 0 {
                    break 'sensors;
                }
                fields_left -= 1;
                out.push(sep);
                if nan_at == Some(field) {
                    out.push_str("NaN");
                } else {
                    let d = if mode == OutputMode::Calibrated && (3..6).contains(&k) {
                        5
                    } else {
                        decimals
                    };
                    fmt_num(&mut out, v, d, spec.precision, spanish);
                }
                field += 1;
            }
        }
        if let (Some(sync), false, true) = (sync, calibrated, fields_left > 0) {
            out.push(sep);
            let _ = write!(out, "{}", sync[n]);
        }
        out.push('\n');
    }
    out
}
