//! Issue 15: BicycleParameters' raw measurements (`*Measured.txt`) → benchmark parameters with
//! standard errors, against that lab's own results (the `*Benchmark.txt` beside them).

use bikeproc::inertia::measured::{MeasuredBicycle, MeasuredError, MeasuredFile};
use std::path::{Path, PathBuf};

mod common;

fn reference() -> PathBuf {
    common::root().join("../shared/reference/bicycleparameters")
}

/// A published entry: name, value, standard error, and half a unit of the last digit written of
/// each (the files of some bicycles are rounded to three or four digits).
struct Published {
    name: String,
    value: f64,
    se: f64,
    value_half_unit: f64,
    se_half_unit: f64,
}

fn published(path: &Path) -> Vec<Published> {
    let half_unit = |t: &str| {
        let t = t.trim();
        let mantissa = t.split(['e', 'E']).next().unwrap_or(t);
        let decimals = mantissa.split_once('.').map_or(0, |(_, d)| d.len()) as i32;
        let exponent: i32 = t
            .split_once(['e', 'E'])
            .map_or(0, |(_, e)| e.parse().unwrap());
        0.5 * 10f64.powi(exponent - decimals)
    };
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter_map(|l| {
            let (k, v) = l.split_once('=')?;
            let (v, s) = v.split_once("+/-").unwrap_or((v, "0"));
            Some(Published {
                name: k.trim().to_string(),
                value: v.trim().parse().ok()?,
                se: s.trim().parse().ok()?,
                value_half_unit: half_unit(v),
                se_half_unit: half_unit(s),
            })
        })
        .collect()
}

fn measured_files() -> Vec<(String, PathBuf)> {
    let mut files: Vec<(String, PathBuf)> = std::fs::read_dir(reference())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter_map(|p| {
            let name = p
                .file_name()?
                .to_str()?
                .strip_suffix("Measured.txt")?
                .to_string();
            Some((name, p))
        })
        .collect();
    files.sort();
    files
}

/// Acceptance: for every `*Measured.txt` with a `*Benchmark.txt` beside it, every published
/// parameter within 1e-6 relative and its standard error within 2 % (or, where that lab rounded
/// its file, within half a unit of the last digit it wrote).
#[test]
fn every_published_bicycle_is_reproduced_from_its_measurements() {
    let mut checked = 0;
    for (name, path) in measured_files() {
        let bench = reference().join(format!("{name}Benchmark.txt"));
        if !bench.exists() || name == "Silver" {
            continue;
        }
        let b = MeasuredBicycle::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        let (mut worst, mut worst_se) = ((0.0, String::new()), (0.0, String::new()));
        for p in published(&bench) {
            let m = b
                .parameters
                .get(&p.name)
                .unwrap_or_else(|| panic!("{name}: `{}` not computed", p.name));
            let tol = (1e-6 * p.value.abs()).max(p.value_half_unit * (1.0 + 1e-9));
            assert!(
                (m.value - p.value).abs() <= tol,
                "{name} {}: {} vs published {}",
                p.name,
                m.value,
                p.value
            );
            let tol_se = (0.02 * p.se).max(p.se_half_unit * (1.0 + 1e-9));
            assert!(
                (m.se - p.se).abs() <= tol_se,
                "{name} {}: se {} vs published {}",
                p.name,
                m.se,
                p.se
            );
            let rel = (m.value - p.value).abs() / p.value.abs();
            if rel > worst.0 {
                worst = (rel, p.name.clone());
            }
            let rel_se = if p.se > 0.0 {
                (m.se - p.se).abs() / p.se
            } else {
                0.0
            };
            if rel_se > worst_se.0 {
                worst_se = (rel_se, p.name.clone());
            }
        }
        println!(
            "{name}: largest relative difference {:.1e} ({}), of a standard error {:.1e} ({})",
            worst.0, worst.1, worst_se.0, worst_se.1
        );
        checked += 1;
    }
    assert_eq!(checked, 9, "bicycles with a published set");
}

/// Rigidcl is Rigid with the frame re-measured (its file says so): every parameter that does
/// not involve the frame is Rigid's published one.
#[test]
fn rigidcl_shares_everything_but_the_frame_with_rigid() {
    let b = MeasuredBicycle::load(&reference().join("RigidclMeasured.txt")).unwrap();
    let mut compared = 0;
    for p in published(&reference().join("RigidBenchmark.txt")) {
        if p.name.contains('B') {
            continue;
        }
        let m = &b.parameters[&p.name];
        assert!(
            (m.value - p.value).abs() <= 1e-6 * p.value.abs(),
            "{}: {} vs {}",
            p.name,
            m.value,
            p.value
        );
        assert!((m.se - p.se).abs() <= 0.02 * p.se, "{}", p.name);
        compared += 1;
    }
    assert!(compared >= 30, "{compared}");
}

/// The bicycles without a published set: every parameter finite with a standard error, the
/// flywheel's mass the measured one less the front wheel's (Gyro), and a stable range.
#[test]
fn bicycles_without_a_published_set_convert_whole() {
    for name in ["Gyro", "Rigidcl", "Stratos"] {
        let path = reference().join(format!("{name}Measured.txt"));
        let b = MeasuredBicycle::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        for (k, m) in &b.parameters {
            assert!(m.value.is_finite() && m.se.is_finite(), "{name} {k}");
            assert!(
                m.se > 0.0 || ["g", "xcl", "zcl"].contains(&k.as_str()),
                "{name} {k}: no standard error"
            );
        }
        let r = b.report(10.0, 0.01).unwrap();
        assert_eq!(r.stable_ranges_mps.len(), 1, "{name}");
        assert!(
            r.weave_speed_se_mps.is_some_and(|s| s > 0.0 && s < 0.2),
            "{name}"
        );
    }
    let file = MeasuredFile::load(&reference().join("GyroMeasured.txt")).unwrap();
    let b = MeasuredBicycle::from_file(&file).unwrap();
    let m_d = file.entries["mD"].mean().value - file.entries["mF"].mean().value;
    assert!((b.parameters["mD"].value - m_d).abs() < 1e-12);
    assert!(b.parameters["IDxx"].value > 0.0 && b.parameters["IDyy"].value > 0.0);
}

/// Issue 33: a file whose lines end in a carriage return alone (classic Mac OS text) is read
/// line by line as the same file with LF ends: every parameter equal, and recognised as raw
/// measurements (it was read as one line, "standard error `0.001lP = …`", then as a CSV).
#[test]
fn cr_line_ends_read_as_the_same_file() {
    let path = reference().join("RigidMeasured.txt");
    let bytes = std::fs::read(&path).unwrap();
    let cr: Vec<u8> = bytes
        .iter()
        .filter(|&&b| b != b'\r')
        .map(|&b| if b == b'\n' { b'\r' } else { b })
        .collect();
    let a = MeasuredBicycle::from_file(&MeasuredFile::parse(&bytes, &path).unwrap()).unwrap();
    let b = MeasuredBicycle::from_file(&MeasuredFile::parse(&cr, &path).unwrap()).unwrap();
    assert_eq!(a.parameters.len(), b.parameters.len());
    for (k, m) in &a.parameters {
        assert_eq!(m.value, b.parameters[k].value, "{k}");
        assert_eq!(m.se, b.parameters[k].se, "{k}");
    }
    let dir = std::env::temp_dir().join(format!("bikeproc_cr_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("CrMeasured.txt");
    std::fs::write(&file, &cr).unwrap();
    assert_eq!(
        bikeproc::read::kind::recognise(&file),
        bikeproc::read::kind::Kind::MeasuredBicycle
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `--out` read back by `stability --bike` gives the same stable range (1e-9), and `--json`
/// has every parameter with its value and standard error.
#[test]
fn out_file_round_trips_through_stability() {
    let dir = std::env::temp_dir().join(format!("bikeproc_measured_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["Rigid", "Browser", "Balanceassistv1"] {
        let out = dir.join(format!("{name}Benchmark.txt"));
        let input = reference().join(format!("{name}Measured.txt"));
        let m = common::run_json([
            "measured".as_ref(),
            input.as_os_str(),
            "--json".as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
        ]);
        assert_eq!(m["name"], name);
        let params = m["parameters"].as_object().unwrap();
        for k in bikeproc::model::Benchmark::NAMES {
            assert!(
                params[k]["value"].is_f64() && params[k]["se"].is_f64(),
                "{k}"
            );
        }
        let s = common::run_json([
            "stability".as_ref(),
            "--json".as_ref(),
            "--bike".as_ref(),
            out.as_os_str(),
        ]);
        let ranges = |v: &serde_json::Value| -> Vec<f64> {
            v["stable_ranges_mps"]
                .as_array()
                .unwrap()
                .iter()
                .flat_map(|r| {
                    r.as_array()
                        .unwrap()
                        .iter()
                        .map(|x| x.as_f64().unwrap_or(f64::INFINITY))
                })
                .collect()
        };
        let (a, b) = (ranges(&m), ranges(&s));
        assert_eq!(a.len(), b.len(), "{name}");
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 1e-9, "{name}: {x} vs {y}");
        }
        println!("{name}: stable {a:?} m/s, the same read back");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A file without the measurements (Silver's has only rider geometry) and malformed files: an
/// error naming the file, the line, the column or the key, exit 2, and nothing written.
#[test]
fn missing_and_malformed_measurements_are_refused() {
    let silver = reference().join("SilverMeasured.txt");
    let out = common::run([
        "measured".as_ref(),
        silver.as_os_str(),
        "--out".as_ref(),
        std::env::temp_dir()
            .join("bikeproc_silver_never.txt")
            .as_os_str(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("SilverMeasured.txt") && err.contains("missing measurement `dF`"),
        "{err}"
    );
    assert!(!std::env::temp_dir()
        .join("bikeproc_silver_never.txt")
        .exists());

    let rigid = std::fs::read_to_string(reference().join("RigidMeasured.txt")).unwrap();
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "twice",
            format!("{rigid}mB = 22.9+/-0.01\n"),
            ":91:1: `mB` is given twice (first on line 23)",
        ),
        (
            "mixed",
            rigid.replace(
                "dP = 0.03009+/-0.00001, 0.03010+/-0.00001",
                "dP = 0.03009+/-0.00001, 0.03010",
            ),
            ":54:25: `dP`: some repeats",
        ),
        (
            "not a number",
            rigid.replace("mR = 4.90+/-0.01", "mR = 4,90+/-0.01"),
            ":20:",
        ),
        (
            "negative se",
            rigid.replace("mR = 4.90+/-0.01", "mR = 4.90+/--0.01"),
            ":20:13: `mR`: standard error `-0.01`",
        ),
        (
            "zero mass",
            rigid.replace("mR = 4.90+/-0.01", "mR = 0+/-0.01"),
            ":20:6: `mR = 0+/-0.01`: expected a mass above 0 and at most 1000 kg",
        ),
        (
            "no equals",
            rigid.replace("mR = 4.90+/-0.01", "mR 4.90"),
            ":20:1: `mR 4.90`: expected `name = value+/-sigma`",
        ),
        (
            "gap",
            rigid.replace("alphaB4", "alphaB9"),
            "missing measurement `alphaB4`",
        ),
        (
            "no period",
            rigid.replace("TcS1", "TcX1"),
            "missing measurement `TcS1` (a compound pendulum period of the fork)",
        ),
        (
            "nan",
            rigid.replace("mR = 4.90+/-0.01", "mR = nan+/-0.01"),
            ":20:6: `mR`: `nan` is not a number",
        ),
    ];
    let dir = std::env::temp_dir().join(format!("bikeproc_measured_bad_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (what, text, says) in cases {
        let f = dir.join(format!("{}Measured.txt", what.replace(' ', "_")));
        std::fs::write(&f, &text).unwrap();
        let e = MeasuredBicycle::load(&f)
            .err()
            .unwrap_or_else(|| panic!("{what}: accepted"));
        assert!(e.to_string().contains(says), "{what}: {e}");
        let out = common::run(["measured".as_ref(), f.as_os_str()]);
        assert_eq!(out.status.code(), Some(2), "{what}");
    }
    let e = MeasuredFile::parse(b"mB = 1\xff\n", Path::new("x.txt")).unwrap_err();
    assert!(
        matches!(
            e,
            MeasuredError::Parse {
                line: 1,
                column: 7,
                ..
            }
        ),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Issue 33: a raw measurement outside its physical range is refused where it is read, naming
/// the line, the column and the key (exit 2): an absurd standard error (1e308 made every
/// propagated error 0; 500 on 9.86 kg is beyond the README's ten times the value plus one), a
/// period of 1e-300 s (IByy came out −1.133 kg·m²), a head angle of 0° (a trail of 4.46e15 m),
/// an angle of 1e308°.
#[test]
fn raw_measurements_outside_their_range_are_refused() {
    let src = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/reference/bicycleparameters/BrowserMeasured.txt"),
    )
    .unwrap();
    let path =
        std::env::temp_dir().join(format!("bikeproc_range_{}Measured.txt", std::process::id()));
    for (line, want) in [
        (
            "mB = 9.86+/-1e308",
            "a standard error from 0 to ten times the value plus one",
        ),
        (
            "mB = 9.86+/-500",
            "a standard error from 0 to ten times the value plus one",
        ),
        (
            "TcB1 = 1e-300+/-0",
            "a pendulum's period from 0.01 to 100 s",
        ),
        ("gamma = 0+/-0.2", "a head angle above 20°"),
        ("alphaB1 = 1e308+/-0.2", "an angle within ±360°"),
    ] {
        let (key, value) = line.split_once(" = ").unwrap();
        std::fs::write(&path, common::with_key(&src, key, value)).unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_bikeproc"))
            .args(["measured", path.to_str().unwrap()])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{line}: {err}");
        assert!(
            err.contains(&format!("`{line}`: expected")) && err.contains(want),
            "{line}: {err}"
        );
    }
    std::fs::remove_file(&path).ok();
}
