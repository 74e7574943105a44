//! Plots (feature `plot`), at the side of the pipeline: numbers in, SVG text out.
//!
//! Figures for the reports: a signal with its fitted curve, a spectrum with its peaks. Text is
//! laid out with the bundled DejaVu Sans (`assets/fonts`, Bitstream Vera licence), so an SVG
//! does not depend on the fonts of the machine that drew it. Nothing here computes a result.

use crate::fit::Oscillation;
use crate::signal::Signal;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::sync::Once;

static FONT: Once = Once::new();
const FONT_NAME: &str = "DejaVu Sans";
const WIDTH: u32 = 900;
const HEIGHT: u32 = 420;

/// A plotting failure (a drawing-backend error; never expected with in-memory SVG).
#[derive(Debug, thiserror::Error)]
#[error("plot: {0}")]
pub struct PlotError(String);

fn register_font() {
    FONT.call_once(|| {
        // The bytes are a valid TrueType font checked in with the sources; a failure here is
        // a broken checkout, and text would then fall back to no glyph metrics.
        let _ = plotters::style::register_font(
            FONT_NAME,
            FontStyle::Normal,
            include_bytes!("../assets/fonts/DejaVuSans.ttf"),
        );
    });
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy)]
pub enum Mark {
    Line,
    /// A dashed line (imaginary parts, as in the seed's continuation diagrams).
    Dashed,
    /// A thin line (uncertainty bands).
    Thin,
    Dots,
}

/// One named series of points.
#[derive(Debug, Clone)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub color: RGBColor,
    pub mark: Mark,
}

/// A tick label without "-0.000".
fn tick(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].bytes().all(|b| b == b'0' || b == b'.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// Decimals that resolve a tick step of `span / 8`.
fn decimals_for(span: f64) -> usize {
    if !(span.is_finite() && span > 0.0) {
        return 2;
    }
    (2.0 - (span / 8.0).log10().floor()).clamp(0.0, 8.0) as usize
}

/// Keeps at most two points (min and max) per horizontal pixel, in order: the drawn picture is
/// the same, the file is small.
pub fn decimate(points: &[(f64, f64)], x_range: (f64, f64), columns: usize) -> Vec<(f64, f64)> {
    if points.len() <= 2 * columns {
        return points.to_vec();
    }
    let (x0, x1) = x_range;
    let width = (x1 - x0).max(f64::MIN_POSITIVE);
    let mut out = Vec::with_capacity(2 * columns + 2);
    let mut i = 0;
    while i < points.len() {
        let col = (((points[i].0 - x0) / width) * columns as f64).floor();
        let mut j = i;
        let (mut lo, mut hi) = (i, i);
        while j < points.len() && (((points[j].0 - x0) / width) * columns as f64).floor() == col {
            if points[j].1 < points[lo].1 {
                lo = j;
            }
            if points[j].1 > points[hi].1 {
                hi = j;
            }
            j += 1;
        }
        let (a, b) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        out.push(points[a]);
        if b != a {
            out.push(points[b]);
        }
        i = j;
    }
    out
}

/// An x–y chart of several series with a legend; `log_y` for spectra.
pub fn chart(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    log_y: bool,
) -> Result<String, PlotError> {
    chart_shaded(title, x_label, y_label, series, log_y, &[])
}

/// As [`chart`], with x ranges shaded (stable speed ranges); linear y only.
pub fn chart_shaded(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    log_y: bool,
    shades: &[(f64, f64, RGBColor)],
) -> Result<String, PlotError> {
    register_font();
    let pts = series.iter().flat_map(|s| s.points.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for &(x, y) in pts {
        if x.is_finite() && y.is_finite() && (!log_y || y > 0.0) {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
    }
    if x0.partial_cmp(&x1) != Some(std::cmp::Ordering::Less) {
        (x0, x1) = (0.0, 1.0);
    }
    if y0.partial_cmp(&y1) != Some(std::cmp::Ordering::Less) {
        (y0, y1) = if log_y { (1e-6, 1.0) } else { (-1.0, 1.0) };
    }
    let err = |e: &dyn std::fmt::Display| PlotError(e.to_string());
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let font = (FONT_NAME, 16).into_font();
        let mut builder = ChartBuilder::on(&root);
        builder
            .caption(title, font)
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(74);
        let xd = decimals_for(x1 - x0);
        if log_y {
            let (ly0, ly1) = (y0.max(y1 * 1e-6), y1 * 2.0);
            let mut chart = builder
                .build_cartesian_2d(x0..x1, (ly0..ly1).log_scale())
                .map_err(|e| err(&e))?;
            chart
                .configure_mesh()
                .x_desc(x_label)
                .y_desc(y_label)
                .label_style((FONT_NAME, 12))
                .x_label_formatter(&|v| tick(*v, xd))
                .y_label_formatter(&|v| format!("{v:.0e}"))
                .draw()
                .map_err(|e| err(&e))?;
            draw_series(&mut chart, series, (x0, x1), |y| y > 0.0)?;
        } else {
            let pad = 0.05 * (y1 - y0);
            let yd = decimals_for(y1 - y0);
            let mut chart = builder
                .build_cartesian_2d(x0..x1, (y0 - pad)..(y1 + pad))
                .map_err(|e| err(&e))?;
            for &(a, b, color) in shades {
                let rect = Rectangle::new(
                    [(a.max(x0), y0 - pad), (b.min(x1), y1 + pad)],
                    color.mix(0.12).filled(),
                );
                chart
                    .draw_series(std::iter::once(rect))
                    .map_err(|e| err(&e))?;
            }
            chart
                .configure_mesh()
                .x_desc(x_label)
                .y_desc(y_label)
                .label_style((FONT_NAME, 12))
                .x_label_formatter(&|v| tick(*v, xd))
                .y_label_formatter(&|v| tick(*v, yd))
                .draw()
                .map_err(|e| err(&e))?;
            draw_series(&mut chart, series, (x0, x1), |_| true)?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}

fn draw_series<
    'a,
    DB: DrawingBackend + 'a,
    CT: plotters::coord::CoordTranslate<From = (f64, f64)>,
>(
    chart: &mut ChartContext<'a, DB, CT>,
    series: &[Series],
    x_range: (f64, f64),
    keep: impl Fn(f64) -> bool,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let err = |e: &dyn std::fmt::Display| PlotError(e.to_string());
    for s in series {
        let pts: Vec<(f64, f64)> = decimate(&s.points, x_range, WIDTH as usize)
            .into_iter()
            .filter(|p| keep(p.1) && p.1.is_finite())
            .collect();
        let color = s.color;
        let anno = match s.mark {
            Mark::Line => chart
                .draw_series(LineSeries::new(pts, color.stroke_width(1)))
                .map_err(|e| err(&e))?,
            Mark::Thin => chart
                .draw_series(LineSeries::new(pts, color.mix(0.45).stroke_width(1)))
                .map_err(|e| err(&e))?,
            Mark::Dashed => chart
                .draw_series(DashedLineSeries::new(pts, 6, 4, color.stroke_width(1)))
                .map_err(|e| err(&e))?,
            Mark::Dots => chart
                .draw_series(pts.into_iter().map(|p| Circle::new(p, 2, color.filled())))
                .map_err(|e| err(&e))?,
        };
        if !s.name.is_empty() {
            anno.label(s.name.clone()).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
            });
        }
    }
    chart
        .configure_series_labels()
        .label_font((FONT_NAME, 12))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(&e))
}

/// The signal (grey) and the fitted damped sinusoid over the free-decay segment (red).
pub fn fit_svg(signal: &Signal, osc: &Oscillation, title: &str) -> Result<String, PlotError> {
    let t = signal.times_s();
    let data: Vec<(f64, f64)> = t
        .iter()
        .copied()
        .zip(signal.values.iter().copied())
        .collect();
    let (a, b) = osc.segment_s;
    let fitted: Vec<(f64, f64)> = t
        .iter()
        .filter(|&&ti| ti >= a && ti <= b)
        .map(|&ti| (ti, osc.fit.eval(ti)))
        .collect();
    let unit = if signal.unit.is_empty() {
        String::new()
    } else {
        format!(" ({})", signal.unit)
    };
    chart(
        title,
        "time (s)",
        &format!("signal{unit}"),
        &[
            Series {
                name: "measured".into(),
                points: data,
                color: RGBColor(120, 120, 120),
                mark: Mark::Line,
            },
            Series {
                name: "fitted damped sinusoid".into(),
                points: fitted,
                color: RGBColor(200, 30, 30),
                mark: Mark::Line,
            },
        ],
        false,
    )
}

/// The Hann spectrum of the fitted segment up to 4× the main frequency, with the peaks marked.
pub fn spectrum_svg(osc: &Oscillation, title: &str) -> Result<String, PlotError> {
    let f_max = 4.0 * osc.fit.freq_hz().value;
    let sp = &osc.spectrum;
    let pts: Vec<(f64, f64)> = sp
        .freq_hz
        .iter()
        .zip(&sp.magnitude)
        .filter(|(f, _)| **f <= f_max && **f > 0.0)
        .map(|(f, m)| (*f, *m))
        .collect();
    let mut marks = vec![(osc.fit.freq_hz().value, osc.main_peak.magnitude)];
    marks.extend(osc.secondary_peaks.iter().map(|p| (p.freq_hz, p.magnitude)));
    chart(
        title,
        "frequency (Hz)",
        "amplitude",
        &[
            Series {
                name: "Hann-windowed spectrum of the fitted segment".into(),
                points: pts,
                color: RGBColor(30, 60, 200),
                mark: Mark::Line,
            },
            Series {
                name: "fitted frequency and other peaks".into(),
                points: marks,
                color: RGBColor(200, 30, 30),
                mark: Mark::Dots,
            },
        ],
        true,
    )
}

/// One bicycle's continuation diagram: the named eigenvalues against speed, with ±2 standard
/// error bands on the real parts.
pub struct Continuation<'a> {
    pub name: &'a str,
    pub bands: &'a crate::model::uncertain::Bands,
    pub stable: &'a [(f64, Option<f64>)],
    pub color: RGBColor,
    /// The second colour, for the real modes.
    pub color_real: RGBColor,
}

/// Points with error bars at ±2 standard errors in x and y: `(x, y, x_se, y_se)`. A dot per
/// point (the series named `name`) and a segment per bar.
pub fn error_bars(points: &[(f64, f64, f64, f64)], color: RGBColor, name: &str) -> Vec<Series> {
    let mut out = vec![Series {
        name: name.to_string(),
        points: points.iter().map(|p| (p.0, p.1)).collect(),
        color,
        mark: Mark::Dots,
    }];
    for &(x, y, sx, sy) in points {
        for seg in [
            vec![(x, y - 2.0 * sy), (x, y + 2.0 * sy)],
            vec![(x - 2.0 * sx, y), (x + 2.0 * sx, y)],
        ] {
            out.push(Series {
                name: String::new(),
                points: seg,
                color,
                mark: Mark::Line,
            });
        }
    }
    out
}

/// A ride's roll and steer (degrees) against time: the measured angles thin, the fitted curves
/// over the fitted window (shaded) bold. `measured` and `fitted` rows are (t s, θ rad, γ rad).
pub fn ride_svg(
    title: &str,
    measured: &[[f64; 3]],
    fitted: &[[f64; 3]],
    window_s: (f64, f64),
) -> Result<String, PlotError> {
    let (blue, red) = (RGBColor(30, 80, 200), RGBColor(200, 40, 40));
    let column = |rows: &[[f64; 3]], k: usize| -> Vec<(f64, f64)> {
        rows.iter().map(|r| (r[0], r[k].to_degrees())).collect()
    };
    let series = [
        ("roll θ, measured", column(measured, 1), blue, Mark::Thin),
        ("steer γ, measured", column(measured, 2), red, Mark::Thin),
        ("roll θ, fitted modes", column(fitted, 1), blue, Mark::Line),
        ("steer γ, fitted modes", column(fitted, 2), red, Mark::Line),
    ]
    .map(|(name, points, color, mark)| Series {
        name: name.to_string(),
        points,
        color,
        mark,
    });
    chart_shaded(
        title,
        "time in the log (s)",
        "angle (degrees)",
        &series,
        false,
        &[(window_s.0, window_s.1, RGBColor(120, 120, 120))],
    )
}

/// Real parts (solid) and imaginary parts (dashed) of the eigenvalues against speed, as the
/// seed's Figs. 14–17, for one or several bicycles; stable ranges shaded; bands at ±2 se;
/// `extra` series (measured eigenvalues) drawn on top.
pub fn continuation_svg(
    title: &str,
    bikes: &[Continuation<'_>],
    y_range: (f64, f64),
    extra: &[Series],
) -> Result<String, PlotError> {
    let mut series = Vec::new();
    let mut shades = Vec::new();
    for b in bikes {
        let sw = &b.bands.sweep;
        let pick =
            |k: usize, f: &dyn Fn(nalgebra::Complex<f64>, (f64, f64)) -> f64| -> Vec<(f64, f64)> {
                sw.speeds_mps
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| {
                        (
                            v,
                            f(sw.eigenvalues[i][k], b.bands.se[i][k]).clamp(y_range.0, y_range.1),
                        )
                    })
                    .collect()
            };
        let multi = bikes.len() > 1;
        let label = |what: &str| {
            if multi {
                format!("{}: {what}", b.name)
            } else {
                what.to_string()
            }
        };
        series.push(Series {
            name: label("weave, real part"),
            points: pick(0, &|z, _| z.re),
            color: b.color,
            mark: Mark::Line,
        });
        series.push(Series {
            name: label("weave, imaginary part"),
            points: pick(0, &|z, _| z.im.abs()),
            color: b.color,
            mark: Mark::Dashed,
        });
        series.push(Series {
            name: label("capsize and castor, real parts"),
            points: pick(2, &|z, _| z.re),
            color: b.color_real,
            mark: Mark::Line,
        });
        series.push(Series {
            name: String::new(),
            points: pick(3, &|z, _| z.re),
            color: b.color_real,
            mark: Mark::Line,
        });
        for k in [0, 2, 3] {
            for sign in [-2.0, 2.0] {
                let c = if k == 0 { b.color } else { b.color_real };
                series.push(Series {
                    name: String::new(),
                    points: pick(k, &|z, se| z.re + sign * se.0),
                    color: c,
                    mark: Mark::Thin,
                });
            }
        }
        for &(lo, hi) in b.stable {
            shades.push((lo, hi.unwrap_or(f64::INFINITY), b.color));
        }
    }
    // Keep the y axis on the chosen range.
    let xs = bikes
        .first()
        .map(|b| {
            (
                b.bands.sweep.speeds_mps[0],
                *b.bands.sweep.speeds_mps.last().unwrap_or(&1.0),
            )
        })
        .unwrap_or((0.0, 1.0));
    series.push(Series {
        name: String::new(),
        points: vec![(xs.0, y_range.0), (xs.1, y_range.1)],
        color: WHITE,
        mark: Mark::Dots,
    });
    series.extend_from_slice(extra);
    chart_shaded(
        title,
        "speed (m/s)",
        "eigenvalue (1/s)",
        &series,
        false,
        &shades,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_never_show_negative_zero() {
        assert_eq!(tick(-0.0001, 3), "0.000");
        assert_eq!(tick(-0.5, 1), "-0.5");
    }

    #[test]
    fn decimation_keeps_extremes_in_order() {
        let pts: Vec<(f64, f64)> = (0..10_000)
            .map(|i| (i as f64, ((i * 7919) % 101) as f64))
            .collect();
        let d = decimate(&pts, (0.0, 10_000.0), 100);
        assert!(d.len() <= 200);
        assert!(d.windows(2).all(|w| w[0].0 <= w[1].0));
        assert_eq!(d.iter().map(|p| p.1).fold(f64::MIN, f64::max), 100.0);
        assert_eq!(d.iter().map(|p| p.1).fold(f64::MAX, f64::min), 0.0);
    }
}
