//! The Markdown helpers every report shares: a value with its standard error, a relative
//! difference, the rounding a published table implies, a verdict as a list.

pub(super) fn pm(v: f64, se: f64, d: usize) -> String {
    format!("{v:.d$} ± {se:.d$}")
}

pub(super) fn pct(ours: f64, published: f64) -> String {
    format!("{:+.2} %", 100.0 * (ours / published - 1.0))
}

/// Half a unit of the last digit written in `text` (a number as a file gives it).
pub(super) fn half_unit_of_last_digit(text: &str) -> f64 {
    let t = text.trim();
    let (mantissa, exponent) = match t.split_once(['e', 'E']) {
        Some((m, e)) => (m, e.parse::<i32>().unwrap_or(0)),
        None => (t, 0),
    };
    let decimals = mantissa.split_once('.').map_or(0, |(_, d)| d.len()) as i32;
    0.5 * 10f64.powi(exponent - decimals)
}

/// A gap verdict (lines `Where: …`, `Which: …`, `How far: …`) as a Markdown list.
pub(super) fn verdict_list(verdict: &str) -> String {
    verdict
        .lines()
        .map(|l| format!("- {l}"))
        .collect::<Vec<_>>()
        .join("\n")
}
