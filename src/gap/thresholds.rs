//! The gap stage's decision thresholds and error-model factors, shared by its files: when a
//! campaign is too thin, when an effect explains the gap, when two candidates are tied, which
//! pairs are tried. Each value's reason is in its doc; the measurements behind them are in
//! docs/decisions/.

/// A candidate that leaves the rides left out further than this from its prediction (RMS, in
/// their standard errors; ≈ 1 when the explanation is right) does not explain the gap.
pub const EXPLAINED_HELDOUT_RMS: f64 = 2.0;

/// How many of its standard errors a fitted value may lie outside its plausible range and
/// still count as plausible: two, where the fit cannot tell its value from the range's edge
/// at 95 %. At one, candidates fitted just past their edge ranked behind every plausible one.
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#plausible_se).
pub const PLAUSIBLE_SE: f64 = 2.0;

/// The significance level of the campaign's test.
pub const SIGNIFICANCE: f64 = 0.01;

/// The shared part of the rides' motion-size error, as a multiple of the ride stage's own
/// ([`crate::ride::dynamic::NONLINEAR_SE_PER_RAD2`]): one coefficient κ per condition and part
/// (σ, ω, |γ/θ|, arg γ/θ) by which a ride's fit differs from the small motion's in proportion to
/// its motion's size. The difference has one sign for a bicycle's rides near one speed, so a
/// ride's own error does not cover it; four times it gave the blind studies' gains a median z of
/// +0.58 (98 % within 2). The blind runs behind the value, and what it leaves:
/// [docs/decisions/constants.md](../../docs/decisions/constants.md#nonlinear_common_factor).
pub const NONLINEAR_COMMON_FACTOR: f64 = 4.0;
/// The best candidate is told from another when the rides left out favour it by more than this
/// in Σz² …
pub const TIE_CHI2: f64 = 2.0;
/// … and by more than this many of that sum's standard deviations had the two been equally
/// right (`distinguishable`).
pub const TIE_SE: f64 = 2.0;
/// Fewer usable rides than this support no conclusion.
pub const MIN_RIDES: usize = 4;
/// Speeds spanning less than this (m/s) are "a single speed".
pub const MIN_SPEED_SPAN_MPS: f64 = 0.5;
/// A study's pair screen ([`super::PairSearch::Screen`]): the best single effect with every
/// other, and the next `PAIR_POOL − 1` best among themselves. A campaign fits every pair.
pub const PAIR_POOL: usize = 4;
/// A single effect closes the gap when the rides left out are predicted within this RMS
/// normalized residual (two standard errors); pairs are tried only when none does.
pub const CLOSED_RMS: f64 = 2.0;
/// A pair must beat the best single effect's held-out Σz² by this much (the 1 % point of χ²
/// with one degree of freedom: the pair's extra parameter) and by the BIC.
pub const PAIR_GAIN_CHI2: f64 = 6.63;

/// The experimental mode shape's standard error has at least this relative part in |γ/θ| …
pub const SHAPE_RATIO_FLOOR: f64 = 0.0;
/// … and this much in its phase (rad).
pub const SHAPE_PHASE_FLOOR_RAD: f64 = 0.0;
