//! Spectral stage: a [`Signal`] → its amplitude spectrum and peaks.
//!
//! In: a signal on a uniform grid (gaps allowed). Out: the magnitude of a Hann-windowed,
//! zero-padded FFT (rustfft), the main peak located between bins by Gaussian (log-parabolic)
//! interpolation, and secondary peaks — a second peak is itself a finding (the Cardan joint's
//! swing mode, seed §5.3.3.4 and §5.3.4.5).
//!
//! This is the lab's method (seed §5.3.3.2: the FFT's peak) made sub-bin; it serves as the first
//! guess of the least-squares fit in [`crate::fit`], which is what the results come from.
//!
//! [`Spectrum`] is the whole padded spectrum (for figures); [`ZoomSpectrum`] gives the same
//! peaks for the fit at an eighth of the transform: the record's own length transformed, and
//! the padded bins evaluated (Goertzel) only around the coarse peaks that could matter.

use crate::signal::Signal;
use rustfft::{num_complex::Complex, FftPlanner};

/// Zero padding: the transform length is at least this many times the record's length.
pub const PAD_FACTOR: usize = 8;
/// The padded transform is never longer than this (a one-hour log at 100 Hz needs 2²²).
const MAX_FFT_LEN: usize = 1 << 22;

/// The one-sided amplitude spectrum of a signal.
#[derive(Debug, Clone)]
pub struct Spectrum {
    /// Frequency of each padded bin, Hz.
    pub freq_hz: Vec<f64>,
    /// |X(f)|, normalised so that a sinusoid of amplitude A gives a peak of about A.
    pub magnitude: Vec<f64>,
    /// Resolution of the unpadded record, `sample_rate / N` (Hz): the lab's FFT bin.
    pub resolution_hz: f64,
}

/// The data window of a spectrum.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Window {
    /// Periodic Hann: low leakage, for steady or slowly decaying records.
    Hann,
    /// No taper: for a stretch that starts inside a free decay, which tapers itself.
    Rectangular,
}

/// A spectral peak.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Peak {
    /// Interpolated peak frequency, Hz.
    pub freq_hz: f64,
    /// Interpolated magnitude.
    pub magnitude: f64,
}

/// Least-squares straight line through `(t, x)`: returns `(intercept at t = 0, slope)`.
pub fn linear_trend(t: &[f64], x: &[f64]) -> (f64, f64) {
    let n = t.len() as f64;
    if t.len() < 2 {
        return (x.first().copied().unwrap_or(0.0), 0.0);
    }
    let tm = t.iter().sum::<f64>() / n;
    let xm = x.iter().sum::<f64>() / n;
    let (mut stt, mut stx) = (0.0, 0.0);
    for (&ti, &xi) in t.iter().zip(x) {
        stt += (ti - tm) * (ti - tm);
        stx += (ti - tm) * (xi - xm);
    }
    let slope = if stt > 0.0 { stx / stt } else { 0.0 };
    (xm - slope * tm, slope)
}

impl Spectrum {
    /// The spectrum of `signal` after removing its straight-line trend; gaps are zero after
    /// detrending (they lower the peak a little, they do not move it).
    ///
    /// # Panics
    /// Never on data; an empty signal gives an empty spectrum.
    pub fn of(signal: &Signal, window: Window) -> Spectrum {
        let (Some(&first), Some(&last)) = (signal.index.first(), signal.index.last()) else {
            return Spectrum {
                freq_hz: vec![],
                magnitude: vec![],
                resolution_hz: f64::NAN,
            };
        };
        let grid = detrended_grid(signal, first, last);
        spectrum_of_grid(&grid, signal.sample_rate_hz, window)
    }

    /// Peaks, strongest first: local maxima at or above `min_freq_hz`, at least 2 unpadded bins
    /// apart (the Hann window's main-lobe half-width), at least `min_relative` of the strongest
    /// and clearly above the noise floor (5× the median magnitude).
    pub fn peaks(&self, min_freq_hz: f64, min_relative: f64, max_count: usize) -> Vec<Peak> {
        let m = &self.magnitude;
        if m.len() < 3 {
            return vec![];
        }
        let floor = noise_floor(m);
        let candidates: Vec<Peak> = (1..m.len() - 1)
            .filter(|&k| {
                m[k] > m[k - 1]
                    && m[k] >= m[k + 1]
                    && self.freq_hz[k] >= min_freq_hz
                    && m[k] > floor
            })
            .map(|k| self.interpolate(k))
            .collect();
        select_peaks(
            candidates,
            min_relative,
            2.0 * self.resolution_hz,
            max_count,
        )
    }

    /// The strongest peak at or above `min_freq_hz`.
    pub fn main_peak(&self, min_freq_hz: f64) -> Option<Peak> {
        self.peaks(min_freq_hz, 1.0, 1).into_iter().next()
    }

    /// Gaussian interpolation: a parabola through the logarithms of three bins.
    fn interpolate(&self, k: usize) -> Peak {
        let df = self.freq_hz[1] - self.freq_hz[0];
        let m = &self.magnitude;
        interpolate_peak(self.freq_hz[k], df, (m[k - 1], m[k], m[k + 1]))
    }
}

/// Transforms kept between calls on one thread: rustfft's planner (the plans of the lengths
/// seen), the real transform's twiddle factors per length, and the work buffer (kept up to
/// [`KEEP_BUFFER_LEN`] points, so that repeated spectra do not fault fresh pages in).
struct Transforms {
    planner: FftPlanner<f64>,
    twiddles: Vec<(usize, Vec<Complex<f64>>)>,
    buffer: Vec<Complex<f64>>,
}

/// The largest work buffer a thread keeps between spectra (16 MB).
const KEEP_BUFFER_LEN: usize = 1 << 20;

thread_local! {
    static TRANSFORMS: std::cell::RefCell<Transforms> = std::cell::RefCell::new(Transforms {
        planner: FftPlanner::new(),
        twiddles: Vec::new(),
        buffer: Vec::new(),
    });
}

/// `|X_k|` for k = 0…len/2 of the DFT of the real sequence `x` zero-padded to `len` (even),
/// each input sample weighted by `w(i)`. The real transform as a complex one of half the length
/// (Brigham, "The Fast Fourier Transform", §10.10): z_j = x_{2j} + i x_{2j+1}, Z = DFT_{len/2}(z),
/// X_k = E_k + e^{−2πik/len} O_k with E_k = (Z_k + Z̄_{M−k})/2 and O_k = (Z_k − Z̄_{M−k})/(2i).
fn real_dft_magnitudes(x: &[f64], w: impl Fn(usize) -> f64, len: usize) -> Vec<f64> {
    let m = len / 2;
    TRANSFORMS.with(|cell| {
        let mut tr = cell.borrow_mut();
        let Transforms {
            planner,
            twiddles,
            buffer,
        } = &mut *tr;
        buffer.clear();
        buffer.resize(m, Complex::new(0.0, 0.0));
        for (j, slot) in buffer.iter_mut().enumerate() {
            let (i0, i1) = (2 * j, 2 * j + 1);
            let re = x.get(i0).map_or(0.0, |v| v * w(i0));
            let im = x.get(i1).map_or(0.0, |v| v * w(i1));
            if i0 >= x.len() {
                break;
            }
            *slot = Complex::new(re, im);
        }
        planner.plan_fft_forward(m).process(buffer);
        let tw = match twiddles.iter().position(|(l, _)| *l == len) {
            Some(k) => &twiddles[k].1,
            None => {
                let step = -2.0 * std::f64::consts::PI / len as f64;
                let t: Vec<Complex<f64>> = (0..=m)
                    .map(|k| {
                        let (s, c) = (step * k as f64).sin_cos();
                        Complex::new(c, s)
                    })
                    .collect();
                twiddles.push((len, t));
                &twiddles[twiddles.len() - 1].1
            }
        };
        // Z at k and at M − k, both taken modulo M (Z_M is Z_0): no division per bin.
        let z_at = |k: usize| if k == m { buffer[0] } else { buffer[k] };
        let out = (0..=m)
            .map(|k| {
                let zk = z_at(k);
                let zc = z_at(m - k).conj();
                let even = (zk + zc) * 0.5;
                let odd = (zk - zc) * Complex::new(0.0, -0.5);
                let xk = even + tw[k] * odd;
                xk.norm_sqr().sqrt()
            })
            .collect();
        if buffer.len() > KEEP_BUFFER_LEN {
            *buffer = Vec::new();
        }
        out
    })
}

/// The signal less its straight-line trend on its full grid of `last − first + 1` samples,
/// zero at the gaps.
fn detrended_grid(signal: &Signal, first: u64, last: u64) -> Vec<f64> {
    let n = (last - first + 1) as usize;
    let t = signal.times_s();
    let (a, b) = linear_trend(&t, &signal.values);
    let mut grid = vec![0.0; n];
    for ((&i, &v), &ti) in signal.index.iter().zip(&signal.values).zip(&t) {
        grid[(i - first) as usize] = v - (a + b * ti);
    }
    grid
}

/// The length of the padded transform of `n` samples: [`PAD_FACTOR`] times the next power of
/// two, at most [`MAX_FFT_LEN`], and even (so that the real transform can halve it).
fn padded_len(n: usize) -> usize {
    (n.next_power_of_two() * PAD_FACTOR)
        .min(MAX_FFT_LEN)
        .max(n + n % 2)
}

/// The window's weight of sample `i` of `n`.
fn window_weight(window: Window, i: usize, n: usize) -> f64 {
    match window {
        Window::Hann => 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos(),
        Window::Rectangular => 1.0,
    }
}

/// The amplitude scale of a spectrum of `n` samples: 2 / Σw, so that a sinusoid of amplitude
/// A peaks at about A.
fn amplitude_scale(window: Window, n: usize) -> f64 {
    let wsum: f64 = match window {
        Window::Hann => (0..n).map(|i| window_weight(window, i, n)).sum(),
        Window::Rectangular => n as f64,
    };
    if wsum > 0.0 {
        2.0 / wsum
    } else {
        0.0
    }
}

fn spectrum_of_grid(grid: &[f64], rate_hz: f64, window: Window) -> Spectrum {
    let n = grid.len();
    let len = padded_len(n);
    let weight = |i: usize| window_weight(window, i, n);
    let scale = amplitude_scale(window, n);
    let mut magnitude = real_dft_magnitudes(grid, weight, len);
    for v in &mut magnitude {
        *v *= scale;
    }
    Spectrum {
        freq_hz: (0..magnitude.len())
            .map(|k| k as f64 * rate_hz / len as f64)
            .collect(),
        magnitude,
        resolution_hz: rate_hz / n as f64,
    }
}

/// Coarse bins whose magnitude is below this fraction of a wanted level cannot hold a padded
/// peak at that level: between two bins one transform length apart a sinusoid's peak sinks by
/// at most 3.92 dB (0.637, rectangular window; 1.42 dB with Hann), and the coarse bins are at
/// most `1/N` apart.
const SCALLOP_FLOOR: f64 = 0.6;

/// The most coarse peaks [`ZoomSpectrum::peaks`] refines, strongest first. Each refinement runs
/// over the whole record; a record of a few dozen samples spread over a 300,000-sample grid by
/// one long hole (found by fuzzing: 42 rows, 516 bytes) has thousands of coarse peaks within the
/// scallop loss of each other, and refining them all took 12 s (0.3 s with this cap). A
/// spectrum that flat has no dominant frequency to find beyond the strongest few; no spectrum
/// of the reports reaches the cap (they regenerate byte for byte with it).
const MAX_REFINED: usize = 64;

/// The padded spectrum of [`Spectrum::of`] where it matters for peaks, at a fraction of its
/// cost: the transform on the record's own length (the next power of two, [`PAD_FACTOR`]
/// times fewer bins), then the padded bins around each coarse peak that could matter
/// evaluated directly (Goertzel's recurrence, all `ZOOM_BINS` of a peak in one pass).
///
/// Its peaks are those of [`Spectrum::of`] (the same padded bins, the same interpolation) with
/// one difference: the noise floor is 5× the median of the coarse bins, not of the padded ones.
/// A padded peak is found if its coarse neighbours reach `SCALLOP_FLOOR` of the level asked
/// for, which a mode's main lobe (two coarse bins wide) always does; a rectangular window's
/// sidelobes, one coarse bin wide, can fall between the coarse bins and be missed (they are
/// leakage, not modes).
#[derive(Debug, Clone)]
pub struct ZoomSpectrum {
    /// The windowed, detrended samples (zero at gaps), times the amplitude scale.
    samples: Vec<f64>,
    /// Magnitudes at the coarse bins `k · rate / (len / PAD_FACTOR)`.
    coarse: Vec<f64>,
    /// The padded transform's length (that of [`Spectrum::of`]).
    len: usize,
    rate_hz: f64,
    /// Resolution of the unpadded record, `sample_rate / N` (Hz): the lab's FFT bin.
    pub resolution_hz: f64,
}

/// Padded bins evaluated around a coarse peak: from the coarse bin before it to the one after.
const ZOOM_BINS: usize = 2 * PAD_FACTOR + 1;

impl ZoomSpectrum {
    /// The zoomed spectrum of `signal` (detrended, gaps zero, as [`Spectrum::of`]). Falls back
    /// to coarse = padded (no zoom needed) when the padded length is not [`PAD_FACTOR`] times
    /// an even length of at least the record's.
    pub fn of(signal: &Signal, window: Window) -> ZoomSpectrum {
        let (Some(&first), Some(&last)) = (signal.index.first(), signal.index.last()) else {
            return ZoomSpectrum {
                samples: vec![],
                coarse: vec![],
                len: 0,
                rate_hz: signal.sample_rate_hz,
                resolution_hz: f64::NAN,
            };
        };
        let grid = detrended_grid(signal, first, last);
        let n = grid.len();
        let len = padded_len(n);
        let coarse_len = len / PAD_FACTOR;
        let zoomed = len % PAD_FACTOR == 0 && coarse_len >= n && coarse_len % 2 == 0;
        let scale = amplitude_scale(window, n);
        let samples: Vec<f64> = grid
            .iter()
            .enumerate()
            .map(|(i, v)| v * window_weight(window, i, n) * scale)
            .collect();
        let coarse = real_dft_magnitudes(&samples, |_| 1.0, if zoomed { coarse_len } else { len });
        ZoomSpectrum {
            samples,
            coarse,
            len: if zoomed { len } else { 0 },
            rate_hz: signal.sample_rate_hz,
            resolution_hz: signal.sample_rate_hz / n as f64,
        }
    }

    /// Padded bins per coarse bin (1 when the coarse bins are the padded ones).
    fn factor(&self) -> usize {
        if self.len == 0 {
            1
        } else {
            PAD_FACTOR
        }
    }

    /// The padded length (that of the coarse transform when it is not zoomed).
    fn padded_len(&self) -> usize {
        if self.len == 0 {
            2 * (self.coarse.len().max(1) - 1)
        } else {
            self.len
        }
    }

    /// |X| at padded bins `first, first + 1, …, first + NB − 1` (bins past the Nyquist
    /// frequency read 0), by Goertzel's recurrence s_i = x_i + 2 cos(w) s_{i−1} − s_{i−2},
    /// |X(w)|² = s₁² + s₂² − 2 cos(w) s₁ s₂, for all bins in one pass over the samples.
    fn padded_bins<const NB: usize>(&self, first: usize) -> [f64; NB] {
        let len = self.padded_len();
        let count = NB.min((len / 2 + 1).saturating_sub(first));
        let mut coef = [0.0; NB];
        for (b, c) in coef.iter_mut().enumerate() {
            *c = 2.0 * (2.0 * std::f64::consts::PI * (first + b) as f64 / len as f64).cos();
        }
        let (mut s1, mut s2) = ([0.0; NB], [0.0; NB]);
        for &x in &self.samples {
            for b in 0..NB {
                let s0 = x + coef[b] * s1[b] - s2[b];
                s2[b] = s1[b];
                s1[b] = s0;
            }
        }
        let mut out = [0.0; NB];
        for b in 0..count {
            let p = s1[b] * s1[b] + s2[b] * s2[b] - coef[b] * s1[b] * s2[b];
            out[b] = p.max(0.0).sqrt();
        }
        out
    }

    /// The padded peak near coarse bin `k` (a coarse local maximum): the largest interior local
    /// maximum, at or above `min_freq_hz`, of the padded bins within a coarse bin of it;
    /// interpolated as [`Spectrum::peaks`] does. For the `dominant` lobe (the largest coarse
    /// bin, whose padded maximum lies within half a coarse bin of it: nothing leaks into it
    /// strongly enough to move it) the bins within half a coarse bin first, the whole window
    /// only when their largest is at an edge.
    fn refine(&self, k: usize, min_freq_hz: f64, dominant: bool) -> Option<Peak> {
        let f = self.factor();
        let len = self.padded_len();
        let df = self.rate_hz / len as f64;
        if f == 1 {
            let m = &self.coarse;
            return Some(interpolate_peak(
                k as f64 * df,
                df,
                (m[k - 1], m[k], m[k + 1]),
            ));
        }
        // The dominant lobe's half-bin window, kept unless its largest bin is at an edge.
        let half = PAD_FACTOR / 2;
        let near = dominant
            .then(|| self.padded_bins::<{ PAD_FACTOR + 1 }>(k * f - half))
            .filter(|m| {
                let largest = (0..m.len()).max_by(|&a, &b| m[a].total_cmp(&m[b]));
                !matches!(largest, Some(0) | Some(PAD_FACTOR))
            });
        let (first, m): (usize, Vec<f64>) = match near {
            Some(m) => (k * f - half, m.to_vec()),
            None => (
                (k - 1) * f,
                self.padded_bins::<ZOOM_BINS>((k - 1) * f).to_vec(),
            ),
        };
        let count = m.len().min((len / 2 + 1).saturating_sub(first));
        (1..count.saturating_sub(1))
            .filter(|&b| {
                m[b] > m[b - 1] && m[b] >= m[b + 1] && (first + b) as f64 * df >= min_freq_hz
            })
            .max_by(|&a, &b| m[a].total_cmp(&m[b]))
            .map(|b| interpolate_peak((first + b) as f64 * df, df, (m[b - 1], m[b], m[b + 1])))
    }

    /// Peaks as [`Spectrum::peaks`] gives them (strongest first, at least 2 record bins apart,
    /// at least `min_relative` of the strongest, above 5× the median coarse magnitude), and of
    /// at least `min_magnitude`: a coarse peak is refined only if it could reach that and the
    /// floor.
    pub fn peaks(
        &self,
        min_freq_hz: f64,
        min_relative: f64,
        min_magnitude: f64,
        max_count: usize,
    ) -> Vec<Peak> {
        let c = &self.coarse;
        if c.len() < 3 {
            return vec![];
        }
        let floor = noise_floor(c);
        let coarse_df = self.rate_hz / (self.padded_len() / self.factor()) as f64;
        let mut coarse_peaks: Vec<usize> = (1..c.len() - 1)
            .filter(|&k| {
                c[k] > c[k - 1]
                    && c[k] >= c[k + 1]
                    && (k + 1) as f64 * coarse_df >= min_freq_hz
                    && c[k] > SCALLOP_FLOOR * floor.max(min_magnitude)
            })
            .collect();
        coarse_peaks.sort_by(|&a, &b| c[b].total_cmp(&c[a]).then(a.cmp(&b)));
        let coarse_top = c[1..c.len() - 1].iter().copied().fold(0.0, f64::max);
        let mut candidates: Vec<Peak> = Vec::new();
        for k in coarse_peaks.into_iter().take(MAX_REFINED) {
            // Strongest first: once a coarse peak cannot reach the level the list asks for,
            // none after it can.
            let strongest = candidates.iter().map(|p| p.magnitude).fold(0.0, f64::max);
            if c[k] < SCALLOP_FLOOR * min_relative * strongest {
                break;
            }
            if candidates.len() >= max_count.saturating_mul(4).max(8)
                && c[k] < SCALLOP_FLOOR * candidates_kth(&candidates, max_count)
            {
                break;
            }
            let dominant = c[k] >= coarse_top;
            if let Some(p) = self.refine(k, min_freq_hz, dominant) {
                if p.magnitude > floor && p.magnitude >= min_magnitude {
                    candidates.push(p);
                }
            }
        }
        select_peaks(
            candidates,
            min_relative,
            2.0 * self.resolution_hz,
            max_count,
        )
    }

    /// The strongest peak at or above `min_freq_hz`.
    pub fn main_peak(&self, min_freq_hz: f64) -> Option<Peak> {
        self.peaks(min_freq_hz, 1.0, 0.0, 1).into_iter().next()
    }
}

/// The level a peak must stand above: 5× the median magnitude (by selection, O(n): the same
/// element a full sort would put there). `magnitudes` must not be empty.
fn noise_floor(magnitudes: &[f64]) -> f64 {
    let mut scratch = magnitudes.to_vec();
    let mid = scratch.len() / 2;
    5.0 * *scratch.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// The magnitude of the `k`-th strongest of `peaks` (0 if there are fewer).
fn candidates_kth(peaks: &[Peak], k: usize) -> f64 {
    let mut m: Vec<f64> = peaks.iter().map(|p| p.magnitude).collect();
    m.sort_by(|a, b| b.total_cmp(a));
    m.get(k.saturating_sub(1)).copied().unwrap_or(0.0)
}

/// Gaussian interpolation at a bin of frequency `freq_hz` (bins `df` apart) from the
/// magnitudes of the bin before it, it, and the one after: a parabola through their logarithms.
fn interpolate_peak(freq_hz: f64, df: f64, (a, b, c): (f64, f64, f64)) -> Peak {
    if a <= 0.0 || b <= 0.0 || c <= 0.0 {
        return Peak {
            freq_hz,
            magnitude: b,
        };
    }
    let (la, lb, lc) = (a.ln(), b.ln(), c.ln());
    let den = la - 2.0 * lb + lc;
    let delta = if den < 0.0 {
        0.5 * (la - lc) / den
    } else {
        0.0
    };
    let mag = (lb - 0.25 * (la - lc) * delta).exp();
    Peak {
        freq_hz: freq_hz + delta * df,
        magnitude: mag,
    }
}

/// From candidate peaks: strongest first, each at least `min_relative` of the strongest and
/// `apart_hz` from those already taken, at most `max_count`.
fn select_peaks(
    mut candidates: Vec<Peak>,
    min_relative: f64,
    apart_hz: f64,
    max_count: usize,
) -> Vec<Peak> {
    candidates.sort_by(|p, q| q.magnitude.total_cmp(&p.magnitude));
    let mut out: Vec<Peak> = Vec::new();
    for p in candidates {
        if let Some(top) = out.first() {
            if p.magnitude < min_relative * top.magnitude {
                break;
            }
        }
        if out
            .iter()
            .all(|q| (q.freq_hz - p.freq_hz).abs() >= apart_hz)
        {
            out.push(p);
            if out.len() == max_count {
                break;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naive_dft_mag(x: &[f64], len: usize, k: usize) -> f64 {
        let n = x.len();
        let mut re = 0.0;
        let mut im = 0.0;
        let mut wsum = 0.0;
        for (i, &xi) in x.iter().enumerate() {
            let w = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos();
            wsum += w;
            let ph = -2.0 * std::f64::consts::PI * (k * i) as f64 / len as f64;
            re += xi * w * ph.cos();
            im += xi * w * ph.sin();
        }
        (re * re + im * im).sqrt() * 2.0 / wsum
    }

    #[test]
    fn fft_matches_naive_dft() {
        // Seeded pseudo-random input (a fixed LCG), compared with the O(N²) definition.
        let mut uniform = crate::testing::lcg_uniform(12345);
        let x: Vec<f64> = (0..100).map(|_| uniform() - 0.5).collect();
        let sp = spectrum_of_grid(&x, 100.0, Window::Hann);
        let len = (sp.freq_hz.len() - 1) * 2;
        for k in [0, 1, 7, 100, 333, 512] {
            let want = naive_dft_mag(&x, len, k);
            assert!(
                (sp.magnitude[k] - want).abs() < 1e-12 * (1.0 + want),
                "bin {k}"
            );
        }
    }

    /// A seeded record: two decaying sinusoids (0.8 and 2.9 Hz, the second 20 % of the first)
    /// in noise, with a few dropped samples.
    fn two_mode_signal(n: usize) -> Signal {
        let mut uniform = crate::testing::lcg_uniform(777);
        let index: Vec<u64> = (0..n as u64).filter(|i| i % 397 != 5).collect();
        let values = index
            .iter()
            .map(|&i| {
                let t = i as f64 / 100.0;
                let two_pi = 2.0 * std::f64::consts::PI;
                (-0.03 * t).exp() * (two_pi * 0.8003 * t + 0.3).cos()
                    + 0.2 * (-0.05 * t).exp() * (two_pi * 2.9 * t).sin()
                    + 0.01 * (uniform() - 0.5)
            })
            .collect();
        Signal {
            name: "x".into(),
            unit: "".into(),
            sample_rate_hz: 100.0,
            t0_s: 0.0,
            index,
            values,
        }
    }

    #[test]
    fn zoomed_peaks_are_the_padded_spectrums() {
        // The padded bins by Goertzel against the whole padded transform: each mode's peak the
        // same, to rounding (the floors differ, coarse vs padded median; both modes stand far
        // above them).
        for n in [1000, 2500, 6000] {
            let sig = two_mode_signal(n);
            for window in [Window::Rectangular, Window::Hann] {
                let full = Spectrum::of(&sig, window).peaks(0.1, 0.0, 12);
                let zoom = ZoomSpectrum::of(&sig, window).peaks(0.1, 0.0, 0.0, 12);
                let near = |peaks: &[Peak], hz: f64| {
                    *peaks
                        .iter()
                        .min_by(|a, b| (a.freq_hz - hz).abs().total_cmp(&(b.freq_hz - hz).abs()))
                        .unwrap()
                };
                for mode_hz in [0.8003, 2.9] {
                    let (f, z) = (near(&full, mode_hz), near(&zoom, mode_hz));
                    assert!((f.freq_hz - mode_hz).abs() < 0.05, "{n} {window:?}: {f:?}");
                    assert!((f.freq_hz - z.freq_hz).abs() < 1e-10, "{f:?} vs {z:?}");
                    assert!(
                        (f.magnitude / z.magnitude - 1.0).abs() < 1e-9,
                        "{f:?} vs {z:?}"
                    );
                }
                let main = ZoomSpectrum::of(&sig, window).main_peak(0.1).unwrap();
                assert_eq!(main, zoom[0]);
                assert!((main.freq_hz - full[0].freq_hz).abs() < 1e-10);
            }
        }
    }

    #[test]
    fn interpolated_peak_is_sub_bin() {
        // 0.8003 Hz for 60 s at 100 Hz: the lab's bin is 0.0167 Hz; interpolation does far better.
        let f = 0.8003;
        let x: Vec<f64> = (0..6000)
            .map(|i| (2.0 * std::f64::consts::PI * f * i as f64 / 100.0 + 0.3).cos())
            .collect();
        let sig = Signal {
            name: "x".into(),
            unit: "".into(),
            sample_rate_hz: 100.0,
            t0_s: 0.0,
            index: (0..6000).collect(),
            values: x,
        };
        let p = Spectrum::of(&sig, Window::Hann).main_peak(0.05).unwrap();
        assert!((p.freq_hz - f).abs() < 1e-4, "{}", p.freq_hz);
        assert!((p.magnitude - 1.0).abs() < 0.01, "{}", p.magnitude);
    }
}
