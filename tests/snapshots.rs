//! Issue 16: every command's text output on the lab's campaign in `data/`, as a lab engineer
//! reads it, kept as a snapshot (`tests/snapshots/`; a change shows as a diff to review, and
//! `INSTA_UPDATE=always cargo test --release --test snapshots` accepts it). No output and no
//! report shows NaN or inf as a number.

mod common;

/// Words that are a number gone wrong.
fn bad_numbers(text: &str) -> Vec<String> {
    text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '.'))
        .filter(|w| {
            let w = w.trim_matches('.');
            w.eq_ignore_ascii_case("nan") || w == "inf" || w == "Inf" || w == "infinity"
        })
        .map(str::to_string)
        .collect()
}

fn text_of(args: &[&str]) -> String {
    let out = common::run(args);
    assert!(
        out.status.success(),
        "bikeproc {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).expect("UTF-8 output");
    let bad = bad_numbers(&text);
    assert!(
        bad.is_empty(),
        "bikeproc {}: {bad:?} in\n{text}",
        args.join(" ")
    );
    text
}

macro_rules! snapshot {
    ($name:ident, $($arg:expr),+) => {
        #[test]
        fn $name() {
            let text = text_of(&[$($arg),+]);
            insta::assert_snapshot!(stringify!($name), text);
        }
    };
}

snapshot!(period_frame_torsion, "period", "data/frame_torsion/");
snapshot!(
    period_one_log,
    "period",
    "data/frame_torsion/frame_torsion_1a.log"
);
snapshot!(calibrate_bar, "calibrate-bar", "data/bar_calibration");
snapshot!(inertia_frame_torsion, "inertia", "data/frame_torsion");
snapshot!(
    inertia_handlebar_torsion,
    "inertia",
    "data/handlebar_torsion"
);
snapshot!(inertia_frame_compound, "inertia", "data/frame_compound");
snapshot!(inertia_rear_wheel, "inertia", "data/rear_wheel_compound");
snapshot!(
    stability_lab_bike,
    "stability",
    "--bike",
    "data/lab_bike.toml",
    "--speeds",
    "0:10:0.5"
);
snapshot!(
    dynamic_ride_03,
    "dynamic",
    "data/ride_03.log",
    "--speed",
    "3.9"
);
snapshot!(dynamic_campaign, "dynamic", "data/rides.toml");
snapshot!(gap_campaign, "gap", "data/rides.toml");
snapshot!(
    measured_rigid,
    "measured",
    "../shared/reference/bicycleparameters/RigidMeasured.txt"
);

/// No report shows NaN or inf as a number.
#[test]
fn no_report_shows_nan_or_inf() {
    let mut stack = vec![common::root().join("reports")];
    let mut files = 0;
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "md" || x == "svg") {
                let text = std::fs::read_to_string(&p).unwrap();
                let bad = bad_numbers(&text);
                assert!(bad.is_empty(), "{}: {bad:?}", p.display());
                files += 1;
            }
        }
    }
    assert!(files > 50, "{files} report files");
}
