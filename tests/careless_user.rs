//! Issue 77's audit replayed: every command a careless user typed that destroyed a file,
//! panicked, answered another question or said too little, each with its exit code and
//! message. Nothing here may exit 0 where it is refused, or 101 (a panic) at all; `data/` and
//! `reports/` are byte-identical after the replay (every case works on scratch copies).

use common::root;
use std::path::{Path, PathBuf};

mod common;

/// Exit code, standard output and standard error of `bikeproc ARGS`.
fn bikeproc(args: &[&str]) -> (i32, String, String) {
    let out = common::run(args);
    let code = out.status.code().unwrap_or(-1);
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    );
    assert_ne!(code, 101, "{args:?} panicked: {stderr}");
    (code, stdout, stderr)
}

/// `bikeproc ARGS` refused: exit code 2 and a message holding `says`, said once, with no number
/// written as hundreds of digits.
fn refused(args: &[&str], says: &str) -> String {
    let (code, _, err) = bikeproc(args);
    assert_eq!(code, 2, "{args:?}: {err}");
    assert!(err.contains(says), "{args:?}: expected `{says}` in: {err}");
    assert_eq!(err.matches(says).count(), 1, "{args:?} said twice: {err}");
    assert!(longest_digits(&err) < 25, "{args:?}: {err}");
    err
}

fn longest_digits(text: &str) -> usize {
    text.split(|c: char| !c.is_ascii_digit())
        .map(str::len)
        .max()
        .unwrap_or(0)
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bikeproc_careless_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Every file under `dir` with its bytes, in path order.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((p.clone(), std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

const REFERENCE_BIKES: &str = "../shared/reference/bicycleparameters";
/// `design` of the lab bicycle over 3.5–5 m/s, the variables and options to follow.
const DESIGN_LAB: [&str; 5] = [
    "design",
    "--bike",
    "data/lab_bike.toml",
    "--stable",
    "3.5:5",
];
const CSV_RIDE: &str = "../shared/reference/rides/balanceassist_uncontrolled_18kmh.csv";

/// The whole replay, one case after another, and then `data/` and `reports/` as they were.
#[test]
fn the_audits_cases_are_refused_or_answered() {
    let data_before = snapshot(&root().join("data"));
    let reports_before = snapshot(&root().join("reports"));
    data_loss();
    panics();
    silently_wrong();
    ignored_flags();
    messages();
    assert!(
        data_before == snapshot(&root().join("data")),
        "data/ changed"
    );
    assert!(
        reports_before == snapshot(&root().join("reports")),
        "reports/ changed"
    );
}

/// An output that is an input is refused before any work; a written bicycle file reads back.
fn data_loss() {
    let dir = scratch("loss");
    let bike = dir.join("X.toml");
    std::fs::copy(root().join("data/lab_bike.toml"), &bike).unwrap();
    let before = std::fs::read(&bike).unwrap();
    // `design` of the trail over 3.5–5 m/s, written to `out`.
    let design = |out: &str| -> Vec<String> {
        let args = [
            "design",
            "--bike",
            s(&bike),
            "--stable",
            "3.5:5",
            "--vary",
            "trail",
        ];
        let mut args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
        args.extend(["--out".to_string(), out.to_string()]);
        args
    };
    for out in [s(&bike).to_string(), format!("{}/./X.toml", s(&dir))] {
        let args = design(&out);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        refused(&args, "refused as the output");
    }
    assert_eq!(
        std::fs::read(&bike).unwrap(),
        before,
        "the lab bicycle file changed"
    );

    let raw = dir.join("RigidMeasured.txt");
    std::fs::copy(root().join(REFERENCE_BIKES).join("RigidMeasured.txt"), &raw).unwrap();
    let raw_before = std::fs::read(&raw).unwrap();
    refused(
        &["measured", s(&raw), "--out", s(&raw)],
        "refused as the output",
    );
    assert_eq!(std::fs::read(&raw).unwrap(), raw_before);
    // A name read back as raw measurements is refused; a `.toml` is written as TOML.
    refused(
        &[
            "measured",
            s(&raw),
            "--out",
            s(&dir.join("OtherMeasured.txt")),
        ],
        "read as a bicycle's raw measurements",
    );

    // Written in the format its name says, and read back by `stability` whatever the name.
    for name in ["Y.toml", "YBenchmark.txt", "y.params"] {
        let out = dir.join(name);
        let mut args = design(s(&out));
        args.push("--json".into());
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (code, json, err) = bikeproc(&args);
        assert_eq!(code, 0, "{name}: {err}");
        let d: serde_json::Value = serde_json::from_str(&json).unwrap();
        let (code, back, err) = bikeproc(&["stability", "--bike", s(&out), "--json"]);
        assert_eq!(code, 0, "{name} read back: {err}");
        let back: serde_json::Value = serde_json::from_str(&back).unwrap();
        // The design's own weave speed, found again from the file (to the search's 1e-6 m/s
        // margin and the text's 17 digits).
        let designed = d["after_weave_speed_mps"].as_f64().unwrap();
        let read = back["weave_speed_mps"].as_f64().unwrap();
        assert!(
            (designed - read).abs() < 1e-6,
            "{name}: {designed} vs {read}"
        );
    }
    let toml = dir.join("b.toml");
    let (code, _, err) = bikeproc(&["measured", s(&raw), "--out", s(&toml)]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(bikeproc(&["stability", "--bike", s(&toml)]).0, 0);

    // A report folder replaced whole is never a folder the reports are made from.
    let lab = dir.join("lab");
    std::fs::create_dir_all(&lab).unwrap();
    std::fs::copy(root().join("data/rides.toml"), lab.join("rides.toml")).unwrap();
    for out in [s(&lab).to_string(), s(&dir).to_string()] {
        refused(
            &["report", "--data", s(&lab), "--out", &out],
            "refused as the output",
        );
    }
    assert!(lab.join("rides.toml").is_file());
    // A file as the folder: refused at once, not after the reports are made.
    let file = dir.join("F");
    std::fs::write(&file, "").unwrap();
    let (code, _, err) = bikeproc(&["report", "--out", s(&file)]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("not a regular file (not a folder)"), "{err}");
}

fn panics() {
    refused(
        &[
            "stability",
            "--bike",
            "data/lab_bike.toml",
            "--speeds",
            "0:1e308:1e307",
        ],
        "--speeds",
    );
    // A bicycle file without standard errors: the gap runs, and says the model is taken as exact.
    for bike in [
        format!("{REFERENCE_BIKES}/BenchmarkBenchmark.txt"),
        "data/lab_bike_seed.toml".to_string(),
    ] {
        let (code, out, err) = bikeproc(&["gap", "data/rides.toml", "--bike", &bike]);
        assert_eq!(code, 0, "{bike}: {err}");
        assert!(out.contains("Test:"), "{bike}: {out}");
        if bike.ends_with("BenchmarkBenchmark.txt") {
            assert!(
                err.contains("no standard errors in the bicycle file"),
                "{err}"
            );
        }
    }
}

fn silently_wrong() {
    // The closest design is never worse than the bicycle unchanged: here the range is reached.
    let rider = format!("{REFERENCE_BIKES}/JasonRigidBenchmark.txt");
    let (code, json, err) = bikeproc(&[
        "design",
        "--bike",
        "data/lab_bike.toml",
        "--rider",
        &rider,
        "--stable",
        "3:9",
        "--vary",
        "trail,head_angle,wheelbase",
        "--max-change",
        "0.95",
        "--json",
    ]);
    let d: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert!(code == 0 || code == 3, "{err}");
    let shortfall = |w: &serde_json::Value, c: &serde_json::Value| {
        (w.as_f64().unwrap_or(9.0) - 3.0).max(0.0).powi(2)
            + (9.0 - c.as_f64().unwrap_or(0.0)).max(0.0).powi(2)
    };
    let before = shortfall(&d["before_weave_speed_mps"], &d["before_capsize_speed_mps"]);
    let after = shortfall(&d["after_weave_speed_mps"], &d["after_capsize_speed_mps"]);
    assert!(after < 0.5 * before, "shortfall {before} → {after}");

    for vary in [
        "rR,rR,w",
        "trail,trail",
        "trail,c",
        "head_angle,lam",
        "wheelbase,w",
    ] {
        refused(&[&DESIGN_LAB[..], &["--vary", vary]].concat(), "twice");
    }
    refused(
        &[
            "dynamic",
            CSV_RIDE,
            "--window",
            "141.28:142.71",
            "--columns",
            "roll=roll_rad,steer=roll_rad",
        ],
        "would be both roll and steer",
    );
    let dir = scratch("wrong");
    let backward = dir.join("backward.csv");
    common::weave_csv(&backward, Some(-0.5));
    refused(&["dynamic", s(&backward)], "not a riding speed");

    // The same rides in two manifests of one study.
    let text = std::fs::read_to_string(root().join("data/rides.toml")).unwrap();
    let data = root().join("data");
    let moved = format!("allow_outside_folder = true\n{text}")
        .replace("bike = \"", &format!("bike = \"{}/", s(&data)))
        .replace("log = \"", &format!("log = \"{}/", s(&data)));
    for name in ["A.toml", "B.toml"] {
        std::fs::write(dir.join(name), &moved).unwrap();
    }
    refused(
        &["gap", s(&dir.join("A.toml")), s(&dir.join("B.toml"))],
        "is also in the condition",
    );
}

fn ignored_flags() {
    // --speed beside a wheel-speed column: the column is used, and the output says so.
    let (code, out, err) = bikeproc(&[
        "dynamic",
        CSV_RIDE,
        "--window",
        "141.28:142.71",
        "--speed",
        "2",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("not used: the reading given 2.000 ± 0.035 m/s: the wheel reads +3.0"),
        "{out}"
    );
    refused(
        &["dynamic", "data/rides.toml", "--speed", "4"],
        "--speed is for one ride",
    );
    refused(
        &["dynamic", "data/ride_03.log", "--window", "1:5"],
        "--window is for a CSV ride",
    );
    refused(
        &[
            "dynamic",
            CSV_RIDE,
            "--columns",
            "roll=roll_rad,roll=steer_deg",
        ],
        "is given twice",
    );
    // A grid that stops short of the capsize speed says where the search ended.
    let (code, out, _) = bikeproc(&[
        "stability",
        "--bike",
        "data/lab_bike.toml",
        "--speeds",
        "4:5:10",
    ]);
    assert_eq!(code, 0);
    assert!(
        out.contains("to at least 5 m/s (the end of the search)"),
        "{out}"
    );
    assert!(out.contains("capsize speed  none up to 5 m/s"), "{out}");
    // A window past the recording's end is said as the part the recording holds.
    let dir = scratch("flags");
    let cut = dir.join("cut.csv");
    let whole = std::fs::read_to_string(root().join(CSV_RIDE)).unwrap();
    let kept: String = whole
        .lines()
        .take_while(|l| {
            l.split(',')
                .next()
                .and_then(|t| t.parse::<f64>().ok())
                .is_none_or(|t| t <= 146.0)
        })
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(&cut, kept).unwrap();
    let (code, out, err) = bikeproc(&["dynamic", s(&cut), "--window", "145.5:150"]);
    assert!(code == 0 || code == 2, "{err}");
    if code == 0 {
        assert!(out.contains(" – 146.00 s ("), "{out}");
        assert!(out.contains("of 145.5 – 150 s asked"), "{out}");
    }
}

fn messages() {
    for value in ["-0.5", "1e308", "-inf"] {
        let err = refused(
            &[&DESIGN_LAB[..], &["--vary", "trail", "--max-change", value]].concat(),
            "--max-change",
        );
        assert!(!err.contains("unexpected argument"), "{err}");
    }
    refused(
        &[
            "stability",
            "--bike",
            "data/lab_bike.toml",
            "--speeds",
            "-1:5:1",
        ],
        "--speeds",
    );
    // A study listing what is no campaign: said as what it is.
    let dir = scratch("messages");
    std::fs::copy(root().join("data/lab_bike.toml"), dir.join("bike.toml")).unwrap();
    std::fs::copy(root().join("data/ride_03.log"), dir.join("ride.log")).unwrap();
    std::fs::write(
        dir.join("inner.toml"),
        "version = 1\nconditions = [\"bike.toml\"]\n",
    )
    .unwrap();
    for (condition, what) in [
        ("inner.toml", "a study"),
        ("bike.toml", "a lab bicycle file"),
        ("ride.log", "ride"),
    ] {
        let study = dir.join(format!("study_{condition}.toml"));
        std::fs::write(
            &study,
            format!("version = 1\nconditions = [\"{condition}\"]\n"),
        )
        .unwrap();
        let err = refused(&["gap", s(&study)], "not a condition of a study");
        assert!(err.contains(what), "{condition}: {err}");
    }
    // Tabs between the fields: said, for a ride and a recording alike.
    let tabs = dir.join("tabs.csv");
    std::fs::write(&tabs, "time_s\troll_rad\tsteer_rad\n0\t0.01\t0.02\n").unwrap();
    refused(&["dynamic", s(&tabs)], "fields separated by tabs");
    refused(&["period", s(&tabs)], "fields separated by tabs");
    // A table of 10,000 columns is a table: its message is about its columns, and short.
    let wide = dir.join("wide.csv");
    let mut text = String::from("time_s,value");
    for k in 0..10_000 {
        text += &format!(",channel_{k}");
    }
    text += "\n";
    for i in 0..50 {
        text += &format!("{},{}{}\n", i as f64 / 100.0, i, ",0".repeat(10_000));
    }
    std::fs::write(&wide, text).unwrap();
    let err = refused(&["dynamic", s(&wide)], "no roll rate or roll angle");
    assert!(err.contains("and 9982 more") && err.len() < 2_000, "{err}");
    // Ranges out to 1e308 are ranges: cut to the recording, and said with their ends as given.
    let (code, out, err) = bikeproc(&["dynamic", CSV_RIDE, "--window", "141.28:1e308"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("of 141.28 – 1e308 s asked"), "{out}");
    let (code, _, err) = bikeproc(&[
        "period",
        "data/frame_torsion/frame_torsion_1a.log",
        "--segment",
        "1:1e308",
    ]);
    assert!(code == 0 || code == 2, "{err}");
    assert!(longest_digits(&err) < 25, "{err}");
    // A segment outside the recording: said once, as that.
    refused(
        &[
            "period",
            "data/frame_torsion/frame_torsion_1a.log",
            "--segment",
            "500:600",
        ],
        "lies outside the recording",
    );
}
