//! Every malformed input in `fixtures/bad/` gets one line naming the file and the line, exit
//! code 2, and never a panic; random bytes and random edits of valid logs never panic the reader.

use bikeproc::read::log::{Log, ReadOptions};
use proptest::prelude::*;
use std::path::Path;
use std::process::Command;

mod common;

#[test]
fn every_bad_fixture_is_one_line_with_file_and_line_and_exit_2() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/bad");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "log" || e == "csv"))
        .collect();
    files.sort();
    assert!(files.len() >= 20, "only {} fixtures", files.len());
    for f in files {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_bikeproc"));
        cmd.arg("period").arg(&f);
        if name == "no_cal.log" {
            cmd.args(["--channel", "Gyr_Z"]);
        }
        let out = cmd.output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{name}: {stderr}");
        let lines: Vec<&str> = stderr.lines().collect();
        assert_eq!(lines.len(), 1, "{name}: {stderr}");
        // `error: PATH:LINE[:COL]: message`
        let after = lines[0]
            .split_once(&format!("{name}:"))
            .map(|(_, r)| r)
            .unwrap_or_else(|| panic!("{name}: {stderr}"));
        let line_no: String = after.chars().take_while(char::is_ascii_digit).collect();
        assert!(
            line_no.parse::<usize>().is_ok_and(|l| l >= 1),
            "{name}: no line number in {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
    }
}

/// Valid logs in every mode and both locales, orientation and calibrated.
fn valid_logs() -> Vec<String> {
    common::torsion_logs(true)
        .into_iter()
        .flat_map(|r| [r.angles_log, r.cal_log])
        .collect()
}

fn exercise(bytes: &[u8]) {
    let opts = ReadOptions::default();
    if let Ok(log) = Log::parse(bytes, Path::new("prop.log"), &opts) {
        if let Ok(sig) = bikeproc::signal::dominant_rotation(&log, None) {
            let _ = bikeproc::fit::analyse(&sig, &Default::default());
        }
        let _ = bikeproc::signal::channel(&log, "Gyr_Z", None);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2000)) {
        exercise(&bytes);
    }

    #[test]
    fn random_edits_of_valid_logs_never_panic(
        which in 0usize..6,
        edits in proptest::collection::vec((0.0f64..1.0, 0usize..6, any::<u8>(), 0usize..40), 1..8),
    ) {
        let base = &VALID.with(|v| v[which].clone());
        let mut bytes = base.as_bytes().to_vec();
        for (pos, kind, byte, len) in edits {
            let at = ((bytes.len() as f64) * pos) as usize;
            let at = at.min(bytes.len());
            match kind {
                0 => { let end = (at + len).min(bytes.len()); bytes.drain(at..end); }
                1 => bytes.insert(at, byte),
                2 => if at < bytes.len() { bytes[at] = byte },
                3 => { for b in "NaN".bytes().rev() { bytes.insert(at, b) } }
                4 => { for b in "\t-1e308".bytes().rev() { bytes.insert(at, b) } }
                _ => { let end = (at + len).min(bytes.len()); let chunk = bytes[at..end].to_vec(); for (i, b) in chunk.into_iter().enumerate() { bytes.insert(at + i, b) } }
            }
        }
        exercise(&bytes);
    }
}

thread_local! {
    static VALID: Vec<String> = valid_logs();
}

/// Issue 14: the inputs that aborted, overflowed or were refused for the receiver's jitter now
/// get messages that say what is wrong (and exit 2, as every fixture above).
#[test]
fn far_times_and_absurd_rates_say_what_is_wrong() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/bad");
    for (file, says) in [
        ("far_time_stamp.log", "a hole of 1.000000e12 s"),
        ("far_time_stamp.csv", "a hole of 1.000000e12 s"),
        ("row_at_1e300.log", "a hole of 1.000000e300 s"),
        ("long_hole.log", "a hole of 2.000000e3 s"),
        ("long_hole.csv", "a hole of 2.991010e3 s"),
        (
            "latin1_bytes.csv",
            "latin1_bytes.csv:9:13: bytes that are not UTF-8 text in field 3",
        ),
        ("sample_rate_1e300.log", "at most 100000"),
        (
            "time_backwards.log",
            "time goes backwards: 0.2 s after 0.51 s",
        ),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_bikeproc"))
            .arg("period")
            .arg(dir.join(file))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{file}: {stderr}");
        assert!(stderr.contains(says), "{file}: {stderr}");
    }
}

/// Issue 14: habits of editors and spreadsheets are no error. A byte-order mark, old Mac line
/// ends (CR alone) and a tab at every line's end give the same samples as the clean file, in
/// every mode and locale; a 5 MB field is quoted in 40 characters, not echoed.
#[test]
fn editor_habits_read_as_the_clean_file() {
    let opts = ReadOptions::default();
    for text in valid_logs() {
        let clean = Log::parse(text.as_bytes(), Path::new("clean.log"), &opts).unwrap();
        let variants = [
            format!("\u{feff}{text}"),
            text.replace('\n', "\r"),
            text.replace('\n', "\t\n"),
            text.replace('\n', "\r\n"),
        ];
        for (k, v) in variants.iter().enumerate() {
            let log = Log::parse(v.as_bytes(), Path::new("habit.log"), &opts)
                .unwrap_or_else(|e| panic!("variant {k}: {e}"));
            assert_eq!(log.grid_index, clean.grid_index, "variant {k}");
            assert_eq!(log.data, clean.data, "variant {k}");
        }
    }
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/bad/bad_number.log"),
    )
    .unwrap();
    let huge = text.replace("abc", &"x".repeat(5_000_000));
    let e = Log::parse(huge.as_bytes(), Path::new("huge.log"), &opts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("(5000000 bytes)"), "{}", &e[..e.len().min(300)]);
    assert!(e.len() < 300, "{} bytes of message", e.len());
}

/// Issue 33: a bar calibration file edited to a number outside its range (a NaN or absurd
/// standard error, a negative one, a correlation outside [−1, 1], a NaN fixture inertia) is
/// refused where it is read, naming the file, the line and the key (exit 2); it gave every
/// inertia ± 0.0000 or "k = 34.321 ± -0.075" before.
#[test]
fn a_bar_calibration_out_of_range_is_refused_with_its_key() {
    let dir = common::data_copy("cal", &["bar_calibration", "frame_torsion"]);
    let original =
        std::fs::read_to_string(common::root().join("data/bar_calibration/calibration.toml"))
            .unwrap();
    let run = || {
        std::process::Command::new(env!("CARGO_BIN_EXE_bikeproc"))
            .arg("inertia")
            .arg(dir.join("frame_torsion"))
            .output()
            .unwrap()
    };
    for (key, value, line) in [
        ("stiffness_se_nm_per_rad", "nan", 5),
        ("stiffness_se_nm_per_rad", "1e300", 5),
        ("stiffness_se_nm_per_rad", "-0.075", 5),
        ("stiffness_fixture_correlation", "nan", 8),
        ("stiffness_fixture_correlation", "5", 8),
        ("fixture_inertia_kgm2", "nan", 6),
    ] {
        std::fs::write(
            dir.join("bar_calibration/calibration.toml"),
            common::with_key(&original, key, value),
        )
        .unwrap();
        let out = run();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{key} = {value}: {err}");
        assert!(
            err.contains("calibration.toml") && err.contains(&format!("line {line}: {key} = ")),
            "{key} = {value}: {err}"
        );
    }
    std::fs::write(dir.join("bar_calibration/calibration.toml"), &original).unwrap();
    assert_eq!(run().status.code(), Some(0));
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 33: a ride listed twice in a campaign is refused (it was analysed as one more ride,
/// its evidence counted twice, in `gap` and `dynamic`).
#[test]
fn a_ride_listed_twice_is_refused() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = std::env::temp_dir().join(format!("bikeproc_twice_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for f in [
        "ride_01.log",
        "ride_01_cal.log",
        "ride_02.log",
        "ride_02_cal.log",
        "lab_bike.toml",
    ] {
        std::fs::copy(root.join("data").join(f), dir.join(f)).unwrap();
    }
    std::fs::write(
        dir.join("rides.toml"),
        "version = 1\nbike = \"lab_bike.toml\"\n\n[[ride]]\nlog = \"ride_01.log\"\nnoted_speed_mps = 3.5\n\n\
         [[ride]]\nlog = \"ride_02.log\"\nnoted_speed_mps = 3.7\n\n\
         [[ride]]\nlog = \"./ride_01.log\"\nnoted_speed_mps = 3.5\n",
    )
    .unwrap();
    // The same name twice (second case): the error is at the second listing (line 13), not
    // the first (5).
    let text = std::fs::read_to_string(dir.join("rides.toml")).unwrap();
    let same_name = text.replace("./ride_01.log", "ride_01.log");
    for (manifest, name) in [(&text, "./ride_01.log"), (&same_name, "ride_01.log")] {
        std::fs::write(dir.join("rides.toml"), manifest).unwrap();
        for command in ["gap", "dynamic"] {
            let out = std::process::Command::new(env!("CARGO_BIN_EXE_bikeproc"))
                .arg(command)
                .arg(dir.join("rides.toml"))
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{command}: {err}");
            let want = format!("rides.toml:13: {name} is listed twice");
            assert!(err.contains(&want), "{command}: {err}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 33: one recording twice in a torsion test (it gave f ± 0.00000 and a spread of 0.00 %)
/// or in two tests (exit 0, only χ² 147 hinted) is refused, naming the test and the line.
#[test]
fn a_recording_in_two_places_is_refused() {
    let dir = common::data_copy("duplog", &["bar_calibration", "frame_torsion"]);
    let manifest = dir.join("frame_torsion/manifest.toml");
    let original = std::fs::read_to_string(&manifest).unwrap();
    for (from, to, want) in [
        (
            r#"logs = ["frame_torsion_1a.log", "frame_torsion_1b.log"]"#,
            r#"logs = ["frame_torsion_1a.log", "frame_torsion_1a.log"]"#,
            "manifest.toml:14: test \"1\" lists frame_torsion_1a.log twice",
        ),
        (
            r#"logs = ["frame_torsion_2a.log", "frame_torsion_2b.log"]"#,
            r#"logs = ["frame_torsion_1a.log", "frame_torsion_1b.log"]"#,
            "manifest.toml:22: frame_torsion_1a.log is in test \"1\" and in test \"2\"",
        ),
    ] {
        assert!(original.contains(from));
        std::fs::write(&manifest, original.replacen(from, to, 1)).unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_bikeproc"))
            .arg("inertia")
            .arg(dir.join("frame_torsion"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains(want), "{err}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 33: manifest numbers beyond their physical range are refused naming the line and the
/// key: a centre of gravity 5 m from the bar's axis (it gave −5.48e20 kg·m² and a warning that
/// blamed the axes), a bar's shear modulus of 1e300 Pa (a theoretical stiffness of 4.9e299).
#[test]
fn manifest_numbers_beyond_their_physical_range_are_refused() {
    let dir = common::data_copy(
        "range",
        &["bar_calibration", "empty_fixture", "frame_torsion"],
    );
    let edit = |file: &str, key: &str, value: &str| {
        let path = dir.join(file);
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::write(path, common::with_key(&text, key, value)).unwrap();
    };
    let run = |command: &str, sub: &str| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_bikeproc"))
            .arg(command)
            .arg(dir.join(sub))
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    edit("frame_torsion/manifest.toml", "cg_distance_m", "5");
    let (code, err) = run("inertia", "frame_torsion");
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("`cg_distance_m = 5`: expected at most 2"),
        "{err}"
    );
    edit("bar_calibration/manifest.toml", "shear_modulus_pa", "1e300");
    let (code, err) = run("calibrate-bar", "bar_calibration");
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("manifest.toml:13: `shear_modulus_pa = 1e300`"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
