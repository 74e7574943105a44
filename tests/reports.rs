//! The checked-in reports are exactly what a fresh regeneration from `data/` and the reference
//! material gives (CI fails otherwise), and regenerating twice gives the same bytes.
#![cfg(feature = "plot")]

use std::path::Path;

#[test]
fn checked_in_reports_match_a_fresh_regeneration() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let reference = root.join("../shared/reference");
    let data = root.join("data");
    let files = bikeproc::report::build(&data, &reference, &mut |_| {}).expect("reports build");
    let again = bikeproc::report::build(&data, &reference, &mut |_| {}).expect("reports build");
    assert!(files == again, "two regenerations differ");
    let mut stale = Vec::new();
    for (rel, bytes) in &files {
        let on_disk = std::fs::read(root.join("reports").join(rel)).unwrap_or_default();
        if &on_disk != bytes {
            stale.push(rel.display().to_string());
        }
    }
    // Nothing checked in that the generator no longer writes.
    let mut extra = Vec::new();
    let mut stack = vec![root.join("reports")];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(root.join("reports")).unwrap().to_path_buf();
                if !files.iter().any(|(r, _)| *r == rel) {
                    extra.push(rel.display().to_string());
                }
            }
        }
    }
    assert!(
        stale.is_empty() && extra.is_empty(),
        "reports/ is out of date; run `cargo run --release -- report` and commit.\nstale: {stale:?}\nnot generated any more: {extra:?}"
    );
}

/// Issue 31: no text of a figure leaves its canvas (the legends were cut at the right edge).
/// Each `<text>` without a rotation is measured at 0.6 em a character (DejaVu Sans' average
/// advance is 0.55–0.6 em for the labels' letters) from its anchor.
#[test]
fn no_figure_text_leaves_its_canvas() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("reports");
    let mut stack = vec![root.clone()];
    let mut checked = 0;
    let attr = |tag: &str, name: &str| -> Option<f64> {
        let key = format!(" {name}=\"");
        let at = tag.find(&key)? + key.len();
        tag[at..].split('"').next()?.parse().ok()
    };
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
                continue;
            }
            if p.extension().is_none_or(|x| x != "svg") {
                continue;
            }
            let svg = std::fs::read_to_string(&p).unwrap();
            let width = attr(&svg[..svg.find('>').unwrap()], "width").unwrap();
            let mut rest = svg.as_str();
            while let Some(start) = rest.find("<text ") {
                let tag_end = start + rest[start..].find('>').unwrap();
                let tag = &rest[start..tag_end];
                let close = tag_end + rest[tag_end..].find("</text>").unwrap();
                let content = rest[tag_end + 1..close]
                    .trim()
                    .replace("&apos;", "'")
                    .replace("&amp;", "&")
                    .replace("&lt;", "<")
                    .replace("&gt;", ">");
                rest = &rest[close..];
                if tag.contains("transform") {
                    continue;
                }
                let (x, size) = (attr(tag, "x").unwrap(), attr(tag, "font-size").unwrap());
                let w = 0.6 * size * content.chars().count() as f64;
                let left = if tag.contains("text-anchor=\"middle\"") {
                    x - w / 2.0
                } else if tag.contains("text-anchor=\"end\"") {
                    x - w
                } else {
                    x
                };
                assert!(
                    left >= -1.0 && left + w <= width + 1.0,
                    "{}: \"{content}\" spans {left:.0}–{:.0} px of {width} px",
                    p.display(),
                    left + w
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 1000, "{checked} texts checked");
}

/// Every `<text>` of an SVG: (x, content).
fn svg_texts(path: &Path) -> Vec<(f64, String)> {
    let svg = std::fs::read_to_string(path).unwrap();
    let mut out = Vec::new();
    let mut rest = svg.as_str();
    while let Some(start) = rest.find("<text ") {
        let tag_end = start + rest[start..].find('>').unwrap();
        let tag = &rest[start..tag_end];
        let close = tag_end + rest[tag_end..].find("</text>").unwrap();
        let x = tag
            .split(" x=\"")
            .nth(1)
            .and_then(|v| v.split('"').next())
            .and_then(|v| v.parse().ok())
            .unwrap_or(f64::NAN);
        out.push((x, rest[tag_end + 1..close].trim().replace("&apos;", "'")));
        rest = &rest[close..];
    }
    out
}

/// Issue 31: the figures say what they show, as rendered and looked at: capsize and castor
/// named apart and the imaginary parts' unit given; the shaded stable ranges named in the
/// legend only (two bicycles' labels were printed over each other in the plot); the gap's
/// residuals one panel per quantity in its unit; a ride's angles in mrad with the kick and
/// the catch marked and its speed with its SE; a spectrum's amplitude in the signal's unit.
#[test]
fn figures_say_what_they_show() {
    let reports = Path::new(env!("CARGO_MANIFEST_DIR")).join("reports");
    let has = |file: &str, want: &str| {
        let texts = svg_texts(&reports.join(file));
        assert!(
            texts.iter().any(|(_, t)| t.contains(want)),
            "{file}: no text with {want:?}"
        );
    };
    for want in [
        "capsize, real part",
        "castor, real part",
        "imaginary (rad/s)",
    ] {
        has("model/lab_measured.svg", want);
    }
    let plot_width = 900.0;
    for (x, t) in svg_texts(&reports.join("model/benchmark_vs_lab.svg")) {
        if t.contains("stable") {
            assert!(x >= plot_width, "\"{t}\" inside the plot at x = {x}");
        }
    }
    for want in [
        "Δσ (1/s)",
        "Δω (rad/s)",
        "Δ|γ/θ| (rad/rad)",
        "Δarg(γ/θ) (°)",
    ] {
        has("gap/residuals.svg", want);
    }
    for want in ["angle (mrad)", "kick", "catch"] {
        has("dynamic/ride_03.svg", want);
    }
    let title = svg_texts(&reports.join("dynamic/ride_03.svg"))
        .into_iter()
        .find(|(_, t)| t.starts_with("ride_03:"))
        .unwrap()
        .1;
    assert_eq!(title.matches('±').count(), 3, "{title}");
    has("inertia/frame_torsion_1_spectrum.svg", "amplitude (rad)");
}
