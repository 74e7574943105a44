//! Spectral stage: a [`Signal`] → its amplitude spectrum and peaks.
//!
//! In: a signal on a uniform grid (gaps allowed). Out: the magnitude of a Hann-windowed,
//! zero-padded FFT (rustfft), the main peak located between bins by Gaussian (log-parabolic)
//! interpolation, and secondary peaks — a second peak is itself a finding (the Cardan joint's
//! swing mode, seed §5.3.3.4 and §5.3.4.5).
//!
//! This is the lab's method (seed §5.3.3.2: the FFT's peak) made sub-bin; it serves as the first
//! guess of the least-squares fit in [`crate::fit`], which is what the results come from.

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
        let n = (last - first + 1) as usize;
        let t = signal.times_s();
        let (a, b) = linear_trend(&t, &signal.values);
        let mut grid = vec![0.0; n];
        for ((&i, &v), &ti) in signal.index.iter().zip(&signal.values).zip(&t) {
            grid[(i - first) as usize] = v - (a + b * ti);
        }
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
        // The median by selection, O(n) (the same element a full sort would put there).
        let mut scratch = m.clone();
        let mid = scratch.len() / 2;
        let floor = 5.0 * *scratch.select_nth_unstable_by(mid, f64::total_cmp).1;
        let mut candidates: Vec<Peak> = (1..m.len() - 1)
            .filter(|&k| {
                m[k] > m[k - 1]
                    && m[k] >= m[k + 1]
                    && self.freq_hz[k] >= min_freq_hz
                    && m[k] > floor
            })
            .map(|k| self.interpolate(k))
            .collect();
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
                .all(|q| (q.freq_hz - p.freq_hz).abs() >= 2.0 * self.resolution_hz)
            {
                out.push(p);
                if out.len() == max_count {
                    break;
                }
            }
        }
        out
    }

    /// The strongest peak at or above `min_freq_hz`.
    pub fn main_peak(&self, min_freq_hz: f64) -> Option<Peak> {
        self.peaks(min_freq_hz, 1.0, 1).into_iter().next()
    }

    /// Gaussian interpolation: a parabola through the logarithms of three bins.
    fn interpolate(&self, k: usize) -> Peak {
        let df = self.freq_hz[1] - self.freq_hz[0];
        let (a, b, c) = (
            self.magnitude[k - 1],
            self.magnitude[k],
            self.magnitude[k + 1],
        );
        if a <= 0.0 || b <= 0.0 || c <= 0.0 {
            return Peak {
                freq_hz: self.freq_hz[k],
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
            freq_hz: self.freq_hz[k] + delta * df,
            magnitude: mag,
        }
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
        let out = (0..=m)
            .map(|k| {
                let zk = buffer[k % m];
                let zc = buffer[(m - k) % m].conj();
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

fn spectrum_of_grid(grid: &[f64], rate_hz: f64, window: Window) -> Spectrum {
    let n = grid.len();
    // Even, so that the real transform can halve it.
    let len = (n.next_power_of_two() * PAD_FACTOR)
        .min(MAX_FFT_LEN)
        .max(n + n % 2);
    let weight = |i: usize| match window {
        Window::Hann => 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos(),
        Window::Rectangular => 1.0,
    };
    let wsum: f64 = match window {
        Window::Hann => (0..n).map(weight).sum(),
        Window::Rectangular => n as f64,
    };
    let scale = if wsum > 0.0 { 2.0 / wsum } else { 0.0 };
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
        let mut s = 12345u64;
        let x: Vec<f64> = (0..100)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect();
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
