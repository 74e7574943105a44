//! Rides from other instruments, read (issue 13): a CSV of time series whose columns are
//! recognised by name, every quantity in SI units on the file's own time stamps.
//!
//! In: the CSV (`time_s`, `roll_rad`, `roll_rate_rad_per_s`, `steer_deg` or `steer_rad`,
//! `steer_rate_*`, `rear_wheel_speed_m_per_s`, …; other names through [`Columns`]). Out:
//! [`CsvRide`] (a receiver's jitter is kept, not gridded), or, for a long recording, its
//! [`KickSeries`] and the marks to come back to its kicks' windows.
//!
//! A long recording (hours at 100 Hz) is never held whole: its first pass streams it once
//! into a [`KickSeries`] (time, roll rate, wheel turning: 9 bytes a row; a large file in two
//! halves at once), every row checked, noting where every 128th row starts; then only the
//! kicks' windows are read, each from the last note before it
//! ([`crate::ride::csv::ride_decays_file`] finds the kicks and fits them).

use crate::ride::kicks::{KickSeries, MOVING_MPS};
use crate::ride::read::{err, RideError};
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
/// after a colon (a unit its quantity knows: `roll=lean_angle:deg`, `wheel_speed=v:km_per_h`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Columns(pub Vec<(Quantity, String)>);

/// What is wrong with a column mapping ([`Columns`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ColumnsError {
    #[error("`{0}`: expected QUANTITY=COLUMN")]
    NotAPair(String),
    /// The key, and the quantities known (joined).
    #[error("`{0}`: not a quantity (one of {1})")]
    NotAQuantity(String, String),
    /// The unit, its quantity's key, and the units it knows (joined).
    #[error("`{0}`: not a unit of {1} (one of {2})")]
    NotAUnit(String, &'static str, String),
    /// The quantity's key and the two columns given for it.
    #[error("`{0}` is given twice (`{1}` and `{2}`): one column a quantity")]
    Twice(&'static str, String, String),
}

impl std::str::FromStr for Columns {
    type Err = ColumnsError;

    fn from_str(spec: &str) -> Result<Columns, ColumnsError> {
        let mut out: Vec<(Quantity, String)> = Vec::new();
        for part in spec.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            let (key, name) = part
                .split_once('=')
                .ok_or_else(|| ColumnsError::NotAPair(part.to_string()))?;
            let q = Quantity::ALL
                .into_iter()
                .find(|q| q.key() == key.trim())
                .ok_or_else(|| {
                    ColumnsError::NotAQuantity(
                        key.to_string(),
                        Quantity::ALL.map(Quantity::key).join(", "),
                    )
                })?;
            let name = name.trim();
            if let Some((_, unit)) = name.rsplit_once(':') {
                unit_factor(q, unit)?;
            }
            if let Some((_, first)) = out.iter().find(|(g, _)| *g == q) {
                return Err(ColumnsError::Twice(
                    q.key(),
                    first.clone(),
                    name.to_string(),
                ));
            }
            out.push((q, name.to_string()));
        }
        Ok(Columns(out))
    }
}

/// The factor to SI of `unit` written after a column's name for quantity `q`
/// (`roll=lean_angle:deg`): [`Quantity::units`].
fn unit_factor(q: Quantity, unit: &str) -> Result<f64, ColumnsError> {
    let units = q.units();
    units
        .iter()
        .find(|(u, _)| *u == unit.trim())
        .map(|(_, f)| *f)
        .ok_or_else(|| {
            ColumnsError::NotAUnit(
                unit.to_string(),
                q.key(),
                units.iter().map(|(u, _)| *u).collect::<Vec<_>>().join(", "),
            )
        })
}

/// The slowest and fastest sampling rates `--rate` takes (Hz).
pub const RATE_RANGE_HZ: (f64, f64) = (1.0, 100_000.0);

/// Checks a sampling rate given for a table without a time column (`--rate`, `rate_hz`).
pub fn check_rate_hz(rate: f64) -> Result<f64, crate::ride::OutOfRange> {
    crate::ride::OutOfRange::check(rate, RATE_RANGE_HZ, "Hz", "a sampling rate")
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

/// Which column gives which quantity, with its factor to SI, and the time's source.
struct Plan {
    /// (quantity, column, factor, column's name), in [`Quantity::ALL`]'s order.
    found: Vec<(Quantity, usize, f64, String)>,
    /// The table's rate where it has no time column.
    rate_hz: Option<f64>,
}

/// A table's column names for a message: the first twenty, then how many more (a 10,000-column
/// table's message is not its header).
fn columns_text(headers: &[String]) -> String {
    const SHOWN: usize = 20;
    let mut text = headers
        .iter()
        .take(SHOWN)
        .map(String::as_str)
        .collect::<Vec<_>>()
        .join(", ");
    if headers.len() > SHOWN {
        text += &format!(" and {} more", headers.len() - SHOWN);
    }
    text
}

/// The columns of [`Quantity`] among `headers`, by their recognised names or by `given`; a
/// time column, or a rate for a table without one (never both).
fn plan(
    path: &Path,
    headers: &[String],
    find: impl Fn(&[&str]) -> Option<usize>,
    given: &Columns,
    rate_hz: Option<f64>,
) -> Result<Plan, RideError> {
    if let Some(rate) = rate_hz {
        check_rate_hz(rate).map_err(|e| err(path, format!("--rate: {e}")))?;
    }
    let mut found: Vec<(Quantity, usize, f64, String)> = Vec::new();
    for q in Quantity::ALL {
        let pick = match given.0.iter().find(|(g, _)| *g == q) {
            Some((_, given_name)) => {
                let (name, unit) = match given_name.rsplit_once(':') {
                    Some((n, u)) => (n.trim(), Some(u)),
                    None => (given_name.as_str(), None),
                };
                let k = find(&[name]).ok_or_else(|| {
                    err(
                        path,
                        format!(
                            "no column `{name}` for {} (the columns: {})",
                            q.key(),
                            columns_text(headers)
                        ),
                    )
                })?;
                let lower = name.to_ascii_lowercase();
                let deg = lower.ends_with("_deg") || lower.ends_with("_deg_per_s");
                let factor = match unit {
                    Some(u) => unit_factor(q, u).map_err(|e| err(path, e.to_string()))?,
                    None if deg => std::f64::consts::PI / 180.0,
                    None => 1.0,
                };
                Some((k, factor))
            }
            None => q
                .names()
                .iter()
                .find_map(|(n, f)| find(&[n.as_str()]).map(|k| (k, *f))),
        };
        if let Some((k, factor)) = pick {
            if let Some(other) = found.iter().find(|f| f.1 == k) {
                return Err(err(
                    path,
                    format!(
                        "the column `{}` would be both {} and {}: one column is one quantity \
                         (name the other with --columns {}=NAME)",
                        headers[k],
                        other.0.key(),
                        q.key(),
                        q.key()
                    ),
                ));
            }
            found.push((q, k, factor, headers[k].clone()));
        }
    }
    if !found
        .iter()
        .any(|f| matches!(f.0, Quantity::Roll | Quantity::RollRate))
    {
        return Err(err(
            path,
            format!(
                "no roll rate or roll angle among its columns ({}): kicks are found and \
                 fitted in one of them; name it with --columns roll_rate=NAME (rad/s, or \
                 NAME:deg for °/s) or roll=NAME",
                columns_text(headers)
            ),
        ));
    }
    let time_column = found
        .iter()
        .find(|f| f.0 == Quantity::Time)
        .map(|f| f.3.clone());
    match (&time_column, rate_hz) {
        (None, None) => Err(err(
            path,
            format!(
                "no time column (time_s, or --columns time=NAME; a table sampled at a fixed \
                 rate without one: --rate HZ, or rate_hz in a manifest); the columns: {}",
                columns_text(headers)
            ),
        )),
        (Some(name), Some(rate)) => Err(err(
            path,
            format!(
                "it has a time column (`{name}`): a rate ({rate} Hz) is for a table without one"
            ),
        )),
        _ => Ok(Plan { found, rate_hz }),
    }
}

/// One row of a ride's CSV in SI units: the time (s) and each quantity the file has, in
/// [`Quantity::ALL`]'s order (`NaN` where it has none).
type Row = [f64; 6];

/// Where a row of a ride's CSV starts, noted on a first pass over a long recording so that a
/// second reads only the kicks' windows: the row's place in the file, its index and its time (s).
#[derive(Debug, Clone)]
pub(crate) struct RowMark {
    position: csv::Position,
    row: usize,
    time_s: f64,
}

/// Rows from one [`RowMark`] to the next: a second pass reads at most this many rows before
/// each window (1.3 s at 100 Hz), the marks of 10 million rows taking 3 MB.
const MARK_ROWS: usize = 128;

/// A file's size and modification time, the same on two passes over it unless it changed
/// between them.
pub(crate) fn file_stamp(path: &Path) -> Option<(u64, std::time::SystemTime)> {
    let meta = std::fs::metadata(path).ok()?;
    Some((meta.len(), meta.modified().ok()?))
}

/// Streams the rows of a ride's CSV through `each(row index, row, where it starts)`, every
/// value checked where it is read: a finite number in its quantity's physical range (a wheel
/// speed from −1 m/s, an encoder's noise at a standstill, to a riding speed's most; an angle
/// within ±π; a rate within ±100 rad/s), times that advance; a roll or roll rate that never
/// changes is refused (no motion recorded). Reading stops where `each` returns `false` (the
/// rest of the file unread and unchecked). Gives the columns used and the number of rows read.
fn stream_rows(
    path: &Path,
    given: &Columns,
    rate_hz: Option<f64>,
    each: impl FnMut(usize, &Row, Option<&csv::Position>) -> bool,
) -> Result<(Vec<(Quantity, String)>, usize), RideError> {
    let (mut rows, plan) = open_rows(path, given, rate_hz, u64::MAX)?;
    let (n, still) = rows_from(&mut rows, &plan, 0, each)?;
    still.refuse(path, &plan, n)?;
    Ok((plan.columns(), n))
}

/// A ride's CSV opened as text ([`crate::read::kind::open_text`]) up to `limit_bytes`, its header
/// read and its columns planned.
fn open_rows(
    path: &Path,
    given: &Columns,
    rate_hz: Option<f64>,
    limit_bytes: u64,
) -> Result<
    (
        crate::read::csv::CsvRows<QuoteWatch<impl std::io::Read + Send>>,
        Plan,
    ),
    RideError,
> {
    use std::io::Read;
    let file = crate::read::kind::open_text(path).map_err(|e| {
        let at = e.line.map_or(String::new(), |l| format!("line {l}: "));
        err(path, format!("{at}{}", e.message))
    })?;
    let rows = crate::read::csv::CsvRows::open(QuoteWatch::new(file.take(limit_bytes)), path)?;
    let plan = plan(path, &rows.headers, |n| rows.find(n), given, rate_hz)?;
    Ok((rows, plan))
}

/// The quantities a ride's CSV carries, from its header alone (named, or mapped by `given`),
/// in [`Quantity::ALL`]'s order; the errors of a header that cannot be read as a ride.
pub fn quantities(
    path: &Path,
    given: &Columns,
    rate_hz: Option<f64>,
) -> Result<Vec<Quantity>, RideError> {
    let (_, plan) = open_rows(path, given, rate_hz, u64::MAX)?;
    Ok(plan.found.iter().map(|f| f.0).collect())
}

impl Plan {
    /// The quantities found and their columns' names (the time's source last where the table
    /// has none).
    fn columns(&self) -> Vec<(Quantity, String)> {
        let mut columns: Vec<(Quantity, String)> =
            self.found.iter().map(|f| (f.0, f.3.clone())).collect();
        if let Some(rate) = self.rate_hz {
            columns.push((Quantity::Time, format!("row number at {rate} Hz")));
        }
        columns
    }
}

/// The roll's and the roll rate's first values over some rows, and whether every other was the
/// same (no motion recorded).
#[derive(Debug, Clone, Copy)]
struct Stillness([(Option<f64>, bool); 2]);

impl Default for Stillness {
    fn default() -> Stillness {
        Stillness([(None, true); 2])
    }
}

impl Stillness {
    /// Quantity `w` (0: roll, 1: roll rate) read as `x`.
    fn see(&mut self, w: usize, x: f64) {
        match self.0[w].0 {
            None => self.0[w].0 = Some(x),
            Some(v) if v != x => self.0[w].1 = false,
            _ => {}
        }
    }

    /// Over these rows and `later` ones.
    fn then(self, later: Stillness) -> Stillness {
        Stillness([0, 1].map(|w| {
            let (a, b) = (self.0[w], later.0[w]);
            let same = a.0.zip(b.0).is_none_or(|(x, y)| x == y);
            (a.0.or(b.0), a.1 && b.1 && same)
        }))
    }

    /// The error of a file whose roll or roll rate never changes over its `rows` (> 1).
    fn refuse(&self, path: &Path, plan: &Plan, rows: usize) -> Result<(), RideError> {
        for (w, q) in [(0, Quantity::Roll), (1, Quantity::RollRate)] {
            if let (Some(v), true) = self.0[w] {
                if rows > 1 {
                    let name = plan
                        .found
                        .iter()
                        .find(|f| f.0 == q)
                        .map_or("", |f| f.3.as_str());
                    return Err(err(
                        path,
                        format!(
                            "{} `{name}` is {v} in every row: no motion was recorded",
                            q.key()
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// [`stream_rows`]' reading from the next row of `rows`, whose index is `first_row` (its time,
/// where the table has none, from that index). Gives the index after the last row read and
/// the roll's and roll rate's [`Stillness`] over the rows read.
fn rows_from<R: std::io::Read>(
    rows: &mut crate::read::csv::CsvRows<R>,
    plan: &Plan,
    first_row: usize,
    mut each: impl FnMut(usize, &Row, Option<&csv::Position>) -> bool,
) -> Result<(usize, Stillness), RideError> {
    let ranges: Vec<Option<(f64, f64, &str)>> = plan
        .found
        .iter()
        .map(|f| match f.0 {
            Quantity::Time => None,
            Quantity::WheelSpeed => Some((-1.0, crate::ride::speed::MAX_READING_MPS, "m/s")),
            Quantity::Roll | Quantity::Steer => {
                Some((-std::f64::consts::PI, std::f64::consts::PI, "rad"))
            }
            Quantity::RollRate | Quantity::SteerRate => Some((-100.0, 100.0, "rad/s")),
        })
        .collect();
    let slot = |q: Quantity| Quantity::ALL.iter().position(|&a| a == q).unwrap_or(0);
    let mut row: Row = [f64::NAN; 6];
    let mut n = first_row;
    let mut previous_t: Option<f64> = None;
    let mut still = Stillness::default();
    while let Some(line) = rows.next_row()? {
        for ((q, k, factor, name), range) in plan.found.iter().zip(&ranges) {
            let x = rows.number(line, *k)? * factor;
            if let Some((lo, hi, unit)) = range {
                if !(*lo..=*hi).contains(&x) {
                    return Err(rows
                        .error(
                            line,
                            k + 1,
                            format!(
                                "{} `{name}` = {x} {unit}: expected from {} to {} {unit}",
                                q.key(),
                                short(*lo),
                                short(*hi)
                            ),
                        )
                        .into());
                }
            }
            match q {
                Quantity::Roll => still.see(0, x),
                Quantity::RollRate => still.see(1, x),
                _ => {}
            }
            row[slot(*q)] = x;
        }
        if let Some(rate) = plan.rate_hz {
            row[0] = n as f64 / rate;
        } else if let Some(t0) = previous_t.filter(|t0| row[0] <= *t0) {
            return Err(rows
                .error(
                    line,
                    1,
                    format!("time {} s does not advance from {t0} s", row[0]),
                )
                .into());
        }
        previous_t = Some(row[0]);
        let more = each(n, &row, rows.record().position());
        n += 1;
        if !more {
            break;
        }
    }
    Ok((n, still))
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
    read_csv_ride_within(path, given, rate_hz, None)
}

/// Time windows (s) by their starts, with the latest end among each one and those before it: a
/// time lies in some window when the latest end among the windows started by then reaches it
/// (a binary search a row, where a scan of every window made a long recording's second pass
/// quadratic in its kicks).
struct Windows {
    sorted: Vec<(f64, f64)>,
    latest_end: Vec<f64>,
}

impl Windows {
    fn new(windows: &[(f64, f64)]) -> Windows {
        let mut sorted = windows.to_vec();
        sorted.sort_by(|x, y| x.0.total_cmp(&y.0));
        let latest_end = sorted
            .iter()
            .scan(f64::NEG_INFINITY, |m, &(_, b)| {
                *m = m.max(b);
                Some(*m)
            })
            .collect();
        Windows { sorted, latest_end }
    }

    /// How many windows start by `t`.
    fn started(&self, t: f64) -> usize {
        self.sorted.partition_point(|&(a, _)| a <= t)
    }

    /// Whether `t` lies in a window.
    fn holds(&self, t: f64) -> bool {
        self.reaches(self.started(t), t)
    }

    /// Whether one of the first `started` windows reaches `t`.
    fn reaches(&self, started: usize, t: f64) -> bool {
        started > 0 && self.latest_end[started - 1] >= t
    }

    /// The last window's end (−∞ without windows).
    fn last_end(&self) -> f64 {
        self.latest_end.last().copied().unwrap_or(f64::NEG_INFINITY)
    }
}

/// A [`CsvRide`] of the columns read and the values kept.
fn ride_of(path: &Path, columns: Vec<(Quantity, String)>, values: [Vec<f64>; 6]) -> CsvRide {
    let [time_s, roll, roll_rate, steer, steer_rate, wheel] = values;
    let has = |q: Quantity| columns.iter().any(|c| c.0 == q);
    let column = |q: Quantity, v: Vec<f64>| has(q).then_some(v);
    CsvRide {
        path: path.to_path_buf(),
        time_s,
        roll_rad: column(Quantity::Roll, roll),
        roll_rate_rad_per_s: column(Quantity::RollRate, roll_rate),
        steer_rad: column(Quantity::Steer, steer),
        steer_rate_rad_per_s: column(Quantity::SteerRate, steer_rate),
        wheel_speed_mps: column(Quantity::WheelSpeed, wheel),
        columns,
    }
}

/// Appends the quantities of `row` that the file has to `values`.
fn keep(values: &mut [Vec<f64>; 6], row: &Row) {
    for (v, x) in values.iter_mut().zip(row) {
        if !x.is_nan() {
            v.push(*x);
        }
    }
}

/// [`read_csv_ride`] keeping only the rows within one of `windows` (s; every row when
/// `None`): a long recording's kicks in memory of their own size, the file read (and checked)
/// up to the last window's end.
pub fn read_csv_ride_within(
    path: &Path,
    given: &Columns,
    rate_hz: Option<f64>,
    windows: Option<&[(f64, f64)]>,
) -> Result<CsvRide, RideError> {
    let mut values: [Vec<f64>; 6] = Default::default();
    let windows = windows.map(Windows::new);
    let (columns, _) = stream_rows(path, given, rate_hz, |_, row, _| {
        if windows.as_ref().is_none_or(|w| w.holds(row[0])) {
            keep(&mut values, row);
        }
        // Times advance: past the last window's end nothing more is needed.
        windows.as_ref().is_none_or(|w| row[0] <= w.last_end())
    })?;
    Ok(ride_of(path, columns, values))
}

/// [`read_csv_ride_within`] on a second pass over a file whose rows a first one checked and
/// marked ([`RowMark`], in order): before each window not yet reached it reads on from the last
/// mark before its start, a long recording's kicks read without the rows between them. The file
/// must be as the first pass found it (`stamp`).
pub(crate) fn read_marked_windows(
    path: &Path,
    given: &Columns,
    rate_hz: Option<f64>,
    windows: &[(f64, f64)],
    marks: &[RowMark],
    stamp: Option<(u64, std::time::SystemTime)>,
) -> Result<CsvRide, RideError> {
    let file = std::fs::File::open(path).map_err(|e| err(path, format!("cannot read: {e}")))?;
    if stamp.is_none() || file_stamp(path) != stamp {
        return Err(err(
            path,
            "it changed while it was read (its size or time differ from the first pass's): \
             read it again",
        ));
    }
    let mut rows = crate::read::csv::CsvRows::open(file, path)?;
    let plan = plan(path, &rows.headers, |n| rows.find(n), given, rate_hz)?;
    let windows = Windows::new(windows);
    let mut values: [Vec<f64>; 6] = Default::default();
    // The index of the next row the reader gives, and the first window not yet read.
    let (mut next_row, mut next) = (0usize, 0usize);
    while next < windows.sorted.len() {
        let start = windows.sorted[next].0;
        let before = marks.partition_point(|m| m.time_s <= start);
        if let Some(mark) = before.checked_sub(1).map(|i| &marks[i]) {
            if mark.row > next_row {
                rows.seek(mark.position.clone())?;
                next_row = mark.row;
            }
        }
        // Read on to the first row beyond every window started by then.
        let mut reached = windows.sorted.len();
        let (read_to, _) = rows_from(&mut rows, &plan, next_row, |_, row, _| {
            let started = windows.started(row[0]);
            if windows.reaches(started, row[0]) {
                keep(&mut values, row);
                true
            } else if started > next {
                reached = started;
                false
            } else {
                true
            }
        })?;
        if read_to == next_row {
            break;
        }
        next_row = read_to;
        next = reached;
    }
    Ok(ride_of(path, plan.columns(), values))
}

/// A long recording's first pass ([`KickSeries::read`]): its kick series and the marks for
/// the second.
#[derive(Debug)]
pub(crate) struct FirstPass {
    pub(crate) series: KickSeries,
    pub(crate) marks: Vec<RowMark>,
}

/// Files from this size (bytes) have their kicks' pass read in two halves at once
/// ([`KickSeries::read_halves`]): half the time of one pass on two cores.
const HALVES_FROM_BYTES: u64 = 16 << 20;

/// The second half of a file read by [`KickSeries::read_halves`], as read: each row's time
/// (where the file has a time column), kick value and wheel turning, a mark (its index and
/// place in the half) every [`MARK_ROWS`] rows, the rows read, their [`Stillness`], and
/// whether a `"` was among the bytes.
#[derive(Debug, Default)]
struct LaterHalf {
    times: Vec<f64>,
    values: Vec<f32>,
    moving: Vec<bool>,
    marks: Vec<(usize, csv::Position)>,
    rows: usize,
    still: Stillness,
    quoted: bool,
}

impl LaterHalf {
    /// The rows of `path` from byte `cut` (a line's start) on; `None` on any error.
    fn read(path: &Path, headers: Vec<String>, plan: &Plan, cut: u64) -> Option<LaterHalf> {
        use std::io::{Read, Seek};
        let mut file = std::fs::File::open(path).ok()?;
        file.seek(std::io::SeekFrom::Start(cut)).ok()?;
        let limit = crate::read::kind::MAX_INPUT_BYTES.saturating_sub(cut);
        let mut rows =
            crate::read::csv::CsvRows::headless(QuoteWatch::new(file.take(limit)), path, headers);
        let mut half = LaterHalf::default();
        let (rows_read, still) = rows_from(&mut rows, plan, 0, |j, row, position| {
            if plan.rate_hz.is_none() {
                half.times.push(row[0]);
            }
            let (value, moving) = kick_sample(row);
            half.values.push(value as f32);
            half.moving.push(moving);
            if let Some(position) = position.filter(|_| j % MARK_ROWS == 0) {
                half.marks.push((j, position.clone()));
            }
            true
        })
        .ok()?;
        half.rows = rows_read;
        half.still = still;
        half.quoted = rows.get_ref().quoted;
        Some(half)
    }
}

/// What a row gives a [`KickSeries`]: its roll rate (or, in a file without one, its roll) and
/// whether the wheel turns at over [`MOVING_MPS`] (always, in a file without a wheel speed).
fn kick_sample(row: &Row) -> (f64, bool) {
    // Row: time, roll, roll rate, steer, steer rate, wheel speed.
    let value = if row[2].is_nan() { row[1] } else { row[2] };
    (value, row[5].is_nan() || row[5] > MOVING_MPS)
}

/// A reader noting whether a `"` passed through it: a quoted field may hold a line break, and
/// a file with one is not cut at a line break.
struct QuoteWatch<R> {
    inner: R,
    quoted: bool,
}

impl<R> QuoteWatch<R> {
    fn new(inner: R) -> QuoteWatch<R> {
        QuoteWatch {
            inner,
            quoted: false,
        }
    }
}

impl<R: std::io::Read> std::io::Read for QuoteWatch<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.quoted |= buf[..n].contains(&b'"');
        Ok(n)
    }
}

impl KickSeries {
    /// From a ride in memory; `None` when it has neither roll rate nor roll.
    pub(crate) fn of_ride(ride: &CsvRide) -> Option<KickSeries> {
        let mut series = KickSeries::default();
        let (values, from_roll) = match (&ride.roll_rate_rad_per_s, &ride.roll_rad) {
            (Some(r), _) => (r, false),
            (None, Some(r)) => (r, true),
            (None, None) => return None,
        };
        for (i, &t) in ride.time_s.iter().enumerate() {
            let moving = ride
                .wheel_speed_mps
                .as_ref()
                .is_none_or(|w| w[i] > MOVING_MPS);
            series.push(t, values[i], moving);
        }
        if from_roll {
            series.differentiate();
        }
        Some(series)
    }

    /// Streams a ride's CSV into its kick series (every row checked as [`read_csv_ride`]
    /// checks it), with a mark every [`MARK_ROWS`] rows or so. A file of
    /// [`HALVES_FROM_BYTES`] or more is read in two halves at once where it can be
    /// ([`KickSeries::read_halves`]), the same series from either way.
    pub(crate) fn read(
        path: &Path,
        given: &Columns,
        rate_hz: Option<f64>,
    ) -> Result<FirstPass, RideError> {
        KickSeries::read_from_halves_of(path, given, rate_hz, HALVES_FROM_BYTES)
    }

    /// [`KickSeries::read`], in halves from `halves_from_bytes`.
    fn read_from_halves_of(
        path: &Path,
        given: &Columns,
        rate_hz: Option<f64>,
        halves_from_bytes: u64,
    ) -> Result<FirstPass, RideError> {
        let size = std::fs::metadata(path).map_or(0, |m| m.len());
        if (halves_from_bytes..crate::read::kind::MAX_INPUT_BYTES).contains(&size) {
            if let Some(read) = KickSeries::read_halves(path, given, rate_hz, size) {
                return Ok(read);
            }
        }
        let mut series = KickSeries::default();
        let mut marks = Vec::new();
        let (columns, _) = stream_rows(path, given, rate_hz, |n, row, position| {
            series.take(&mut marks, n, row, position);
            true
        })?;
        Ok(series.finish(columns, marks))
    }

    /// Row `n` pushed ([`KickSeries::push`]), marked where `n` is a multiple of [`MARK_ROWS`].
    fn take(
        &mut self,
        marks: &mut Vec<RowMark>,
        n: usize,
        row: &Row,
        position: Option<&csv::Position>,
    ) {
        let (value, moving) = kick_sample(row);
        self.push(row[0], value, moving);
        if let Some(position) = position.filter(|_| n % MARK_ROWS == 0) {
            marks.push(RowMark {
                position: position.clone(),
                row: n,
                time_s: row[0],
            });
        }
    }

    /// The series of every row read, its roll differentiated where the file has no roll rate.
    fn finish(mut self, columns: Vec<(Quantity, String)>, marks: Vec<RowMark>) -> FirstPass {
        // The columns have a roll rate or a roll angle ([`plan`] refuses a file with neither).
        if !columns.iter().any(|c| c.0 == Quantity::RollRate) {
            self.differentiate();
        }
        FirstPass {
            series: self,
            marks,
        }
    }

    /// [`KickSeries::read`] of a file of `size` bytes in two halves at once, cut at the first line
    /// break from its middle on: the first half into the series as it is read, the second into
    /// [`LaterHalf`] (the times of its rows, where they count from the first row, known only
    /// once the first half is counted), appended after. `None` wherever this cannot give what
    /// one pass would (a `"` in the file, whose quoted field might hold the line break; no line
    /// break; any error, found again with its line by the pass over the whole).
    fn read_halves(
        path: &Path,
        given: &Columns,
        rate_hz: Option<f64>,
        size: u64,
    ) -> Option<FirstPass> {
        use std::io::{Read, Seek};
        let cut = {
            let mut file = std::fs::File::open(path).ok()?;
            file.seek(std::io::SeekFrom::Start(size / 2)).ok()?;
            let mut head = Vec::with_capacity(1 << 16);
            file.take(1 << 16).read_to_end(&mut head).ok()?;
            size / 2 + head.iter().position(|&b| b == b'\n')? as u64 + 1
        };
        let (mut first, plan) = open_rows(path, given, rate_hz, cut).ok()?;
        let headers = first.headers.clone();
        let mut last_t = f64::NEG_INFINITY;
        let (later, (mut series, mut marks, n1, still, end)) = std::thread::scope(|scope| {
            let later = scope.spawn(|| LaterHalf::read(path, headers, &plan, cut));
            let mut series = KickSeries::default();
            let mut marks = Vec::new();
            let read = rows_from(&mut first, &plan, 0, |n, row, position| {
                series.take(&mut marks, n, row, position);
                last_t = row[0];
                true
            });
            let later = later.join().ok().flatten();
            let first = read
                .ok()
                .filter(|_| !first.get_ref().quoted)
                .map(|(n1, still)| (series, marks, n1, still, first.position().clone()));
            later.zip(first)
        })?;
        if later.quoted || later.rows == 0 {
            return None;
        }
        // The second half's rows and marks, numbered on from the first's.
        let time = |j: usize| match plan.rate_hz {
            Some(rate) => (n1 + j) as f64 / rate,
            None => later.times[j],
        };
        if plan.rate_hz.is_none() && last_t >= time(0) {
            return None;
        }
        let still = still.then(later.still);
        still.refuse(path, &plan, n1 + later.rows).ok()?;
        for j in 0..later.rows {
            series.push(time(j), f64::from(later.values[j]), later.moving[j]);
        }
        for (j, at) in later.marks {
            let position = {
                let mut p = csv::Position::new();
                p.set_byte(cut + at.byte())
                    .set_line(end.line() - 1 + at.line())
                    .set_record(end.record() + at.record());
                p
            };
            marks.push(RowMark {
                position,
                row: n1 + j,
                time_s: time(j),
            });
        }
        Some(series.finish(plan.columns(), marks))
    }
}

/// A range's end in a message: four decimals at most, trailing zeros dropped (±π is
/// "3.1416", 30 is "30").
fn short(x: f64) -> String {
    let s = format!("{x:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scratch directory of this test's own.
    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("bikeproc_csv_{name}_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A recording of `rows` rows at 100 Hz: with a time column or without, its roll rate or
    /// its roll, a wheel speed that stops for a while (rows 3,000–3,999), seeded noise.
    fn recording(rows: usize, time: bool, rate: bool) -> String {
        use crate::sim::draw::Draw;
        let mut rng = crate::sim::draw::seeded(32);
        let mut text = String::new();
        text += if time { "time_s," } else { "" };
        text += if rate {
            "roll_rate_rad_per_s"
        } else {
            "roll_rad"
        };
        text += ",rear_wheel_speed_m_per_s\n";
        for i in 0..rows {
            if time {
                text += &format!("{:.2},", i as f64 * 0.01);
            }
            let x = 0.05 * (i as f64 * 0.05).sin() + 0.002 * rng.normal();
            let v = if (3000..4000).contains(&i) { 0.0 } else { 5.0 };
            text += &format!("{x:.5},{v:.3}\n");
        }
        text
    }

    /// The row `mark` names, read by seeking a fresh reader to it: its line and its first value.
    fn row_at(path: &Path, mark: &RowMark) -> (u64, f64) {
        let file = std::fs::File::open(path).unwrap();
        let mut rows = crate::read::csv::CsvRows::open(file, path).unwrap();
        rows.seek(mark.position.clone()).unwrap();
        let line = rows.next_row().unwrap().unwrap();
        (line, rows.number(line, 0).unwrap())
    }

    /// Issue 32 item 5: the first pass read in two halves at once gives the series one pass
    /// gives, bit for bit (the times, the kick values, the wheel turning), with a
    /// time column or with `--rate`, from a roll rate or a roll (differentiated across the
    /// cut); every mark of either way names the row it says, at its line (the header is line 1).
    #[test]
    fn halves_read_what_one_pass_reads() {
        let dir = scratch("halves");
        for (time, rate) in [(true, true), (false, true), (true, false)] {
            let path = dir.join("ride.csv");
            let text = recording(20_011, time, rate);
            std::fs::write(&path, &text).unwrap();
            let rate_hz = (!time).then_some(100.0);
            let given = Columns::default();
            let size = text.len() as u64;
            assert!(KickSeries::read_halves(&path, &given, rate_hz, size).is_some());
            let one = KickSeries::read_from_halves_of(&path, &given, rate_hz, u64::MAX).unwrap();
            let two = KickSeries::read_from_halves_of(&path, &given, rate_hz, 0).unwrap();
            let (one, one_marks, two, two_marks) = (one.series, one.marks, two.series, two.marks);
            assert_eq!(one.len(), 20_011);
            assert!(one == two, "the halves' series differ from one pass's");
            assert_eq!(one_marks.len(), 20_011_usize.div_ceil(MARK_ROWS));
            assert!(two_marks.len() >= one_marks.len());
            for mark in one_marks.iter().chain(&two_marks) {
                let (line, first) = row_at(&path, mark);
                assert_eq!(line, mark.row as u64 + 2, "{mark:?}");
                let want = text.lines().nth(mark.row + 1).unwrap();
                let want: f64 = want.split(',').next().unwrap().parse().unwrap();
                assert_eq!(first, want, "{mark:?}");
                let t = if time { want } else { mark.row as f64 / 100.0 };
                assert_eq!(mark.time_s, t, "{mark:?}");
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A file the halves cannot read as one pass does is read in one pass: a quoted field (which
    /// may hold a line break) anywhere, or a bad value in the second half, whose error then
    /// names its line in the whole file.
    #[test]
    fn a_quote_or_an_error_is_read_in_one_pass() {
        let dir = scratch("quoted");
        let path = dir.join("ride.csv");
        let text = recording(20_000, true, true);
        let given = Columns::default();
        let quoted = text.replacen("\n1.00,", "\n\"1.00\",", 1);
        std::fs::write(&path, &quoted).unwrap();
        assert!(KickSeries::read_halves(&path, &given, None, quoted.len() as u64).is_none());
        assert_eq!(
            KickSeries::read_from_halves_of(&path, &given, None, 0)
                .unwrap()
                .series
                .len(),
            20_000
        );
        let bad = text.replacen("\n150.00,", "\n150.00x,", 1);
        std::fs::write(&path, &bad).unwrap();
        assert!(KickSeries::read_halves(&path, &given, None, bad.len() as u64).is_none());
        let error = KickSeries::read_from_halves_of(&path, &given, None, 0)
            .unwrap_err()
            .to_string();
        assert!(
            error.contains(":15002:1:") && error.contains("150.00x"),
            "{error}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Issue 32 item 5: the second pass from the first's marks keeps exactly the rows the
    /// windowed reader keeps (every window's rows, in order, once, overlapping windows too), and
    /// refuses a file that changed between the passes.
    #[test]
    fn the_marked_pass_keeps_what_the_windowed_reader_keeps() {
        let dir = scratch("marked");
        let path = dir.join("ride.csv");
        std::fs::write(&path, recording(20_000, true, true)).unwrap();
        let given = Columns::default();
        let marks = KickSeries::read_from_halves_of(&path, &given, None, 0)
            .unwrap()
            .marks;
        // Out of order, overlapping, nested, a single instant, far apart (a seek each) and
        // one past the end.
        let windows = [
            (150.0, 151.0),
            (3.0, 7.5),
            (6.0, 6.5),
            (7.0, 12.25),
            (90.0, 90.0),
            (120.3, 121.0),
            (199.5, 400.0),
        ];
        let stamp = file_stamp(&path);
        let marked = read_marked_windows(&path, &given, None, &windows, &marks, stamp).unwrap();
        let kept = read_csv_ride_within(&path, &given, None, Some(&windows)).unwrap();
        assert_eq!(marked.time_s, kept.time_s);
        assert_eq!(marked.roll_rate_rad_per_s, kept.roll_rate_rad_per_s);
        assert_eq!(marked.wheel_speed_mps, kept.wheel_speed_mps);
        assert_eq!(marked.columns, kept.columns);
        // 3.00–12.25 s, 90.00, 120.30–121.00, 150.00–151.00 and 199.50–199.99 s.
        assert_eq!(marked.time_s.len(), 926 + 1 + 71 + 101 + 50);
        let other = stamp.map(|(len, time)| (len + 1, time));
        let error = read_marked_windows(&path, &given, None, &windows, &marks, other).unwrap_err();
        assert!(
            error.to_string().contains("changed while it was read"),
            "{error}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
