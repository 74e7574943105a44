//! Log reading: the lab's IMU log files (`../shared/formats/imu-log.md`) → [`Log`].
//!
//! In: the text of a `NAME.log` (orientation: Euler, Quaternion or Matrix) or `NAME_cal.log`
//! (Calibrated) file, tab-separated or in the Spanish locale (`;` and decimal `,`).
//! Out: every data column on the sensors' 100 Hz grid (a row's place on the grid comes from the
//! packet counter, the reliable clock; the receiver's time stamps, which jitter and arrive late
//! in bursts, only resolve the counter's wraps over long gaps and catch a corrupt counter), the
//! gaps left by dropped packets and
//! corrupt rows, and per sensor its orientation as unit quaternions (rotation sensor → global).
//!
//! Nothing is bridged: a missing sample is simply absent from [`Log::grid_index`]. Every error names
//! the file, the line and the column, and says what was expected.

use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion};
use std::fmt;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The packet counter is an unsigned 16-bit number: it wraps from 65535 to 0.
const COUNTER_MODULUS: u64 = 65_536;

/// How late the receiver may stamp a packet (s): Bluetooth delivers packets in bursts, tens of
/// milliseconds late, and the stamps jitter by about a millisecond. A row's counter step is
/// taken when the time step agrees with it within this (and 2 % of a longer gap's drift).
const RECEIVER_LATENCY_S: f64 = 0.1;

/// The receiver's random stamping error beyond its latency (s): a few milliseconds of jitter,
/// allowed seven times over, either way.
const RECEIVER_JITTER_S: f64 = 0.02;

/// The highest sample rate a header may state (Hz): inertial sensors log at up to a few kHz.
const MAX_SAMPLE_RATE_HZ: f64 = 100_000.0;

/// How an orientation file encodes each sensor's rotation, or `Calibrated` for a `_cal` file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OutputMode {
    /// `Roll Pitch Yaw` in degrees, aerospace Z-Y-X sequence.
    Euler,
    /// `q0 q1 q2 q3`, `q0` the scalar part.
    Quaternion,
    /// `M11 … M33`, row by row.
    Matrix,
    /// `Acc_X … Mag_Z`: acceleration (m/s²), angular rate (rad/s), magnetic field (a.u.).
    Calibrated,
}

impl OutputMode {
    /// The per-sensor column names the mode requires, in file order.
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            OutputMode::Euler => &["Roll", "Pitch", "Yaw"],
            OutputMode::Quaternion => &["q0", "q1", "q2", "q3"],
            OutputMode::Matrix => &[
                "M11", "M12", "M13", "M21", "M22", "M23", "M31", "M32", "M33",
            ],
            OutputMode::Calibrated => &[
                "Acc_X", "Acc_Y", "Acc_Z", "Gyr_X", "Gyr_Y", "Gyr_Z", "Mag_X", "Mag_Y", "Mag_Z",
            ],
        }
    }

    /// The largest magnitude channel `channel` of this mode can read, with room for the
    /// exporter's rounding: Euler roll and yaw wrap at ±180°, pitch stays within ±90° (the
    /// format's contract); a unit quaternion's and a rotation matrix's entries lie within ±1;
    /// a calibrated sensor's accelerations within ±1000 m/s² (100 g), its angular rates within
    /// ±100 rad/s (a MEMS gyroscope's range is ±35 at most), its magnetic field (about 1 in
    /// the lab) within ±1000. A value beyond is a corrupted packet, not a reading.
    pub fn limit(self, channel: &str) -> f64 {
        const ROUNDING: f64 = 0.01;
        match (self, channel) {
            (OutputMode::Euler, "Pitch") => 90.0 + ROUNDING,
            (OutputMode::Euler, _) => 180.0 + ROUNDING,
            (OutputMode::Quaternion | OutputMode::Matrix, _) => 1.0 + ROUNDING,
            (OutputMode::Calibrated, c) if c.starts_with("Acc") => 1000.0,
            (OutputMode::Calibrated, c) if c.starts_with("Gyr") => 100.0,
            (OutputMode::Calibrated, _) => 1000.0,
        }
    }

    /// The name the header's `Output mode:` line uses.
    pub fn name(self) -> &'static str {
        match self {
            OutputMode::Euler => "Euler",
            OutputMode::Quaternion => "Quaternion",
            OutputMode::Matrix => "Matrix",
            OutputMode::Calibrated => "Calibrated",
        }
    }

    fn parse(s: &str) -> Option<Self> {
        [
            OutputMode::Euler,
            OutputMode::Quaternion,
            OutputMode::Matrix,
            OutputMode::Calibrated,
        ]
        .into_iter()
        .find(|m| m.name().eq_ignore_ascii_case(s))
    }
}

/// What went wrong in a log file.
#[derive(Debug, Clone, PartialEq)]
pub enum LogErrorKind {
    Io(String),
    Binary,
    Empty,
    NoColumnRow,
    MissingKey(&'static str),
    BadSampleRate(String),
    UnknownMode(String),
    UnknownSeparator,
    MissingColumn(String),
    DuplicateColumn(String),
    NoSensorColumns,
    FieldCount {
        expected: usize,
        found: usize,
    },
    BadNumber {
        column: String,
        text: String,
    },
    BadCounter(String),
    TimeBackwards {
        previous_s: f64,
        now_s: f64,
    },
    CounterBackwards {
        previous: u64,
        now: u64,
    },
    CounterRepeats(u64),
    CounterTimeMismatch {
        counter_samples: u64,
        time_samples: f64,
    },
    /// A hole longer than [`MAX_GAP_S`], or holes that make the grid span beyond
    /// [`grid_span_limit`]: not one recording.
    GapTooLong {
        gap_s: f64,
    },
    QuaternionNorm(f64),
    NotRotation {
        orthonormality_error: f64,
        det: f64,
    },
    TooManyCorruptRun {
        run: usize,
        limit: usize,
    },
    TooManyCorrupt {
        corrupt: usize,
        rows: usize,
        limit_percent: f64,
    },
    NoData,
}

impl fmt::Display for LogErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use LogErrorKind::*;
        match self {
            Io(e) => write!(f, "cannot read: {e}"),
            Binary => write!(f, "binary data where text was expected (is this a log file?)"),
            Empty => write!(f, "the file is empty"),
            NoColumnRow => write!(f, "no row of column names after the header"),
            MissingKey(k) => write!(f, "header line `// {k}: …` is missing"),
            BadSampleRate(s) => write!(
                f,
                "sample rate `{s}`: expected a positive number of Hz, at most {MAX_SAMPLE_RATE_HZ}"
            ),
            UnknownMode(s) => write!(
                f,
                "unknown output mode `{s}`: expected Euler, Quaternion, Matrix or Calibrated"
            ),
            UnknownSeparator => write!(
                f,
                "cannot tell the field separator: expected tabs, or `;` (Spanish locale)"
            ),
            MissingColumn(c) => write!(f, "column `{c}` is missing"),
            DuplicateColumn(c) => write!(f, "column `{c}` appears twice"),
            NoSensorColumns => write!(f, "no sensor columns for the output mode"),
            FieldCount { expected, found } => {
                write!(f, "{found} fields, expected {expected} (one per column)")
            }
            BadNumber { column, text } => write!(
                f,
                "`{}` in column {column}: expected a number",
                excerpt(text)
            ),
            BadCounter(t) => write!(
                f,
                "counter `{}`: expected a whole number from 0 to 65535",
                excerpt(t)
            ),
            TimeBackwards { previous_s, now_s } => write!(
                f,
                "time goes backwards: {now_s} s after {previous_s} s, more than a receiver's late \
                 delivery and jitter ({:.2} s) explain",
                RECEIVER_LATENCY_S + RECEIVER_JITTER_S
            ),
            CounterBackwards { previous, now } => {
                write!(f, "packet counter jumps backwards from {previous} to {now}")
            }
            CounterRepeats(c) => write!(f, "packet counter {c} repeats"),
            CounterTimeMismatch { counter_samples, time_samples } => write!(
                f,
                "counter and time disagree: the counter advances {counter_samples} samples, \
                 the time {time_samples:.2}"
            ),
            GapTooLong { gap_s } => write!(
                f,
                "{}",
                gap_too_long_message(*gap_s)
            ),
            QuaternionNorm(n) => write!(f, "quaternion of norm {n}: expected a unit quaternion"),
            NotRotation { orthonormality_error, det } => write!(
                f,
                "not a rotation matrix (largest |MᵀM − I| = {orthonormality_error:.2e}, det = {det:.4}): \
                 expected orthonormal rows and det = +1"
            ),
            TooManyCorruptRun { run, limit } => write!(
                f,
                "{run} corrupt rows (cut short, NaN, or a value beyond its channel's range) in a row: more than the limit of {limit}"
            ),
            TooManyCorrupt { corrupt, rows, limit_percent } => write!(
                f,
                "{corrupt} of {rows} rows are corrupt (cut short, NaN, or a value beyond its channel's range): more than {limit_percent} %"
            ),
            NoData => write!(f, "no data rows"),
        }
    }
}

/// An error in a log file, with where it is.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct LogError {
    pub path: PathBuf,
    /// 1-based line, when the error is on one.
    pub line: Option<usize>,
    /// 1-based character column, when the error is in one field.
    pub column: Option<usize>,
    pub kind: LogErrorKind,
}

impl fmt::Display for LogError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.path.display())?;
        if let Some(l) = self.line {
            write!(f, ":{l}")?;
            if let Some(c) = self.column {
                write!(f, ":{c}")?;
            }
        }
        write!(f, ": {}", self.kind)
    }
}

/// Limits on corrupt rows (cut short, holding NaN, or a value beyond its channel's range) that are kept as gaps.
#[derive(Debug, Clone)]
pub struct ReadOptions {
    /// Longest run of consecutive corrupt rows accepted (default 25 rows = 0.25 s at 100 Hz).
    pub max_corrupt_run: usize,
    /// Largest fraction of corrupt rows accepted, in percent (default 5 %).
    pub max_corrupt_percent: f64,
    /// Keep only this sensor's (by id or label) columns and sensor: the others' rows are read
    /// and checked as rows, their values not kept (a long log of two sensors held both, where
    /// a pendulum's period needs one). An id or label the log lacks keeps every sensor.
    pub only_sensor: Option<String>,
    /// Read the header alone (its metadata, columns and sensors), no data row: what a caller
    /// checks before it reads a long log whole.
    pub header_only: bool,
}

impl Default for ReadOptions {
    /// The reader's limits (25 corrupt rows in a run, 5 % in all), every sensor kept.
    fn default() -> Self {
        ReadOptions {
            max_corrupt_run: 25,
            max_corrupt_percent: 5.0,
            only_sensor: None,
            header_only: false,
        }
    }
}

/// One sensor of the receiver: its serial, where it is mounted, and its columns.
#[derive(Debug, Clone)]
pub struct Sensor {
    pub id: String,
    /// Free text from the header (`frame`, `handlebar`, `torsion bar`, …); empty when not given.
    pub label: String,
    /// Indices into [`Log::columns`], in the order of [`OutputMode::channels`].
    pub channel_columns: Vec<usize>,
    /// Rotation sensor frame → global frame at each kept sample ([`Log::orientation`]): made
    /// and checked while reading for quaternion and matrix files (a row that is no rotation is
    /// the reader's error), on first use for Euler files (every three angles are a rotation:
    /// reading a long log's numbers alone, as `read_log` does, took a third longer with them).
    orientation: std::sync::OnceLock<Vec<UnitQuaternion<f64>>>,
}

/// What the reader found missing: dropped packets and corrupt rows, both left as gaps.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GapReport {
    /// Grid samples with no data (dropped packets plus corrupt rows).
    pub missing_samples: u64,
    /// Separate places where the grid has a hole.
    pub gaps: usize,
    /// The longest hole, in samples.
    pub longest_gap_samples: u64,
    /// Rows that were cut short, held NaN or a value beyond its channel's range (counted in `missing_samples` too).
    pub corrupt_rows: usize,
    /// Line of the first corrupt row.
    pub first_corrupt_line: Option<usize>,
    /// Rows whose receiver time is more than half a sample off the time the counter gives
    /// them (jitter, late delivery): placed by the counter all the same.
    pub time_off_rows: usize,
}

/// A log file read onto the sensors' sample grid.
#[derive(Debug, Clone)]
pub struct Log {
    pub path: PathBuf,
    pub sample_rate_hz: f64,
    pub mode: OutputMode,
    /// Every `// Key: value` header line, in file order (unknown keys included).
    pub metadata: Vec<(String, String)>,
    /// Whether the file used `;` and decimal `,` (Spanish locale).
    pub spanish_locale: bool,
    /// Names of the data columns (all but `Counter` and `Time`), as written.
    pub columns: Vec<String>,
    /// Line of the row of column names.
    pub column_row_line: usize,
    /// Per data column, the value at each kept sample (Euler roll and yaw unwrapped, in degrees).
    pub data: Vec<Vec<f64>>,
    /// Grid position of each kept sample: samples since the first row, at `sample_rate_hz`.
    pub grid_index: Vec<u64>,
    pub sensors: Vec<Sensor>,
    pub gaps: GapReport,
    /// The packet counter of the first sample kept: the two files of a pair, written from the
    /// same packets, start at the same one.
    pub first_counter: u64,
    /// Things the reader tolerated and the user should know.
    pub warnings: Vec<String>,
}

impl Log {
    /// Reads a log file from disk, a block of lines at a time: the file is never held whole
    /// (its columns are what stays in memory).
    pub fn open(path: &Path, options: &ReadOptions) -> Result<Log, LogError> {
        let reader = crate::read::kind::open_text(path).map_err(|e| LogError {
            path: path.to_path_buf(),
            line: e.line.map(|l| l as usize),
            column: None,
            kind: LogErrorKind::Io(
                e.message
                    .strip_prefix("cannot read: ")
                    .unwrap_or(&e.message)
                    .to_string(),
            ),
        })?;
        let size = std::fs::metadata(path).ok().map(|m| m.len());
        Parser::new(path, options).parse(reader, size)
    }

    /// Parses the bytes of a log file; `path` is used in messages only. Never panics.
    pub fn parse(bytes: &[u8], path: &Path, options: &ReadOptions) -> Result<Log, LogError> {
        Parser::new(path, options).parse(bytes, Some(bytes.len() as u64))
    }

    /// Index of a data column by exact name, or by the short name (`Roll`, `Gyr_Z`) when one
    /// sensor has it (with a sensor id, `00300417_Gyr_Z`).
    pub fn column_index(&self, name: &str) -> Option<usize> {
        if let Some(i) = self.columns.iter().position(|c| c == name) {
            return Some(i);
        }
        let mut found = self
            .columns
            .iter()
            .enumerate()
            .filter(|(_, c)| short_name(c) == name);
        match (found.next(), found.next()) {
            (Some((i, _)), None) => Some(i),
            _ => None,
        }
    }

    /// A sensor by id or by its label (case-insensitive).
    pub fn sensor(&self, key: &str) -> Option<&Sensor> {
        self.sensors.iter().find(|s| s.id == key).or_else(|| {
            self.sensors
                .iter()
                .find(|s| s.label.eq_ignore_ascii_case(key))
        })
    }

    /// `sensor`'s rotation sensor frame → global frame at each kept sample, sign-continuous
    /// (consecutive quaternions have a non-negative dot product); empty for a `_cal` file.
    ///
    /// # Panics
    /// When `sensor` is not one of this log's [`Log::sensors`] (its columns are then not this
    /// log's): a misuse, never the data.
    pub fn orientation<'l>(&'l self, sensor: &'l Sensor) -> &'l [UnitQuaternion<f64>] {
        sensor.orientation.get_or_init(|| {
            // Checked while reading for the other modes; Euler angles are always a rotation.
            orientations(self.mode, &self.data, &sensor.channel_columns).unwrap_or_default()
        })
    }

    /// `sensor`'s orientations as [`Log::orientation`] gives them (sign-continuous), handed
    /// to `visit` one at a time, in order, until it breaks, and not stored: the ones the reader
    /// made where it did (quaternion and matrix files), else each made afresh from an Euler
    /// file's angles (a long log's quaternions held whole were 32 bytes a row). The number of
    /// orientations, or `None` where a row is no rotation (then [`Log::orientation`] has none).
    pub fn each_orientation(
        &self,
        sensor: &Sensor,
        mut visit: impl FnMut(&UnitQuaternion<f64>) -> std::ops::ControlFlow<()>,
    ) -> Option<usize> {
        if let Some(q) = sensor.orientation.get() {
            let _ = q.iter().try_for_each(visit);
            return Some(q.len());
        }
        if self.mode == OutputMode::Calibrated {
            return Some(0);
        }
        let n = self.data.first().map_or(0, Vec::len);
        let mut prev: Option<UnitQuaternion<f64>> = None;
        for i in 0..n {
            let mut q = orientation(self.mode, |c| self.data[sensor.channel_columns[c]][i]).ok()?;
            if let Some(p) = &prev {
                q = continuing(p, q);
            }
            if visit(&q).is_break() {
                return Some(n);
            }
            prev = Some(q);
        }
        Some(n)
    }

    /// `sensor`'s orientation at kept sample `i`: [`Log::orientation`]'s where the reader made
    /// them, else made afresh from the Euler angles, its sign as the sensor wrote it (`q` and
    /// `−q` are one rotation: what depends on the sign alone, an average, takes
    /// [`Log::each_orientation`]). `None` beyond the samples or where the row is no rotation.
    pub fn orientation_at(&self, sensor: &Sensor, i: usize) -> Option<UnitQuaternion<f64>> {
        if let Some(q) = sensor.orientation.get() {
            return q.get(i).copied();
        }
        if self.mode == OutputMode::Calibrated || i >= self.data.first().map_or(0, Vec::len) {
            return None;
        }
        orientation(self.mode, |c| self.data[sensor.channel_columns[c]][i]).ok()
    }

    /// Time of each kept sample on the sensor clock, seconds from the first row.
    pub fn times_s(&self) -> impl Iterator<Item = f64> + '_ {
        let dt = 1.0 / self.sample_rate_hz;
        self.grid_index.iter().map(move |&i| i as f64 * dt)
    }

    /// Number of grid samples the log spans, kept or missing.
    pub fn grid_len(&self) -> u64 {
        self.grid_index.last().map_or(0, |&l| l + 1)
    }

    /// The `_cal` partner of an orientation file: `NAME.log` → `NAME_cal.log`.
    pub fn cal_path(angles_path: &Path) -> PathBuf {
        let stem = angles_path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        angles_path.with_file_name(format!("{stem}_cal.log"))
    }
}

/// The channel part of a column name: `00300417_Gyr_Z` → `Gyr_Z`, `Roll` → `Roll`.
fn short_name(column: &str) -> &str {
    match column.split_once('_') {
        Some((prefix, rest)) if is_sensor_id(prefix) => rest,
        _ => column,
    }
}

/// Sensor ids are the hardware serials: all digits or hex-like upper-case, never a channel name.
fn is_sensor_id(s: &str) -> bool {
    !s.is_empty()
        && s.chars().any(|c| c.is_ascii_digit())
        && s.chars()
            .all(|c| c.is_ascii_digit() || c.is_ascii_uppercase())
}

struct Parser<'a> {
    path: &'a Path,
    options: &'a ReadOptions,
}

impl<'a> Parser<'a> {
    fn new(path: &'a Path, options: &'a ReadOptions) -> Self {
        Parser { path, options }
    }

    fn err(&self, line: Option<usize>, column: Option<usize>, kind: LogErrorKind) -> LogError {
        LogError {
            path: self.path.to_path_buf(),
            line,
            column,
            kind,
        }
    }

    /// Reads a log from `reader`; `size_hint` is the file's size when known (bytes).
    fn parse(&self, mut reader: impl Read + Send, size_hint: Option<u64>) -> Result<Log, LogError> {
        let io = |e: std::io::Error| self.err(None, None, LogErrorKind::Io(e.to_string()));
        // The head: the lines up to and including the column row's (the first that is neither
        // a comment nor blank), or the whole file when it has none (or ends its lines with CR
        // alone). The data rows after it are read a batch of blocks at a time.
        let mut head = Vec::new();
        let mut scanned = 0;
        let head_end = loop {
            let mut found = None;
            while let Some(i) = head[scanned..].iter().position(|&b| b == b'\n') {
                let mut line = head[scanned..scanned + i].trim_ascii();
                if scanned == 0 {
                    line = line.strip_prefix("\u{feff}".as_bytes()).unwrap_or(line);
                }
                scanned += i + 1;
                if !(line.is_empty() || line.starts_with(b"//")) {
                    found = Some(scanned);
                    break;
                }
            }
            if found.is_some() {
                break found;
            }
            let n = (&mut reader)
                .take(HEAD_CHUNK_BYTES)
                .read_to_end(&mut head)
                .map_err(io)?;
            if n == 0 {
                break None;
            }
        };
        let head_read_bytes = head.len() as u64;
        let carry = head.split_off(head_end.unwrap_or(head.len()));
        let bytes = &head[..];
        if bytes.is_empty() {
            return Err(self.err(Some(1), None, LogErrorKind::Empty));
        }
        let text = match std::str::from_utf8(bytes) {
            Ok(t) if !t.contains('\0') => t,
            Ok(t) => {
                let at = t.find('\0').unwrap_or(0);
                return Err(self.err(Some(line_of(bytes, at)), None, LogErrorKind::Binary));
            }
            Err(e) => {
                return Err(self.err(
                    Some(line_of(bytes, e.valid_up_to())),
                    None,
                    LogErrorKind::Binary,
                ))
            }
        };
        if text.trim().is_empty() {
            return Err(self.err(Some(1), None, LogErrorKind::Empty));
        }
        // A byte-order mark (an editor on Windows), and old Mac line ends (CR alone).
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let cr_only;
        let text = if !text.contains('\n') && text.contains('\r') {
            cr_only = text.replace('\r', "\n");
            cr_only.as_str()
        } else {
            text
        };

        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, trim_line_end(l)));
        // Header.
        let mut metadata = Vec::new();
        let mut sensor_labels: Vec<(String, String)> = Vec::new();
        let mut column_row = None;
        for (no, line) in lines.by_ref() {
            if let Some(rest) = line.strip_prefix("//") {
                if let Some((k, v)) = rest.split_once(':') {
                    let (k, v) = (k.trim().to_string(), v.trim().to_string());
                    if let Some(id) = k.strip_prefix("Sensor ") {
                        sensor_labels.push((id.trim().to_string(), v.clone()));
                    }
                    metadata.push((k, v));
                }
                continue;
            }
            if line.trim().is_empty() {
                continue;
            }
            column_row = Some((no, line));
            break;
        }
        let meta = |key: &str| {
            metadata
                .iter()
                .find(|(k, _)| k.eq_ignore_ascii_case(key))
                .map(|(_, v)| v.as_str())
        };
        let header_line = |key: &str| {
            text.lines()
                .position(|l| {
                    l.starts_with("//")
                        && l[2..]
                            .trim_start()
                            .to_ascii_lowercase()
                            .starts_with(&key.to_ascii_lowercase())
                })
                .map(|i| i + 1)
        };
        // Where the header ends: the row of column names, or the file's last line.
        let header_end = column_row.map_or_else(|| text.lines().count().max(1), |(no, _)| no);
        let rate_text = meta("Sample rate").ok_or_else(|| {
            self.err(
                Some(header_end),
                None,
                LogErrorKind::MissingKey("Sample rate"),
            )
        })?;
        let sample_rate_hz = rate_text
            .trim_end_matches("Hz")
            .trim()
            .replace(',', ".")
            .parse::<f64>()
            .ok()
            .filter(|r| r.is_finite() && *r > 0.0 && *r <= MAX_SAMPLE_RATE_HZ)
            .ok_or_else(|| {
                self.err(
                    header_line("Sample rate"),
                    None,
                    LogErrorKind::BadSampleRate(rate_text.to_string()),
                )
            })?;
        let mode_text = meta("Output mode").ok_or_else(|| {
            self.err(
                Some(header_end),
                None,
                LogErrorKind::MissingKey("Output mode"),
            )
        })?;
        let mode = OutputMode::parse(mode_text).ok_or_else(|| {
            self.err(
                header_line("Output mode"),
                None,
                LogErrorKind::UnknownMode(mode_text.to_string()),
            )
        })?;
        let declared_comma = meta("Decimal separator").map(|v| v.trim() == ",");

        let (col_line_no, col_line) = column_row
            .ok_or_else(|| self.err(Some(header_end), None, LogErrorKind::NoColumnRow))?;
        let separator = if col_line.contains('\t') {
            '\t'
        } else if col_line.contains(';') {
            ';'
        } else {
            return Err(self.err(Some(col_line_no), None, LogErrorKind::UnknownSeparator));
        };
        let decimal_comma = declared_comma.unwrap_or(separator == ';');
        let names_text: Vec<&str> = col_line.split(separator).map(str::trim).collect();
        for (i, n) in names_text.iter().enumerate() {
            if names_text[..i].contains(n) {
                return Err(self.err(
                    Some(col_line_no),
                    Some(field_col(col_line, separator, i)),
                    LogErrorKind::DuplicateColumn(n.to_string()),
                ));
            }
        }
        let find = |n: &str| names_text.iter().position(|c| *c == n);
        let counter_col = find("Counter").ok_or_else(|| {
            self.err(
                Some(col_line_no),
                None,
                LogErrorKind::MissingColumn("Counter".into()),
            )
        })?;
        let time_col = find("Time").ok_or_else(|| {
            self.err(
                Some(col_line_no),
                None,
                LogErrorKind::MissingColumn("Time".into()),
            )
        })?;
        // Data columns: everything but Counter and Time, in file order.
        let data_fields: Vec<usize> = (0..names_text.len())
            .filter(|&i| i != counter_col && i != time_col)
            .collect();
        let columns: Vec<String> = data_fields
            .iter()
            .map(|&i| names_text[i].to_string())
            .collect();

        // Sensors: from the header's `Sensor <ID>` lines, else from the column prefixes.
        let mut ids: Vec<String> = sensor_labels.iter().map(|(id, _)| id.clone()).collect();
        if ids.is_empty() {
            for c in &columns {
                if let Some((p, _)) = c.split_once('_') {
                    if is_sensor_id(p) && !ids.iter().any(|i| i == p) {
                        ids.push(p.to_string());
                    }
                }
            }
        }
        let channels = mode.channels();
        let mut sensors = Vec::new();
        let unprefixed = channels.iter().all(|ch| columns.iter().any(|c| c == ch));
        if unprefixed && ids.len() <= 1 {
            let id = ids.first().cloned().unwrap_or_default();
            let label = sensor_labels
                .first()
                .map(|(_, l)| l.clone())
                .unwrap_or_default();
            let channel_columns = channels
                .iter()
                .filter_map(|ch| columns.iter().position(|c| c == ch))
                .collect();
            sensors.push(Sensor {
                id,
                label,
                channel_columns,
                orientation: std::sync::OnceLock::new(),
            });
        } else {
            if ids.is_empty() {
                return Err(self.err(Some(col_line_no), None, LogErrorKind::NoSensorColumns));
            }
            for id in &ids {
                let mut channel_columns = Vec::with_capacity(channels.len());
                for ch in channels {
                    let want = format!("{id}_{ch}");
                    let i = columns.iter().position(|c| *c == want).ok_or_else(|| {
                        self.err(
                            Some(col_line_no),
                            None,
                            LogErrorKind::MissingColumn(want.clone()),
                        )
                    })?;
                    channel_columns.push(i);
                }
                let label = sensor_labels
                    .iter()
                    .find(|(i, _)| i == id)
                    .map(|(_, l)| l.clone())
                    .unwrap_or_default();
                sensors.push(Sensor {
                    id: id.clone(),
                    label,
                    channel_columns,
                    orientation: std::sync::OnceLock::new(),
                });
            }
        }

        // The log from what its header gave and what its rows give.
        let assemble =
            |metadata, columns, sensors, data, grid_index, gaps, first_counter, warnings| Log {
                path: self.path.to_path_buf(),
                sample_rate_hz,
                mode,
                metadata,
                spanish_locale: separator == ';',
                columns,
                column_row_line: col_line_no,
                data,
                grid_index,
                sensors,
                gaps,
                first_counter,
                warnings,
            };
        if self.options.header_only {
            let none = GapReport::default();
            return Ok(assemble(
                metadata,
                columns,
                sensors,
                Vec::new(),
                Vec::new(),
                none,
                0,
                Vec::new(),
            ));
        }
        // One sensor's columns kept, where one is asked for and the log has it.
        let (columns, data_fields, sensors) =
            match self.options.only_sensor.as_deref().and_then(|key| {
                sensors
                    .iter()
                    .position(|s| s.id == key || s.label.eq_ignore_ascii_case(key))
            }) {
                Some(k) if sensors.len() > 1 => {
                    let mut sensor = sensors.swap_remove(k);
                    let keep = std::mem::take(&mut sensor.channel_columns);
                    sensor.channel_columns = (0..keep.len()).collect();
                    (
                        keep.iter().map(|&c| columns[c].clone()).collect::<Vec<_>>(),
                        keep.iter().map(|&c| data_fields[c]).collect::<Vec<_>>(),
                        vec![sensor],
                    )
                }
                _ => (columns, data_fields, sensors),
            };

        // Data rows.
        let n_fields = names_text.len();
        // Each field's physical range (a sensor's channel; the others unbounded).
        let limits: Vec<f64> = names_text
            .iter()
            .map(|n| {
                channels
                    .iter()
                    .find(|ch| n == *ch || n.strip_suffix(**ch).is_some_and(|p| p.ends_with('_')))
                    .map_or(f64::INFINITY, |ch| mode.limit(ch))
            })
            .collect();
        let mut data: Vec<Vec<f64>> = vec![Vec::new(); columns.len()];
        let mut grid_index: Vec<u64> = Vec::new();
        let mut gaps = GapReport::default();
        let mut corrupt_run = 0usize;
        let mut rows = 0usize;
        // Last accepted row (counter, time, grid position) and the last row seen at all.
        let mut prev: Option<(u64, f64, u64)> = None;
        let mut first_counter = 0;
        // The last row whose time agreed with the counter: (time, grid position).
        let mut anchor = (0.0_f64, 0_u64);
        // The data rows, after the column row: parsed a block of lines at a time on rayon's
        // threads (each row's counter and numbers), then placed on the grid in file order. A
        // block stops at its first malformed row; the rows before it are placed first, so the
        // error reported is the first in the file, as a line-by-line reading finds it.
        let rest_start = {
            let end = col_line.as_ptr() as usize - text.as_ptr() as usize + col_line.len();
            text[end..].find('\n').map_or(text.len(), |i| end + i + 1)
        };
        // The data rows' bytes: what the head holds after the column row (the whole file's
        // rest when it ends its lines with CR alone), then the rest of the reader.
        let mut blocks = BlockReader {
            pending: [&text.as_bytes()[rest_start..], &carry].concat(),
            spare: Vec::new(),
            reader,
            done: false,
            read_bytes: head_read_bytes,
        };
        let mut batch: Vec<Vec<u8>> = Vec::with_capacity(BLOCKS_PER_BATCH);
        blocks
            .fill(&mut batch)
            .map_err(|k| self.err(None, None, k))?;
        if let (Some(first), Some(size)) = (batch.first(), size_hint) {
            // Room for the whole file's rows at the first block's bytes per line, so that the
            // columns are not copied as they grow (pages never written cost no memory).
            let lines = first.iter().filter(|&&b| b == b'\n').count();
            let rows = (lines as f64 * size as f64 / first.len() as f64 * 1.05) as usize;
            grid_index.reserve_exact(rows);
            data.iter_mut().for_each(|d| d.reserve_exact(rows));
        }
        let row_format = RowFormat {
            separator,
            n_fields,
            counter_col,
            decimal_comma,
            limits: &limits,
            names: &names_text,
            mode,
            rotations: sensors
                .iter()
                .map(|s| s.channel_columns.iter().map(|&c| data_fields[c]).collect())
                .collect(),
        };
        // One data row placed on the grid by its counter (a corrupt one counted as a gap).
        let mut place = |row: &ParsedRow,
                         line: &[u8],
                         no: usize,
                         values: &[f64]|
         -> Result<(), LogError> {
            let (counter, corrupt) = (row.counter.map(u64::from), row.corrupt);
            // The row's text, for a message only (it was read as text).
            let line = || std::str::from_utf8(line).unwrap_or_default();
            rows += 1;
            if corrupt {
                gaps.corrupt_rows += 1;
                gaps.first_corrupt_line.get_or_insert(no);
                corrupt_run += 1;
                if corrupt_run > self.options.max_corrupt_run {
                    return Err(self.err(
                        Some(no),
                        None,
                        LogErrorKind::TooManyCorruptRun {
                            run: corrupt_run,
                            limit: self.options.max_corrupt_run,
                        },
                    ));
                }
                return Ok(());
            }
            corrupt_run = 0;
            let Some(counter) = counter else {
                return Ok(());
            };
            let time = values[time_col];
            let grid = match prev {
                None => {
                    anchor = (time, 0);
                    first_counter = counter;
                    0
                }
                Some((pc, pt, pg)) => {
                    // The counter is the clock; the receiver's stamps jitter and arrive late
                    // in bursts, so a stamp may repeat or fall a little behind the previous one.
                    if time < pt - RECEIVER_LATENCY_S - RECEIVER_JITTER_S {
                        return Err(self.err(
                            Some(no),
                            Some(field_col(line(), separator, time_col)),
                            LogErrorKind::TimeBackwards {
                                previous_s: pt,
                                now_s: time,
                            },
                        ));
                    }
                    let step = self
                        .grid_step(pc, counter, time - pt, sample_rate_hz)
                        .map_err(|k| {
                            self.err(Some(no), Some(field_col(line(), separator, counter_col)), k)
                        })?;
                    let grid = pg + step;
                    // Off: more than half a sample from the time the counter gives it, counted
                    // from the last row that was not off (so a slow drift is followed).
                    let (at, ag) = anchor;
                    if ((time - at) * sample_rate_hz - (grid - ag) as f64).abs() > 0.5 {
                        gaps.time_off_rows += 1;
                    } else {
                        anchor = (time, grid);
                    }
                    if grid > grid_span_limit(grid_index.len(), sample_rate_hz) {
                        return Err(self.err(
                            Some(no),
                            Some(field_col(line(), separator, time_col)),
                            LogErrorKind::GapTooLong {
                                gap_s: (grid - grid_index.len() as u64) as f64 / sample_rate_hz,
                            },
                        ));
                    }
                    grid
                }
            };
            if let Some((_, _, pg)) = prev {
                let hole = grid - pg - 1;
                if hole > 0 {
                    gaps.gaps += 1;
                    gaps.missing_samples += hole;
                    gaps.longest_gap_samples = gaps.longest_gap_samples.max(hole);
                }
            }
            prev = Some((counter, time, grid));
            grid_index.push(grid);
            for (d, &fi) in data.iter_mut().zip(&data_fields) {
                d.push(values[fi]);
            }
            Ok(())
        };
        // The first line of the block being placed.
        let mut first_line = col_line_no + 1;
        // Each block parsed into the rows and numbers of a block placed before (or new ones).
        let parse_batch = |batch: Vec<Vec<u8>>, spare: Vec<ParsedBlock>| -> Vec<ParsedBlock> {
            use rayon::prelude::*;
            let mut spare = spare.into_iter();
            let jobs: Vec<_> = batch
                .into_iter()
                .map(|block| (block, spare.next().unwrap_or_default()))
                .collect();
            jobs.into_par_iter()
                .map(|(block, into)| row_format.parse_block(block, into))
                .collect()
        };
        // A batch is placed on the grid (in order, on this thread) while the next is read and
        // parsed (on the others), into the buffers of the batch placed before.
        let mut parsed = parse_batch(batch, Vec::new());
        let mut spare: Vec<ParsedBlock> = Vec::new();
        while !parsed.is_empty() {
            let (placed, next) = rayon::join(
                || -> Result<(), LogError> {
                    for block in &parsed {
                        for (r, row) in block.rows.iter().enumerate() {
                            let values = &block.values[r * n_fields..(r + 1) * n_fields];
                            let line = &block.bytes[row.text()];
                            place(row, line, first_line + row.line as usize, values)?;
                        }
                        if let Some((line, col, kind)) = &block.error {
                            return Err(self.err(Some(first_line + line), *col, kind.clone()));
                        }
                        first_line += block.lines;
                    }
                    Ok(())
                },
                || {
                    let mut batch = Vec::with_capacity(BLOCKS_PER_BATCH);
                    let spare = std::mem::take(&mut spare);
                    blocks.fill(&mut batch).map(|()| parse_batch(batch, spare))
                },
            );
            placed?;
            let next = next.map_err(|k| self.err(None, None, k))?;
            spare = std::mem::replace(&mut parsed, next);
            for block in &mut spare {
                blocks.spare.push(std::mem::take(&mut block.bytes));
            }
        }
        if grid_index.is_empty() {
            return Err(self.err(Some(col_line_no), None, LogErrorKind::NoData));
        }
        let percent = 100.0 * gaps.corrupt_rows as f64 / rows.max(1) as f64;
        if percent > self.options.max_corrupt_percent {
            return Err(self.err(
                gaps.first_corrupt_line,
                None,
                LogErrorKind::TooManyCorrupt {
                    corrupt: gaps.corrupt_rows,
                    rows,
                    limit_percent: self.options.max_corrupt_percent,
                },
            ));
        }

        let mut warnings = Vec::new();
        if gaps.missing_samples > 0 {
            warnings.push(format!(
                "{}: {} missing samples in {} gaps (longest {} samples = {:.2} s); kept as gaps",
                self.path.display(),
                gaps.missing_samples,
                gaps.gaps,
                gaps.longest_gap_samples,
                gaps.longest_gap_samples as f64 / sample_rate_hz
            ));
        }
        if gaps.corrupt_rows > 0 {
            warnings.push(format!(
                "{}:{}: {} corrupt rows (cut short, NaN, or a value beyond its channel's range) kept as gaps",
                self.path.display(),
                gaps.first_corrupt_line.unwrap_or(0),
                gaps.corrupt_rows
            ));
        }

        // Orientations.
        if mode == OutputMode::Euler {
            use rayon::prelude::*;
            // Roll and yaw wrap at ±180°; pitch stays within ±90°. One column per thread.
            let wrapping: Vec<usize> = sensors
                .iter()
                .flat_map(|s| [s.channel_columns[0], s.channel_columns[2]])
                .collect();
            data.par_iter_mut()
                .enumerate()
                .filter(|(ci, _)| wrapping.contains(ci))
                .for_each(|(_, column)| unwrap_degrees(column));
        }

        Ok(assemble(
            metadata,
            columns,
            sensors,
            data,
            grid_index,
            gaps,
            first_counter,
            warnings,
        ))
    }

    /// Samples between two rows: the counter's step (mod 65536) made consistent with the time step.
    fn grid_step(&self, prev: u64, now: u64, dt_s: f64, rate_hz: f64) -> Result<u64, LogErrorKind> {
        let d = (now + COUNTER_MODULUS - prev) % COUNTER_MODULUS;
        if d == 0 {
            return Err(LogErrorKind::CounterRepeats(now));
        }
        if dt_s > MAX_GAP_S {
            return Err(LogErrorKind::GapTooLong { gap_s: dt_s });
        }
        let by_time = dt_s * rate_hz;
        // Longer gaps than one counter period: add whole periods to agree with the time.
        let wraps = ((by_time - d as f64) / COUNTER_MODULUS as f64)
            .round()
            .max(0.0) as u64;
        let step = d + wraps * COUNTER_MODULUS;
        // The receiver's clock jitters, drifts a little and stamps packets late in bursts.
        let tolerance =
            0.5 + 0.02 * by_time.abs() + (RECEIVER_LATENCY_S + RECEIVER_JITTER_S) * rate_hz;
        if (step as f64 - by_time).abs() <= tolerance {
            return Ok(step);
        }
        if d > COUNTER_MODULUS / 2 && by_time < (COUNTER_MODULUS / 2) as f64 {
            return Err(LogErrorKind::CounterBackwards {
                previous: prev,
                now,
            });
        }
        Err(LogErrorKind::CounterTimeMismatch {
            counter_samples: step,
            time_samples: by_time,
        })
    }
}

/// A field as an error message quotes it: at most 40 characters, the rest elided.
fn excerpt(text: &str) -> String {
    match text.char_indices().nth(40) {
        Some((i, _)) => format!("{}… ({} bytes)", &text[..i], text.len()),
        None => text.to_string(),
    }
}

/// 1-based line of byte offset `at`.
fn line_of(bytes: &[u8], at: usize) -> usize {
    1 + bytes[..at.min(bytes.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
}

/// A line without what ends it: spaces and tabs at a line's end are no field (a
/// spreadsheet's export adds a tab), and a CR is the Windows line end's.
fn trim_line_end(line: &str) -> &str {
    line.trim_end_matches(['\r', '\t', ' '])
}

/// Bytes of text per block of lines parsed on one thread.
const BLOCK_BYTES: usize = 1 << 19;
/// Blocks parsed together before they are placed on the grid: enough for both cores, few
/// enough that the parsed numbers held beside the columns stay a few megabytes.
const BLOCKS_PER_BATCH: usize = 8;

/// Bytes of the head read at a time while looking for the column row.
const HEAD_CHUNK_BYTES: u64 = 64 * 1024;

/// The data rows' bytes in blocks of about [`BLOCK_BYTES`] that end at a line's end, read a
/// batch at a time so that a long log is never held whole. A block's line numbers are counted
/// by its own parse ([`RowFormat::parse_block`], on its thread) and made absolute when the
/// blocks are placed in order.
struct BlockReader<R> {
    /// Read and not yet handed out: the start of a line.
    pending: Vec<u8>,
    /// Blocks already placed, their buffers kept for the next ones (fresh ones of half a
    /// megabyte each are fresh pages: their faults took a tenth of a log's reading).
    spare: Vec<Vec<u8>>,
    reader: R,
    done: bool,
    /// Bytes read from the file so far, head included.
    read_bytes: u64,
}

impl<R: Read> BlockReader<R> {
    /// The next block: whole lines of at least [`BLOCK_BYTES`] (a line longer than that
    /// whole), or what is left at the file's end; `None` at the end.
    fn next_block(&mut self) -> Result<Option<Vec<u8>>, LogErrorKind> {
        let mut searched = 0;
        loop {
            if self.pending.len() >= BLOCK_BYTES || self.done {
                // The last line end, found in the bytes: a line end is always a character
                // boundary, a block's nominal size need not be (a non-ASCII character there).
                let cut = match self.pending[searched..].iter().rposition(|&b| b == b'\n') {
                    Some(i) => searched + i + 1,
                    None if self.done => self.pending.len(),
                    None => {
                        searched = self.pending.len();
                        self.read_more()?;
                        continue;
                    }
                };
                if cut == 0 {
                    return Ok(None);
                }
                let mut next = self
                    .spare
                    .pop()
                    .unwrap_or_else(|| Vec::with_capacity(BLOCK_BYTES + BLOCK_BYTES / 8));
                next.clear();
                next.extend_from_slice(&self.pending[cut..]);
                self.pending.truncate(cut);
                return Ok(Some(std::mem::replace(&mut self.pending, next)));
            }
            self.read_more()?;
        }
    }

    /// Reads up to a block's size more; marks the end.
    fn read_more(&mut self) -> Result<(), LogErrorKind> {
        let n = (&mut self.reader)
            .take(BLOCK_BYTES as u64)
            .read_to_end(&mut self.pending)
            .map_err(|e| LogErrorKind::Io(e.to_string()))?;
        self.read_bytes += n as u64;
        if self.read_bytes >= crate::read::kind::MAX_INPUT_BYTES {
            return Err(LogErrorKind::Io(crate::read::kind::too_large_message()));
        }
        self.done = n == 0;
        Ok(())
    }

    /// Up to [`BLOCKS_PER_BATCH`] blocks into `batch`; none at the end.
    fn fill(&mut self, batch: &mut Vec<Vec<u8>>) -> Result<(), LogErrorKind> {
        while batch.len() < BLOCKS_PER_BATCH {
            match self.next_block()? {
                Some(block) => batch.push(block),
                None => break,
            }
        }
        Ok(())
    }
}

/// How a data row is written: what [`RowFormat::parse_block`] needs to read its fields.
struct RowFormat<'h> {
    separator: char,
    n_fields: usize,
    counter_col: usize,
    decimal_comma: bool,
    /// Each field's physical range (`v.abs()` beyond it: a corrupt sample).
    limits: &'h [f64],
    /// The column names, for messages.
    names: &'h [&'h str],
    mode: OutputMode,
    /// Each sensor's fields in the order of [`OutputMode::channels`]: in a quaternion or
    /// matrix file, a row that is not a rotation is an error naming its first field.
    rotations: Vec<Vec<usize>>,
}

/// One data row as read: its line (number within its block, from 0, and where its text lies
/// in the block's bytes), counter (when it has one) and whether it is corrupt (cut short, NaN,
/// a value beyond its channel's range). A block is part of a file read to less than
/// [`crate::read::kind::MAX_INPUT_BYTES`] (4 GiB), so its lines and offsets fit 32 bits, and a
/// counter is below [`COUNTER_MODULUS`]: 20 bytes a row where machine words took 48 (every
/// row is written by its block's parse and read again to be placed).
struct ParsedRow {
    line: u32,
    start: u32,
    len: u32,
    counter: Option<u16>,
    corrupt: bool,
}

impl ParsedRow {
    fn text(&self) -> std::ops::Range<usize> {
        let start = self.start as usize;
        start..start + self.len as usize
    }
}

/// A block's data rows, their numbers (`n_fields` per row, in file order), its number of
/// lines, and the first malformed row that ended it: (line within the block, column, what).
#[derive(Default)]
struct ParsedBlock {
    /// The block's bytes (its rows' text, for messages).
    bytes: Vec<u8>,
    rows: Vec<ParsedRow>,
    values: Vec<f64>,
    lines: usize,
    error: Option<(usize, Option<usize>, LogErrorKind)>,
}

impl RowFormat<'_> {
    /// Reads the data rows of `block` (line numbers counted from 0 at its first line);
    /// comment and blank lines are skipped. A byte that is no text (not UTF-8, or NUL) ends
    /// the block with an error on its line, as a malformed row does.
    /// The rows and numbers go into `into`'s buffers (emptied first), kept from a block placed
    /// before.
    fn parse_block(&self, block: Vec<u8>, into: ParsedBlock) -> ParsedBlock {
        let mut out = self.parse_rows(&block, into);
        out.bytes = block;
        out
    }

    /// [`RowFormat::parse_block`] but for keeping the bytes.
    fn parse_rows(&self, block: &[u8], into: ParsedBlock) -> ParsedBlock {
        let n_fields = self.n_fields;
        let valid = match std::str::from_utf8(block) {
            Ok(t) => t,
            Err(e) => std::str::from_utf8(&block[..e.valid_up_to()]).unwrap_or_default(),
        };
        let bad_at = valid
            .find('\0')
            .or((valid.len() < block.len()).then_some(valid.len()));
        // The whole lines before the first byte that is no text.
        let text = match bad_at {
            Some(at) => &valid[..valid[..at].rfind('\n').map_or(0, |i| i + 1)],
            None => valid,
        };
        // Room for rows of 24 bytes and more (a sensor row is longer): no regrowth.
        let room = text.len() / 24 + 1;
        let mut out = ParsedBlock {
            bytes: Vec::new(),
            lines: 0,
            error: None,
            ..into
        };
        out.rows.clear();
        out.values.clear();
        out.rows.reserve(room);
        out.values.reserve(room * n_fields);
        let mut values = vec![0.0; n_fields];
        let checks_rotations = matches!(self.mode, OutputMode::Quaternion | OutputMode::Matrix);
        for (no, raw) in text.lines().enumerate() {
            out.lines = no + 1;
            let line = trim_line_end(raw);
            if line.trim().is_empty() || line.starts_with("//") {
                continue;
            }
            let parsed = match self.parse_plain_row(line.as_bytes(), &mut values) {
                Some(row) => Ok(row),
                None => self.parse_row(line, &mut values),
            };
            match parsed {
                Ok((counter, corrupt)) => {
                    if checks_rotations && !corrupt {
                        let not_rotation = self.rotations.iter().find_map(|fields| {
                            orientation(self.mode, |c| values[fields[c]])
                                .err()
                                .map(|kind| (fields[0], kind))
                        });
                        if let Some((field, kind)) = not_rotation {
                            let col = field_col(line, self.separator, field);
                            out.error = Some((no, Some(col), kind));
                            return out;
                        }
                    }
                    let start = line.as_ptr() as usize - block.as_ptr() as usize;
                    out.rows.push(ParsedRow {
                        line: no as u32,
                        start: start as u32,
                        len: line.len() as u32,
                        // Below COUNTER_MODULUS = 2¹⁶ (both parsers check it).
                        counter: counter.map(|c| c as u16),
                        corrupt,
                    });
                    out.values.extend_from_slice(&values);
                }
                Err((col, kind)) => {
                    out.error = Some((no, col, kind));
                    return out;
                }
            }
        }
        if bad_at.is_some() {
            let no = text.bytes().filter(|&b| b == b'\n').count();
            out.error = Some((no, None, LogErrorKind::Binary));
        }
        out
    }

    /// [`RowFormat::parse_row`] in one pass over the bytes for the row a sensor writes: every
    /// field a plain number ([`PlainNumber`], as [`plain_decimal`] reads it, so the same
    /// doubles; the decimal comma too where the file uses it), the counter digits alone, no
    /// spaces, exactly `n_fields` fields. `None` for any other row, which `parse_row` then reads
    /// and judges. The split, trim and parse of each field apart took half of a log's reading.
    fn parse_plain_row(&self, line: &[u8], values: &mut [f64]) -> Option<(Option<u64>, bool)> {
        let sep = self.separator as u8;
        let comma = if self.decimal_comma { b',' } else { b'.' };
        let n = line.len();
        let (mut corrupt, mut counter, mut i) = (false, None, 0);
        let fields = values.iter_mut().zip(self.limits).take(self.n_fields);
        for (fi, (value, &limit)) in fields.enumerate() {
            let number = PlainNumber::scan(line.get(i..)?, comma);
            i += number.len;
            let ends_here = if fi + 1 == self.n_fields {
                i == n
            } else {
                line.get(i) == Some(&sep)
            };
            if !ends_here {
                return None;
            }
            if fi == self.counter_col {
                let digits_alone = !number.negative && number.point.is_none();
                if !digits_alone || !(1..=5).contains(&number.digits) || number.m >= COUNTER_MODULUS
                {
                    return None;
                }
                counter = Some(number.m);
            } else {
                let v = number.value()?;
                if v.abs() <= limit {
                    *value = v;
                } else {
                    corrupt = true;
                }
            }
            i += 1;
        }
        // Past the last field's end: every field read (none left out by a short `values`).
        (i == n + 1).then_some((counter, corrupt))
    }

    /// One row's counter and whether it is corrupt, its numbers written into `values`; `Err`
    /// with the column and what is wrong for a row that is not a row of this log.
    fn parse_row(
        &self,
        line: &str,
        values: &mut [f64],
    ) -> Result<(Option<u64>, bool), (Option<usize>, LogErrorKind)> {
        let (n_fields, separator) = (self.n_fields, self.separator);
        let mut count = 0usize;
        let mut corrupt = false;
        let mut counter = None;
        // A field's column is counted only for an error message ([`field_col`]).
        let col = |fi: usize| Some(field_col(line, separator, fi));
        // Split on the separator's byte (ASCII: the pieces stay whole characters).
        let sep_byte = separator as u8;
        for (fi, bytes) in line.as_bytes().split(|&b| b == sep_byte).enumerate() {
            count += 1;
            if fi >= n_fields {
                return Err((
                    col(fi),
                    LogErrorKind::FieldCount {
                        expected: n_fields,
                        found: line.split(separator).count(),
                    },
                ));
            }
            let bytes = bytes.trim_ascii();
            let text = || std::str::from_utf8(bytes).unwrap_or_default().trim();
            if fi == self.counter_col {
                // Digits alone, straight from the bytes; the text only for the rest.
                if !bytes.is_empty() && bytes.len() <= 5 && bytes.iter().all(u8::is_ascii_digit) {
                    let c = bytes.iter().fold(0, |c, &b| c * 10 + u64::from(b - b'0'));
                    if c < COUNTER_MODULUS {
                        counter = Some(c);
                        continue;
                    }
                }
                let t = text();
                match t.parse::<u64>() {
                    Ok(c) if c < COUNTER_MODULUS => counter = Some(c),
                    _ if is_nan_text(t) => corrupt = true,
                    _ => return Err((col(fi), LogErrorKind::BadCounter(t.to_string()))),
                }
                continue;
            }
            // The plain forms straight from the bytes; the text only for the rest.
            match plain_decimal(bytes).or_else(|| parse_number(text(), self.decimal_comma)) {
                Some(v) if v.abs() <= self.limits[fi] => values[fi] = v,
                // Not finite, or beyond its channel's range.
                Some(_) => corrupt = true,
                None if text().is_empty() && fi + 1 == n_fields => corrupt = true,
                // A row cut short inside its last number (`-`, `12.`): the packet arrived
                // cut, as an empty last field does.
                None if fi + 1 < n_fields && line.split(separator).count() == fi + 1 => {
                    corrupt = true
                }
                None => {
                    return Err((
                        col(fi),
                        LogErrorKind::BadNumber {
                            column: self.names[fi].to_string(),
                            text: text().to_string(),
                        },
                    ))
                }
            }
        }
        Ok((counter, corrupt || count < n_fields))
    }
}

/// 1-based character column of field `index` of `line` (or the line's end when the row is cut
/// short): counted only for a message, never for every field.
fn field_col(line: &str, sep: char, index: usize) -> usize {
    let mut col = 1;
    for (i, text) in line.split(sep).enumerate() {
        if i == index {
            return col;
        }
        col += text.chars().count() + 1;
    }
    line.chars().count() + 1
}

fn is_nan_text(t: &str) -> bool {
    t.eq_ignore_ascii_case("nan") || t.eq_ignore_ascii_case("-nan")
}

/// A number in either locale; `None` when the text is not a number at all.
/// NaN and infinities parse (to be treated as corrupt samples by the caller).
fn parse_number(t: &str, decimal_comma: bool) -> Option<f64> {
    if decimal_comma && t.contains(',') {
        let mut buf = [0u8; 64];
        if t.len() > buf.len() {
            return None;
        }
        for (b, c) in buf.iter_mut().zip(t.bytes()) {
            *b = if c == b',' { b'.' } else { c };
        }
        plain_decimal(&buf[..t.len()])
            .or_else(|| std::str::from_utf8(&buf[..t.len()]).ok()?.parse().ok())
    } else {
        // The plain forms are [`plain_decimal`]'s, tried before this (by the caller).
        t.parse().ok()
    }
}

/// Exact powers of ten: every one up to 10²² is a double.
const POWERS_OF_TEN: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// The number a sensor writes (`-?digits` or `-?digits.digits`) by Clinger's fast path
/// (W. D. Clinger, "How to read floating point numbers accurately", PLDI 1990): when the digits
/// make an integer m < 2⁵³ and there are k ≤ 22 decimals, m and 10ᵏ are exact doubles and one
/// division rounds m / 10ᵏ correctly, as the standard parser does. `None` for any other form
/// (an exponent, more digits, no digit on a side of the point, signs, words), which the
/// standard parser then reads. A quarter of a log's reading went to the general parser, and
/// as much of a CSV's ([`crate::signal`]).
pub(crate) fn plain_decimal(t: &[u8]) -> Option<f64> {
    let number = PlainNumber::scan(t, b'.');
    if number.len != t.len() {
        return None;
    }
    number.value()
}

/// A number read from the start of some bytes as a sensor writes it: `-?` then digits with at
/// most one point (`.`, or the file's decimal comma), up to the first other byte. Shared by
/// [`plain_decimal`] and the one-pass row reader ([`RowFormat::parse_plain_row`]).
struct PlainNumber {
    negative: bool,
    /// The digits as an integer (wrapped, and then refused, beyond 16 bytes).
    m: u64,
    /// Digits and point, the sign left out.
    digits: usize,
    /// The point's position among them.
    point: Option<usize>,
    /// Bytes read, the sign included.
    len: usize,
}

impl PlainNumber {
    fn scan(t: &[u8], decimal_comma: u8) -> PlainNumber {
        let negative = t.first() == Some(&b'-');
        let start = usize::from(negative);
        let (mut m, mut point, mut i) = (0u64, None, start);
        while let Some(&b) = t.get(i) {
            let d = b.wrapping_sub(b'0');
            if d <= 9 {
                m = m.wrapping_mul(10).wrapping_add(u64::from(d));
            } else if (b == b'.' || b == decimal_comma) && point.is_none() {
                point = Some(i - start);
            } else {
                break;
            }
            i += 1;
        }
        PlainNumber {
            negative,
            m,
            digits: i - start,
            point,
            len: i,
        }
    }

    /// Its decimals, `None` where it is not of the plain form: no digit, a point without a
    /// digit on each side, or more than 15 digits (m < 10¹⁵ < 2⁵³; longer: the general parser).
    fn decimals(&self) -> Option<usize> {
        if self.digits == 0 || self.digits > 16 {
            return None;
        }
        match self.point {
            Some(p) if p == 0 || p + 1 == self.digits => None,
            Some(p) => Some(self.digits - p - 1),
            None if self.digits > 15 => None,
            None => Some(0),
        }
    }

    /// The double it writes, by Clinger's fast path (above).
    fn value(&self) -> Option<f64> {
        let decimals = self.decimals()?;
        // m < 10¹⁵ < 2⁵³: exact through i64, whose conversion is one instruction (u64's is four).
        let v = self.m as i64 as f64 / POWERS_OF_TEN[decimals];
        Some(if self.negative { -v } else { v })
    }
}

/// Removes the ±360° jumps of an angle that wraps at ±180°.
pub fn unwrap_degrees(x: &mut [f64]) {
    let mut offset = 0.0;
    let mut prev = match x.first() {
        Some(&p) => p,
        None => return,
    };
    for v in x.iter_mut().skip(1) {
        let raw = *v;
        let d = raw - prev;
        if d > 180.0 {
            offset -= 360.0 * ((d + 180.0) / 360.0).floor();
        } else if d < -180.0 {
            offset += 360.0 * ((-d + 180.0) / 360.0).floor();
        }
        prev = raw;
        *v = raw + offset;
    }
}

/// Tolerance on a written quaternion's norm and a matrix's orthonormality: a sensor writing
/// 4 decimals is off by ~1e-4; 0.05 catches a broken row without rejecting honest rounding.
const ROTATION_TOLERANCE: f64 = 0.05;

/// The orientation of every sample from a sensor's columns, on rayon's threads in blocks of
/// rows (the Euler angles' sines and cosines were a seventh of a log's reading); then, in
/// order, each quaternion's sign made continuous with the one before. The first row that is
/// not a rotation is the error, whatever thread saw it.
fn orientations(
    mode: OutputMode,
    data: &[Vec<f64>],
    cols: &[usize],
) -> Result<Vec<UnitQuaternion<f64>>, (LogErrorKind, usize)> {
    use rayon::prelude::*;
    const BLOCK: usize = 1 << 14;
    if mode == OutputMode::Calibrated {
        return Ok(Vec::new());
    }
    let n = data.first().map_or(0, Vec::len);
    let mut out = vec![UnitQuaternion::identity(); n];
    let errors: Vec<Option<(LogErrorKind, usize)>> = out
        .par_chunks_mut(BLOCK)
        .enumerate()
        .map(|(b, block)| {
            for (k, q) in block.iter_mut().enumerate() {
                let i = b * BLOCK + k;
                match orientation(mode, |c| data[cols[c]][i]) {
                    Ok(r) => *q = r,
                    Err(kind) => return Some((kind, i)),
                }
            }
            None
        })
        .collect();
    if let Some(e) = errors.into_iter().flatten().next() {
        return Err(e);
    }
    for i in 1..n {
        out[i] = continuing(&out[i - 1], out[i]);
    }
    Ok(out)
}

/// `q` or `−q` (one rotation), whichever continues `prev`: a non-negative dot product.
fn continuing(prev: &UnitQuaternion<f64>, q: UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    if prev.coords.dot(&q.coords) < 0.0 {
        UnitQuaternion::new_unchecked(-q.into_inner())
    } else {
        q
    }
}

/// One sample's orientation from its channel values (`v(k)`: the sensor's k-th channel).
fn orientation(
    mode: OutputMode,
    v: impl Fn(usize) -> f64,
) -> Result<UnitQuaternion<f64>, LogErrorKind> {
    Ok(match mode {
        OutputMode::Euler => {
            let d = std::f64::consts::PI / 180.0;
            UnitQuaternion::from_euler_angles(v(0) * d, v(1) * d, v(2) * d)
        }
        OutputMode::Quaternion => {
            let raw = Quaternion::new(v(0), v(1), v(2), v(3));
            let norm = raw.norm();
            if (norm - 1.0).abs() > ROTATION_TOLERANCE {
                return Err(LogErrorKind::QuaternionNorm(norm));
            }
            UnitQuaternion::from_quaternion(raw)
        }
        OutputMode::Matrix => {
            let m = Matrix3::from_fn(|r, c| v(3 * r + c));
            let err = (m.transpose() * m - Matrix3::identity()).abs().max();
            let det = m.determinant();
            if err > ROTATION_TOLERANCE || det <= 0.0 {
                return Err(LogErrorKind::NotRotation {
                    orthonormality_error: err,
                    det,
                });
            }
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_eps(
                &m,
                1e-12,
                100,
                Rotation3::identity(),
            ))
        }
        OutputMode::Calibrated => UnitQuaternion::identity(),
    })
}

/// The longest hole a recording may hold (s): a link lost for longer than an hour has ended
/// one recording, and the file holds two.
pub const MAX_GAP_S: f64 = 3600.0;

/// The time a recording may lose beyond ten times its own samples (s): a sensor out of the
/// receiver's range for a minute. A short recording with a longer hole is two recordings or a
/// wrong time stamp: 42 rows of which the last was stamped 2994 s after 2.98 s were read as one
/// 17-sample "free decay" over 50 minutes (found by fuzzing).
pub const MAX_HOLE_S: f64 = 60.0;

/// Grid samples of holes a recording may hold beyond ten times its own samples, at any rate:
/// what the spectrum and the fits allocate stays proportional to the data (a row stamped at
/// 1e12 s would otherwise ask for terabytes).
pub const MAX_HOLE_SAMPLES: u64 = 4_000_000;

/// The furthest grid position a recording of `kept` samples at `rate_hz` may reach: ten times
/// its samples plus [`MAX_HOLE_S`] of samples (at most [`MAX_HOLE_SAMPLES`]).
pub fn grid_span_limit(kept: usize, rate_hz: f64) -> u64 {
    let hole = (MAX_HOLE_S * rate_hz).clamp(0.0, MAX_HOLE_SAMPLES as f64) as u64;
    10 * kept as u64 + hole
}

/// The message for a hole beyond [`MAX_GAP_S`] or [`grid_span_limit`].
pub fn gap_too_long_message(gap_s: f64) -> String {
    format!(
        "a hole of {gap_s:.6e} s in the time: over {MAX_GAP_S} s, or over {MAX_HOLE_S} s beyond \
         ten times the data before it: not one recording (split the file, or check the time \
         column)"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Log, LogError> {
        Log::parse(text.as_bytes(), Path::new("t.log"), &ReadOptions::default())
    }

    const HEAD: &str = "// Sample rate: 100 Hz\n// Output mode: Euler\n// Sensor 00300417: frame\nCounter\tTime\t00300417_Roll\t00300417_Pitch\t00300417_Yaw\n";

    /// The one-pass row reader agrees with the field-by-field one wherever it answers, bit for
    /// bit, and answers for the rows sensors write: seeded rows of a counter and four numbers,
    /// each mutated or not (spaces, an exponent, a plus, NaN, empty, cut short, an extra field,
    /// 17 digits, a counter of 65,536 or signed, a value beyond its range, a decimal comma), in
    /// both locales.
    #[test]
    fn the_one_pass_row_reader_is_the_field_by_field_one() {
        use rand::{RngExt as _, SeedableRng as _};
        let mut rng = rand_xoshiro::Xoshiro256StarStar::seed_from_u64(11);
        let limits = [f64::INFINITY, 1e6, 360.0, 90.0, 360.0];
        let names = ["Counter", "Time", "Roll", "Pitch", "Yaw"];
        let (mut answered, mut plain_rows) = (0, 0);
        for comma in [false, true] {
            let format = RowFormat {
                separator: if comma { ';' } else { '\t' },
                n_fields: 5,
                counter_col: 0,
                decimal_comma: comma,
                limits: &limits,
                names: &names,
                mode: OutputMode::Euler,
                rotations: Vec::new(),
            };
            let point = if comma { "," } else { "." };
            for _ in 0..50_000 {
                let mut fields: Vec<String> = vec![(rng.random::<u64>() % 65_536).to_string()];
                for _ in 0..4 {
                    let v = (rng.random::<f64>() - 0.5) * 400.0;
                    let decimals = (rng.random::<u64>() % 7) as usize;
                    fields.push(format!("{v:.decimals$}").replace('.', point));
                }
                let mutated = rng.random::<u64>() % 3 == 0;
                if mutated {
                    let k = (rng.random::<u64>() % 5) as usize;
                    let f = &mut fields[k];
                    match rng.random::<u64>() % 12 {
                        0 => f.insert(0, ' '),
                        1 => f.push_str("e1"),
                        2 => f.insert(0, '+'),
                        3 => *f = "NaN".into(),
                        4 => f.clear(),
                        5 => {
                            fields.truncate(k.max(1));
                        }
                        6 => fields.push("1".into()),
                        7 => *f = "12345678901234567".into(),
                        8 => fields[0] = "65536".into(),
                        9 => fields[0] = format!("-{}", fields[0]),
                        10 => *f = "400".into(),
                        _ => *f = f.replace(point, if comma { "." } else { "," }),
                    }
                }
                let line = fields.join(if comma { ";" } else { "\t" });
                let mut fast_values = [0.0; 5];
                let mut slow_values = [0.0; 5];
                let fast = format.parse_plain_row(line.as_bytes(), &mut fast_values);
                let slow = format.parse_row(&line, &mut slow_values);
                plain_rows += usize::from(!mutated);
                if let Some((counter, corrupt)) = fast {
                    answered += usize::from(!mutated);
                    assert_eq!(slow, Ok((counter, corrupt)), "{line:?}");
                    for k in 1..5 {
                        if fast_values[k].abs() <= limits[k] {
                            assert_eq!(
                                fast_values[k].to_bits(),
                                slow_values[k].to_bits(),
                                "{line:?}"
                            );
                        }
                    }
                }
            }
        }
        assert_eq!(answered, plain_rows, "every unmutated row read in one pass");
    }

    /// The fast path gives the standard parser's double, bit for bit, on the forms sensors
    /// write (seeded random decimals of 1–15 digits, both signs, 0–14 decimals) and leaves every
    /// other form to it.
    #[test]
    fn plain_decimals_are_the_standard_parsers() {
        use rand::{RngExt as _, SeedableRng as _};
        let mut rng = rand_xoshiro::Xoshiro256StarStar::seed_from_u64(3);
        for _ in 0..200_000 {
            let digits = 1 + (rng.random::<u64>() % 15) as usize;
            let decimals = (rng.random::<u64>() % digits as u64) as usize;
            let m = rng.random::<u64>() % 10u64.pow(digits as u32);
            let body = format!("{m:0digits$}");
            let (int, frac) = body.split_at(digits - decimals);
            let sign = if rng.random::<bool>() { "-" } else { "" };
            let text = if decimals > 0 {
                format!("{sign}{int}.{frac}")
            } else {
                format!("{sign}{int}")
            };
            let fast = plain_decimal(text.as_bytes()).expect("a plain decimal");
            let std: f64 = text.parse().expect("a number");
            assert_eq!(fast.to_bits(), std.to_bits(), "{text}");
        }
        for other in [
            "1e5",
            ".5",
            "5.",
            "+1",
            "--1",
            "1.2.3",
            "nan",
            "",
            "-",
            "1234567890123456",
        ] {
            assert_eq!(plain_decimal(other.as_bytes()), None, "{other}");
        }
        assert_eq!(parse_number("12,5", true), Some(12.5));
        assert_eq!(
            parse_number("-0.000", false).map(f64::to_bits),
            Some((-0.0f64).to_bits())
        );
    }

    #[test]
    fn counter_wrap_and_drop_are_gaps() {
        let text = format!("{HEAD}65534\t0.00\t1\t2\t3\n65535\t0.01\t1\t2\t3\n1\t0.03\t1\t2\t3\n");
        let log = parse(&text).unwrap();
        assert_eq!(log.grid_index, vec![0, 1, 3]);
        assert_eq!(log.gaps.missing_samples, 1);
        assert_eq!(log.gaps.longest_gap_samples, 1);
    }

    #[test]
    fn gap_longer_than_counter_period_uses_time() {
        // `rows` rows, then one 65536 + 2 samples after the last: the counter alone says 2.
        let with_hole = |rows: u64| {
            let mut text = String::from(HEAD);
            for k in 0..rows {
                text.push_str(&format!("{}\t{:.2}\t1\t2\t3\n", k + 10, k as f64 / 100.0));
            }
            let t = (rows - 1 + 65_538) as f64 / 100.0;
            text.push_str(&format!("{}\t{t:.3}\t1\t2\t3\n", rows + 9 + 2));
            parse(&text)
        };
        // After 70 s of rows (the grid may span ten times the samples and a minute: 12.7
        // minutes), the hole of 11 minutes is kept as one.
        let log = with_hole(7000).unwrap();
        assert_eq!(log.grid_index.len(), 7001);
        assert_eq!(log.grid_index[7000], 6999 + 65_538);
        // After a second of rows, the same hole is two recordings, not one.
        let e = with_hole(100).unwrap_err();
        assert!(matches!(e.kind, LogErrorKind::GapTooLong { .. }), "{e}");
    }

    /// A receiver whose stamps jitter by ±4 ms, stamp to 0.01 s, and deliver 40 ms late in
    /// bursts every half second: the counter places every row, no gap is invented (issue 14:
    /// a log was rejected for a 3.2 ms jitter).
    #[test]
    fn jitter_and_late_bursts_follow_the_counter() {
        let mut text = String::from(HEAD);
        let mut state = 12_345_u64;
        let mut last = 0.0_f64;
        for k in 0..400_u64 {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            let jitter = ((state >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.008;
            let late = if k % 50 < 4 {
                0.04 - 0.01 * (k % 50) as f64
            } else {
                0.0
            };
            // Stamped to 0.01 s, never before the previous stamp.
            let t = ((k as f64 / 100.0 + jitter + late) * 100.0).round() / 100.0;
            last = t.max(last);
            text += &format!("{}\t{last:.2}\t1\t2\t3\n", (60_000 + k) % COUNTER_MODULUS);
        }
        let log = parse(&text).unwrap();
        assert_eq!(log.grid_index, (0..400).collect::<Vec<u64>>());
        assert_eq!(log.gaps.gaps, 0);
    }

    /// Issue 33: a roll of 400° or 1e300° in one row (beyond the ±180° the format allows) is a
    /// corrupted packet: that row is a gap, counted with its line, not a reading (1e300 was
    /// read as an angle, 400 unwrapped into the roll and ended the ride's free motion).
    #[test]
    fn a_value_beyond_its_channels_range_is_a_corrupt_row() {
        for bad in ["400", "1e300", "-90.5"] {
            // Roll, pitch, yaw: the bad value in the roll, or -90.5 in the pitch.
            let row = if bad == "-90.5" {
                format!("2\t0.01\t1\t{bad}\t3\n")
            } else {
                format!("2\t0.01\t{bad}\t2\t3\n")
            };
            // The range's own ends are readings; 40 rows keep one corrupt below the 5 % limit.
            let mut text = format!("{HEAD}1\t0.00\t1\t2\t3\n{row}");
            for k in 3..=40 {
                text += &format!("{k}\t{:.2}\t180.0\t-90\t-180\n", (k - 1) as f64 / 100.0);
            }
            let log = parse(&text).unwrap();
            assert_eq!(log.gaps.corrupt_rows, 1, "{bad}");
            assert_eq!(log.gaps.first_corrupt_line, Some(6), "{bad}");
            assert_eq!(log.grid_index[..2], [0, 2], "{bad}");
            assert_eq!(log.grid_index.len(), 39, "{bad}");
        }
    }

    /// A row cut short inside its last number (`-`, `12.`, `1e`) is a cut packet, a gap like a
    /// row cut at a separator; a full row with the same text in a field is still an error with
    /// its line and column.
    #[test]
    fn a_row_cut_inside_a_number_is_a_corrupt_row() {
        for cut in ["2\t0.01\t1\t-", "2\t0.01\t12.", "2\t0.01\t1\t2e"] {
            let mut text = format!("{HEAD}1\t0.00\t1\t2\t3\n{cut}\n");
            for k in 3..=40 {
                text += &format!("{k}\t{:.2}\t1\t2\t3\n", (k - 1) as f64 / 100.0);
            }
            let log = parse(&text).unwrap();
            assert_eq!(log.gaps.corrupt_rows, 1, "{cut}");
            assert_eq!(log.grid_index[..2], [0, 2], "{cut}");
        }
        let full = format!("{HEAD}1\t0.00\t1\t-\t3\n");
        let e = parse(&full).unwrap_err().to_string();
        assert!(
            e.contains("t.log:5:") && e.contains("expected a number"),
            "{e}"
        );
    }

    #[test]
    fn euler_unwraps_yaw() {
        let text = format!("{HEAD}1\t0.00\t0\t0\t179\n2\t0.01\t0\t0\t-179\n3\t0.02\t0\t0\t-177\n");
        let log = parse(&text).unwrap();
        let yaw = &log.data[log.column_index("Yaw").unwrap()];
        assert_eq!(yaw, &vec![179.0, 181.0, 183.0]);
    }

    #[test]
    fn spanish_locale_detected_without_header_line() {
        let text = "// Sample rate: 100 Hz\n// Output mode: Euler\nCounter;Time;Roll;Pitch;Yaw\n1;0,00;0,5;-1,25;3\n2;0,01;0,6;-1,5;3\n";
        let log = parse(text).unwrap();
        assert!(log.spanish_locale);
        assert_eq!(log.data[1], vec![-1.25, -1.5]);
        assert_eq!(log.sensors.len(), 1);
    }

    /// A log of 10 MB (two batches of blocks) is read a block of lines at a time: every kept
    /// row on its grid place with its numbers, the dropped packets and corrupt rows counted
    /// across the blocks' seams, and a malformed number deep in the file named at its own line
    /// and column, not at a later block's or a seam's.
    #[test]
    fn a_long_log_is_read_across_blocks() {
        let rows = 300_000usize;
        let mut text = String::from(HEAD);
        let (mut kept, mut dropped, mut corrupt) = (Vec::new(), 0, 0);
        for i in 0..rows {
            if i % 1000 == 999 {
                dropped += 1;
                continue;
            }
            let counter = (1000 + i) % 65536;
            let t = i as f64 * 0.01;
            if i % 777 == 5 {
                corrupt += 1;
                text.push_str(&format!("{counter}\t{t:.2}\tNaN\t0.0\t0.0\n"));
                continue;
            }
            let roll = format!("{:.3}", (i % 3600) as f64 * 0.05 - 90.0);
            text.push_str(&format!(
                "{counter}\t{t:.2}\t{roll}\t{:.3}\t-1.250\n",
                0.001 * i as f64 % 50.0
            ));
            kept.push((i as u64, roll.parse::<f64>().unwrap()));
        }
        assert!(text.len() > 8 * BLOCK_BYTES, "{} bytes", text.len());
        let log = parse(&text).unwrap();
        assert_eq!(log.grid_index.len(), kept.len());
        for (k, &(grid, roll)) in kept.iter().enumerate().step_by(997) {
            assert_eq!(log.grid_index[k], grid);
            assert_eq!(log.data[0][k], roll);
        }
        assert_eq!(log.gaps.corrupt_rows, corrupt);
        // A dropped packet and a corrupt row are each a gap of one sample, apart or together.
        assert!(log.gaps.missing_samples >= dropped as u64 + corrupt as u64 - 1);
        // A malformed number five blocks into the file, at line `line`.
        let at = text.match_indices('\n').nth(4 + 150_122).unwrap().0 + 1;
        let line = text[..at].matches('\n').count() + 1;
        let row_end = at + text[at..].find('\n').unwrap();
        let fields: Vec<&str> = text[at..row_end].split('\t').collect();
        let bad = format!(
            "{}\t{}\t{}\tx2\t{}",
            fields[0], fields[1], fields[2], fields[4]
        );
        let column = fields[..3].iter().map(|f| f.len() + 1).sum::<usize>() + 1;
        let broken = format!("{}{bad}{}", &text[..at], &text[row_end..]);
        let e = parse(&broken).unwrap_err();
        assert!(at > 4 * BLOCK_BYTES);
        assert_eq!((e.line, e.column), (Some(line), Some(column)), "{e}");
    }

    /// Blocks end at line ends, never inside a character: with a two-byte character across
    /// the first block's nominal size, the blocks are whole lines that make up the text, and
    /// the log is read (the character's comment line skipped); a non-ASCII field in a data
    /// row is an error naming its line.
    #[test]
    fn blocks_end_at_line_ends_not_inside_characters() {
        let mut text = String::from(HEAD);
        let mut rows = 0;
        // The data start after HEAD: the first block's nominal end is HEAD.len() + BLOCK_BYTES.
        let boundary = HEAD.len() + BLOCK_BYTES;
        while text.len() + 64 < boundary {
            let counter = rows % 65536;
            text.push_str(&format!(
                "{counter}\t{:.2}\t1.000\t2.000\t3.000\n",
                rows as f64 * 0.01
            ));
            rows += 1;
        }
        while text.len() < boundary - 1 {
            text.push('/');
        }
        text.push_str("é note\n");
        assert!(!text.is_char_boundary(boundary));
        // Read a few hundred bytes at a time, as a pipe may give them.
        struct Trickle<'a>(&'a [u8]);
        impl Read for Trickle<'_> {
            fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
                let n = buf.len().min(self.0.len()).min(333);
                buf[..n].copy_from_slice(&self.0[..n]);
                self.0 = &self.0[n..];
                Ok(n)
            }
        }
        // A comment line longer than a block, after the first.
        let long = format!("{text}//{}\n", "x".repeat(BLOCK_BYTES + 10));
        let mut reader = BlockReader {
            pending: Vec::new(),
            spare: Vec::new(),
            reader: Trickle(&long.as_bytes()[HEAD.len()..]),
            done: false,
            read_bytes: 0,
        };
        let mut blocks = Vec::new();
        while let Some(b) = reader.next_block().unwrap() {
            blocks.push(b);
        }
        assert!(blocks.len() >= 2);
        assert_eq!(blocks.concat(), &long.as_bytes()[HEAD.len()..]);
        assert!(blocks.iter().all(|b| b.ends_with(b"\n")));
        assert!(blocks.iter().all(|b| std::str::from_utf8(b).is_ok()));
        let log = parse(&text).unwrap();
        assert_eq!(log.grid_index.len(), rows);
        let bad = format!(
            "{text}{}\t{:.2}\t1.000\t2,0é0\t3.000\n",
            rows % 65536,
            rows as f64 * 0.01
        );
        let e = parse(&bad).unwrap_err();
        assert_eq!(e.line, Some(bad.lines().count()), "{e}");
        // A byte that is not UTF-8 in the second block: binary data, on its line.
        let mut binary = text.clone().into_bytes();
        binary.extend_from_slice(b"1\t0.01\t1.0\xff\t2.0\t3.0\n");
        let e = Log::parse(&binary, Path::new("t.log"), &ReadOptions::default()).unwrap_err();
        assert!(matches!(e.kind, LogErrorKind::Binary), "{e}");
        assert_eq!(e.line, Some(text.lines().count() + 1), "{e}");
    }

    #[test]
    fn error_names_line_and_column() {
        let text = format!("{HEAD}1\t0.00\t1\tx2\t3\n");
        let e = parse(&text).unwrap_err();
        assert_eq!((e.line, e.column), (Some(5), Some(10)));
        assert!(
            e.to_string()
                .starts_with("t.log:5:10: `x2` in column 00300417_Pitch"),
            "{e}"
        );
    }
}
