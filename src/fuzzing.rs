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
pub const TARGETS: [(&str, Target); 10] = [
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
    use crate::log::{Log, ReadOptions};
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
        let _ = crate::model::uncertain::load(&path);
    }
}

/// A pendulum test folder's `manifest.toml`.
pub fn pendulum_manifest(bytes: &[u8]) {
    if let Some(path) = as_file(bytes, "manifest.toml") {
        let _ = crate::inertia::manifest::Manifest::load(&path);
    }
}

/// A ride campaign's `rides.toml`, its controller table included.
pub fn ride_manifest(bytes: &[u8]) {
    if let Some(path) = as_file(bytes, "rides.toml") {
        let _ = crate::ride::dynamic::RideManifest::load(&path);
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

/// A study manifest (`conditions = [...]`): read, with two campaign manifests beside it
/// (`off.toml`, and `gain.toml` with a controller table) that its conditions may name.
pub fn study_manifest(bytes: &[u8]) {
    const OFF: &str = "version = 1\nbike = \"bike.txt\"\n\n[[ride]]\nlog = \"r.log\"\n";
    const GAIN: &str =
        "version = 1\nbike = \"bike.txt\"\n\n[controller]\nspeeds_mps = [0.0, 4.7]\n\
        roll_rate_nms_per_rad = [28.2, 0.0]\n\n[[ride]]\nlog = \"r.log\"\n";
    if as_file(OFF.as_bytes(), "off.toml").is_none()
        || as_file(GAIN.as_bytes(), "gain.toml").is_none()
    {
        return;
    }
    if let Some(path) = as_file(bytes, "study.toml") {
        let _ = crate::ride::study::Study::load(&path);
    }
}
