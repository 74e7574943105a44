//! What the integration tests share: running the built `bikeproc` from the checkout's root,
//! and small simulated torsion-pendulum logs in every output mode and locale.

// Each test file uses its own part of this module.
#![allow(dead_code)]

use bikeproc::read::log::OutputMode;
use bikeproc::sim::draw::{seeded, Draw};
use bikeproc::sim::imu::{FileSpec, LinkModel, Locale, Precision, SensorModel};
use bikeproc::sim::pendulum::{Pendulum, Placement, Release, Torsion};
use std::ffi::OsStr;
use std::path::PathBuf;
use std::process::{Command, Output};

/// The checkout's root (where `data/`, `fixtures/` and `reports/` are).
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `bikeproc ARGS`, run from the checkout's root.
pub fn run<I, S>(args: I) -> Output
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    Command::new(env!("CARGO_BIN_EXE_bikeproc"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("the built bikeproc runs")
}

/// `bikeproc ARGS` (ARGS asking for `--json`): its JSON, after checking that it succeeded.
pub fn run_json<I, S>(args: I) -> serde_json::Value
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let out = run(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

/// A scratch copy of `data/`'s `folders` under a per-process folder named `name` (the copy's
/// path): a test edits its files, `data/` stays as checked in.
pub fn data_copy(name: &str, folders: &[&str]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bikeproc_{name}_{}", std::process::id()));
    for sub in folders {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
        for e in std::fs::read_dir(root().join("data").join(sub))
            .unwrap()
            .flatten()
        {
            std::fs::copy(e.path(), dir.join(sub).join(e.file_name())).unwrap();
        }
    }
    dir
}

/// `text` (lines of `key = value`) with the first line that sets `key` setting it to `value`;
/// panics when no line does.
pub fn with_key(text: &str, key: &str, value: &str) -> String {
    let mut done = false;
    let out = text
        .lines()
        .map(|l| {
            if !done && l.split('=').next().is_some_and(|k| k.trim() == key) {
                done = true;
                format!("{key} = {value}\n")
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    assert!(done, "no line sets `{key}`");
    out
}

/// One simulated recording: its orientation log and its calibrated (`_cal`) log.
pub struct TorsionLogs {
    /// "Euler, Tab", …
    pub name: String,
    pub angles_log: String,
    pub cal_log: String,
}

/// A 1 kg·m², 20 N·m/rad torsion pendulum (1% damping) released from 10°, recorded for 5 s
/// in every output mode and both locales (six recordings), each with its own sensor
/// placement and sensor errors (the Spanish quaternion log declares its decimal comma). With `receiver_jitter` false the receiver stamps exactly
/// on the sensor's clock (packets are still dropped as the link drops them).
pub fn torsion_logs(receiver_jitter: bool) -> Vec<TorsionLogs> {
    let pend = Pendulum::Torsion(Torsion {
        inertia_kgm2: 1.0,
        stiffness_nm_per_rad: 20.0,
        damping_ratio: 0.01,
        coulomb_nm: 0.0,
        swing: None,
    });
    let release = Release {
        rest_s: 0.5,
        ramp_s: 0.3,
        hold_s: 0.2,
        amplitude_deg: 10.0,
        duration_s: 5.0,
    };
    let mut out = Vec::new();
    let modes = [
        OutputMode::Euler,
        OutputMode::Quaternion,
        OutputMode::Matrix,
    ];
    for (k, mode) in modes.into_iter().enumerate() {
        for locale in [Locale::Tab, Locale::Spanish] {
            let mut rng = seeded(10 + k as u64);
            let placement = Placement {
                body_rest: rng.rotation(),
                axis_heading_rad: 0.0,
                sensor_offset_m: nalgebra::Vector3::new(0.2, 0.0, 0.0),
            };
            let mut spec = FileSpec::single_sensor(
                mode,
                locale,
                Precision::Sensor,
                ("00300417", "frame"),
                65_300,
            );
            // One Spanish recording declares its decimal comma, the others leave it implied.
            spec.declare_decimal = k == 1;
            if !receiver_jitter {
                spec.jitter_s = 0.0;
                spec.late_bursts_per_minute = 0.0;
            }
            let rec = bikeproc::sim::simulate_pendulum(
                &pend,
                &release,
                &placement,
                &SensorModel::typical(&mut rng),
                &LinkModel::default(),
                &spec,
                k as u64,
            );
            out.push(TorsionLogs {
                name: format!("{mode:?}, {locale:?}"),
                angles_log: rec.angles_log,
                cal_log: rec.cal_log,
            });
        }
    }
    out
}

/// A short CSV ride at `path`: 4 s at 100 Hz of a weave (σ −0.5 1/s, ω 5 rad/s) in roll and
/// steer (`time_s`, `roll_rad`, `steer_rad`), and the rear wheel's speed where `wheel_mps` is
/// given (`rear_wheel_speed_m_per_s`, constant).
pub fn weave_csv(path: &std::path::Path, wheel_mps: Option<f64>) {
    let mut text = String::from("time_s,roll_rad,steer_rad");
    text += if wheel_mps.is_some() {
        ",rear_wheel_speed_m_per_s\n"
    } else {
        "\n"
    };
    for i in 0..400 {
        let t = i as f64 / 100.0;
        let e = (-0.5 * t).exp();
        text += &format!(
            "{t},{},{}",
            0.05 * e * (5.0 * t).sin(),
            0.08 * e * (5.0 * t + 1.0).sin()
        );
        text += &wheel_mps.map_or("\n".to_string(), |w| format!(",{w}\n"));
    }
    std::fs::write(path, text).unwrap();
}
