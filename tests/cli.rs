//! The command line as a user meets it: `bikeproc period` on the real reference recordings,
//! its JSON, and `bikeproc simulate` giving byte-identical files for the same seed.

use bikeproc::report::{published_periods, within_reference_bar};
use common::root;
use std::path::Path;

mod common;

fn bikeproc(args: &[&str]) -> (i32, String, String) {
    let out = common::run(args);
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn period_agrees_with_the_published_periods_of_real_recordings() {
    let reference = root().join("../shared/reference");
    let readme = std::fs::read_to_string(reference.join("README.md"))
        .expect("../shared/reference/README.md");
    let published: Vec<_> = published_periods(&readme)
        .into_iter()
        .filter(|p| p.period_s.is_some())
        .collect();
    assert_eq!(
        published.len(),
        4,
        "the README lists four published periods"
    );
    for p in published {
        let file = reference.join("signals").join(&p.file);
        let (code, out, err) = bikeproc(&["period", file.to_str().unwrap(), "--json"]);
        assert_eq!(code, 0, "{}: {err}", p.file);
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        let (t, se) = (
            v["period_s"].as_f64().unwrap(),
            v["period_se_s"].as_f64().unwrap(),
        );
        let (z, ok) = within_reference_bar(t, se, p.period_s.unwrap(), p.period_se_s.unwrap());
        assert!(
            ok,
            "{}: {t} ± {se} vs published {:?} ({z:.2} σ)",
            p.file, p.period_s
        );
    }
}

#[test]
fn period_json_has_the_documented_fields() {
    let file =
        root().join("../shared/reference/signals/resonance_wheel_radial_torsional_500hz.csv");
    let (code, out, err) = bikeproc(&["period", file.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    for key in [
        "period_s",
        "period_se_s",
        "freq_hz",
        "freq_se_hz",
        "natural_freq_hz",
        "damping_ratio",
        "damping_ratio_se",
    ] {
        assert!(v[key].as_f64().is_some_and(f64::is_finite), "{key}");
    }
    assert_eq!(v["segment_s"].as_array().map(Vec::len), Some(2));
    assert!(v["secondary_peaks_hz"].is_array());
    // f = 1/T, consistently.
    let (f, t) = (
        v["freq_hz"].as_f64().unwrap(),
        v["period_s"].as_f64().unwrap(),
    );
    assert!((f * t - 1.0).abs() < 1e-12);
}

#[test]
fn simulate_is_byte_identical_for_the_same_seed_and_reads_back() {
    let dir = std::env::temp_dir().join(format!("bikeproc_cli_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut texts = Vec::new();
    for run in ["a", "b"] {
        let out = dir.join(format!("{run}.log"));
        let (code, truth, err) = bikeproc(&[
            "simulate",
            "compound",
            "--out",
            out.to_str().unwrap(),
            "--seed",
            "17",
            "--locale",
            "spanish",
            "--mode",
            "matrix",
        ]);
        assert_eq!(code, 0, "{err}");
        texts.push((
            std::fs::read(&out).unwrap(),
            std::fs::read(dir.join(format!("{run}_cal.log"))).unwrap(),
            truth,
        ));
    }
    assert!(
        texts[0] == texts[1],
        "same arguments and seed gave different files"
    );
    // And the core measures it: the compound pendulum's truth within 5 standard errors (the
    // nonlinear sin θ lengthens the period at 8°: by θ₀²/16 = 0.12 %, so compare the fit with a
    // small-amplitude truth corrected to that order).
    let truth: serde_json::Value = serde_json::from_str(&texts[0].2).unwrap();
    let (code, out, err) = bikeproc(&["period", dir.join("a.log").to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let theta0 = truth["amplitude_rad"].as_f64().unwrap();
    let f_truth = truth["damped_freq_hz"].as_f64().unwrap() / (1.0 + theta0 * theta0 / 16.0);
    let (f, se) = (
        v["freq_hz"].as_f64().unwrap(),
        v["freq_se_hz"].as_f64().unwrap(),
    );
    assert!(
        (f - f_truth).abs() / f_truth < 5e-4,
        "{f} ± {se} vs {f_truth}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_cardan_swing_shows_as_a_secondary_peak() {
    use bikeproc::read::log::{Log, OutputMode, ReadOptions};
    use bikeproc::sim::imu::{FileSpec, LinkModel, Locale, Precision, SensorModel};
    use bikeproc::sim::pendulum::{Pendulum, Placement, Release, Swing, Torsion};
    let pend = Pendulum::Torsion(Torsion {
        inertia_kgm2: 1.3579 / 1.0,
        stiffness_nm_per_rad: 34.33,
        damping_ratio: 0.004,
        coulomb_nm: 0.01,
        swing: Some(Swing {
            freq_hz: 1.4,
            damping_ratio: 0.02,
            coupling: 0.05,
            release_amplitude_deg: 2.0,
        }),
    });
    let release = Release {
        rest_s: 3.0,
        ramp_s: 1.0,
        hold_s: 1.0,
        amplitude_deg: 8.0,
        duration_s: 60.0,
    };
    let mut rng = bikeproc::sim::draw::seeded(5);
    let mut sensor = SensorModel::typical(&mut rng);
    // The gyro's z roughly along the bar, tilted 20° towards the swing's axis (global X).
    sensor.mounting =
        nalgebra::UnitQuaternion::from_axis_angle(&nalgebra::Vector3::y_axis(), 20f64.to_radians());
    let placement = Placement {
        body_rest: nalgebra::UnitQuaternion::identity(),
        axis_heading_rad: 0.0,
        sensor_offset_m: nalgebra::Vector3::new(0.3, 0.0, 0.0),
    };
    let spec = FileSpec::single_sensor(
        OutputMode::Euler,
        Locale::Tab,
        Precision::Sensor,
        ("00300417", "frame"),
        0,
    );
    let rec = bikeproc::sim::simulate_pendulum(
        &pend,
        &release,
        &placement,
        &sensor,
        &LinkModel::default(),
        &spec,
        5,
    );
    let cal = Log::parse(
        rec.cal_log.as_bytes(),
        Path::new("cal.log"),
        &ReadOptions::default(),
    )
    .unwrap();
    let sig = bikeproc::signal::channel(&cal, "Gyr_Z", None).unwrap();
    let osc = bikeproc::fit::analyse(&sig, &Default::default()).unwrap();
    let truth = pend.truth(&release);
    assert!((osc.fit.freq_hz().value / truth.damped_freq_hz - 1.0).abs() < 1e-3);
    assert!(
        osc.secondary_peaks
            .iter()
            .any(|p| (p.freq_hz / 1.4 - 1.0).abs() < 0.02),
        "{:?}",
        osc.secondary_peaks
    );
}

/// Issue 16: every subcommand's help shows an example of it, and the exit codes; `--version`
/// names the build.
#[test]
fn every_subcommand_help_has_an_example_and_the_exit_codes() {
    let commands: Vec<Vec<&str>> = vec![
        vec!["period"],
        vec!["calibrate-bar"],
        vec!["inertia"],
        vec!["measured"],
        vec!["stability"],
        vec!["dynamic"],
        vec!["gap"],
        vec!["simulate"],
        vec!["simulate", "torsion"],
        vec!["simulate", "compound"],
        vec!["simulate", "ride"],
        vec!["simulate", "rides"],
        vec!["simulate", "ride-faults"],
        vec!["simulate", "blind"],
        vec!["simulate", "campaign"],
        vec!["report"],
    ];
    for c in commands {
        let mut args = c.clone();
        args.push("--help");
        let (code, out, err) = bikeproc(&args);
        assert_eq!(code, 0, "{c:?}: {err}");
        let example = out
            .split_once("Example")
            .map(|(_, rest)| rest)
            .unwrap_or_else(|| panic!("{c:?}: no example in\n{out}"));
        assert!(
            example.contains(&format!("bikeproc {}", c.join(" "))),
            "{c:?}: the example does not run it:\n{example}"
        );
        if c.len() == 1 {
            assert!(out.contains("Exit codes: 0"), "{c:?}: no exit codes");
        }
        if out.contains("--json") {
            assert!(
                out.contains("JSON (--json): {"),
                "{c:?}: --json without its shape"
            );
        }
    }
    let (code, out, _) = bikeproc(&["--version"]);
    assert_eq!(code, 0);
    assert!(
        out.starts_with("bikeproc ") && out.contains("commit"),
        "{out}"
    );
}

/// Issue 31 item 2: a noted speed the log's own measure contradicts (14, ride_03's 3.9 m/s
/// noted in km/h; 9, another ride's) is refused with exit 2 and a hint; the right reading is
/// taken. The kinematic speed's error is a tenth of the speed, so 10 combined errors is a
/// reading about twice the speed.
#[test]
fn a_noted_speed_the_log_contradicts_is_refused_with_a_hint() {
    let ride = root().join("data/ride_03.log");
    let ride = ride.to_str().unwrap();
    let (code, _, err) = bikeproc(&["dynamic", ride, "--speed", "14"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("ride_03.log") && err.contains("km/h? 14 km/h is 3.89 m/s"),
        "{err}"
    );
    let (code, _, err) = bikeproc(&["dynamic", ride, "--speed", "9"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("this ride's reading"), "{err}");
    let (code, out, err) = bikeproc(&["dynamic", ride, "--speed", "4.1"]);
    assert_eq!(code, 0, "{err}");
    assert!(!out.contains("DISAGREE"), "{out}");
    // What the reader kept as gaps is said, as `period` says it: ride_03's one corrupt row
    // (line 1058, written so by the generator) and its six dropped packets.
    assert!(
        err.contains("ride_03.log:1058: 1 corrupt rows") && err.contains("6 missing samples"),
        "{err}"
    );
}

/// Issue 31: a CSV written without its header row is read from its first row: the same
/// period as with the header, every sample kept (1,001), the value column named by position.
#[test]
fn a_csv_without_its_header_row_loses_no_sample() {
    let with =
        root().join("../shared/reference/signals/resonance_wheel_radial_torsional_500hz.csv");
    let text = std::fs::read_to_string(&with).unwrap();
    let dir = std::env::temp_dir().join(format!("bikeproc_nohdr_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let without = dir.join("no_header.csv");
    std::fs::write(&without, text.split_once('\n').unwrap().1).unwrap();
    let json = |p: &Path| {
        let (code, out, err) = bikeproc(&["period", p.to_str().unwrap(), "--json"]);
        assert_eq!(code, 0, "{err}");
        serde_json::from_str::<serde_json::Value>(&out).unwrap()
    };
    let (a, b) = (json(&with), json(&without));
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(a["period_s"], b["period_s"]);
    assert_eq!(a["samples"], b["samples"]);
    let (code, out, _) = bikeproc(&["period", with.to_str().unwrap()]);
    assert_eq!(code, 0);
    assert!(out.contains("(1001 samples"), "{out}");
}

/// Issue 31 item 3: an input given to a command that does not read its kind is recognised by
/// its content and told what it is and which command reads it, with exit code 2.
#[test]
fn inputs_of_the_wrong_kind_are_named_with_the_command_that_reads_them() {
    let cases: [(&[&str], &str); 12] = [
        (&["inertia", "data/ride_03.log"], "a ride's IMU log"),
        (
            &["gap", "data/ride_03.log"],
            "use `bikeproc dynamic data/ride_03.log`",
        ),
        (
            &["stability", "--bike", "data/rides.toml"],
            "use `bikeproc gap data/rides.toml`",
        ),
        (
            &[
                "stability",
                "--bike",
                "data/lab_bike.toml",
                "--controller",
                "data/rides.toml",
            ],
            "without a [controller] table",
        ),
        (&["dynamic", "data/"], "this is a folder"),
        (
            &["dynamic", "data/frame_torsion/frame_torsion_1a.log"],
            "use `bikeproc period data/frame_torsion/frame_torsion_1a.log`",
        ),
        (
            &["dynamic", "data/ride_03_cal.log"],
            "use `bikeproc dynamic data/ride_03.log`",
        ),
        (
            &["calibrate-bar", "data/frame_torsion"],
            "use `bikeproc inertia data/frame_torsion`",
        ),
        (
            &["inertia", "data/bar_calibration"],
            "use `bikeproc calibrate-bar`",
        ),
        (&["measured", "data/lab_bike.toml"], "a lab bicycle file"),
        (
            &["period", "fixtures/bad/semicolons.csv"],
            "separated by ';'",
        ),
        (
            &["period", "fixtures/bad/decimal_commas.csv"],
            "decimal commas?",
        ),
    ];
    for (args, want) in cases {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_bikeproc"))
            .args(args)
            .current_dir(root())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(want), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
    }
    // `report` away from a checkout says where to run it.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_bikeproc"))
        .arg("report")
        .current_dir(std::env::temp_dir())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("in the checkout's top folder"), "{err}");
}

/// Issue 33: the simulator's physical arguments are checked where they are read (a NaN, a
/// negative or zero inertia, an infinite stiffness: exit 2, no file written); a speed grid
/// never reaches beyond its end.
#[test]
fn arguments_out_of_their_physical_range_are_refused() {
    let dir = std::env::temp_dir().join(format!("bikeproc_args_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("s.log");
    for bad in [
        "--inertia-kgm2=nan",
        "--inertia-kgm2=-1",
        "--inertia-kgm2=0",
        "--stiffness-nm-per-rad=inf",
        "--damping-ratio=nan",
        "--duration-s=0",
    ] {
        let (code, _, err) =
            bikeproc(&["simulate", "torsion", "--out", out.to_str().unwrap(), bad]);
        assert_eq!(code, 2, "{bad}: {err}");
        assert!(err.contains("expected a number"), "{bad}: {err}");
        assert!(!out.exists(), "{bad}: a file was written");
    }
    std::fs::remove_dir_all(&dir).ok();
    let bike = root().join("data/lab_bike.toml");
    let (code, json, err) = bikeproc(&[
        "stability",
        "--bike",
        bike.to_str().unwrap(),
        "--speeds",
        "0:10:20",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let speeds: Vec<f64> = v["eigenvalues"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["speed_mps"].as_f64().unwrap())
        .collect();
    assert_eq!(speeds, vec![0.0]);
}

/// Issue 33, weak messages: a reading of 1e-300 m/s is no riding speed (it gave "no weave at
/// −0.202 m/s"); a window from NaN says so (it gave "END must be after START").
#[test]
fn absurd_readings_and_windows_are_named_for_what_they_are() {
    let ride = root().join("data/ride_03.log");
    let ride = ride.to_str().unwrap();
    let (code, _, err) = bikeproc(&["dynamic", ride, "--speed", "1e-300"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("1e-300 m/s is not a riding speed"), "{err}");
    let (code, _, err) = bikeproc(&["dynamic", ride, "--window", "nan:150"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("START and END must be finite"), "{err}");
}

/// Issue 32 item 1: another lab's logger writes one comma-separated line per control step,
/// channel names and no time column, as `.log`. The balance-assist recording with its two
/// time columns dropped, given `--rate 100` (the rate it was sampled at: its own `time`
/// column is the row number / 100), gives the eigenvalue that the same rows with their time
/// column give, to the last printed digit; its units can be said after a colon
/// (`gyro_x:deg_per_s` is π/180 of the same column read as rad/s, so its frequency is too);
/// a campaign manifest takes the rate as `rate_hz`. Without a rate it is refused naming
/// `--rate`; a rate for a table with a time column, or an IMU log, is refused.
#[test]
fn a_table_without_a_time_column_is_read_at_its_rate() {
    let csv =
        root().join("../shared/reference/rides/balanceassist_controlled/gain6_10kmh_kick1.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let keep: Vec<usize> = (0..header.len())
        .filter(|&i| header[i] != "Time" && header[i] != "time")
        .collect();
    let time_col = header.iter().position(|h| *h == "time").unwrap();
    let pick = |fields: &[&str]| {
        keep.iter()
            .map(|&i| fields[i])
            .collect::<Vec<_>>()
            .join(",")
    };
    let mut out = pick(&header) + "\n";
    let mut off_s: f64 = 0.0;
    for (k, line) in lines.enumerate() {
        let fields: Vec<&str> = line.split(',').collect();
        let t: f64 = fields[time_col].parse().unwrap();
        off_s = off_s.max((t - k as f64 / 100.0).abs());
        out += &(pick(&fields) + "\n");
    }
    // The recording's own clock is the row number at 100 Hz within a tenth of a sample.
    assert!(off_s < 1e-3, "{off_s} s");
    let dir = std::env::temp_dir().join(format!("bikeproc_rate_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("kick.log");
    std::fs::write(&log, out).unwrap();
    let (log_s, csv_s) = (log.to_str().unwrap(), csv.to_str().unwrap());
    let weave = |args: &[&str]| -> [f64; 4] {
        let (code, out, err) = bikeproc(args);
        assert_eq!(code, 0, "{args:?}: {err}");
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        let w = &v["weave"];
        ["re", "im", "re_se", "im_se"].map(|k| w[k].as_f64().unwrap_or_else(|| panic!("{v}")))
    };
    let common = ["--speed", "2.778", "--json"];
    let with_time = weave(
        &[
            &["dynamic", csv_s, "--columns", "roll_rate=gyro_x,time=time"],
            &common[..],
        ]
        .concat(),
    );
    let at_rate = weave(
        &[
            &[
                "dynamic",
                log_s,
                "--columns",
                "roll_rate=gyro_x",
                "--rate",
                "100",
            ],
            &common[..],
        ]
        .concat(),
    );
    // The same rows on clocks a tenth of a sample apart: the same eigenvalue and errors
    // within a tenth of its standard error.
    for k in 0..4 {
        assert!(
            (with_time[k] - at_rate[k]).abs() < 0.1 * with_time[2 + k % 2],
            "{with_time:?} {at_rate:?}"
        );
    }
    let in_degrees = weave(
        &[
            &[
                "dynamic",
                log_s,
                "--columns",
                "roll_rate=gyro_x:deg_per_s",
                "--rate",
                "100",
            ],
            &common[..],
        ]
        .concat(),
    );
    assert!(
        (in_degrees[1] - at_rate[1]).abs() < 3.0 * at_rate[3],
        "{in_degrees:?} {at_rate:?}"
    );
    // Refusals, exit 2, each naming its cause.
    let (code, _, err) = bikeproc(&["dynamic", log_s, "--columns", "roll_rate=gyro_x"]);
    assert_eq!(code, 2);
    assert!(
        err.contains("no time column") && err.contains("--rate"),
        "{err}"
    );
    let (code, _, err) = bikeproc(&[
        "dynamic",
        csv_s,
        "--columns",
        "roll_rate=gyro_x,time=time",
        "--rate",
        "100",
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("it has a time column (`time`)"), "{err}");
    let ride = root().join("data/ride_03.log");
    let (code, _, err) = bikeproc(&["dynamic", ride.to_str().unwrap(), "--rate", "100"]);
    assert_ne!(code, 0);
    assert!(err.contains("--rate is for a table"), "{err}");
    let (code, _, err) = bikeproc(&[
        "dynamic",
        log_s,
        "--columns",
        "roll_rate=gyro_x:furlong",
        "--rate",
        "100",
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("not a unit of roll_rate"), "{err}");
    // A campaign of such files: the rate in the manifest.
    let bike = root().join("../shared/reference/bicycleparameters/Balanceassistv1Benchmark.txt");
    let manifest = dir.join("rides.toml");
    std::fs::write(
        &manifest,
        format!(
            "version = 1\nbike = \"{}\"\nallow_outside_folder = true\n\n[[ride]]\nlog = \"kick.log\"\ncolumns = \"roll_rate=gyro_x\"\nrate_hz = 100\nnoted_speed_mps = 2.778\n",
            bike.display()
        ),
    )
    .unwrap();
    let (code, out, err) = bikeproc(&["dynamic", manifest.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let im = v["rides"][0]["weave"]["im"]
        .as_f64()
        .unwrap_or_else(|| panic!("{v}"));
    assert!((im - at_rate[1]).abs() < 1e-9 * im, "{v}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 32 item 1, files as they come: a roll-rate gyro logged alone, one number a row under
/// its name, no time column (`--rate 100`). `dynamic` takes it for a table (it was refused as
/// "not an IMU log or a manifest"), names its column where no roll rate is known by name, and,
/// told which it is, finds its one kick: a decay x = 0.6 e^{−1.2 t}
/// sin(9 t) rad/s with 0.005 rad/s of noise, fitted to σ within 5 % and ω within 1 %.
#[test]
fn a_roll_rate_logged_alone_is_a_table() {
    use bikeproc::sim::draw::{seeded, Draw};
    let mut rng = seeded(11);
    let mut text = String::from("gyro_x\n");
    for i in 0..1500 {
        let t = i as f64 * 0.01;
        let tau = t - 6.0;
        let kick = if (0.0..6.0).contains(&tau) {
            0.6 * (-1.2 * tau).exp() * (9.0 * tau).sin()
        } else {
            0.0
        };
        text += &format!("{:.5}\n", kick + 0.005 * rng.normal());
    }
    let dir = std::env::temp_dir().join(format!("bikeproc_one_column_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("gyro.log");
    std::fs::write(&path, text).unwrap();
    // Its channel's name is none bikeproc knows: the error lists the columns and says how.
    let (code, _, err) = bikeproc(&["dynamic", path.to_str().unwrap(), "--rate", "100"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("among its columns (gyro_x)") && err.contains("--columns roll_rate=NAME"),
        "{err}"
    );
    let (code, out, err) = bikeproc(&[
        "dynamic",
        path.to_str().unwrap(),
        "--rate",
        "100",
        "--columns",
        "roll_rate=gyro_x",
        "--json",
    ]);
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(code, 0, "{err}");
    let json: serde_json::Value = serde_json::from_str(&out).unwrap();
    let kicks = json["kicks"].as_array().unwrap();
    assert_eq!(kicks.len(), 1, "{out}");
    let weave = &kicks[0]["weave"];
    let (re, im) = (weave["re"].as_f64().unwrap(), weave["im"].as_f64().unwrap());
    println!("σ {re}, ω {im}");
    assert!((re + 1.2).abs() < 0.06, "σ {re}");
    assert!((im - 9.0).abs() < 0.09, "ω {im}");
}

/// Issue 78: formats are recognised by content, so a file's name no longer decides; a campaign
/// manifest with a misspelt table (`[[rides]]`) is not recognised as one, yet is TOML, and goes
/// to the manifest's reader, which names the key and its line (not to the log reader), whatever
/// the file is called.
#[test]
fn a_misspelt_manifest_meets_the_manifests_reader_under_any_name() {
    let dir = std::env::temp_dir().join(format!("bikeproc_misspelt_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let text =
        "version = 1\nbike = \"b.toml\"\n\n[[rides]]\nlog = \"x.log\"\nnoted_speed_mps = 4.0\n";
    for name in ["rides.toml", "campaign.txt"] {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let (code, _, err) = bikeproc(&["dynamic", path.to_str().unwrap()]);
        assert_eq!(code, 2, "{name}: {err}");
        assert!(
            err.contains(&format!("{name}:4: unknown key `rides`")),
            "{name}: {err}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `simulate check-calibration` names a record the code no longer gives (exit 1), and refuses
/// a file that is not a calibration's results (exit 2). The record tampered with is one the
/// check replays: the sync design's first effect-free campaign, its best fit moved by 1e-6.
#[test]
fn a_calibration_record_the_code_no_longer_gives_is_named() {
    let dir = std::env::temp_dir().join(format!("bikeproc_check_cal_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let text = std::fs::read_to_string(root().join("docs/gap-calibration.json")).unwrap();
    let mut records: serde_json::Value = serde_json::from_str(&text).unwrap();
    let entry = records
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .find(|e| e["effect"] == "none" && e["design"] == "sync")
        .unwrap();
    let before = entry["best_params"][0].as_f64().unwrap();
    entry["best_params"][0] = serde_json::json!(before + 1e-6);
    let json = dir.join("gap-calibration.json");
    std::fs::write(&json, serde_json::to_string_pretty(&records).unwrap()).unwrap();
    std::fs::copy(
        root().join("docs/gap-calibration.md"),
        dir.join("gap-calibration.md"),
    )
    .unwrap();
    let bike = root().join("data/lab_bike.toml");
    let args = |file: &Path| {
        [
            "simulate",
            "check-calibration",
            file.to_str().unwrap(),
            "--bike",
            bike.to_str().unwrap(),
        ]
        .map(str::to_string)
    };
    let a = args(&json);
    let (code, _, err) = bikeproc(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("none sync seed 1001: .best_params[0]: recorded"),
        "{err}"
    );
    let bad = dir.join("bad.json");
    std::fs::write(&bad, "[{\"effect\": \"none\",").unwrap();
    let a = args(&bad);
    let (code, _, err) = bikeproc(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("bad.json:1:"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
