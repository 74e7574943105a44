//! Issue 76, item 5: campaign manifests as another lab writes them. A CSV ride whose file has a
//! wheel-speed column needs no noted speed; a treadmill's set speed (`set_speed_mps`) is told
//! apart from a speedometer's reading and from the wheel's, and shown beside the wheel's with
//! their disagreement; a ride without any speed is refused at the manifest's line. (A
//! controller from a file: tests/study.rs.)

use common::{root, run, run_json};
use std::path::{Path, PathBuf};

mod common;

/// A scratch folder holding the lab bicycle, a CSV ride `w.csv` (time, roll, steer and the rear
/// wheel's speed, 4.2 m/s) and the same ride without its wheel column, `nw.csv`; the weave is σ
/// −0.5 1/s, ω 5 rad/s.
fn scratch(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("bikeproc_manifests_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::copy(root().join("data/lab_bike.toml"), dir.join("lab_bike.toml")).unwrap();
    common::weave_csv(&dir.join("w.csv"), Some(4.2));
    common::weave_csv(&dir.join("nw.csv"), None);
    dir
}

/// A manifest in `dir` of one ride: `ride` holds its `[[ride]]` keys.
fn manifest(dir: &Path, ride: &str) -> PathBuf {
    let path = dir.join("rides.toml");
    std::fs::write(
        &path,
        format!("version = 1\nbike = \"lab_bike.toml\"\n\n[[ride]]\n{ride}"),
    )
    .unwrap();
    path
}

/// The one ride of `bikeproc dynamic MANIFEST --json`.
fn ride(path: &Path) -> serde_json::Value {
    let out = run_json(["dynamic", path.to_str().unwrap(), "--json"]);
    out["rides"][0].clone()
}

/// The manifest's defaults for a reading: a display step of 0.1 m/s (uniform within ± half of
/// it) and 1 % of the reading, the set speed's standard error at `v` m/s.
fn reading_se(v: f64) -> f64 {
    (0.1f64.powi(2) / 12.0 + (0.01 * v).powi(2)).sqrt()
}

#[test]
fn a_wheel_speed_column_needs_no_noted_speed() {
    let dir = scratch("wheel");
    let r = ride(&manifest(&dir, "log = \"w.csv\"\n"));
    assert_eq!(r["speed_source"], "wheel_speed");
    let v = r["speed_mps"]["value"].as_f64().unwrap();
    assert!((v - 4.2).abs() < 1e-9, "speed {v}");
    assert!(r.get("given_beside").is_none(), "{r}");
    // The weave is the file's: the speed's source does not touch the fit.
    let w = &r["weave"];
    assert!((w["re"].as_f64().unwrap() + 0.5).abs() < 1e-6, "{w}");
    assert!((w["im"].as_f64().unwrap() - 5.0).abs() < 1e-6, "{w}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_set_speed_is_shown_beside_the_wheels_with_their_disagreement() {
    let dir = scratch("beside");
    let r = ride(&manifest(&dir, "log = \"w.csv\"\nset_speed_mps = 4.0\n"));
    // The wheel's speed is used; the set speed is beside it, 0.2 m/s off.
    assert_eq!(r["speed_source"], "wheel_speed");
    let b = &r["given_beside"];
    assert_eq!(b["source"], "set");
    let se_set = b["speed_mps"]["se"].as_f64().unwrap();
    assert!((se_set - reading_se(4.0)).abs() < 1e-12, "{b}");
    let d = b["wheel_less_given_mps"].as_f64().unwrap();
    assert!((d - 0.2).abs() < 1e-9, "{b}");
    let se_wheel = r["speed_mps"]["se"].as_f64().unwrap();
    let z = b["z"].as_f64().unwrap();
    assert!((z - d / se_wheel.hypot(se_set)).abs() < 1e-9, "{b}");
    // The text says both.
    let out = run(["dynamic", dir.join("rides.toml").to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("not used: the set speed 4.000 ± 0.049 m/s: the wheel reads +0.200 m/s"),
        "{text}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_set_speed_is_the_speed_of_a_ride_without_a_wheel_column() {
    let dir = scratch("set");
    let r = ride(&manifest(&dir, "log = \"nw.csv\"\nset_speed_mps = 4.0\n"));
    assert_eq!(r["speed_source"], "set");
    assert_eq!(r["speed_mps"]["value"].as_f64(), Some(4.0));
    let se = r["speed_mps"]["se"].as_f64().unwrap();
    assert!((se - reading_se(4.0)).abs() < 1e-12, "{se}");
    // A noted reading is the other kind of the same number.
    let r = ride(&manifest(&dir, "log = \"nw.csv\"\nnoted_speed_mps = 4.0\n"));
    assert_eq!(r["speed_source"], "noted");
    std::fs::remove_dir_all(&dir).ok();
}

/// `bikeproc dynamic` on a manifest of `ride`: exit 2, its message naming the manifest, the line
/// of the ride's log, and holding `says`.
fn refused_at(dir: &Path, ride: &str, line: usize, says: &str) {
    let path = manifest(dir, ride);
    let out = run(["dynamic", path.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{ride}: {err}");
    assert!(
        err.contains(&format!("rides.toml:{line}")),
        "{ride}: the file and line in: {err}"
    );
    assert!(err.contains(says), "{ride}: `{says}` in: {err}");
}

#[test]
fn a_ride_without_a_speed_or_with_two_is_refused_at_its_line() {
    let dir = scratch("refused");
    refused_at(
        &dir,
        "log = \"nw.csv\"\n",
        5,
        "no speed: the file has no wheel-speed column",
    );
    refused_at(
        &dir,
        "log = \"w.csv\"\nnoted_speed_mps = 4.0\nset_speed_mps = 4.0\n",
        5,
        "give one",
    );
    refused_at(
        &dir,
        "log = \"nw.csv\"\nset_speed_mps = 90.0\n",
        5,
        "set_speed_mps",
    );
    // An IMU log's ride is a coasting ride released at a noted reading.
    for f in ["ride_03.log", "ride_03_cal.log"] {
        std::fs::copy(root().join("data").join(f), dir.join(f)).unwrap();
    }
    refused_at(&dir, "log = \"ride_03.log\"\n", 5, "no noted_speed_mps");
    refused_at(
        &dir,
        "log = \"ride_03.log\"\nset_speed_mps = 4.0\n",
        5,
        "are for CSV rides",
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 76, item 4: a kick without a resolved weave never enters the diagnosis. A roll-rate
/// record of a decay without oscillation (0.3 e^{−6t} rad/s in 0.02 rad/s of seeded noise,
/// 1.5 s) fits a weave whose ω's standard error exceeds ω (measured: ω 0.02–0.07 ± 130–900
/// rad/s over eight seeds); `bikeproc gap` lists it among the rides not analysed, with that
/// reason, and uses the other ride alone.
#[test]
fn a_decay_that_resolves_no_weave_never_enters_the_diagnosis() {
    use bikeproc::sim::draw::{seeded, Draw};
    let dir = scratch("unresolved");
    let mut rng = seeded(1);
    let mut text = String::from("time_s,roll_rate_rad_per_s,rear_wheel_speed_m_per_s\n");
    for i in 0..150 {
        let t = i as f64 / 100.0;
        text += &format!("{t},{},4.0\n", 0.3 * (-6.0 * t).exp() + 0.02 * rng.normal());
    }
    std::fs::write(dir.join("rr.csv"), text).unwrap();
    let path = dir.join("rides.toml");
    std::fs::write(
        &path,
        "version = 1\nbike = \"lab_bike.toml\"\n\n[[ride]]\nlog = \"w.csv\"\n\n[[ride]]\nlog = \"rr.csv\"\n",
    )
    .unwrap();
    let d = run_json(["gap", path.to_str().unwrap(), "--json"]);
    assert_eq!(d["rides_used"], 1, "{d}");
    let failed = d["rides_failed"].as_array().unwrap();
    assert_eq!(failed.len(), 1, "{d}");
    assert!(
        failed[0]
            .as_str()
            .unwrap()
            .starts_with("rr: no weave resolved"),
        "{failed:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
