//! Issue 14 item 2: the packet counter is the clock. A receiver's time stamps jitter and arrive
//! late in bursts; no valid log is refused for that, and what is read does not depend on them.

use bikeproc::read::log::{Log, OutputMode, ReadOptions};
use bikeproc::signal::{channel, dominant_rotation, Signal};
use bikeproc::sim::draw::{seeded, Draw};
use proptest::prelude::*;
use std::path::Path;

mod common;

/// `log` with its receiver's time column restamped: Gaussian jitter of `jitter_s`, and bursts
/// (on average `bursts_per_s`) in which 2–10 packets are held and delivered at once, all
/// stamped with the delivery time, the first of them up to `max_late_s` late.
fn restamp(log: &str, jitter_s: f64, bursts_per_s: f64, max_late_s: f64, seed: u64) -> String {
    let mut rng = seeded(seed);
    let lines: Vec<&str> = log.lines().collect();
    let head = lines
        .iter()
        .position(|l| l.starts_with("Counter") || l.starts_with("PacketCounter"))
        .expect("a column row");
    let sep = if lines[head].contains(';') { ';' } else { '\t' };
    let comma = sep == ';';
    let time_col = lines[head]
        .split(sep)
        .position(|c| c.trim() == "Time")
        .expect("a Time column");
    let rows = &lines[head + 1..];
    let times: Vec<f64> = rows
        .iter()
        .map(|r| {
            let t = r.split(sep).nth(time_col).unwrap().replace(',', ".");
            t.parse::<f64>().unwrap()
        })
        .collect();
    let mut stamped: Vec<f64> = times.iter().map(|t| t + jitter_s * rng.normal()).collect();
    let mut k = 0;
    while k < times.len() {
        if rng.uniform() < bursts_per_s * 0.01 {
            let n = 2 + (rng.uniform() * 9.0) as usize;
            let last = (k + n - 1).min(times.len() - 1);
            // Delivered when the burst's last packet is, plus what keeps the first's delay
            // within max_late_s.
            let slack = (max_late_s - (times[last] - times[k])).max(0.0);
            let delivered = times[last] + slack * rng.uniform();
            for s in &mut stamped[k..=last] {
                *s = delivered;
            }
            k = last + 1;
        } else {
            k += 1;
        }
    }
    let mut out: Vec<String> = lines[..=head].iter().map(|l| l.to_string()).collect();
    for (r, t) in rows.iter().zip(&stamped) {
        let mut fields: Vec<String> = r.split(sep).map(str::to_string).collect();
        let text = format!("{:.3}", t.max(0.0));
        fields[time_col] = if comma { text.replace('.', ",") } else { text };
        out.push(fields.join(&sep.to_string()));
    }
    out.join("\n") + "\n"
}

fn signals(log: &Log) -> Vec<Signal> {
    let mut out = Vec::new();
    if log.mode == OutputMode::Calibrated {
        for c in ["Gyr_X", "Gyr_Z", "Acc_Y"] {
            out.push(channel(log, c, None).expect("the channel"));
        }
    } else {
        out.push(dominant_rotation(log, None).expect("a rotation"));
    }
    out
}

fn assert_same(a: &Signal, b: &Signal, what: &str) {
    assert_eq!(a.index, b.index, "{what}: the grid");
    assert_eq!(a.values.len(), b.values.len(), "{what}");
    for (x, y) in a.values.iter().zip(&b.values) {
        assert!(
            (x - y).abs() <= 1e-12 * x.abs().max(1.0),
            "{what}: {x} vs {y}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Acceptance: jitter of σ 1–3 ms and late bursts of up to 100 ms on the receiver's time,
    /// in every mode and locale: no log is refused, the grid and the signals are the
    /// jitter-free ones (to 1e-12), no hole is invented, and the rows whose time was off are
    /// counted.
    #[test]
    fn jitter_and_late_bursts_change_nothing(
        jitter_ms in 1.0f64..3.0,
        bursts_per_s in 0.0f64..2.0,
        max_late_ms in 20.0f64..100.0,
        seed in 0u64..1_000_000,
    ) {
        let opts = ReadOptions::default();
        for common::TorsionLogs { name, angles_log: angles, cal_log: cal } in common::torsion_logs(false) {
            for (kind, text) in [("angles", &angles), ("cal", &cal)] {
                let clean = Log::parse(text.as_bytes(), Path::new("clean.log"), &opts)
                    .unwrap_or_else(|e| panic!("{name} {kind}: {e}"));
                let jittery = restamp(text, jitter_ms * 1e-3, bursts_per_s, max_late_ms * 1e-3, seed);
                let log = Log::parse(jittery.as_bytes(), Path::new("jittery.log"), &opts)
                    .unwrap_or_else(|e| panic!("{name} {kind}, jitter {jitter_ms} ms: {e}"));
                prop_assert_eq!(&log.grid_index, &clean.grid_index);
                prop_assert_eq!(log.gaps.gaps, clean.gaps.gaps);
                prop_assert_eq!(clean.gaps.time_off_rows, 0);
                // σ ≥ 1 ms: some stamps are over half a sample (5 ms) off.
                prop_assert!(jitter_ms < 1.5 || log.gaps.time_off_rows > 0);
                for (a, b) in signals(&clean).iter().zip(&signals(&log)) {
                    assert_same(a, b, &format!("{name} {kind}"));
                }
            }
        }
    }
}

/// A genuine contradiction is still refused, naming the line: a stamp 0.5 s before the
/// previous one (beyond any late delivery), and a time step no number of counter periods
/// explains.
#[test]
fn contradictions_are_still_errors() {
    let angles = common::torsion_logs(false).remove(0).angles_log;
    let lines: Vec<&str> = angles.lines().collect();
    let head = lines.iter().position(|l| l.starts_with("Counter")).unwrap();
    let edit = |row: usize, new_time: f64| -> String {
        let mut out: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
        let mut f: Vec<String> = out[head + 1 + row]
            .split('\t')
            .map(str::to_string)
            .collect();
        f[1] = format!("{new_time:.3}");
        out[head + 1 + row] = f.join("\t");
        out.join("\n") + "\n"
    };
    let t = |row: usize| -> f64 {
        lines[head + 1 + row]
            .split('\t')
            .nth(1)
            .unwrap()
            .parse()
            .unwrap()
    };
    let opts = ReadOptions::default();
    let back = edit(200, t(199) - 0.5);
    let e = Log::parse(back.as_bytes(), Path::new("back.log"), &opts)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(&format!("back.log:{}", head + 1 + 200 + 1)),
        "{e}"
    );
    assert!(e.contains("backwards"), "{e}");
    let far = edit(200, t(199) + 30.0);
    let e = Log::parse(far.as_bytes(), Path::new("far.log"), &opts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("counter and time disagree"), "{e}");
}
