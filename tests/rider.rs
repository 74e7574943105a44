//! Issue 34, item 3: a rider joins the rear frame. `bikeproc stability --bike B --rider R`
//! against the same bicycle written out with the rider combined by another route (the bodies'
//! inertias summed about the rear contact, the joint body's own parallel-axis term taken off).

use bikeproc::model::{Benchmark, Rider};
use std::path::{Path, PathBuf};
use std::process::Command;

fn reference(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/reference/bicycleparameters")
        .join(name)
}

/// `bikeproc stability --json` (0–20 m/s: a rider moves the capsize speed beyond 10) with the
/// given arguments: weave and capsize speeds
/// and their standard errors.
fn stability(args: &[&str]) -> [f64; 4] {
    let out = Command::new(env!("CARGO_BIN_EXE_bikeproc"))
        .arg("stability")
        .args(args)
        .args(["--speeds", "0:20:0.5", "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    [
        "weave_speed_mps",
        "capsize_speed_mps",
        "weave_speed_se_mps",
        "capsize_speed_se_mps",
    ]
    .map(|k| j[k].as_f64().unwrap_or_else(|| panic!("{k}: {}", j[k])))
}

/// The bicycle with the rider in its rear frame, by the inertia about the rear contact: for
/// each body, `I_O = I_G + m [z², x² + z², x², −x z]` (xx, yy, zz, xz); the joint body's own
/// inertia is the sum of both `I_O` less the joint mass's term at the joint centre.
fn combined_about_the_contact(b: &Benchmark, r: &Rider) -> Benchmark {
    let about_o = |m: f64, x: f64, z: f64, own: [f64; 4]| {
        [
            own[0] + m * z * z,
            own[1] + m * (x * x + z * z),
            own[2] + m * x * x,
            own[3] - m * x * z,
        ]
    };
    let rb = &r.body;
    let frame = about_o(b.m_b, b.x_b, b.z_b, [b.i_bxx, b.i_byy, b.i_bzz, b.i_bxz]);
    let rider = about_o(
        rb.mass_kg,
        rb.x_m,
        rb.z_m,
        [rb.ixx_kgm2, rb.iyy_kgm2, rb.izz_kgm2, rb.ixz_kgm2],
    );
    let m = b.m_b + rb.mass_kg;
    let x = (b.m_b * b.x_b + rb.mass_kg * rb.x_m) / m;
    let z = (b.m_b * b.z_b + rb.mass_kg * rb.z_m) / m;
    let joint = about_o(m, x, z, [0.0; 4]);
    let mut out = *b;
    out.m_b = m;
    out.x_b = x;
    out.z_b = z;
    out.i_bxx = frame[0] + rider[0] - joint[0];
    out.i_byy = frame[1] + rider[1] - joint[1];
    out.i_bzz = frame[2] + rider[2] - joint[2];
    out.i_bxz = frame[3] + rider[3] - joint[3];
    out
}

fn check(bike: &str, rider: &str) {
    let (bike_path, rider_path) = (reference(bike), reference(rider));
    let b = Benchmark::load(&bike_path).unwrap();
    let r = Rider::load(&rider_path).unwrap();
    let joined = combined_about_the_contact(&b, &r);
    let dir = std::env::temp_dir().join(format!("bikeproc_rider_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join(format!("{bike}_with_rider.txt"));
    std::fs::write(&file, joined.to_text()).unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let with = stability(&["--bike", &s(&bike_path), "--rider", &s(&rider_path)]);
    let by_hand = stability(&["--bike", &s(&file)]);
    let alone = stability(&["--bike", &s(&bike_path)]);
    std::fs::remove_dir_all(&dir).ok();
    println!("{bike} + {rider}: {with:?}; combined by hand {by_hand:?}; without {alone:?}");
    for k in 0..2 {
        assert!(
            (with[k] - by_hand[k]).abs() < 1e-6,
            "{bike}: speed {k}: {} against {}",
            with[k],
            by_hand[k]
        );
        // A rider of 70–90 kg moves the speeds: the comparison is not of two identical files.
        assert!(
            (with[k] - alone[k]).abs() > 0.05,
            "{bike}: the rider changed nothing"
        );
    }
    // The standard errors carried, the bicycle's and the rider's (JasonBrowser's mass ± 2 kg),
    // through the combination: each parameter moved by a thousandth of its SE, combined by
    // hand, the speeds found again (central differences), summed in quadrature.
    let (values, rider_values) = (b.to_array(), r.body.to_array());
    let mut var = [0.0f64; 2];
    for k in 0..33 {
        let se = if k < 26 { b.se[k] } else { r.se[k - 26] };
        let h = 1e-3 * se;
        if h == 0.0 {
            continue;
        }
        let at = |d: f64| {
            let (mut v, mut rv) = (values, rider_values);
            if k < 26 {
                v[k] += d;
            } else {
                rv[k - 26] += d;
            }
            let rider = Rider {
                body: bikeproc::model::RigidBody::from_array(&rv),
                se: r.se,
            };
            speeds(&combined_about_the_contact(
                &Benchmark::from_array(&v),
                &rider,
            ))
        };
        let (p, m) = (at(h), at(-h));
        for i in 0..2 {
            var[i] += ((p[i] - m[i]) / (2.0 * h) * se).powi(2);
        }
    }
    for i in 0..2 {
        let se = var[i].sqrt();
        assert!(
            (with[2 + i] - se).abs() < 1e-3 * se,
            "{bike}: SE {i}: {} against {se}",
            with[2 + i]
        );
    }
}

/// The weave and capsize speeds of `b` (0–20 m/s, refined to 1e-13 m/s).
fn speeds(b: &Benchmark) -> [f64; 2] {
    let s = bikeproc::model::uncertain::Parametrized::from_benchmark("b", b)
        .nominal_canonical()
        .stability(20.0, 0.01)
        .unwrap();
    [s.weave_speed_mps.unwrap(), s.capsize_speed_mps.unwrap()]
}

#[test]
fn a_rider_joins_the_rear_frame() {
    check("RigidBenchmark.txt", "JasonRigidBenchmark.txt");
    check("BrowserBenchmark.txt", "JasonBrowserBenchmark.txt");
}

/// A bicycle file given as the rider, a rider off the plane of symmetry, and a rider without
/// his mass are refused with the file named.
#[test]
fn a_wrong_rider_file_is_refused() {
    let dir = std::env::temp_dir().join(format!("bikeproc_bad_rider_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let jason = std::fs::read_to_string(reference("JasonRigidBenchmark.txt")).unwrap();
    let cases = [
        (
            "bicycle.txt",
            std::fs::read_to_string(reference("RigidBenchmark.txt")).unwrap(),
            "not a rider's",
        ),
        (
            "off.txt",
            jason.replace("yB = 2.77335755173e-08", "yB = 0.3"),
            "plane of symmetry",
        ),
        (
            "nomass.txt",
            jason.replace("mB = 83.5", ""),
            "missing parameter `mB`",
        ),
        (
            "heavy.txt",
            jason.replace("mB = 83.5", "mB = 8350"),
            "1–300 kg",
        ),
    ];
    for (name, text, expected) in cases {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_bikeproc"))
            .args(["stability", "--bike"])
            .arg(reference("RigidBenchmark.txt"))
            .arg("--rider")
            .arg(&path)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{name}: {err}");
        assert!(
            err.contains(expected) && err.contains(name),
            "{name}: {err}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
