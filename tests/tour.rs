//! Issue 16: the README's five-minute tour works as written. Every `bikeproc …` line of its
//! shell block runs from the checkout and succeeds with text that a lab engineer can read (no
//! NaN or inf shown as a number), and every figure the tour names is one `report` writes.

mod common;

/// The tour's section of the README: from its heading to the next one.
fn tour() -> String {
    let readme = std::fs::read_to_string(common::root().join("README.md")).unwrap();
    let start = readme
        .find("## A five-minute tour")
        .expect("the tour's heading");
    let rest = &readme[start + 3..];
    rest[..rest.find("\n## ").unwrap_or(rest.len())].to_string()
}

#[test]
fn the_readme_tour_runs_as_written() {
    let tour = tour();
    let block = tour
        .split("```sh")
        .nth(1)
        .and_then(|b| b.split("```").next())
        .expect("a sh block");
    let commands: Vec<Vec<&str>> = block
        .lines()
        .map(str::trim)
        .filter(|l| l.starts_with("bikeproc "))
        .map(|l| l.split_whitespace().skip(1).collect())
        .collect();
    assert!(commands.len() >= 6, "{commands:?}");
    let steps = ["calibrate-bar", "inertia", "stability", "dynamic", "gap"];
    for s in steps {
        assert!(commands.iter().any(|c| c[0] == s), "the tour lacks {s}");
    }
    for c in &commands {
        let out = common::run(c);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "bikeproc {}: {}",
            c.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            stdout.lines().count() >= 3,
            "bikeproc {}: {stdout}",
            c.join(" ")
        );
        for bad in ["NaN", " inf", "-inf"] {
            assert!(
                !stdout.contains(bad),
                "bikeproc {}: `{bad}` in\n{stdout}",
                c.join(" ")
            );
        }
    }
    let figures: Vec<&str> = tour
        .split('`')
        .filter(|w| w.starts_with("reports/") && w.ends_with(".svg"))
        .collect();
    assert!(figures.len() >= 4, "{figures:?}");
    for f in figures {
        assert!(common::root().join(f).is_file(), "{f} is not in reports/");
    }
}
