//! The eigenvalues of a small real matrix, and nothing else: what the model's stability sweeps
//! and the gap's candidate fits ask for hundreds of thousands of times.
//!
//! In: a real n×n matrix (row-major). Out: its n eigenvalues, or `None` when the iteration does
//! not settle. Three classical steps (Golub & Van Loan, *Matrix Computations*, 4th ed., §7.5
//! and §7.7):
//! 1. balancing by powers of two (Parlett & Reinsch 1969), which leaves the eigenvalues exact
//!    and brings rows and columns to comparable norms (the tyre model mixes angles with
//!    forces of hundreds of newtons);
//! 2. reduction to upper Hessenberg form by Householder reflections (Algorithm 7.4.2);
//! 3. Francis' implicit double-shift QR iteration on the Hessenberg matrix (Algorithm 7.5.1),
//!    deflating where a subdiagonal entry is negligible against its diagonal neighbours, with
//!    exceptional shifts after 10 and 20 iterations without deflation.
//!
//! No Schur vectors are accumulated (nalgebra's `Schur` forms them always): on the tyre model's
//! 9×9 state matrix this takes 4.5 µs, balancing included, against nalgebra's 5.7 µs, and the
//! eigenvalues of that matrix were a fifth of `bikeproc gap`'s time.

use nalgebra::Complex;

/// Iterations allowed per eigenvalue before giving up (the classical bound is 30).
const ITERATIONS_PER_EIGENVALUE: usize = 30;

/// The eigenvalues of the n×n matrix `a` (row-major, `a[r * n + c]`), unsorted; `a` is
/// overwritten. `None` when an entry is not finite or the QR iteration does not converge within
/// 30 iterations per eigenvalue.
///
/// # Panics
/// When `a.len() != n * n` (a caller's error, never the data's).
pub fn eigenvalues_in_place(a: &mut [f64], n: usize) -> Option<Vec<Complex<f64>>> {
    assert_eq!(
        a.len(),
        n * n,
        "eigenvalues_in_place: {n}×{n} needs {} entries",
        n * n
    );
    if !a.iter().all(|x| x.is_finite()) {
        return None;
    }
    // The sizes the project uses get their own instances, the loops' bounds known to the
    // compiler (4.8 → 4.5 µs on the tyre model's 9×9).
    match n {
        0 => Some(Vec::new()),
        4 => eigenvalues_of_size(a, Fixed::<4>),
        9 => eigenvalues_of_size(a, Fixed::<9>),
        _ => eigenvalues_of_size(a, n),
    }
}

/// A matrix size: known when compiled ([`Fixed`]) or at run time (`usize`).
trait Size: Copy {
    fn n(self) -> usize;
}

#[derive(Clone, Copy)]
struct Fixed<const N: usize>;

impl<const N: usize> Size for Fixed<N> {
    #[inline(always)]
    fn n(self) -> usize {
        N
    }
}

impl Size for usize {
    #[inline(always)]
    fn n(self) -> usize {
        self
    }
}

fn eigenvalues_of_size(a: &mut [f64], size: impl Size) -> Option<Vec<Complex<f64>>> {
    balance(a, size);
    hessenberg(a, size);
    francis_qr(a, size)
}

/// Parlett–Reinsch balancing by powers of two: a diagonal similarity `D⁻¹ A D` that makes each
/// row's and column's off-diagonal 1-norms comparable. Exact in floating point.
fn balance(a: &mut [f64], size: impl Size) {
    let n = size.n();
    const RADIX: f64 = 2.0;
    let mut changed = true;
    while changed {
        changed = false;
        for i in 0..n {
            let (mut col, mut row) = (0.0, 0.0);
            for j in (0..n).filter(|&j| j != i) {
                col += a[j * n + i].abs();
                row += a[i * n + j].abs();
            }
            if col == 0.0 || row == 0.0 {
                continue;
            }
            let total = col + row;
            let mut f = 1.0;
            let (mut c, mut g) = (col, row / RADIX);
            while c < g {
                f *= RADIX;
                c *= RADIX * RADIX;
            }
            g = row * RADIX;
            while c > g {
                f /= RADIX;
                c /= RADIX * RADIX;
            }
            if (c + row) / f < 0.95 * total {
                changed = true;
                for j in 0..n {
                    a[i * n + j] /= f;
                    a[j * n + i] *= f;
                }
            }
        }
    }
}

/// Householder reduction to upper Hessenberg form, in place (entries below the subdiagonal
/// set to zero).
fn hessenberg(a: &mut [f64], size: impl Size) {
    let n = size.n();
    let mut v = vec![0.0; n];
    for k in 0..n.saturating_sub(2) {
        // The column below the subdiagonal: x = a[k+1.., k].
        let scale: f64 = (k + 1..n).map(|i| a[i * n + k].abs()).sum();
        if scale == 0.0 {
            continue;
        }
        let mut norm2 = 0.0;
        for i in k + 1..n {
            v[i] = a[i * n + k] / scale;
            norm2 += v[i] * v[i];
        }
        let alpha = -v[k + 1].signum() * norm2.sqrt();
        // v = x − α e₁ (x scaled), H = I − β v vᵀ with β = 2 / vᵀv.
        v[k + 1] -= alpha;
        let vtv: f64 = (k + 1..n).map(|i| v[i] * v[i]).sum();
        if vtv == 0.0 {
            continue;
        }
        let beta = 2.0 / vtv;
        // From the left: rows k+1.., columns k...
        for j in k..n {
            let s: f64 = (k + 1..n).map(|i| v[i] * a[i * n + j]).sum::<f64>() * beta;
            for i in k + 1..n {
                a[i * n + j] -= s * v[i];
            }
        }
        // From the right: every row, columns k+1...
        for i in 0..n {
            let s: f64 = (k + 1..n).map(|j| a[i * n + j] * v[j]).sum::<f64>() * beta;
            for j in k + 1..n {
                a[i * n + j] -= s * v[j];
            }
        }
        for i in k + 2..n {
            a[i * n + k] = 0.0;
        }
    }
}

/// The eigenvalues of the upper Hessenberg matrix `h` by Francis' double-shift QR.
fn francis_qr(h: &mut [f64], size: impl Size) -> Option<Vec<Complex<f64>>> {
    let n = size.n();
    let at = |r: usize, c: usize| r * n + c;
    let norm: f64 = (0..n)
        .flat_map(|r| (r.saturating_sub(1)..n).map(move |c| (r, c)))
        .map(|(r, c)| h[at(r, c)].abs())
        .sum();
    let mut out = vec![Complex::new(0.0, 0.0); n];
    if norm == 0.0 {
        return Some(out);
    }
    // The exceptional shifts move the whole matrix by `shift`; added back to each eigenvalue.
    let mut shift = 0.0;
    let mut total_iterations = 0;
    // The active block is rows/columns lo..=hi; eigenvalues are taken from its bottom.
    let mut hi = n as isize - 1;
    while hi >= 0 {
        let hi_u = hi as usize;
        let mut iterations = 0;
        loop {
            // The lowest negligible subdiagonal entry: the block splits there.
            let mut lo = hi_u;
            while lo > 0 {
                let mut s = h[at(lo - 1, lo - 1)].abs() + h[at(lo, lo)].abs();
                if s == 0.0 {
                    s = norm;
                }
                if h[at(lo, lo - 1)].abs() <= f64::EPSILON * s {
                    h[at(lo, lo - 1)] = 0.0;
                    break;
                }
                lo -= 1;
            }
            let x = h[at(hi_u, hi_u)];
            if lo == hi_u {
                // One real eigenvalue deflated.
                out[hi_u] = Complex::new(x + shift, 0.0);
                hi -= 1;
                break;
            }
            let y = h[at(hi_u - 1, hi_u - 1)];
            let w = h[at(hi_u, hi_u - 1)] * h[at(hi_u - 1, hi_u)];
            if lo == hi_u - 1 {
                // A 2×2 block deflated: its two eigenvalues.
                let p = 0.5 * (y - x);
                let q = p * p + w;
                let z = q.abs().sqrt();
                let x = x + shift;
                if q >= 0.0 {
                    // Real pair; the smaller root from the product, without cancellation.
                    let z = p + z.copysign(p);
                    let big = x + z;
                    let small = if z != 0.0 { x - w / z } else { big };
                    out[hi_u - 1] = Complex::new(big, 0.0);
                    out[hi_u] = Complex::new(small, 0.0);
                } else {
                    out[hi_u - 1] = Complex::new(x + p, -z);
                    out[hi_u] = Complex::new(x + p, z);
                }
                hi -= 2;
                break;
            }
            if iterations == ITERATIONS_PER_EIGENVALUE || total_iterations > 30 * n {
                return None;
            }
            let (mut x, mut y, mut w) = (x, y, w);
            if iterations == 10 || iterations == 20 {
                // An exceptional shift breaks a cycle of the standard one.
                shift += x;
                for i in 0..=hi_u {
                    h[at(i, i)] -= x;
                }
                let s = h[at(hi_u, hi_u - 1)].abs() + h[at(hi_u - 1, hi_u - 2)].abs();
                x = 0.75 * s;
                y = x;
                w = -0.4375 * s * s;
            }
            iterations += 1;
            total_iterations += 1;
            double_shift_step(h, size, lo, hi_u, x, y, w);
        }
    }
    Some(out)
}

/// One implicit double-shift QR step on rows and columns `lo..=hi` of the Hessenberg matrix
/// `h`, the shifts being the eigenvalues of the trailing 2×2 block `[[y, ·], [·, x]]` with
/// off-diagonal product `w`. The step starts at the lowest row `m ≥ lo` below which two
/// consecutive subdiagonal entries are small enough to begin the bulge there.
fn double_shift_step(h: &mut [f64], size: impl Size, lo: usize, hi: usize, x: f64, y: f64, w: f64) {
    let n = size.n();
    let at = |r: usize, c: usize| r * n + c;
    // The first column of (H − s₁)(H − s₂), at row m, scaled.
    let mut m = hi - 2;
    let (mut p, mut q, mut r);
    loop {
        let z = h[at(m, m)];
        let rr = x - z;
        let ss = y - z;
        p = (rr * ss - w) / h[at(m + 1, m)] + h[at(m, m + 1)];
        q = h[at(m + 1, m + 1)] - z - rr - ss;
        r = h[at(m + 2, m + 1)];
        let s = p.abs() + q.abs() + r.abs();
        let inv = 1.0 / s;
        p *= inv;
        q *= inv;
        r *= inv;
        if m == lo {
            break;
        }
        let u = h[at(m, m - 1)].abs() * (q.abs() + r.abs());
        let v = p.abs() * (h[at(m - 1, m - 1)].abs() + z.abs() + h[at(m + 1, m + 1)].abs());
        if u <= f64::EPSILON * v {
            break;
        }
        m -= 1;
    }
    for i in m + 2..=hi {
        h[at(i, i - 2)] = 0.0;
        if i != m + 2 {
            h[at(i, i - 3)] = 0.0;
        }
    }
    // Chase the bulge down with 3×3 (last: 2×2) Householder reflections.
    for k in m..hi {
        let last = k == hi - 1;
        let mut scale = 0.0;
        if k != m {
            p = h[at(k, k - 1)];
            q = h[at(k + 1, k - 1)];
            r = if last { 0.0 } else { h[at(k + 2, k - 1)] };
            scale = p.abs() + q.abs() + r.abs();
            if scale == 0.0 {
                continue;
            }
            let inv = 1.0 / scale;
            p *= inv;
            q *= inv;
            r *= inv;
        }
        let s = (p * p + q * q + r * r).sqrt().copysign(p);
        if s == 0.0 {
            continue;
        }
        if k == m {
            if lo != m {
                h[at(k, k - 1)] = -h[at(k, k - 1)];
            }
        } else {
            h[at(k, k - 1)] = -s * scale;
        }
        p += s;
        // (Reciprocals: the divisions were half of the iteration's time.)
        let (inv_s, inv_p) = (1.0 / s, 1.0 / p);
        let (vx, vy, vz) = (p * inv_s, q * inv_s, r * inv_s);
        let (q, r) = (q * inv_p, r * inv_p);
        // Rows k, k+1, k+2 from the left, columns k..=hi (the columns right of the block
        // change only the Schur form, not its eigenvalues).
        let (upper, below) = h.split_at_mut((k + 1) * n);
        let row_k = &mut upper[k * n + k..=k * n + hi];
        let (row_1, rest) = below.split_at_mut(n);
        let row_1 = &mut row_1[k..=hi];
        if last {
            for (a, b) in row_k.iter_mut().zip(row_1.iter_mut()) {
                let t = *a + q * *b;
                *b -= t * vy;
                *a -= t * vx;
            }
        } else {
            let row_2 = &mut rest[k..=hi];
            for ((a, b), c) in row_k.iter_mut().zip(row_1.iter_mut()).zip(row_2.iter_mut()) {
                let t = *a + q * *b + r * *c;
                *c -= t * vz;
                *b -= t * vy;
                *a -= t * vx;
            }
        }
        // Columns k, k+1, k+2 from the right, rows lo..=min(hi, k+3).
        let width = if last { 2 } else { 3 };
        for i in lo..=hi.min(k + 3) {
            let cols = &mut h[i * n + k..i * n + k + width];
            let mut t = vx * cols[0] + vy * cols[1];
            if !last {
                t += vz * cols[2];
                cols[2] -= t * r;
            }
            cols[1] -= t * q;
            cols[0] -= t;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt as _, SeedableRng as _};

    fn sorted(mut e: Vec<Complex<f64>>) -> Vec<Complex<f64>> {
        e.sort_by(|x, y| x.re.total_cmp(&y.re).then(x.im.total_cmp(&y.im)));
        e
    }

    /// Row-major `S D S⁻¹` for a block-diagonal `D` of the given eigenvalues (a complex pair
    /// as the real block [[σ, ω], [−ω, σ]]) and a random well-conditioned `S`.
    fn similar_to(eigen: &[Complex<f64>], rng: &mut impl rand::Rng) -> (Vec<f64>, usize) {
        let n = eigen.len();
        let mut d = nalgebra::DMatrix::<f64>::zeros(n, n);
        let mut i = 0;
        while i < n {
            let z = eigen[i];
            if z.im != 0.0 {
                d[(i, i)] = z.re;
                d[(i + 1, i + 1)] = z.re;
                d[(i, i + 1)] = z.im;
                d[(i + 1, i)] = -z.im;
                i += 2;
            } else {
                d[(i, i)] = z.re;
                i += 1;
            }
        }
        let s = nalgebra::DMatrix::<f64>::from_fn(n, n, |r, c| {
            let u: f64 = rng.random();
            f64::from(u8::from(r == c)) * 2.0 + u - 0.5
        });
        let a = &s * d * s.clone().try_inverse().expect("S is diagonally dominant");
        (a.transpose().as_slice().to_vec(), n)
    }

    /// Known spectra (real roots, complex pairs, a repeated pair of moduli alike — the case
    /// nalgebra's own iteration can cycle on) come back to 1e-11 of the largest modulus.
    #[test]
    fn similar_matrices_give_their_known_eigenvalues() {
        let mut rng = rand_xoshiro::Xoshiro256StarStar::seed_from_u64(7);
        let c = Complex::new;
        let spectra: Vec<Vec<Complex<f64>>> = vec![
            vec![c(-3.0, 0.0), c(-0.5, 4.0), c(-0.5, -4.0), c(1.2, 0.0)],
            vec![c(-1.0, 2.0), c(-1.0, -2.0), c(1.0, 2.0), c(1.0, -2.0)],
            vec![
                c(0.0, 5.0),
                c(0.0, -5.0),
                c(-12.0, 0.0),
                c(-0.01, 0.0),
                c(40.0, 0.0),
            ],
            vec![
                c(-80.0, 0.0),
                c(-2.0, 7.0),
                c(-2.0, -7.0),
                c(-3.0, 0.0),
                c(-1.0, 0.3),
                c(-1.0, -0.3),
                c(-200.0, 0.0),
                c(0.5, 0.0),
                c(-30.0, 0.0),
            ],
        ];
        for spectrum in &spectra {
            for _ in 0..20 {
                let (mut a, n) = similar_to(spectrum, &mut rng);
                let got = sorted(eigenvalues_in_place(&mut a, n).expect("converges"));
                let want = sorted(spectrum.clone());
                let scale = want.iter().map(|z| z.norm()).fold(0.0, f64::max);
                for (g, w) in got.iter().zip(&want) {
                    assert!(
                        (g - w).norm() < 1e-11 * scale,
                        "{g} against {w} in {want:?}"
                    );
                }
            }
        }
    }

    /// Random dense matrices of 1–12 rows (entries spread over six decades, as the tyre model's
    /// are) against nalgebra's Schur decomposition, an independent implementation.
    #[test]
    fn random_matrices_agree_with_nalgebra_schur() {
        let mut rng = rand_xoshiro::Xoshiro256StarStar::seed_from_u64(11);
        let mut worst = 0.0f64;
        for trial in 0..600 {
            let n = 1 + trial % 12;
            let a = nalgebra::DMatrix::<f64>::from_fn(n, n, |_, _| {
                let u: f64 = rng.random();
                let e: f64 = rng.random();
                (u - 0.5) * 10f64.powf(6.0 * e - 3.0)
            });
            let Some(schur) = nalgebra::Schur::try_new(a.clone(), f64::EPSILON, 1000) else {
                continue;
            };
            let want = sorted(schur.complex_eigenvalues().iter().copied().collect());
            let mut rows = a.transpose().as_slice().to_vec();
            let got = sorted(eigenvalues_in_place(&mut rows, n).expect("converges"));
            // Matched one to one by nearness (sorting by real part can pair a near-tie
            // differently).
            let norm = a.iter().map(|x| x.abs()).sum::<f64>();
            let mut left = want.clone();
            for g in &got {
                let k = (0..left.len())
                    .min_by(|&i, &j| (left[i] - g).norm().total_cmp(&(left[j] - g).norm()))
                    .expect("as many eigenvalues");
                worst = worst.max((left.swap_remove(k) - g).norm() / norm);
            }
        }
        // Both are backward stable: eigenvalues of these well-separated random spectra agree
        // to a few hundred ulps of the matrix's norm.
        assert!(worst < 1e-10, "worst difference {worst:e} of the norm");
    }

    #[test]
    fn edge_cases() {
        assert_eq!(eigenvalues_in_place(&mut [], 0), Some(vec![]));
        assert_eq!(
            eigenvalues_in_place(&mut [3.5], 1),
            Some(vec![Complex::new(3.5, 0.0)])
        );
        assert_eq!(
            eigenvalues_in_place(&mut [0.0; 9], 3),
            Some(vec![Complex::new(0.0, 0.0); 3])
        );
        assert_eq!(
            eigenvalues_in_place(&mut [1.0, f64::NAN, 0.0, 1.0], 2),
            None
        );
        // A rotation by 90°: ±i exactly.
        let e = sorted(eigenvalues_in_place(&mut [0.0, 1.0, -1.0, 0.0], 2).unwrap());
        assert_eq!(e, vec![Complex::new(0.0, -1.0), Complex::new(0.0, 1.0)]);
        // Cyclic permutations: the n-th roots of unity, where the standard shifts stall and
        // only the exceptional ones move the iteration.
        for n in 2..=10 {
            let mut p = vec![0.0; n * n];
            for r in 0..n {
                p[r * n + (r + 1) % n] = 1.0;
            }
            for z in eigenvalues_in_place(&mut p, n).expect("converges") {
                assert!((z.norm() - 1.0).abs() < 1e-12, "{z} for n = {n}");
                assert!((z.powi(n as i32) - 1.0).norm() < 1e-11, "{z} for n = {n}");
            }
        }
        // A Jordan block: a defective triple root at 2, found to the cube root of ε.
        let mut j = [2.0, 1.0, 0.0, 0.0, 2.0, 1.0, 0.0, 0.0, 2.0];
        for z in eigenvalues_in_place(&mut j, 3).unwrap() {
            assert!((z - Complex::new(2.0, 0.0)).norm() < 1e-5, "{z}");
        }
    }
}
