//! Entry points for the fuzzers (`fuzz/`, cargo-fuzz on nightly) and for the replay of their
//! corpus on stable (`tests/fuzz_corpus.rs`): each takes arbitrary bytes as one kind of outside
//! file, reads it as bikeproc would and analyses what it accepts. Every one must return, never
//! panic, hang or allocate beyond what the bytes justify; what it returns is of no interest.
//!
//! Readers that take a path get the bytes through a file in a per-process folder under the
//! system's temporary directory (named after the target, so a manifest's relative paths point
//! beside it, where nothing is).

use std::path::{Path, PathBuf};

/// A fuzz target: arbitrary bytes in, nothing out.
pub type Target = fn(&[u8]);

/// The fuzz targets by name: the folder names under `fuzz/seeds/` and `fuzz/fuzz_targets/`.
pub const TARGETS: [(&str, Target); 11] = [
    ("log_file", log_file),
    ("csv_signal", csv_signal),
    ("bicycle_text", bicycle_text),
    ("lab_bike", lab_bike),
    ("pendulum_manifest", pendulum_manifest),
    ("ride_manifest", ride_manifest),
    ("csv_ride", csv_ride),
    ("measured_file", measured_file),
    ("controller_file", controller_file),
    ("study_manifest", study_manifest),
    ("controller_from_file", controller_from_file),
];

/// Writes `bytes` to `name` in this process's fuzzing folder and gives its path.
fn as_file(bytes: &[u8], name: &str) -> Option<PathBuf> {
    let dir = std::env::temp_dir().join(format!("bikeproc-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).ok()?;
    let path = dir.join(name);
    std::fs::write(&path, bytes).ok()?;
    Some(path)
}

/// A log (orientation or calibrated, either locale): read, its signals extracted and fitted.
pub fn log_file(bytes: &[u8]) {
    use crate::read::log::{Log, ReadOptions};
    let Ok(log) = Log::parse(bytes, Path::new("fuzz.log"), &ReadOptions::default()) else {
        return;
    };
    if let Ok(s) = crate::signal::dominant_rotation(&log, None) {
        let _ = crate::fit::analyse(&s, &Default::default());
    }
    for c in ["Gyr_Z", "Acc_X"] {
        if let Some(s) = crate::signal::channel(&log, c, None) {
            let _ = crate::fit::analyse(&s, &Default::default());
        }
    }
}

/// A CSV signal `time_s,value`: read and fitted.
pub fn csv_signal(bytes: &[u8]) {
    if let Ok(s) = crate::signal::Signal::from_csv_reader(bytes, Path::new("fuzz.csv")) {
        let _ = crate::fit::analyse(&s, &Default::default());
    }
}

/// A BicycleParameters `*Benchmark.txt` or a benchmark TOML: read, and its stability found.
pub fn bicycle_text(bytes: &[u8]) {
    use crate::model::{Benchmark, Canonical};
    let Ok(text) = std::str::from_utf8(bytes) else {
        return;
    };
    let parsed = [
        Benchmark::parse_text(text, Path::new("fuzz.txt")),
        Benchmark::parse_toml(text, Path::new("fuzz.toml")),
    ];
    for b in parsed.iter().flatten() {
        let _ = Canonical::from_benchmark(b).stability(10.0, 0.1);
    }
}

/// The lab's bicycle file (`lab_bike.toml`): read, and its benchmark parameters derived.
pub fn lab_bike(bytes: &[u8]) {
    if let Some(path) = as_file(bytes, "lab_bike.toml") {
        let _ = crate::read::bicycle::load(&path);
    }
}

/// A pendulum test folder's `manifest.toml`.
pub fn pendulum_manifest(bytes: &[u8]) {
    if let Some(path) = as_file(bytes, "manifest.toml") {
        let _ = crate::read::manifest::Manifest::load(&path);
    }
}

/// A ride campaign's `rides.toml`, its controller table or file included (beside it: a log,
/// the benchmark bicycle and `ctl.toml`).
pub fn ride_manifest(bytes: &[u8]) {
    // What a manifest may name beside it: a log, a bicycle, a controller file.
    if !beside_manifests() {
        return;
    }
    if let Some(path) = as_file(bytes, "rides.toml") {
        let _ = crate::read::rides::RideManifest::load(&path);
    }
}

/// A ride from another instrument as CSV: read, and every free decay in it fitted.
pub fn csv_ride(bytes: &[u8]) {
    use crate::ride::csv::{read_csv_ride, ride_decays, Columns};
    let Some(path) = as_file(bytes, "ride.csv") else {
        return;
    };
    if let Ok(ride) = read_csv_ride(&path, &Columns::default(), None) {
        let _ = ride_decays(&ride, None, None, None, &Default::default());
    }
}

/// A BicycleParameters `*Measured.txt`: read, converted to benchmark parameters, and the
/// bicycle's stability found.
pub fn measured_file(bytes: &[u8]) {
    use crate::inertia::measured::{MeasuredBicycle, MeasuredFile};
    let Ok(file) = MeasuredFile::parse(bytes, Path::new("FuzzMeasured.txt")) else {
        return;
    };
    if let Ok(b) = MeasuredBicycle::from_file(&file) {
        let _ = b.report(10.0, 0.1);
    }
}

/// A steer controller's file (a `[controller]` table): read, and the benchmark bicycle's
/// eigenvalues with it closing the loop at a few speeds across its table.
pub fn controller_file(bytes: &[u8]) {
    use crate::model::{Benchmark, Canonical, SteerControl};
    let Some(path) = as_file(bytes, "controller.toml") else {
        return;
    };
    if let Ok((control, _)) = SteerControl::load(&path) {
        let bike = Canonical::from_benchmark(&Benchmark::meijaard_2007()).with_control(control);
        for v in [0.0, 1.0, 4.7, 10.0, 40.0] {
            let _ = bike.eigenvalues(v);
        }
    }
}

/// A study manifest (`conditions = [...]`): read, with three campaign manifests beside it that
/// its conditions may name (`off.toml`; `gain.toml` with a controller table; `file.toml` with
/// a controller file), and each condition's model made.
pub fn study_manifest(bytes: &[u8]) {
    if !beside_manifests() {
        return;
    }
    if let Some(path) = as_file(bytes, "study.toml") {
        if let Ok(study) = crate::read::study::Study::load(&path) {
            for (_, m) in &study.conditions {
                let _ = m.model(None);
            }
        }
    }
}

/// A controller file a campaign manifest names (`controller = "ctl.toml"`): the manifest
/// read with it, and its model's eigenvalues across the table.
pub fn controller_from_file(bytes: &[u8]) {
    if !beside_manifests() || as_file(bytes, "ctl.toml").is_none() {
        return;
    }
    if let Some(path) = as_file(FILE.as_bytes(), "file.toml") {
        if let Ok(m) = crate::read::rides::RideManifest::load(&path) {
            if let Ok(model) = m.model(None) {
                for v in [0.0, 1.0, 4.7, 10.0, 40.0] {
                    let _ = model.nominal_canonical().eigenvalues(v);
                }
            }
        }
    }
}

/// A campaign without a controller (`off.toml`).
const OFF: &str = "version = 1\nbike = \"bike.txt\"\n\n[[ride]]\nlog = \"r.log\"\n\
    noted_speed_mps = 3.0\n";
/// A campaign with its controller's table (`gain.toml`).
const GAIN: &str = "version = 1\nbike = \"bike.txt\"\n\n[controller]\nspeeds_mps = [0.0, 4.7]\n\
    roll_rate_nms_per_rad = [28.2, 0.0]\n\n[[ride]]\nlog = \"r.log\"\nnoted_speed_mps = 3.0\n";
/// A campaign whose controller is a file (`file.toml`, naming `ctl.toml`).
const FILE: &str = "version = 1\nbike = \"bike.txt\"\ncontroller = \"ctl.toml\"\n\n[[ride]]\n\
    log = \"r.log\"\nnoted_speed_mps = 3.0\n";
/// The controller file `file.toml` names, until a target writes its own.
const CONTROLLER: &str = "[controller]\nspeeds_mps = [0.0, 4.7, 20.0]\n\
    roll_rate_nms_per_rad = [28.2, 0.0, 0.0]\n";

/// Writes what manifests name beside them (the benchmark bicycle, an empty log, the three
/// campaigns and a controller file); `false` when the folder cannot be written.
fn beside_manifests() -> bool {
    let bike = crate::model::Benchmark::meijaard_2007().to_text();
    [
        (bike.as_str(), "bike.txt"),
        ("", "r.log"),
        (OFF, "off.toml"),
        (GAIN, "gain.toml"),
        (FILE, "file.toml"),
        (CONTROLLER, "ctl.toml"),
    ]
    .iter()
    .all(|(text, name)| as_file(text.as_bytes(), name).is_some())
}
