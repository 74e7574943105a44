//! Issue 14 items 5–6: what a lab feeds bikeproc by mistake gets a clear error and the README's
//! exit code (2 for input, 1 for anything else), never an abort, a hang, a panic or a quiet
//! wrong answer. One test per row of the table that is not a reader fixture
//! (`tests/bad_inputs.rs`, `tests/inertia.rs`).

use common::root;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

mod common;

fn bikeproc(args: &[&str]) -> Output {
    common::run(args)
}

/// Exit code `code`, no panic, and `says` in the one-line message.
fn refused(out: &Output, code: i32, says: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains(says), "expected `{says}` in: {err}");
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("bikeproc_robust_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const BENCHMARK: &str = "../shared/reference/bicycleparameters/BenchmarkBenchmark.txt";

#[test]
fn unbounded_work_is_refused_before_it_starts() {
    refused(
        &bikeproc(&["stability", "--bike", BENCHMARK, "--speeds", "0:10:1e-9"]),
        2,
        "at most a million speeds",
    );
}

/// Issue 33's weak messages: a speed grid with an infinite step (was "the mass matrix M is
/// singular") and a ride that does not exist (was "no bicycle to compare with") name their cause.
#[test]
fn weak_messages_name_the_real_cause() {
    for grid in ["0:10:inf", "0:inf:1", "nan:10:1"] {
        refused(
            &bikeproc(&["stability", "--bike", BENCHMARK, "--speeds", grid]),
            2,
            "finite",
        );
    }
    refused(
        &bikeproc(&["dynamic", "/nonexistent/x.log"]),
        2,
        "/nonexistent/x.log: cannot read",
    );
}

/// A unit hint only where the key it suggests exists: `mass_g` for the rod's `mass_kg` is a
/// unit to change, `rol_nm_per_rad` in a controller is a typo of `roll_nm_per_rad` (it was told
/// to write `rol_nm_per_deg`).
#[test]
fn a_unit_hint_names_a_key_that_exists() {
    let dir = scratch("unit_hint");
    let controller = dir.join("controller.toml");
    std::fs::write(
        &controller,
        "[controller]\nspeeds_mps = [0.0, 20.0]\nrol_nm_per_rad = [1.0, 1.0]\n",
    )
    .unwrap();
    let out = bikeproc(&[
        "stability",
        "--bike",
        "data/lab_bike.toml",
        "--controller",
        controller.to_str().unwrap(),
    ]);
    refused(&out, 2, "controller.toml:3: unknown key `rol_nm_per_rad`");
    refused(&out, 2, "`roll_nm_per_rad`");
    let bar = dir.join("bar");
    std::fs::create_dir_all(&bar).unwrap();
    let manifest = std::fs::read_to_string(root().join("data/bar_calibration/manifest.toml"))
        .unwrap()
        .replace("mass_kg = 22.31", "mass_g = 22310");
    std::fs::write(bar.join("manifest.toml"), manifest).unwrap();
    refused(
        &bikeproc(&["calibrate-bar", bar.to_str().unwrap()]),
        2,
        "`mass_g`: wrong unit; bikeproc takes SI units, write `mass_kg`",
    );
}

/// A benchmark parameter no bicycle reaches is named with its file (1e300 in `mH` said "the
/// eigenvalues could not be computed (non-finite state matrix)" without a file; `c` printed
/// three hundred digits).
#[test]
fn a_benchmark_parameter_beyond_any_bicycle_is_named() {
    let dir = scratch("huge_benchmark");
    let text = std::fs::read_to_string(root().join(BENCHMARK)).unwrap();
    for (key, says) in [
        ("mH", "mH = 1e300 kg: beyond any bicycle's"),
        ("IBxx", "IBxx = 1e300 kg·m²: beyond any bicycle's"),
        ("rF", "rF = 1e300 m: beyond any bicycle's"),
        ("c", "trail c = 1e300 m"),
    ] {
        let edited: String = text
            .lines()
            .map(|l| {
                if l.split('=').next().is_some_and(|k| k.trim() == key) {
                    format!("{key} = 1e300\n")
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        let file = dir.join(format!("Huge{key}Benchmark.txt"));
        std::fs::write(&file, edited).unwrap();
        let out = bikeproc(&["stability", "--bike", file.to_str().unwrap()]);
        refused(&out, 2, &format!("Huge{key}Benchmark.txt: {says}"));
    }
}

#[test]
fn speeds_and_resamples_are_checked_before_any_work() {
    for (speed, says) in [
        ("-1", "not a riding speed"),
        ("nan", "not a riding speed"),
        ("1000", "not a riding speed"),
    ] {
        refused(
            &bikeproc(&["dynamic", "data/ride_03.log", "--speed", speed]),
            2,
            says,
        );
    }
    refused(
        &bikeproc(&["dynamic", "data/ride_03.log", "--resamples", "0"]),
        2,
        "20..=100000",
    );
}

#[test]
fn a_key_twice_in_a_bicycle_file_is_refused() {
    let d = scratch("dup");
    let text = std::fs::read_to_string(root().join(BENCHMARK)).unwrap();
    let path = d.join("TwiceBenchmark.txt");
    std::fs::write(&path, format!("{text}mB = 3.0+/-0.1\n")).unwrap();
    refused(
        &bikeproc(&["stability", "--bike", path.to_str().unwrap()]),
        2,
        "`mB` is given twice",
    );
    std::fs::write(
        &path,
        text.replacen("mB = ", "mB = 85.0+/-1e300\n# was: mB = ", 1),
    )
    .unwrap();
    refused(
        &bikeproc(&["stability", "--bike", path.to_str().unwrap()]),
        2,
        "a standard error from 0",
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_lab_bicycle_with_a_negative_standard_error_is_refused() {
    let d = scratch("labse");
    let text = std::fs::read_to_string(root().join("data/lab_bike.toml")).unwrap();
    let i = text.find("ixx_se_kgm2 = ").expect("an I_xx standard error");
    let end = i + text[i..].find('\n').unwrap();
    let bad = format!("{}ixx_se_kgm2 = -1.0{}", &text[..i], &text[end..]);
    let path = d.join("lab_bike.toml");
    std::fs::write(&path, bad).unwrap();
    refused(
        &bikeproc(&["stability", "--bike", path.to_str().unwrap()]),
        2,
        "a standard error from 0 to 1000",
    );
    std::fs::remove_dir_all(&d).ok();
}

/// A campaign whose every ride fails, and one whose speed is not a bicycle's or whose logs lie
/// outside its folder: exit 2 from `dynamic` and `gap`.
#[test]
fn campaigns_that_cannot_be_analysed_exit_2() {
    let d = scratch("campaign");
    std::fs::copy(root().join("data/lab_bike.toml"), d.join("lab_bike.toml")).unwrap();
    // Two "rides" that are pendulum logs: no ride in them.
    let logs: Vec<PathBuf> = std::fs::read_dir(root().join("data/frame_torsion"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with("a.log"))
        .take(2)
        .collect();
    let mut manifest = String::from("version = 1\nbike = \"lab_bike.toml\"\n");
    for (k, l) in logs.iter().enumerate() {
        std::fs::copy(l, d.join(format!("ride_{k}.log"))).unwrap();
        let cal = l.to_string_lossy().replace(".log", "_cal.log");
        if Path::new(&cal).exists() {
            std::fs::copy(&cal, d.join(format!("ride_{k}_cal.log"))).unwrap();
        }
        manifest += &format!("[[ride]]\nlog = \"ride_{k}.log\"\nnoted_speed_mps = 4.0\n");
    }
    let path = d.join("rides.toml");
    std::fs::write(&path, &manifest).unwrap();
    let p = path.to_str().unwrap();
    refused(&bikeproc(&["dynamic", p]), 2, "no ride of");
    refused(&bikeproc(&["gap", p]), 2, "no ride of");
    std::fs::write(&path, manifest.replace("4.0", "1000.0")).unwrap();
    refused(&bikeproc(&["dynamic", p]), 2, "not a riding speed");
    std::fs::write(
        &path,
        manifest.replace("\"ride_0.log\"", "\"../../../../../../../etc/hostname\""),
    )
    .unwrap();
    refused(
        &bikeproc(&["dynamic", p]),
        2,
        "lies outside the manifest's folder",
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn simulate_never_writes_into_data_without_out() {
    for what in ["campaign", "rides", "ride-faults"] {
        refused(&bikeproc(&["simulate", what]), 2, "--out");
    }
}

#[cfg(unix)]
#[test]
fn an_out_that_is_a_symlink_or_a_device_is_refused() {
    let d = scratch("symlink");
    let target = d.join("target.log");
    std::fs::write(&target, "keep").unwrap();
    let link = d.join("link.log");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    refused(
        &bikeproc(&["simulate", "torsion", "--out", link.to_str().unwrap()]),
        1,
        "a symlink",
    );
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "keep");
    refused(
        &bikeproc(&["simulate", "torsion", "--out", "/dev/null"]),
        1,
        "a device",
    );
    // Issue 33: the log's companion `_cal.log` a symlink: refused, and the log itself not
    // written either (it was, before the set was checked whole).
    let log = d.join("p.log");
    std::os::unix::fs::symlink(&target, d.join("p_cal.log")).unwrap();
    refused(
        &bikeproc(&["simulate", "torsion", "--out", log.to_str().unwrap()]),
        1,
        "a symlink",
    );
    assert!(!log.exists(), "{} left behind", log.display());
    let leftovers: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
    std::fs::remove_dir_all(&d).ok();
}

/// Standard output closed early (`… | head -1`) or full (`> /dev/full`): a message, exit 1.
#[cfg(target_os = "linux")]
#[test]
fn a_closed_or_full_stdout_is_an_error_not_a_panic() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_bikeproc"))
        .args(["stability", "--json", "--bike", BENCHMARK])
        .current_dir(root())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    refused(&out, 1, "broken pipe");
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_bikeproc"))
        .args(["stability", "--json", "--bike", BENCHMARK])
        .current_dir(root())
        .stdout(full)
        .output()
        .unwrap();
    refused(&out, 1, "No space left on device");
}

/// Issue 33: a full standard error never panics (`eprintln!` did, exit 101): the error of a bad
/// file keeps its exit 2; a command whose warnings could not be written ends with 1; `--help`
/// into a full standard output ends with 1, not 0.
#[cfg(target_os = "linux")]
#[test]
fn a_full_stderr_or_help_into_a_full_stdout_is_no_panic() {
    let full = || {
        std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap()
    };
    let run = |args: &[&str], stdout_full: bool| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_bikeproc"));
        c.args(args).current_dir(root()).stderr(full());
        if stdout_full {
            c.stdout(full());
        } else {
            c.stdout(Stdio::null());
        }
        c.output().unwrap().status.code()
    };
    assert_eq!(run(&["period", "fixtures/bad/empty.log"], false), Some(2));
    // frame_torsion_1a.log warns of its gaps and corrupt rows.
    assert_eq!(
        run(
            &["period", "data/frame_torsion/frame_torsion_1a.log"],
            false
        ),
        Some(1)
    );
    assert_eq!(run(&["--help"], true), Some(1));
    assert_eq!(run(&["--version"], true), Some(1));
    assert_eq!(run(&["no-such-command"], false), Some(2));
}

/// Issue 33: `--version` and `period …` into a closed standard output (`>&-`) ended with 0, the
/// output silently lost (Rust's standard library ignores EBADF there): now a message and 1.
#[cfg(target_os = "linux")]
#[test]
fn a_closed_stdout_is_said_and_ends_with_1() {
    for args in [
        vec!["--version"],
        vec!["period", "data/frame_torsion/frame_torsion_1a.log"],
    ] {
        let out = Command::new("sh")
            .arg("-c")
            .arg("exec \"$0\" \"$@\" >&-")
            .arg(env!("CARGO_BIN_EXE_bikeproc"))
            .args(&args)
            .current_dir(root())
            .output()
            .unwrap();
        refused(&out, 1, "standard output goes nowhere");
    }
}

/// A ride log of 1 s, a `_cal` file of another ride or of half the ride, and one sensor's data
/// written for both: each refused with its real cause, not a misleading one ("the frame sensor
/// did not move", "too short … caught").
#[test]
fn a_rides_pair_that_is_not_one_recording_is_named_so() {
    let d = scratch("pairs");
    let angles = std::fs::read_to_string(root().join("data/ride_03.log")).unwrap();
    let cal = std::fs::read_to_string(root().join("data/ride_03_cal.log")).unwrap();
    let other_cal = std::fs::read_to_string(root().join("data/ride_05_cal.log")).unwrap();
    let head = |t: &str, n: usize| t.lines().take(n).collect::<Vec<_>>().join("\n") + "\n";
    let n_cal = cal.lines().count();
    let mut same = String::new();
    for l in angles.lines() {
        let mut f: Vec<&str> = l.split('\t').collect();
        if f.len() == 8 && f[0].starts_with(|c: char| c.is_ascii_digit()) {
            let frame: Vec<&str> = f[2..5].to_vec();
            f.splice(5..8, frame);
        }
        same += &(f.join("\t") + "\n");
    }
    for (name, a, c, says) in [
        (
            "short",
            head(&angles, 110),
            head(&cal, 110),
            // 110 lines: about 1 s, its hundredths as the packets dropped at its start leave.
            "the log holds 1.0",
        ),
        ("mixed", angles.clone(), other_cal, "not the same recording"),
        (
            "half",
            angles.clone(),
            head(&cal, n_cal / 2),
            "not the same recording",
        ),
        ("same", same, cal.clone(), "give the same orientations"),
    ] {
        std::fs::write(d.join(format!("{name}.log")), a).unwrap();
        std::fs::write(d.join(format!("{name}_cal.log")), c).unwrap();
        let log = d.join(format!("{name}.log"));
        refused(
            &bikeproc(&[
                "dynamic",
                log.to_str().unwrap(),
                "--speed",
                "4",
                "--bike",
                "data/lab_bike.toml",
            ]),
            2,
            says,
        );
    }
    std::fs::remove_dir_all(&d).ok();
}

/// Issue 33: an endless or binary input is refused at its first 64 KiB: `/dev/zero` linked as a
/// log (it read 4.2 GB before running out of memory) and 8 MiB of NUL bytes as a CSV (a line of
/// that size in the error), each in one short line with exit 2.
#[cfg(target_os = "linux")]
#[test]
fn endless_or_binary_inputs_are_refused_at_their_head() {
    let d = scratch("binary");
    let zero = d.join("zero.log");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    let nul = d.join("nul.csv");
    std::fs::write(&nul, vec![0u8; 8 << 20]).unwrap();
    for (args, want) in [
        (
            vec!["period", zero.to_str().unwrap()],
            "zero.log:1: cannot read: binary data",
        ),
        (
            vec!["period", nul.to_str().unwrap()],
            "nul.csv:1: cannot read: binary data",
        ),
        (vec!["dynamic", nul.to_str().unwrap()], "binary data"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_bikeproc"))
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(want) && err.len() < 300, "{args:?}: {err}");
    }
    std::fs::remove_dir_all(&d).ok();
}
