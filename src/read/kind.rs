//! What an input is, recognised by its content, never by its name: so that a file given to the
//! wrong command is told what it is and which command reads it, instead of meeting another
//! format's parser.
//!
//! In: a path (a file or a folder). Out: [`Kind`], with [`Kind::describe`] (what it is, in
//! words) and [`Kind::command`] (the command that reads it). Only the first few kilobytes of a
//! file are read; a kind not recognised is [`Kind::Unknown`], and the command's own reader then
//! says what is wrong.

use std::io::Read as _;
use std::path::{Path, PathBuf};

/// An input given to a command that does not read its kind: what it is and which command
/// does, in one line.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct WrongKind(pub String);

/// What an input is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Kind {
    /// An IMU log of the frame and handlebar sensors: a ride's angles (orientations) file.
    RideAngles,
    /// A ride's calibrated file (`Output mode: Calibrated`, two sensors), read beside its
    /// angles file.
    RideCalibrated,
    /// An IMU log of one sensor: a pendulum recording.
    PendulumLog,
    /// A pendulum test manifest (`kind = "torsion"`, `"compound"`, `"bar_calibration"`, …).
    TestManifest(String),
    /// A folder holding a pendulum test manifest of that kind.
    TestFolder(String),
    /// A campaign of rides (`[[ride]]` tables).
    RideManifest,
    /// A study: several campaigns of one bicycle (`conditions = [...]`).
    StudyManifest,
    /// A lab bicycle (a TOML with a `[geometry]` table).
    LabBike,
    /// Benchmark parameters in BicycleParameters' text (`IBxx = 0.53+/-0.002` …) or TOML.
    Benchmark,
    /// BicycleParameters' raw measurements (`*Measured.txt`: periods, angles, masses).
    MeasuredBicycle,
    /// A steer controller (a `[controller]` table and no rides).
    Controller,
    /// A table of named columns (CSV: comma-, semicolon- or tab-separated).
    Table,
    /// A folder holding none of the above's manifests.
    Folder,
    /// Not recognised.
    Unknown,
}

impl Kind {
    /// What it is, in words.
    pub fn describe(&self) -> String {
        match self {
            Kind::RideAngles => "a ride's IMU log (the frame and handlebar sensors' angles)".into(),
            Kind::RideCalibrated => {
                "a ride's calibrated IMU log (rates and accelerations), the companion of its \
                 angles file"
                    .into()
            }
            Kind::PendulumLog => "an IMU log of one sensor (a pendulum recording)".into(),
            Kind::TestManifest(k) => format!("a pendulum test manifest (kind = \"{k}\")"),
            Kind::TestFolder(k) => format!("a pendulum test folder (kind = \"{k}\")"),
            Kind::RideManifest => "a campaign of rides (a rides manifest)".into(),
            Kind::StudyManifest => "a study of several campaigns (a study manifest)".into(),
            Kind::LabBike => "a lab bicycle file (it has a [geometry] table)".into(),
            Kind::Benchmark => "a bicycle's benchmark parameters".into(),
            Kind::MeasuredBicycle => "a bicycle's raw measurements (BicycleParameters)".into(),
            Kind::Controller => "a steer controller (a [controller] table)".into(),
            Kind::Table => "a table of time series (CSV)".into(),
            Kind::Folder => "a folder".into(),
            Kind::Unknown => "a file of a kind bikeproc does not know".into(),
        }
    }

    /// The command that reads it, as the user types it.
    pub fn command(&self, path: &Path) -> Option<String> {
        let p = path.display();
        Some(match self {
            Kind::RideAngles => format!("bikeproc dynamic {p}"),
            Kind::RideCalibrated => {
                let angles = angles_beside(path);
                format!("bikeproc dynamic {}", angles.display())
            }
            Kind::PendulumLog => format!("bikeproc period {p}"),
            Kind::TestManifest(k) | Kind::TestFolder(k) => {
                let folder = match self {
                    Kind::TestManifest(_) => path.parent().unwrap_or(path).display().to_string(),
                    _ => p.to_string(),
                };
                if k == "bar_calibration" || k == "empty_fixture" {
                    format!("bikeproc calibrate-bar {folder}")
                } else {
                    format!("bikeproc inertia {folder}")
                }
            }
            Kind::RideManifest | Kind::StudyManifest => format!("bikeproc gap {p}"),
            Kind::LabBike | Kind::Benchmark | Kind::MeasuredBicycle => {
                format!("bikeproc stability --bike {p}")
            }
            Kind::Controller => format!("bikeproc stability --bike BIKE --controller {p}"),
            Kind::Table => format!("bikeproc period {p}"),
            Kind::Folder => {
                let rides = path.join("rides.toml");
                if rides.is_file() {
                    format!("bikeproc gap {}", rides.display())
                } else {
                    return None;
                }
            }
            Kind::Unknown => return None,
        })
    }
}

/// A ride's angles file beside its calibrated one (`ride_03_cal.log` → `ride_03.log`).
pub fn angles_beside(calibrated: &Path) -> PathBuf {
    let stem = calibrated
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = stem.strip_suffix("_cal").unwrap_or(&stem);
    let mut name = stem.to_string();
    if let Some(ext) = calibrated.extension() {
        name = format!("{name}.{}", ext.to_string_lossy());
    }
    calibrated.with_file_name(name)
}

/// The largest input bikeproc reads (bytes): a day of 100 Hz rows of two sensors is about
/// 1.5 GB; beyond this a reader of a device or a runaway file would only fill the memory.
pub const MAX_INPUT_BYTES: u64 = 4 << 30;

/// How much of an input is looked at before it is read as text.
const HEAD_BYTES: usize = 64 * 1024;

/// The longest first line an input may have (bytes): a table of some 200,000 columns' header;
/// longer, it is not a line-based text file of bikeproc's formats.
const MAX_FIRST_LINE_BYTES: usize = 4 << 20;

/// Opens `path` as a line-based text input: its first 64 KiB must hold no NUL byte and (when
/// more follows) a line break, and the whole is read to at most [`MAX_INPUT_BYTES`]. Refused
/// with the reason otherwise: `/dev/zero` linked as a log read 4.2 GB before running out of
/// memory, and 2 GiB of NUL bytes as a CSV became a 2 GiB error line.
pub fn open_text(path: &Path) -> Result<impl std::io::Read + Send, NotText> {
    let io = |e: std::io::Error| NotText {
        line: None,
        message: format!("cannot read: {e}"),
    };
    let mut file = std::fs::File::open(path).map_err(io)?;
    let mut head = Vec::with_capacity(HEAD_BYTES);
    (&mut file)
        .take(HEAD_BYTES as u64)
        .read_to_end(&mut head)
        .map_err(io)?;
    if let Some(at) = head.iter().position(|&b| b == 0) {
        return Err(NotText {
            line: Some(1 + head[..at].iter().filter(|&&b| b == b'\n').count() as u64),
            message: format!(
                "binary data (a NUL byte at byte {at}): not a text file of bikeproc's formats"
            ),
        });
    }
    if head.len() == HEAD_BYTES && !head.contains(&b'\n') {
        // A wide table's header (10,000 columns is some 200 KiB) is read on to its line break,
        // up to MAX_FIRST_LINE_BYTES, every byte of it text.
        let mut more = Vec::new();
        (&mut file)
            .take((MAX_FIRST_LINE_BYTES - HEAD_BYTES) as u64)
            .read_to_end(&mut more)
            .map_err(io)?;
        let end = more.iter().position(|&b| b == b'\n' || b == 0);
        match end.map(|at| (at, more[at])) {
            Some((_, b'\n')) => {}
            Some((at, _)) => {
                return Err(NotText {
                    line: Some(1),
                    message: format!(
                        "binary data (a NUL byte at byte {}): not a text file of bikeproc's \
                         formats",
                        HEAD_BYTES + at
                    ),
                })
            }
            None if more.len() + HEAD_BYTES < MAX_FIRST_LINE_BYTES => {}
            None => {
                return Err(NotText {
                    line: Some(1),
                    message: format!(
                        "no line break in the first {} MiB: not a line-based text file (a \
                         table's header line is at most that long)",
                        MAX_FIRST_LINE_BYTES >> 20
                    ),
                })
            }
        }
        head.extend(more);
    }
    let rest = file.take(MAX_INPUT_BYTES - head.len() as u64);
    Ok(std::io::Cursor::new(head).chain(rest))
}

/// Why an input is not read as text: the line where that shows (when one does) and what.
#[derive(Debug, Clone, PartialEq)]
pub struct NotText {
    pub line: Option<u64>,
    pub message: String,
}

impl std::fmt::Display for NotText {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

/// [`open_text`] read whole; refused beyond [`MAX_INPUT_BYTES`].
pub fn read_text_bytes(path: &Path) -> Result<Vec<u8>, NotText> {
    // Room for the whole file at once: the reader's chain gives no size hint, and growing by
    // doubling copied a long log's bytes over again.
    let size = std::fs::metadata(path).map_or(0, |m| m.len().min(MAX_INPUT_BYTES));
    let mut bytes = Vec::with_capacity(usize::try_from(size).unwrap_or(0).saturating_add(1));
    open_text(path)?
        .read_to_end(&mut bytes)
        .map_err(|e| NotText {
            line: None,
            message: format!("cannot read: {e}"),
        })?;
    if bytes.len() as u64 >= MAX_INPUT_BYTES {
        return Err(NotText {
            line: None,
            message: too_large_message(),
        });
    }
    Ok(bytes)
}

/// What a file of [`MAX_INPUT_BYTES`] or more is told (the whole-file read above and the log
/// reader's streaming one).
pub fn too_large_message() -> String {
    format!(
        "larger than {} GiB: split the recording",
        MAX_INPUT_BYTES >> 30
    )
}

/// How much of a file is read to recognise it.
const SNIFF_BYTES: u64 = 16 * 1024;

/// What `path` is (see [`Kind`]); [`Kind::Unknown`] when it cannot be read.
pub fn recognise(path: &Path) -> Kind {
    if path.is_dir() {
        return folder_kind(path);
    }
    let Ok(file) = std::fs::File::open(path) else {
        return Kind::Unknown;
    };
    let mut head = Vec::new();
    if file.take(SNIFF_BYTES).read_to_end(&mut head).is_err() {
        return Kind::Unknown;
    }
    let text = String::from_utf8_lossy(&head);
    // Lines end in LF or CRLF, or in CR alone in a file without LF (classic Mac OS text).
    let end = if text.contains('\n') { '\n' } else { '\r' };
    let lines: Vec<&str> = text.split(end).map(str::trim).collect();
    if lines.iter().any(|l| l.starts_with("// Sample rate")) {
        let sensors = lines.iter().filter(|l| l.starts_with("// Sensor ")).count();
        let calibrated = lines
            .iter()
            .any(|l| l.starts_with("// Output mode") && l.contains("Calibrated"));
        return match (sensors >= 2, calibrated) {
            (true, true) => Kind::RideCalibrated,
            (true, false) => Kind::RideAngles,
            (false, _) => Kind::PendulumLog,
        };
    }
    let key = |k: &str| {
        lines
            .iter()
            .any(|l| l.split_once('=').is_some_and(|(name, _)| name.trim() == k))
    };
    if lines.contains(&"[[ride]]") {
        return Kind::RideManifest;
    }
    if key("conditions") {
        return Kind::StudyManifest;
    }
    if lines.contains(&"[geometry]") {
        return Kind::LabBike;
    }
    if let Some(k) = lines.iter().find_map(|l| test_kind(l)) {
        return Kind::TestManifest(k);
    }
    if lines.contains(&"[controller]") {
        return Kind::Controller;
    }
    if key("IBxx") || key("mB") && key("xB") {
        return Kind::Benchmark;
    }
    if key("TcB1") || key("TxB1") || key("alphaB1") || key("mB") {
        return Kind::MeasuredBicycle;
    }
    if lines
        .first()
        .is_some_and(|l| l.contains(',') || l.contains(';') || l.contains('\t'))
        || single_column(&lines)
    {
        return Kind::Table;
    }
    Kind::Unknown
}

/// A table of one channel: a name of one word (or a first number) over rows of one number each
/// (a microcontroller logging its roll-rate gyro alone), judged on the first rows read.
fn single_column(lines: &[&str]) -> bool {
    let number = |l: &str| l.parse::<f64>().is_ok_and(f64::is_finite);
    let rows: Vec<&str> = lines.iter().copied().filter(|l| !l.is_empty()).collect();
    let (Some(first), true) = (rows.first(), rows.len() >= 3) else {
        return false;
    };
    let named = first
        .chars()
        .all(|c| c.is_alphanumeric() || "_-.()/".contains(c))
        && first.chars().next().is_some_and(char::is_alphabetic);
    // The last line read may be cut short by the sniff's length.
    (named || number(first)) && rows[1..rows.len() - 1].iter().all(|l| number(l))
}

/// The `kind = "…"` of a test manifest's line.
fn test_kind(line: &str) -> Option<String> {
    let (name, value) = line.split_once('=')?;
    if name.trim() != "kind" {
        return None;
    }
    let v = value.trim().trim_matches('"').trim();
    (!v.is_empty()).then(|| v.to_string())
}

/// A folder's kind: that of the test manifest in it, if any.
fn folder_kind(path: &Path) -> Kind {
    let Ok(entries) = std::fs::read_dir(path) else {
        return Kind::Folder;
    };
    let mut tomls: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml") && p.is_file())
        .collect();
    tomls.sort();
    tomls
        .iter()
        .find_map(|t| match recognise(t) {
            Kind::TestManifest(k) => Some(Kind::TestFolder(k)),
            _ => None,
        })
        .unwrap_or(Kind::Folder)
}

/// Whether `path` holds a TOML document (any), for a file [`recognise`] does not know: a
/// manifest with a misspelt table is still handed to the manifest's reader, which names the
/// line, rather than to another format's. An IMU log or a CSV table is never valid TOML.
pub fn is_toml_document(path: &Path) -> bool {
    read_text_bytes(path)
        .ok()
        .and_then(|b| String::from_utf8(b).ok())
        .is_some_and(|t| t.parse::<toml::Table>().is_ok())
}

/// The message for `path` given where `wanted` (in words) is expected: what it is, and the
/// command that reads it. `None` when its kind is among `accepted` or not recognised (the
/// reader then speaks).
pub fn mismatch(path: &Path, accepted: &dyn Fn(&Kind) -> bool, wanted: &str) -> Option<String> {
    let kind = recognise(path);
    if kind == Kind::Unknown || accepted(&kind) {
        return None;
    }
    let mut message = format!(
        "{}: this is {}, not {wanted}",
        path.display(),
        kind.describe()
    );
    if let Some(c) = kind.command(path) {
        message += &format!("; use `{c}`");
    } else if kind == Kind::Folder {
        message += "; give the file itself";
    }
    Some(message)
}

/// `Err(WrongKind)` from [`mismatch`].
pub fn expect(
    path: &Path,
    accepted: &dyn Fn(&Kind) -> bool,
    wanted: &str,
) -> Result<(), WrongKind> {
    match mismatch(path, accepted, wanted) {
        Some(m) => Err(WrongKind(m)),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(p: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(p)
    }

    #[test]
    fn the_checked_in_inputs_are_recognised() {
        assert_eq!(recognise(&data("ride_03.log")), Kind::RideAngles);
        assert_eq!(recognise(&data("ride_03_cal.log")), Kind::RideCalibrated);
        assert_eq!(
            recognise(&data("frame_torsion/frame_torsion_1a.log")),
            Kind::PendulumLog
        );
        assert_eq!(
            recognise(&data("frame_torsion")),
            Kind::TestFolder("torsion".into())
        );
        assert_eq!(
            recognise(&data("bar_calibration")),
            Kind::TestFolder("bar_calibration".into())
        );
        assert_eq!(recognise(&data("rides.toml")), Kind::RideManifest);
        assert_eq!(recognise(&data("lab_bike.toml")), Kind::LabBike);
        assert_eq!(recognise(&data("")), Kind::Folder);
        assert_eq!(angles_beside(&data("ride_03_cal.log")), data("ride_03.log"));
    }

    /// One channel logged alone is a table, named or not; prose, a key list and a single
    /// number are not.
    #[test]
    fn a_table_of_one_channel_is_a_table() {
        let dir = std::env::temp_dir().join(format!("bikeproc_kind_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let rows: String = (0..400)
            .map(|k| format!("{:.4}\n", (0.1 * k as f64).sin()))
            .collect();
        for (name, text, kind) in [
            ("named.log", format!("gyro_x\n{rows}"), Kind::Table),
            ("unnamed.log", rows.clone(), Kind::Table),
            (
                "crlf.txt",
                format!("roll_rate_rad_per_s\r\n{}", rows.replace('\n', "\r\n")),
                Kind::Table,
            ),
            (
                "prose.txt",
                "A note\non the rides\nof Tuesday\n".to_string(),
                Kind::Unknown,
            ),
            ("words.log", format!("gyro x\n{rows}"), Kind::Unknown),
            ("two.log", "speed\n4.1\n".to_string(), Kind::Unknown),
        ] {
            let path = dir.join(name);
            std::fs::write(&path, text).unwrap();
            assert_eq!(recognise(&path), kind, "{name}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
