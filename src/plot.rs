//! Plots (feature `plot`), at the side of the pipeline: numbers in, SVG text out.
//!
//! Figures for the reports: a signal with its fitted curve, a spectrum with its peaks. Text is
//! laid out with the bundled DejaVu Sans (`assets/fonts`, Bitstream Vera licence), so an SVG
//! does not depend on the fonts of the machine that drew it. Nothing here computes a result.

use crate::fit::Oscillation;
use crate::signal::Signal;
use plotters::coord::Shift;
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
    /// A line, 2 px: a model or a fit.
    Line,
    /// A dashed line (imaginary parts, as in the seed's continuation diagrams).
    Dashed,
    /// A thin pale line (uncertainty bands).
    Thin,
    /// Dots: measurements.
    Dots,
    /// A 1 px line in full colour (error bars).
    Bar,
}

/// One named series of points.
#[derive(Debug, Clone)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub color: RGBColor,
    pub mark: Mark,
}

/// A shaded range of x (a stable speed range, a fitted window), labelled in the legend. A chart
/// with one label's shades fills them over its height; with several (two bicycles' stable
/// ranges), each label's are a strip along the top, one row per label, so that no overlap makes
/// a colour of its own.
#[derive(Debug, Clone)]
pub struct Shade {
    pub from: f64,
    pub to: f64,
    pub color: RGBColor,
    pub label: String,
}

/// An event at an x (the kick), drawn as a labelled vertical line.
#[derive(Debug, Clone)]
pub struct Event {
    pub at: f64,
    pub label: String,
}

/// Everything one chart shows.
#[derive(Debug, Clone, Default)]
pub struct Chart<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub series: &'a [Series],
    /// A logarithmic y axis (spectra).
    pub log_y: bool,
    pub shades: &'a [Shade],
    pub events: &'a [Event],
    /// The y axis' range; curves leaving it are clipped at the frame, not flattened along it.
    /// Without it, the range of the data.
    pub y_range: Option<(f64, f64)>,
    /// The x axis' range (panels stacked over one x axis share it); without it, the data's.
    pub x_range: Option<(f64, f64)>,
}

/// A tick label without "-0.000" and without trailing zeros ("2.5", not "2.500").
fn tick(v: f64, decimals: usize) -> String {
    let mut s = format!("{v:.decimals$}");
    if s.contains('.') {
        s = s.trim_end_matches('0').trim_end_matches('.').to_string();
    }
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

/// A polyline clipped to `y0 ≤ y ≤ y1`: the runs inside, each ending where it crosses the
/// frame (linear interpolation), so a curve leaving the axes leaves them instead of running
/// along the edge. Non-finite points break a run.
pub fn clip(points: &[(f64, f64)], (y0, y1): (f64, f64)) -> Vec<Vec<(f64, f64)>> {
    let inside = |p: (f64, f64)| p.0.is_finite() && p.1.is_finite() && p.1 >= y0 && p.1 <= y1;
    let cross = |a: (f64, f64), b: (f64, f64), y: f64| {
        let t = (y - a.1) / (b.1 - a.1);
        (a.0 + t * (b.0 - a.0), y)
    };
    let mut runs = Vec::new();
    let mut run: Vec<(f64, f64)> = Vec::new();
    for (k, &p) in points.iter().enumerate() {
        let prev = k.checked_sub(1).map(|j| points[j]);
        let finite = |q: (f64, f64)| q.0.is_finite() && q.1.is_finite();
        match (prev.filter(|q| finite(*q)), inside(p)) {
            (_, true) if run.is_empty() => {
                if let Some(q) = prev.filter(|q| finite(*q) && !inside(*q)) {
                    run.push(cross(q, p, if q.1 > y1 { y1 } else { y0 }));
                }
                run.push(p);
            }
            (_, true) => run.push(p),
            (Some(q), false) if finite(p) => {
                if inside(q) {
                    run.push(cross(q, p, if p.1 > y1 { y1 } else { y0 }));
                } else if (q.1 > y1 && p.1 < y0) || (q.1 < y0 && p.1 > y1) {
                    // Through the whole frame between two samples.
                    let (a, b) = if q.1 > y1 { (y1, y0) } else { (y0, y1) };
                    runs.push(vec![cross(q, p, a), cross(q, p, b)]);
                }
                if !run.is_empty() {
                    runs.push(std::mem::take(&mut run));
                }
            }
            _ => {
                if !run.is_empty() {
                    runs.push(std::mem::take(&mut run));
                }
            }
        }
    }
    if !run.is_empty() {
        runs.push(run);
    }
    runs
}

/// Least width of the legend panel at the right of every figure (px): the legend never covers
/// data.
const LEGEND_WIDTH: u32 = 250;

/// The legend panel's width for these entries: the longest label's at 7 px a character (the
/// 12 px font's widest average) after the 42 px of its swatch, so that no label is cut.
fn legend_width(series: &[Series], shades: &[Shade]) -> u32 {
    series
        .iter()
        .map(|s| s.name.chars().count())
        .chain(shades.iter().map(|s| s.label.chars().count()))
        .map(|n| 42 + 7 * n as u32 + 8)
        .max()
        .unwrap_or(0)
        .max(LEGEND_WIDTH)
}

/// The data's bounds: x from every series, y from `y_range` or the series.
fn bounds(c: &Chart) -> (f64, f64, f64, f64) {
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for &(x, y) in c.series.iter().flat_map(|s| s.points.iter()) {
        if x.is_finite() && y.is_finite() && (!c.log_y || y > 0.0) {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
    }
    if let Some(r) = c.x_range {
        (x0, x1) = r;
    }
    if x0.partial_cmp(&x1) != Some(std::cmp::Ordering::Less) {
        (x0, x1) = (0.0, 1.0);
    }
    if let Some(r) = c.y_range {
        (y0, y1) = r;
    } else if y0.partial_cmp(&y1) != Some(std::cmp::Ordering::Less) {
        (y0, y1) = if c.log_y { (1e-6, 1.0) } else { (-1.0, 1.0) };
    } else if !c.log_y {
        let pad = 0.05 * (y1 - y0);
        (y0, y1) = (y0 - pad, y1 + pad);
    }
    (x0, x1, y0, y1)
}

fn err(e: &dyn std::fmt::Display) -> PlotError {
    PlotError(e.to_string())
}

/// The axes, grid and labels of a chart, the y ticks written by `$y_fmt` (linear and
/// logarithmic axes are different types, hence a macro).
macro_rules! mesh {
    ($chart:expr, $c:expr, $xd:expr, $y_fmt:expr) => {
        $chart
            .configure_mesh()
            .x_desc($c.x_label)
            .y_desc($c.y_label)
            .label_style((FONT_NAME, 12))
            .x_label_formatter(&|v| tick(*v, $xd))
            .y_label_formatter($y_fmt)
            .draw()
            .map_err(|e| err(&e))
    };
}

/// Draws `c` into `area` (no legend: see [`legend_into`]).
fn plot_into<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, c: &Chart) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let (x0, x1, y0, y1) = bounds(c);
    let mut builder = ChartBuilder::on(area);
    if !c.title.is_empty() {
        builder.caption(c.title, (FONT_NAME, 16).into_font());
    }
    builder
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(74);
    let xd = decimals_for(x1 - x0);
    let columns = area.dim_in_pixel().0 as usize;
    if c.log_y {
        let (ly0, ly1) = (y0.max(y1 * 1e-6), y1 * 2.0);
        let mut chart = builder
            .build_cartesian_2d(x0..x1, (ly0..ly1).log_scale())
            .map_err(|e| err(&e))?;
        mesh!(chart, c, xd, &|v: &f64| format!("{v:.0e}"))?;
        for s in c.series {
            let pts: Vec<(f64, f64)> = decimate(&s.points, (x0, x1), columns)
                .into_iter()
                .filter(|p| p.1 > 0.0 && p.1.is_finite())
                .collect();
            draw_marks(&mut chart, s, vec![pts])?;
        }
    } else {
        let yd = decimals_for(y1 - y0);
        let mut chart = builder
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| err(&e))?;
        let mut labels: Vec<&str> = Vec::new();
        for sh in c.shades {
            if !labels.contains(&sh.label.as_str()) {
                labels.push(&sh.label);
            }
        }
        let strip = if labels.len() > 1 {
            // 10 px per label's row, in data units.
            let rows_px = area.dim_in_pixel().1.saturating_sub(44 + 24).max(1) as f64;
            Some(10.0 * (y1 - y0) / rows_px)
        } else {
            None
        };
        for sh in c.shades {
            let (a, b) = (sh.from.max(x0), sh.to.min(x1));
            if a >= b {
                continue;
            }
            let (lo, hi, alpha) = match strip {
                Some(h) => {
                    let row = labels.iter().position(|l| *l == sh.label).unwrap_or(0) as f64;
                    (y1 - (row + 1.0) * h, y1 - row * h, 0.55)
                }
                None => (y0, y1, 0.12),
            };
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(a, lo), (b, hi)],
                    sh.color.mix(alpha).filled(),
                )))
                .map_err(|e| err(&e))?;
        }
        mesh!(chart, c, xd, &|v: &f64| tick(*v, yd))?;
        for s in c.series {
            let pts = decimate(&s.points, (x0, x1), columns);
            let runs = match s.mark {
                Mark::Dots => vec![pts
                    .into_iter()
                    .filter(|p| p.1.is_finite() && p.1 >= y0 && p.1 <= y1)
                    .collect()],
                _ => clip(&pts, (y0, y1)),
            };
            draw_marks(&mut chart, s, runs)?;
        }
        // The events (the shaded ranges are named in the legend).
        let font = (FONT_NAME, 12).into_font();
        for ev in c.events.iter().filter(|e| e.at >= x0 && e.at <= x1) {
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(ev.at, y0), (ev.at, y1)],
                    5,
                    4,
                    BLACK.stroke_width(1),
                ))
                .map_err(|e| err(&e))?;
            let pos = chart.backend_coord(&(ev.at, y1));
            area.draw(&Text::new(
                ev.label.clone(),
                (pos.0 + 4, pos.1 + 18),
                font.clone(),
            ))
            .map_err(|e| err(&e))?;
        }
    }
    Ok(())
}

/// Draws a series' runs in its mark.
fn draw_marks<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate<From = (f64, f64)>>(
    chart: &mut ChartContext<'a, DB, CT>,
    s: &Series,
    runs: Vec<Vec<(f64, f64)>>,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let color = s.color;
    for run in runs {
        match s.mark {
            Mark::Line => chart.draw_series(LineSeries::new(run, color.stroke_width(2))),
            Mark::Bar => chart.draw_series(LineSeries::new(run, color.stroke_width(1))),
            Mark::Thin => chart.draw_series(LineSeries::new(run, color.mix(0.45).stroke_width(1))),
            Mark::Dashed => {
                let scale = pixels_per_unit(chart);
                for dash in dashes(&run, scale, 7.0, 5.0) {
                    chart
                        .draw_series(LineSeries::new(dash, color.stroke_width(2)))
                        .map_err(|e| err(&e))?;
                }
                continue;
            }
            Mark::Dots => {
                chart.draw_series(run.into_iter().map(|p| Circle::new(p, 2, color.filled())))
            }
        }
        .map_err(|e| err(&e))?;
    }
    Ok(())
}

/// Pixels per data unit in x and y of a chart's plotting area.
fn pixels_per_unit<DB: DrawingBackend, CT: plotters::coord::CoordTranslate<From = (f64, f64)>>(
    chart: &ChartContext<'_, DB, CT>,
) -> (f64, f64) {
    let spec = chart.as_coord_spec();
    let (p0, px, py) = (
        spec.translate(&(0.0, 0.0)),
        spec.translate(&(1.0, 0.0)),
        spec.translate(&(0.0, 1.0)),
    );
    (
        f64::from(px.0 - p0.0).abs().max(1e-12),
        f64::from(py.1 - p0.1).abs().max(1e-12),
    )
}

/// A polyline cut into dashes `on` pixels long with `off`-pixel gaps, measured along the curve
/// (the pattern runs on across the points, so a finely sampled curve stays smooth).
pub fn dashes(
    points: &[(f64, f64)],
    (sx, sy): (f64, f64),
    on: f64,
    off: f64,
) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let mut current: Vec<(f64, f64)> = Vec::new();
    let (mut drawing, mut left) = (true, on);
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = ((b.0 - a.0) * sx).hypot((b.1 - a.1) * sy);
        if !len.is_finite() || len == 0.0 {
            continue;
        }
        let mut at = 0.0;
        if drawing && current.is_empty() {
            current.push(a);
        }
        while len - at > left {
            at += left;
            let t = at / len;
            let p = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
            if drawing {
                current.push(p);
                out.push(std::mem::take(&mut current));
                left = off;
            } else {
                current.push(p);
                left = on;
            }
            drawing = !drawing;
        }
        left -= len - at;
        if drawing {
            current.push(b);
        }
    }
    if current.len() > 1 {
        out.push(current);
    }
    out
}

/// The legend of `series` (named ones) and `shades` in its own panel, each entry drawn in its
/// series' mark.
fn legend_into<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    series: &[Series],
    shades: &[Shade],
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let font = (FONT_NAME, 12).into_font();
    let mut y = 52;
    let mut seen: Vec<String> = Vec::new();
    for s in series.iter().filter(|s| !s.name.is_empty()) {
        if seen.contains(&s.name) {
            continue;
        }
        seen.push(s.name.clone());
        let (x, c) = (8, s.color);
        match s.mark {
            Mark::Line => area.draw(&PathElement::new(
                vec![(x, y), (x + 26, y)],
                c.stroke_width(2),
            )),
            Mark::Bar => area.draw(&PathElement::new(
                vec![(x, y), (x + 26, y)],
                c.stroke_width(1),
            )),
            Mark::Thin => area.draw(&PathElement::new(
                vec![(x, y), (x + 26, y)],
                c.mix(0.45).stroke_width(1),
            )),
            Mark::Dashed => area
                .draw(&PathElement::new(
                    vec![(x, y), (x + 9, y)],
                    c.stroke_width(2),
                ))
                .and_then(|()| {
                    area.draw(&PathElement::new(
                        vec![(x + 15, y), (x + 26, y)],
                        c.stroke_width(2),
                    ))
                }),
            Mark::Dots => area
                .draw(&Circle::new((x + 6, y), 3, c.filled()))
                .and_then(|()| area.draw(&Circle::new((x + 19, y), 3, c.filled()))),
        }
        .map_err(|e| err(&e))?;
        area.draw(&Text::new(s.name.clone(), (x + 34, y - 7), font.clone()))
            .map_err(|e| err(&e))?;
        y += 20;
    }
    for sh in shades.iter().filter(|s| !s.label.is_empty()) {
        if seen.contains(&sh.label) {
            continue;
        }
        seen.push(sh.label.clone());
        area.draw(&Rectangle::new(
            [(8, y - 6), (34, y + 6)],
            sh.color.mix(0.2).filled(),
        ))
        .map_err(|e| err(&e))?;
        area.draw(&Text::new(sh.label.clone(), (42, y - 7), font.clone()))
            .map_err(|e| err(&e))?;
        y += 20;
    }
    Ok(())
}

/// A figure: the chart at the left, its legend in a panel at the right.
pub fn chart_svg(c: &Chart) -> Result<String, PlotError> {
    register_font();
    stacked_svg(&[(HEIGHT, c.clone())])
}

/// Charts stacked over one x axis (each `(height in px, chart)`): the x range is the union of
/// theirs, so that a time or a speed lies at the same place in every panel, and one legend at
/// the right holds every panel's entries.
pub fn stacked_svg(panels: &[(u32, Chart<'_>)]) -> Result<String, PlotError> {
    register_font();
    let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
    for (_, c) in panels {
        let (a, b, _, _) = bounds(c);
        x0 = x0.min(a);
        x1 = x1.max(b);
    }
    let series: Vec<Series> = panels.iter().flat_map(|(_, c)| c.series.to_vec()).collect();
    let shades: Vec<Shade> = panels.iter().flat_map(|(_, c)| c.shades.to_vec()).collect();
    let legend_w = legend_width(&series, &shades);
    let height: u32 = panels.iter().map(|(h, _)| h).sum();
    let mut svg = String::new();
    {
        let root =
            SVGBackend::with_string(&mut svg, (WIDTH + legend_w, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let (mut plot, legend) = root.split_horizontally(WIDTH);
        for (h, c) in panels {
            let (this, rest) = plot.split_vertically(*h);
            let c = Chart {
                x_range: Some((x0, x1)),
                ..c.clone()
            };
            plot_into(&this, &c)?;
            plot = rest;
        }
        legend_into(&legend, &series, &shades)?;
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}

/// An x–y chart of several series with a legend; `log_y` for spectra.
pub fn chart(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    log_y: bool,
) -> Result<String, PlotError> {
    chart_svg(&Chart {
        title,
        x_label,
        y_label,
        series,
        log_y,
        ..Chart::default()
    })
}

/// The signal (grey dots) and the fitted damped sinusoid over the free-decay segment (red
/// line), and under them the residual, measured − fitted, over the segment.
pub fn fit_svg(signal: &Signal, osc: &Oscillation, title: &str) -> Result<String, PlotError> {
    register_font();
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
    let residual: Vec<(f64, f64)> = data
        .iter()
        .filter(|p| p.0 >= a && p.0 <= b && p.1.is_finite())
        .map(|&(ti, v)| (ti, v - osc.fit.eval(ti)))
        .collect();
    let unit = if signal.unit.is_empty() {
        String::new()
    } else {
        format!(" ({})", signal.unit)
    };
    let grey = RGBColor(120, 120, 120);
    let red = RGBColor(200, 30, 30);
    let series = [
        Series {
            name: "measured".into(),
            points: data,
            color: grey,
            mark: Mark::Dots,
        },
        Series {
            name: "fitted damped sinusoid".into(),
            points: fitted,
            color: red,
            mark: Mark::Line,
        },
    ];
    let shades = [Shade {
        from: a,
        to: b,
        color: RGBColor(120, 120, 120),
        label: "fitted segment".into(),
    }];
    let y_label = format!("signal{unit}");
    let residual_label = format!("residual{unit}");
    let zero = Series {
        name: String::new(),
        points: vec![(a, 0.0), (b, 0.0)],
        color: red,
        mark: Mark::Bar,
    };
    let residual_series = [
        Series {
            name: "residual, measured − fitted".into(),
            points: residual,
            color: RGBColor(30, 60, 200),
            mark: Mark::Dots,
        },
        zero,
    ];
    stacked_svg(&[
        (
            HEIGHT,
            Chart {
                title,
                x_label: "time (s)",
                y_label: &y_label,
                series: &series,
                shades: &shades,
                ..Chart::default()
            },
        ),
        (
            HEIGHT / 2,
            Chart {
                x_label: "time (s)",
                y_label: &residual_label,
                series: &residual_series,
                ..Chart::default()
            },
        ),
    ])
}

/// The Hann spectrum of the fitted segment up to 4× the main frequency, with the peaks marked.
pub fn spectrum_svg(sig: &Signal, osc: &Oscillation, title: &str) -> Result<String, PlotError> {
    let f_max = 4.0 * osc.fit.freq_hz().value;
    let sp = &osc.spectrum(sig);
    let pts: Vec<(f64, f64)> = sp
        .freq_hz
        .iter()
        .zip(&sp.magnitude)
        .filter(|(f, _)| **f <= f_max && **f > 0.0)
        .map(|(f, m)| (*f, *m))
        .collect();
    let mut marks = vec![(osc.fit.freq_hz().value, osc.main_peak.magnitude)];
    marks.extend(osc.secondary_peaks.iter().map(|p| (p.freq_hz, p.magnitude)));
    let y_label = if sig.unit.is_empty() {
        "amplitude (the signal's unit)".to_string()
    } else {
        format!("amplitude ({})", sig.unit)
    };
    chart(
        title,
        "frequency (Hz)",
        &y_label,
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

/// A colour at half its brightness (castor beside capsize).
fn darker(c: RGBColor) -> RGBColor {
    RGBColor(c.0 / 2, c.1 / 2, c.2 / 2)
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
                mark: Mark::Bar,
            });
        }
    }
    out
}

/// A ride's roll and steer (mrad, as the text's noise and residuals) against time: the measured
/// angles as dots, the fitted modes over the fitted window (shaded) as lines, the `events`
/// (the kick, the catch: time s and name) marked where they fall in the plot. `measured` and
/// `fitted` rows are (t s, θ rad, γ rad).
pub fn ride_svg(
    title: &str,
    measured: &[[f64; 3]],
    fitted: &[[f64; 3]],
    window_s: (f64, f64),
    events: &[(f64, &str)],
) -> Result<String, PlotError> {
    let (blue, red) = (RGBColor(30, 80, 200), RGBColor(200, 40, 40));
    let (pale_blue, pale_red) = (RGBColor(140, 165, 230), RGBColor(235, 150, 150));
    let column = |rows: &[[f64; 3]], k: usize| -> Vec<(f64, f64)> {
        rows.iter().map(|r| (r[0], 1e3 * r[k])).collect()
    };
    let series = [
        (
            "roll θ, measured",
            column(measured, 1),
            pale_blue,
            Mark::Dots,
        ),
        (
            "steer γ, measured",
            column(measured, 2),
            pale_red,
            Mark::Dots,
        ),
        ("roll θ, fitted modes", column(fitted, 1), blue, Mark::Line),
        ("steer γ, fitted modes", column(fitted, 2), red, Mark::Line),
    ]
    .map(|(name, points, color, mark)| Series {
        name: name.to_string(),
        points,
        color,
        mark,
    });
    chart_svg(&Chart {
        title,
        x_label: "time in the log (s)",
        y_label: "angle (mrad)",
        series: &series,
        shades: &[Shade {
            from: window_s.0,
            to: window_s.1,
            color: RGBColor(120, 120, 120),
            label: "fitted window".into(),
        }],
        events: &events
            .iter()
            .map(|&(at, label)| Event {
                at,
                label: label.into(),
            })
            .collect::<Vec<_>>(),
        ..Chart::default()
    })
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
    let (mut series, shades) = continuation_layers(bikes);
    series.extend_from_slice(extra);
    chart_svg(&continuation_chart(title, &series, &shades, y_range))
}

/// The chart of a continuation diagram: eigenvalues against speed, y in `y_range`.
fn continuation_chart<'a>(
    title: &'a str,
    series: &'a [Series],
    shades: &'a [Shade],
    y_range: (f64, f64),
) -> Chart<'a> {
    Chart {
        title,
        x_label: "speed (m/s)",
        y_label: "eigenvalue: real part (1/s), imaginary (rad/s)",
        series,
        shades,
        y_range: Some(y_range),
        ..Chart::default()
    }
}

/// Several bicycles' continuation diagrams overlaid (as [`continuation_svg`], y in
/// `y_range`), and under them a detail of the real parts near zero (y in `±detail`), where the
/// weave and capsize speeds are read (as the seed's Figs. 16–17).
pub fn comparison_svg(
    title: &str,
    bikes: &[Continuation<'_>],
    y_range: (f64, f64),
    detail: f64,
) -> Result<String, PlotError> {
    let (series, shades) = continuation_layers(bikes);
    // The detail repeats the real parts without legend entries (the panel above names them).
    let detail_series: Vec<Series> = series
        .iter()
        .filter(|s| !matches!(s.mark, Mark::Dashed))
        .map(|s| Series {
            name: String::new(),
            ..s.clone()
        })
        .collect();
    let detail_title = format!("detail: real parts near zero (±{detail} 1/s)");
    stacked_svg(&[
        (HEIGHT, continuation_chart(title, &series, &shades, y_range)),
        (
            HEIGHT * 3 / 4,
            Chart {
                title: &detail_title,
                x_label: "speed (m/s)",
                y_label: "real part (1/s)",
                series: &detail_series,
                y_range: Some((-detail, detail)),
                ..Chart::default()
            },
        ),
    ])
}

/// The series and shades of overlaid continuation diagrams: per bicycle the weave's real and
/// imaginary parts, capsize and castor, their ±2 SE bands and the stable ranges.
fn continuation_layers(bikes: &[Continuation<'_>]) -> (Vec<Series>, Vec<Shade>) {
    let mut series = Vec::new();
    let mut shades = Vec::new();
    for b in bikes {
        let sw = &b.bands.sweep;
        let pick =
            |k: usize, f: &dyn Fn(nalgebra::Complex<f64>, (f64, f64)) -> f64| -> Vec<(f64, f64)> {
                sw.speeds_mps
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| (v, f(sw.eigenvalues[i][k], b.bands.se[i][k])))
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
        // Below the merge speed the weave is two real roots: both drawn.
        series.push(Series {
            name: String::new(),
            points: pick(1, &|z, _| z.re),
            color: b.color,
            mark: Mark::Line,
        });
        let castor = darker(b.color_real);
        series.push(Series {
            name: label("capsize, real part"),
            points: pick(2, &|z, _| z.re),
            color: b.color_real,
            mark: Mark::Line,
        });
        series.push(Series {
            name: label("castor, real part"),
            points: pick(3, &|z, _| z.re),
            color: castor,
            mark: Mark::Line,
        });
        // The bands at ±2 standard errors, left out where a pair of roots is within them of
        // each other: at a double root (the weave's merge, capsize meeting castor) the
        // eigenvalue is not differentiable in the parameters and the linear propagation's error
        // is not one (it shot up to a spike there).
        for k in [0, 1, 2, 3] {
            let partner = k ^ 1;
            for sign in [-2.0, 2.0] {
                let c = [b.color, b.color, b.color_real, castor][k];
                let points = sw
                    .speeds_mps
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| {
                        let (z, w) = (sw.eigenvalues[i][k], sw.eigenvalues[i][partner]);
                        let (se, se_w) = (b.bands.se[i][k], b.bands.se[i][partner]);
                        let reach = 2.0 * (se.0.hypot(se.1) + se_w.0.hypot(se_w.1));
                        let near_double = z != w.conj() && (z - w).norm() < reach;
                        (
                            v,
                            if near_double {
                                f64::NAN
                            } else {
                                z.re + sign * se.0
                            },
                        )
                    })
                    .collect();
                series.push(Series {
                    name: String::new(),
                    points,
                    color: c,
                    mark: Mark::Thin,
                });
            }
        }
        for &(lo, hi) in b.stable {
            shades.push(Shade {
                from: lo,
                to: hi.unwrap_or(f64::INFINITY),
                color: b.color,
                label: label("stable"),
            });
        }
    }
    (series, shades)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_never_show_negative_zero_or_trailing_zeros() {
        assert_eq!(tick(-0.0001, 3), "0");
        assert_eq!(tick(-0.5, 1), "-0.5");
        assert_eq!(tick(2.5, 3), "2.5");
        assert_eq!(tick(5.0, 3), "5");
        assert_eq!(tick(40.0, 0), "40");
    }

    /// Dashes run on across points: a straight line of 48 px sampled every px gives four
    /// 7 px dashes with 5 px gaps.
    #[test]
    fn dashes_follow_the_curve() {
        let pts: Vec<(f64, f64)> = (0..=48).map(|i| (i as f64, 0.0)).collect();
        let d = dashes(&pts, (1.0, 1.0), 7.0, 5.0);
        assert_eq!(d.len(), 4);
        for (k, dash) in d.iter().enumerate() {
            let start = 12.0 * k as f64;
            assert!((dash[0].0 - start).abs() < 1e-9, "{dash:?}");
            assert!(
                (dash.last().unwrap().0 - (start + 7.0)).abs() < 1e-9,
                "{dash:?}"
            );
        }
    }

    /// A curve leaving the frame is cut where it crosses it, not drawn along the edge.
    #[test]
    fn clipping_cuts_at_the_frame() {
        let pts = [(0.0, 0.0), (1.0, 2.0), (2.0, 4.0), (3.0, 2.0), (4.0, 0.0)];
        let runs = clip(&pts, (-1.0, 3.0));
        assert_eq!(runs.len(), 2);
        assert_eq!(runs[0], vec![(0.0, 0.0), (1.0, 2.0), (1.5, 3.0)]);
        assert_eq!(runs[1], vec![(2.5, 3.0), (3.0, 2.0), (4.0, 0.0)]);
        // Through the whole frame between two samples.
        let runs = clip(&[(0.0, -5.0), (1.0, 5.0)], (-1.0, 1.0));
        assert_eq!(runs, vec![vec![(0.4, -1.0), (0.6, 1.0)]]);
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
