//! Issue 34, item 4: `bikeproc compare` against `bikeproc stability` of each bicycle.

use std::path::PathBuf;
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn json(args: &[&str]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_bikeproc"))
        .args(args)
        .arg("--json")
        .current_dir(root())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// Each bicycle's speeds and errors are `stability`'s, the differences are against the first
/// with the errors combined in quadrature, and the figure holds both panels.
#[test]
fn compare_puts_stabilitys_speeds_side_by_side() {
    let bikes = [
        "../shared/reference/bicycleparameters/BenchmarkBenchmark.txt",
        "data/lab_bike.toml",
        "../shared/reference/bicycleparameters/RigidBenchmark.txt",
    ];
    let svg = std::env::temp_dir().join(format!("bikeproc_compare_{}.svg", std::process::id()));
    let mut args = vec!["compare"];
    args.extend(bikes);
    args.extend(["--svg", svg.to_str().unwrap()]);
    let c = json(&args);
    let rows = c["bikes"].as_array().unwrap();
    assert_eq!(rows.len(), 3);
    let first = json(&["stability", "--bike", bikes[0], "--speeds", "0:10:1"]);
    for (bike, row) in bikes.iter().zip(rows) {
        let s = json(&["stability", "--bike", bike, "--speeds", "0:10:1"]);
        for what in ["weave", "capsize"] {
            let v = row[format!("{what}_speed_mps")]["value"].as_f64().unwrap();
            let se = row[format!("{what}_speed_mps")]["se"].as_f64().unwrap();
            assert_eq!(v, s[format!("{what}_speed_mps")].as_f64().unwrap());
            assert_eq!(se, s[format!("{what}_speed_se_mps")].as_f64().unwrap());
            let d = &row[format!("{what}_speed_difference_mps")];
            if *bike == bikes[0] {
                assert!(d.is_null());
                continue;
            }
            let (v0, se0) = (
                first[format!("{what}_speed_mps")].as_f64().unwrap(),
                first[format!("{what}_speed_se_mps")].as_f64().unwrap(),
            );
            assert!((d["value"].as_f64().unwrap() - (v - v0)).abs() < 1e-12);
            assert!((d["se"].as_f64().unwrap() - se.hypot(se0)).abs() < 1e-12);
        }
    }
    let text = std::fs::read_to_string(&svg).unwrap();
    std::fs::remove_file(&svg).ok();
    assert!(text.starts_with("<svg") && text.contains("detail: real parts near zero"));
    assert!(text.contains("lab_bike") && text.contains("RigidBenchmark"));
}
