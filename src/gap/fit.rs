//! Fitting the candidate effects to a campaign's weaves (the eigenvalue, and the mode shape
//! |γ/θ| with its phase): generalized least squares with the full covariance (each ride's fit
//! errors, its speed's, and the model's from the measured parameters, correlated across
//! rides), a bounded Nelder–Mead search after a grid, standard errors from the χ² curvature,
//! and leave-one-ride-out predictions.
//!
//! The Nelder–Mead ([`nelder_mead`]) is in-house for a measured reason (`benches/kernels`): it
//! keeps every vertex inside the effects' physical box, which argmin's `NelderMead` does not, and
//! on Rosenbrock's function from (−1.2, 1) it reaches f = 1.2e-12 in 12.2 µs against argmin's
//! 8.0e-13 in 36.2 µs (medians).

use super::conditions::{ConditionModel, Layout};
use super::effects::{
    any_change, clock, for_ride, linear_bike_assuming, steer_friction_nm, true_speed, Assumed,
    Change, Effect,
};
use super::linear::{LinearBike, Modes};
use super::observe::{Observation, Parts};
use super::speed_grid;
use crate::model::uncertain::Parametrized;
use crate::model::Benchmark;
use crate::ride::dynamic::COASTING_BIAS_SE_FRACTION;
use nalgebra::{Complex, DMatrix, DVector};

use speed_grid::Prediction;

/// A campaign (or a study of several conditions, each a campaign) ready to fit: the rides,
/// each condition's measured bicycle, each ride's condition and unextended weave (the branch
/// to follow) and the covariance of the residuals.
#[derive(Clone)]
pub struct Campaign<'a> {
    pub obs: &'a [Observation],
    /// The conditions: one for a single campaign ([`super::conditions`]).
    pub conditions: &'a [ConditionModel],
    /// Each ride's condition (an index into `conditions`).
    pub ride_condition: Vec<usize>,
    pub guesses: Vec<Complex<f64>>,
    /// The parts of each ride's residual: 2, the eigenvalue's real and imaginary parts; 4, and
    /// the mode shape's |γ/θ| and phase (rad).
    pub parts: Parts,
    /// Covariance of `[re₀, im₀, (|γ/θ|₀, arg₀,) re₁, …]` of the residuals (experiment − model):
    /// given whole at the measured bicycle; at a candidate's fit ([`Campaign::at_fit`]) made
    /// on first use ([`Campaign::cov`]) from `exp_cov`, `model_factor` and the coasting shifts'
    /// errors. A large campaign reads only its rides' blocks ([`Campaign::cov_block`]): at
    /// 1,000 rides the whole, 4,000 × 4,000, cost 0.13 s and 128 MB per candidate.
    pub cov: std::sync::OnceLock<DMatrix<f64>>,
    /// Its Cholesky factor, made once ([`Campaign::factor`]).
    pub factor: std::sync::OnceLock<Option<nalgebra::Cholesky<f64, nalgebra::Dyn>>>,
    /// Its inverse, made on first use (`Campaign::make_inverse`).
    pub inverse: std::sync::OnceLock<Option<Inverse>>,
    /// The model's part of `cov` as a factor U, `cov = exp_cov + U Uᵀ` (at the measured
    /// bicycle, or at a candidate's fit: [`Campaign::at_fit`]), so that the inverse keeps the
    /// structure ([`LowRankInverse`]).
    pub model_factor: DMatrix<f64>,
    /// The common parts of `exp_cov` (the coasting correction's error shared by the rides and
    /// the motion's size's, `W Wᵀ`, one column each): the rest is block-diagonal over the
    /// rides, which `Campaign::make_inverse` uses.
    pub exp_common: &'a DMatrix<f64>,
    /// The values the library assumes ([`Assumed::NOMINAL`]; others to measure what the
    /// fits owe to them, [`assumed_se`]).
    pub assumed: Assumed,
    /// The experimental part of `cov` (the rides' fit and speed errors, the scatter between
    /// kicks, the coasting correction's); the rest is the model's, from the measured
    /// parameters' errors: at the unextended model in `cov`, at a candidate's fit in
    /// [`Campaign::at_fit`].
    pub exp_cov: &'a DMatrix<f64>,
    /// Each condition's bicycle as a function of the measured inputs (with the condition's
    /// known masses and controller): what [`Campaign::at_fit`] propagates their errors through.
    pub models: &'a [Parametrized],
    /// Each coasting ride's replay on the measured bicycle ([`super::coasting`]).
    pub coasting: &'a super::coasting::CoastingBase,
    /// At the fit of a candidate with coasting shifts ([`Campaign::at_fit`]): the candidate's
    /// effects and what its coasting replay adds to each ride's prediction under them, held
    /// while it is fitted again; `None` elsewhere.
    pub coasting_shift: Option<(Vec<Effect>, Vec<[f64; 4]>)>,
    /// From this many rides a ride left out is refitted by an unchecked Newton step
    /// ([`refit_near`], [`super::GapOptions::trusted_newton_rides`]).
    pub trusted_newton_rides: usize,
    /// Whether a condition with many rides is predicted from a grid of speeds
    /// ([`super::GapOptions::speed_grid`]).
    pub speed_grid: bool,
    /// Whether every pair of the library is fitted where no single effect closes the gap,
    /// not the screen's ([`super::PairSearch`]).
    pub every_pair: bool,
    /// Whether every three effects of the library are fitted where no pair closes the gap in
    /// a study, not the screen's ([`super::PairSearch::EveryTriple`]).
    pub every_triple: bool,
}

/// χ² of a subset of rides.
pub struct Subset<'c, 'a> {
    campaign: &'c Campaign<'a>,
    rides: Vec<usize>,
    solve: Solve,
}

/// How a subset's χ² is computed.
enum Solve {
    /// By the Cholesky factor of the subset's covariance.
    Cholesky(nalgebra::Cholesky<f64, nalgebra::Dyn>),
    /// Every ride, rᵀ S r by the campaign's inverse S, kept by its structure
    /// ([`LowRankInverse`]): O(N k) a product where the Cholesky factor's solve is O(N²) and
    /// factoring each candidate's covariance O(N³).
    Inverse,
    /// Every ride but `left_out`, from the whole campaign's inverse covariance S: with the
    /// residual r of every ride (zero for the one left out) and u = S r,
    /// rᵀ Σ₋ᵢ⁻¹ r = rᵀ S r − uᵢᵀ (Sᵢᵢ)⁻¹ uᵢ (the Schur complement: minimizing the whole
    /// campaign's χ² over ride i's residual). O(N²) per χ² against the O(N³) of factoring
    /// every held-out subset (N residual parts): a 64-ride campaign's held-out fits took most
    /// of its diagnosis that way.
    LeaveOneOut {
        left_out: usize,
        block_inverse: DMatrix<f64>,
    },
}

impl<'a> Campaign<'a> {
    /// The layout of `effects`' parameters over the conditions ([`Layout::new`]).
    pub fn layout(&self, effects: &[Effect]) -> Layout {
        Layout::new(effects, self.conditions)
    }

    /// The candidates this campaign (or study) can fit ([`super::conditions::library`]).
    pub fn library(&self) -> Vec<Effect> {
        super::conditions::library(self.conditions)
    }

    /// Whether the campaign is a study of several conditions.
    pub fn is_study(&self) -> bool {
        self.conditions.len() > 1
    }

    /// The rides of condition `c`.
    pub fn rides_of(&self, c: usize) -> Vec<usize> {
        (0..self.obs.len())
            .filter(|&i| self.ride_condition[i] == c)
            .collect()
    }

    /// Condition `c`'s bicycle with `effects` at its values of `params` (the fitted vector of
    /// `layout`), and those values.
    pub fn bike(
        &self,
        effects: &[Effect],
        layout: &Layout,
        params: &[f64],
        c: usize,
    ) -> (LinearBike, Vec<f64>) {
        self.bike_on(&self.conditions[c].base, effects, layout, params, c)
    }

    /// [`Campaign::bike`] on the measured bicycle `base` in place of condition `c`'s own.
    fn bike_on(
        &self,
        base: &Benchmark,
        effects: &[Effect],
        layout: &Layout,
        params: &[f64],
        c: usize,
    ) -> (LinearBike, Vec<f64>) {
        let own = layout.condition_params(params, c);
        let control = &self.conditions[c].control;
        let bike = linear_bike_assuming(base, control, effects, &own, self.assumed);
        (bike, own)
    }

    /// The residuals of `rides` (experiment − prediction, each ride's [`Campaign::parts`] in
    /// turn, the phase wrapped to ±π), `params` the fitted vector of the effects' layout; `None` when a
    /// ride has no weave or no mode shape.
    pub fn residuals(
        &self,
        effects: &[Effect],
        params: &[f64],
        rides: &[usize],
    ) -> Option<DVector<f64>> {
        let mut r = DVector::zeros(self.parts.count(rides));
        let mut at = 0;
        for (&i, ri) in rides
            .iter()
            .zip(self.residuals_each(effects, params, rides))
        {
            r.rows_mut(at, self.parts.of(i)).copy_from(&ri?);
            at += self.parts.of(i);
        }
        Some(r)
    }

    /// Each of `rides`' residual as [`Campaign::residuals`] has it; `None` where its
    /// prediction fails.
    fn residuals_each(
        &self,
        effects: &[Effect],
        params: &[f64],
        rides: &[usize],
    ) -> Vec<Option<DVector<f64>>> {
        let base = |c: usize| self.conditions[c].base;
        let predicted = self.predictions(effects, params, &base, &self.guesses, rides);
        rides
            .iter()
            .zip(predicted)
            .map(|(&i, p)| {
                let (w, shape) = p?;
                let o = &self.obs[i];
                let mut r = DVector::zeros(self.parts.of(i));
                r[0] = o.weave.re - w.re;
                r[1] = o.weave.im - w.im;
                if let Some(s) = shape {
                    r[2] = o.shape_ratio.value - s.norm();
                    r[3] = crate::signal::wrap_pi(o.shape_phase_rad.value - s.arg());
                }
                Some(r)
            })
            .collect()
    }

    /// The predicted weave and (where its parts include it) mode shape of each of `rides` under
    /// `effects` at `params` (the fitted vector of their layout), each condition's bicycle
    /// `base(c)`, each ride's branch followed from `guesses` (indexed by ride); `None` where a
    /// ride has none. A condition with many rides takes them from a grid of speeds where that
    /// is exact to [`speed_grid::TOLERANCE`]; the others (and every ride of a campaign of
    /// data/'s size) from their own eigenproblems, one per speed where no dry friction makes
    /// each ride's bicycle its own: a study's repeated kicks at a noted speed share it (on the
    /// balance-assist study 24 eigenproblems for 66 rides, its default search 15.9 → 6.5 s).
    fn predictions(
        &self,
        effects: &[Effect],
        params: &[f64],
        base: &dyn Fn(usize) -> Benchmark,
        guesses: &[Complex<f64>],
        rides: &[usize],
    ) -> Vec<Option<Prediction>> {
        let layout = self.layout(effects);
        let mut out: Vec<Option<Prediction>> = vec![None; rides.len()];
        for c in 0..self.conditions.len() {
            let here: Vec<usize> = (0..rides.len())
                .filter(|&k| self.ride_condition[rides[k]] == c)
                .collect();
            if here.is_empty() {
                continue;
            }
            let (bike, own) = self.bike_on(&base(c), effects, &layout, params, c);
            let with_shape = |i: usize| self.parts.of(i) > 2;
            let speeds: Vec<f64> = here
                .iter()
                .map(|&k| true_speed(effects, &own, &self.obs[rides[k]]))
                .collect();
            let branches: Vec<Complex<f64>> = here.iter().map(|&k| guesses[rides[k]]).collect();
            let shape = here.iter().any(|&k| with_shape(rides[k]));
            // A dry friction acts on each ride by its own swing ([`effects::for_ride`]): no
            // grid of one bicycle's speeds serves them.
            let per_ride = steer_friction_nm(effects, &own) != 0.0;
            let grid = (self.speed_grid && !per_ride)
                .then(|| {
                    speed_grid::interpolate(&speeds, &branches, shape, &|v, guess| {
                        bike.weave_and_shape(v, guess, shape)
                    })
                })
                .flatten();
            // As the ride would report it ([`super::effects::predict_weave`]): the weave at its
            // true speed, from the grid or its own eigenproblem, over the clock's scale.
            let clock = clock(effects, &own);
            // Without friction the rides at one speed (repeated kicks at a noted speed) share
            // one eigenproblem, each taking its own branch from it.
            let mut at_speeds: std::collections::HashMap<u64, Option<Modes>> = Default::default();
            for (n, &k) in here.iter().enumerate() {
                let i = rides[k];
                let at_speed = match grid.as_ref().and_then(|g| g[n]) {
                    Some((w, s)) => Some((w, s.filter(|_| with_shape(i)))),
                    None if per_ride => for_ride(&bike, effects, &own, &self.obs[i], guesses[i])
                        .weave_and_shape(speeds[n], guesses[i], with_shape(i)),
                    None => at_speeds
                        .entry(speeds[n].to_bits())
                        .or_insert_with(|| bike.modes(speeds[n]))
                        .as_ref()
                        .and_then(|m| m.weave_and_shape(guesses[i], with_shape(i))),
                };
                out[k] = at_speed.map(|(w, s)| self.with_shift(effects, i, (w / clock, s)));
            }
        }
        out
    }

    /// `p`, ride `i`'s prediction under `effects`, with what its coasting replay adds under
    /// them ([`Campaign::coasting_shift`]), where the campaign holds that candidate's.
    fn with_shift(&self, effects: &[Effect], i: usize, (w, s): Prediction) -> Prediction {
        match &self.coasting_shift {
            Some((of, shifts)) if of.as_slice() == effects => {
                let d = shifts[i];
                let s = s.map(|s| Complex::from_polar(s.norm() + d[2], s.arg() + d[3]));
                (w + Complex::new(d[0], d[1]), s)
            }
            _ => (w, s),
        }
    }

    /// The campaign with a candidate's coasting shifts ([`super::coasting`]) taken
    /// where `effects` at `params` put the bicycle, for predictions under those effects; the
    /// campaign itself for any other candidate, or where no ride coasts. Its covariance is
    /// made afresh where asked for, with those shifts' errors (the whole of it was copied for
    /// every candidate: at 1,000 rides 128 MB, a fifth of the candidates' time).
    pub fn with_coasting(&self, effects: &[Effect], params: &[f64]) -> Campaign<'a> {
        let coasting_shift = super::coasting::CoastingBase::applies_to(effects)
            .then(|| {
                let layout = self.layout(effects);
                self.coasting.shifts(
                    self.obs,
                    self.conditions,
                    &self.ride_condition,
                    effects,
                    &|c| layout.condition_params(params, c),
                )
            })
            .filter(|shifts| shifts.iter().flatten().any(|&d| d != 0.0))
            .map(|shifts| (effects.to_vec(), shifts));
        Campaign {
            obs: self.obs,
            conditions: self.conditions,
            ride_condition: self.ride_condition.clone(),
            guesses: self.guesses.clone(),
            parts: self.parts.clone(),
            cov: std::sync::OnceLock::new(),
            factor: std::sync::OnceLock::new(),
            inverse: std::sync::OnceLock::new(),
            model_factor: self.model_factor.clone(),
            exp_common: self.exp_common,
            assumed: self.assumed,
            exp_cov: self.exp_cov,
            models: self.models,
            coasting: self.coasting,
            coasting_shift,
            trusted_newton_rides: self.trusted_newton_rides,
            speed_grid: self.speed_grid,
            every_pair: self.every_pair,
            every_triple: self.every_triple,
        }
    }

    /// The campaign with the model's part of its covariance taken where `effects` at `params`
    /// put the bicycle, the measured inputs' errors propagated through those predictions
    /// (Gauss, central differences) — generalized least squares with the covariance of the
    /// model being fitted. The unextended model's covariance misstates a large effect's: with a
    /// steer motor's rotor of 0.05 kg·m² withheld from eight blind studies, the inertia fitted
    /// with it had z of sd 1.6 (−1.0 … +3.4) against its truth, with its own 1.1. `None` when a
    /// prediction fails at a perturbed input or the result is not a covariance.
    ///
    /// A damped or speed-moving candidate's coasting rides also get the change of their
    /// coasting replay there ([`super::coasting`]), held while the candidate is fitted again.
    pub fn at_fit(&self, effects: &[Effect], params: &[f64]) -> Option<Campaign<'a>> {
        let models = self.models;
        let all: Vec<usize> = (0..self.obs.len()).collect();
        let nominal_base = |c: usize| self.conditions[c].base;
        let this = self.with_coasting(effects, params);
        let at: Vec<Prediction> = this
            .predictions(effects, params, &nominal_base, &this.guesses, &all)
            .into_iter()
            .collect::<Option<_>>()?;
        let guesses: Vec<Complex<f64>> = at.iter().map(|(w, _)| *w).collect();
        let inputs = &models.first()?.inputs;
        let (_, factor) = crate::uncertainty::propagate_factor(inputs, |x| {
            let base = |c: usize| models[c].benchmark_at(x);
            let pred = this.predictions(effects, params, &base, &guesses, &all);
            let Some(pred) = pred.into_iter().collect::<Option<Vec<Prediction>>>() else {
                return vec![f64::NAN; self.parts.total()];
            };
            let mut out = Vec::with_capacity(self.parts.total());
            for ((w, s), (_, s0)) in pred.iter().zip(&at) {
                out.extend([w.re, w.im]);
                if let (Some(s), Some(s0)) = (s, s0) {
                    out.extend([s.norm(), crate::signal::wrap_near(s.arg(), s0.arg())]);
                }
            }
            out
        });
        if factor.nrows() != self.parts.total() || factor.iter().any(|v| !v.is_finite()) {
            return None;
        }
        Some(Campaign {
            cov: std::sync::OnceLock::new(),
            factor: std::sync::OnceLock::new(),
            inverse: std::sync::OnceLock::new(),
            model_factor: factor,
            ..this
        })
    }

    /// [`Campaign::cov`] whole, made on first use.
    pub fn cov(&self) -> &DMatrix<f64> {
        self.cov.get_or_init(|| {
            let u = &self.model_factor;
            let mut cov = self.exp_cov + u * u.transpose();
            if let Some(d) = self.coasting_error() {
                for (k, e) in d.iter().enumerate() {
                    cov[(k, k)] += e * e;
                }
            }
            cov
        })
    }

    /// Ride `i`'s block of [`Campaign::cov`]: from the whole in a campaign of fewer than
    /// [`STRUCTURED_WHITENING_RIDES`] rides (which makes it), from its parts in a larger one
    /// (whether or not something made the whole: the two differ in the last bits, and a
    /// ride's residual must not depend on what was computed before it).
    pub fn cov_block(&self, i: usize) -> DMatrix<f64> {
        let (start, p) = (self.parts.start(i), self.parts.of(i));
        if self.obs.len() < STRUCTURED_WHITENING_RIDES {
            return self.cov().view((start, start), (p, p)).into_owned();
        }
        let u = self.model_factor.rows(start, p);
        let mut block = self.exp_cov.view((start, start), (p, p)) + u * u.transpose();
        if let Some(error) = self.ride_coasting_error(i) {
            for a in 0..p {
                block[(a, a)] += error[a].powi(2);
            }
        }
        block
    }

    /// The indices of `rides`' parts in the residual vector.
    fn indices(&self, rides: &[usize]) -> Vec<usize> {
        rides
            .iter()
            .flat_map(|&i| {
                let start = self.parts.start(i);
                start..start + self.parts.of(i)
            })
            .collect()
    }

    /// The Cholesky factor of the whole covariance, made on first use; `None` when it is not
    /// positive definite.
    pub fn factor(&self) -> Option<&nalgebra::Cholesky<f64, nalgebra::Dyn>> {
        self.factor
            .get_or_init(|| self.cov().clone().cholesky())
            .as_ref()
    }

    /// [`Campaign::cov`] as Σ = B + V Vᵀ: each ride's block of the experiment's covariance less
    /// its common columns, with a candidate's coasting shifts' own errors on its diagonal (B,
    /// ride by ride), and as V the experiment's common columns and, with `model`, the model's
    /// factor U (without it, the structure of [`Campaign::exp_cov`] and the shifts' errors).
    fn structure(&self, model: bool) -> (Vec<DMatrix<f64>>, DMatrix<f64>) {
        let d = self.coasting_error();
        let (w, u) = (self.exp_common, &self.model_factor);
        let k_u = if model { u.ncols() } else { 0 };
        let blocks = (0..self.obs.len())
            .map(|i| {
                let (start, p) = (self.parts.start(i), self.parts.of(i));
                let wi = w.rows(start, p);
                let mut block = self.exp_cov.view((start, start), (p, p)) - wi * wi.transpose();
                if let Some(d) = &d {
                    for a in 0..p {
                        block[(a, a)] += d[start + a].powi(2);
                    }
                }
                block
            })
            .collect();
        let mut v = DMatrix::zeros(self.parts.total(), w.ncols() + k_u);
        v.columns_mut(0, w.ncols()).copy_from(w);
        v.columns_mut(w.ncols(), k_u).copy_from(&u.columns(0, k_u));
        (blocks, v)
    }

    /// The inverse of [`Campaign::cov`], from its structure ([`Campaign::structure`],
    /// [`LowRankInverse`]); where a block or the update's capacitance is not positive definite,
    /// L⁻ᵀ L⁻¹ from the factor Σ = L Lᵀ.
    fn make_inverse(&self) -> Option<Inverse> {
        let (blocks, v) = self.structure(true);
        match LowRankInverse::new(blocks, &self.parts, &v) {
            Some(s) => Some(Inverse::LowRank(s)),
            None => inverse_from_factor(self.factor()?).map(Inverse::Dense),
        }
    }

    /// A whitening of [`Campaign::cov`] (M with M Σ Mᵀ = I): from a campaign of
    /// [`STRUCTURED_WHITENING_RIDES`] rides on, from its structure ([`LowRankWhitening`],
    /// O(N k²) for N residual parts and k common columns); below, and where a block is not
    /// positive definite, L⁻¹ of its Cholesky factor Σ = L Lᵀ (O(N³): at 1,000 rides, 4,000
    /// parts, it took a fifth of `bikeproc gap`'s time). Any two whitenings differ by a
    /// rotation, under which draws of N(0, I) are the same in distribution.
    pub fn whitening(&self) -> Option<Whitening> {
        self.whitening_of(true)
    }

    /// [`Campaign::whitening`] of the experiment's covariance alone, [`Campaign::exp_cov`].
    pub fn experiment_whitening(&self) -> Option<Whitening> {
        self.whitening_of(false)
    }

    fn whitening_of(&self, model: bool) -> Option<Whitening> {
        if self.obs.len() >= STRUCTURED_WHITENING_RIDES {
            let (blocks, v) = self.structure(model);
            if let Some(w) = LowRankWhitening::new(&blocks, &self.parts, &v) {
                return Some(Whitening::LowRank(w, self.parts.clone()));
            }
        }
        Some(Whitening::Dense(if model {
            self.factor()?.clone()
        } else {
            self.exp_cov.clone().cholesky()?
        }))
    }

    /// The standard deviations (in the residual vector's order) of a candidate's
    /// coasting shifts' own error: [`COASTING_BIAS_SE_FRACTION`] of each shift, independent
    /// between rides and parts (held together across the rides they left the estimate at a
    /// median +0.52 of its errors on 30 noted campaigns, against +0.17). `None` without shifts.
    pub fn coasting_error(&self) -> Option<DVector<f64>> {
        self.coasting_shift.as_ref()?;
        let mut d = DVector::zeros(self.parts.total());
        for i in 0..self.obs.len() {
            let start = self.parts.start(i);
            let error = self.ride_coasting_error(i)?;
            for a in 0..self.parts.of(i) {
                d[start + a] = error[a];
            }
        }
        Some(d)
    }

    /// Ride `i`'s part of [`Campaign::coasting_error`] (`[re, im, |γ/θ|, arg]`).
    fn ride_coasting_error(&self, i: usize) -> Option<[f64; 4]> {
        let (_, shifts) = self.coasting_shift.as_ref()?;
        Some(shifts[i].map(|s| COASTING_BIAS_SE_FRACTION * s))
    }

    /// The inverse of the whole covariance, made once ([`Campaign::make_inverse`]); `None` when
    /// it cannot be made.
    fn inverse(&self) -> Option<&Inverse> {
        self.inverse.get_or_init(|| self.make_inverse()).as_ref()
    }

    /// The subset of `rides`; `None` when its covariance is not positive definite.
    pub fn subset(&self, rides: Vec<usize>) -> Option<Subset<'_, 'a>> {
        let every = rides.len() == self.obs.len() && rides.iter().enumerate().all(|(k, &i)| k == i);
        if every && self.inverse().is_some() {
            return Some(Subset {
                campaign: self,
                solve: Solve::Inverse,
                rides,
            });
        }
        let chol = if every {
            self.factor()?.clone()
        } else {
            let idx = self.indices(&rides);
            let cov = self
                .cov()
                .select_rows(idx.iter())
                .select_columns(idx.iter());
            cov.cholesky()?
        };
        Some(Subset {
            campaign: self,
            solve: Solve::Cholesky(chol),
            rides,
        })
    }

    /// Every ride but `left_out` (`Solve::LeaveOneOut`); `None` when the covariance or the
    /// left-out ride's block of its inverse is singular.
    pub fn leave_one_out(&self, left_out: usize) -> Option<Subset<'_, 'a>> {
        // Made once per campaign ([`Campaign::make_inverse`]): nalgebra's inverse of the
        // factor solved twice and factored the covariance again, half of `gap`'s time at 256
        // rides.
        let block = self.inverse()?.block(&self.parts, left_out);
        Some(Subset {
            campaign: self,
            rides: (0..self.obs.len()).filter(|&j| j != left_out).collect(),
            solve: Solve::LeaveOneOut {
                left_out,
                block_inverse: block.cholesky()?.inverse(),
            },
        })
    }

    /// (experiment − prediction) of ride `i` in its own covariance (its block of
    /// [`Campaign::cov`]): rᵀ Σᵢ⁻¹ r over its parts; `None` when the prediction fails or the
    /// block is singular.
    pub fn ride_chi2(&self, effects: &[Effect], params: &[f64], i: usize) -> Option<f64> {
        Some(self.ride_whitened(effects, params, i)?.norm_squared())
    }

    /// Ride `i`'s residual whitened by its own covariance, `L⁻¹ r` with `Σᵢ = L Lᵀ`: its parts
    /// are independent standard normal when the prediction is right; `None` as
    /// [`Campaign::ride_chi2`].
    pub fn ride_whitened(
        &self,
        effects: &[Effect],
        params: &[f64],
        i: usize,
    ) -> Option<DVector<f64>> {
        let r = self.residuals(effects, params, &[i])?;
        self.cov_block(i).cholesky()?.l().solve_lower_triangular(&r)
    }

    /// The covariance of `rides`' residuals (their rows and columns of [`Campaign::cov`]),
    /// always from its parts: the experiment's, the model's factor and the coasting shifts'
    /// own errors.
    fn cov_of(&self, rides: &[usize]) -> DMatrix<f64> {
        let idx = self.indices(rides);
        let exp = self
            .exp_cov
            .select_rows(idx.iter())
            .select_columns(idx.iter());
        let u = self.model_factor.select_rows(idx.iter());
        let mut cov = exp + &u * u.transpose();
        if let Some(d) = self.coasting_error() {
            for (k, &i) in idx.iter().enumerate() {
                cov[(k, k)] += d[i].powi(2);
            }
        }
        cov
    }

    /// `rides`' residuals at `params` whitened together, `L⁻¹ r` with `L Lᵀ` their joint
    /// covariance (their rows and columns of [`Campaign::cov`], made from its parts: the
    /// measured parameters' error, which moves every ride of a condition alike, and each
    /// ride's own), split back ride by ride in `rides`' order (the parts' squares summed over
    /// every ride are the rides' joint χ², rᵀ Σ⁻¹ r). A ride whose prediction fails is empty
    /// and left out of the others' whitening; every ride is empty when their covariance is
    /// singular.
    pub fn rides_whitened(
        &self,
        effects: &[Effect],
        params: &[f64],
        rides: &[usize],
    ) -> Vec<Vec<f64>> {
        let each = self.residuals_each(effects, params, rides);
        let ok: Vec<usize> = rides
            .iter()
            .zip(&each)
            .filter_map(|(&i, r)| r.as_ref().map(|_| i))
            .collect();
        let r = DVector::from_iterator(
            self.parts.count(&ok),
            each.iter().flatten().flat_map(|r| r.iter().copied()),
        );
        let sizes: Vec<usize> = ok.iter().map(|&i| self.parts.of(i)).collect();
        let mut whitened = whiten_jointly(&self.cov_of(&ok), &r, &sizes).into_iter();
        each.iter()
            .map(|r| match r {
                Some(_) => whitened.next().unwrap_or_default(),
                None => Vec::new(),
            })
            .collect()
    }
}

/// `r` whitened by its covariance `cov` (`L⁻¹ r`, `cov = L Lᵀ`), split into consecutive pieces
/// of `sizes`: the squares of every piece's elements sum to rᵀ cov⁻¹ r. Every piece is empty
/// when `cov` is not positive definite.
fn whiten_jointly(cov: &DMatrix<f64>, r: &DVector<f64>, sizes: &[usize]) -> Vec<Vec<f64>> {
    let Some(w) = cov
        .clone()
        .cholesky()
        .and_then(|c| c.l().solve_lower_triangular(r))
    else {
        return vec![Vec::new(); sizes.len()];
    };
    let mut at = 0;
    sizes
        .iter()
        .map(|&p| {
            at += p;
            w.rows(at - p, p).iter().copied().collect()
        })
        .collect()
}

/// Each ride's residuals at the parameter sets already evaluated for one candidate. The
/// held-out refits ([`refit_near`]) all start from the fit to every ride and take their
/// differences at the same steps around it, so that one campaign's sixteen held-out fits share
/// most of their predictions (they took a third of `bikeproc gap`'s time). Shared by threads
/// (the refits run in parallel): a parameter set two threads evaluate at once is computed by
/// both, the same numbers, and kept once.
pub struct ResidualCache<'c, 'a> {
    campaign: &'c Campaign<'a>,
    effects: &'c [Effect],
    memo: std::sync::Mutex<Vec<std::sync::Arc<Evaluated>>>,
}

/// Each ride's residuals at one parameter set; `None` where its prediction fails.
type RidesResiduals = Vec<Option<DVector<f64>>>;

/// One parameter set's residuals, and what every leave-one-out χ² at it shares.
struct Evaluated {
    params: Vec<f64>,
    per_ride: RidesResiduals,
    /// `(S r, rᵀ S r)` with S the campaign's inverse covariance and r every ride's residual
    /// (zero where the prediction failed): made on the first leave-one-out χ² at these
    /// parameters; `None` when S is not there.
    shared: std::sync::OnceLock<Option<(DVector<f64>, f64)>>,
}

impl<'c, 'a> ResidualCache<'c, 'a> {
    pub fn new(campaign: &'c Campaign<'a>, effects: &'c [Effect]) -> Self {
        ResidualCache {
            campaign,
            effects,
            memo: std::sync::Mutex::new(Vec::new()),
        }
    }

    /// The evaluation at `params`: from the memo, or made (outside the lock) and kept.
    fn evaluated(&self, params: &[f64]) -> std::sync::Arc<Evaluated> {
        let find = |memo: &[std::sync::Arc<Evaluated>]| {
            memo.iter().find(|e| e.params.as_slice() == params).cloned()
        };
        let lock = || self.memo.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(e) = find(&lock()) {
            return e;
        }
        let all: Vec<usize> = (0..self.campaign.obs.len()).collect();
        let per_ride = self.campaign.residuals_each(self.effects, params, &all);
        let made = std::sync::Arc::new(Evaluated {
            params: params.to_vec(),
            per_ride,
            shared: std::sync::OnceLock::new(),
        });
        let mut memo = lock();
        // Another thread may have kept the same parameters meanwhile: the first one stays.
        if let Some(e) = find(&memo) {
            return e;
        }
        memo.push(made.clone());
        made
    }

    /// χ² of `subset` (of this cache's campaign) at `params`, as [`Subset::chi2`].
    pub fn chi2(&self, subset: &Subset<'_, '_>, params: &[f64]) -> f64 {
        let e = self.evaluated(params);
        if subset.rides.iter().any(|&i| e.per_ride[i].is_none()) {
            return f64::INFINITY;
        }
        let parts = &self.campaign.parts;
        if let Solve::LeaveOneOut {
            left_out,
            block_inverse,
        } = &subset.solve
        {
            // Every ride's residual r in S r and rᵀ S r, once per parameter set; then with
            // a = (S r)ᵢ, ride i's part, the χ² of the others is rᵀ S r − aᵀ (Sᵢᵢ)⁻¹ a
            // (the Schur complement of [`Solve::LeaveOneOut`], whatever ride i's own
            // residual): O(N²) per parameter set instead of per held-out ride.
            let shared = e.shared.get_or_init(|| {
                let s = self.campaign.inverse()?;
                let mut r = DVector::zeros(parts.total());
                for (i, ri) in e.per_ride.iter().enumerate() {
                    if let Some(ri) = ri {
                        r.rows_mut(parts.start(i), parts.of(i)).copy_from(ri);
                    }
                }
                let sr = s.mul(parts, &r);
                let q = r.dot(&sr);
                Some((sr, q))
            });
            let Some((sr, q)) = shared else {
                return f64::INFINITY;
            };
            let a = sr.rows(parts.start(*left_out), parts.of(*left_out));
            return left_out_chi2(*q, &a.into_owned(), block_inverse);
        }
        let mut r = DVector::zeros(parts.count(&subset.rides));
        let mut at = 0;
        for &i in &subset.rides {
            if let Some(ri) = &e.per_ride[i] {
                r.rows_mut(at, parts.of(i)).copy_from(ri);
            }
            at += parts.of(i);
        }
        subset.chi2_of(&r)
    }
}

/// L⁻¹ of a lower-triangular `l`, a column at a time: column j is the forward substitution of
/// the j-th unit vector, which starts at row j (a sixth of N³ flops against the half of a
/// general solve's); `None` when a diagonal element is zero. On one thread: it runs inside a
/// `OnceLock`'s initialization, where a thread of rayon's that stole other work could come
/// back to the same lock (the candidates run on rayon's threads already).
fn lower_triangular_inverse(l: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let n = l.nrows();
    if l.ncols() != n || (0..n).any(|i| l[(i, i)] == 0.0) {
        return None;
    }
    let mut inv = DMatrix::zeros(n, n);
    for (j, x) in inv.as_mut_slice().chunks_mut(n.max(1)).enumerate() {
        x[j] = 1.0;
        for k in j..n {
            x[k] /= l[(k, k)];
            let xk = x[k];
            let column = &l.as_slice()[k * n..(k + 1) * n];
            for (xi, lik) in x[k + 1..].iter_mut().zip(&column[k + 1..]) {
                *xi -= xk * lik;
            }
        }
    }
    Some(inv)
}

/// Σ⁻¹ = L⁻ᵀ L⁻¹ from the Cholesky factor Σ = L Lᵀ; `None` as [`lower_triangular_inverse`].
fn inverse_from_factor(chol: &nalgebra::Cholesky<f64, nalgebra::Dyn>) -> Option<DMatrix<f64>> {
    let l_inv = lower_triangular_inverse(&chol.l())?;
    Some(l_inv.tr_mul(&l_inv))
}

/// A campaign's inverse covariance S = Σ⁻¹, dense or by its structure.
#[derive(Clone)]
pub enum Inverse {
    Dense(DMatrix<f64>),
    LowRank(LowRankInverse),
}

impl Inverse {
    /// S r.
    fn mul(&self, parts: &Parts, r: &DVector<f64>) -> DVector<f64> {
        match self {
            Inverse::Dense(s) => s * r,
            Inverse::LowRank(s) => s.mul(parts, r),
        }
    }

    /// Sᵢᵢ, ride `i`'s block.
    fn block(&self, parts: &Parts, i: usize) -> DMatrix<f64> {
        match self {
            Inverse::Dense(s) => {
                let (start, p) = (parts.start(i), parts.of(i));
                s.view((start, start), (p, p)).into_owned()
            }
            Inverse::LowRank(s) => s.block(parts, i),
        }
    }
}

/// The inverse of a covariance block-diagonal over the rides but for a few common columns,
/// Σ = B + V Vᵀ (B each ride's block, V the parts every ride shares: the coasting correction's,
/// the motion's size's, the model's factor from the measured inputs): by Woodbury's identity
/// Σ⁻¹ = B⁻¹ − Z G⁻¹ Zᵀ with Z = B⁻¹ V and G = I + Vᵀ B⁻¹ V. A product Σ⁻¹ r costs O(N k) and a
/// ride's block O(k²) for N residual parts and k columns, where the dense inverse costs O(N²)
/// a product and N² numbers: with 1,000 rides (4,000 parts) the dense one held 128 MB a
/// candidate and the held-out refits' products took most of `bikeproc gap`'s 292 s.
#[derive(Clone)]
pub struct LowRankInverse {
    /// B⁻¹, ride by ride.
    blocks: Vec<DMatrix<f64>>,
    /// Z = B⁻¹ V (N × k).
    z: DMatrix<f64>,
    /// G⁻¹ (k × k).
    g_inv: DMatrix<f64>,
}

impl LowRankInverse {
    /// From B's blocks (in the rides' order of `parts`) and V (N × k); `None` when a block or G
    /// is not positive definite.
    fn new(blocks: Vec<DMatrix<f64>>, parts: &Parts, v: &DMatrix<f64>) -> Option<LowRankInverse> {
        let mut z = DMatrix::zeros(v.nrows(), v.ncols());
        let mut inverses = Vec::with_capacity(blocks.len());
        for (i, block) in blocks.into_iter().enumerate() {
            let (start, p) = (parts.start(i), parts.of(i));
            let inv = block.cholesky()?.inverse();
            z.rows_mut(start, p).copy_from(&(&inv * v.rows(start, p)));
            inverses.push(inv);
        }
        let k = v.ncols();
        let g = DMatrix::identity(k, k) + v.tr_mul(&z);
        Some(LowRankInverse {
            blocks: inverses,
            g_inv: g.cholesky()?.inverse(),
            z,
        })
    }

    /// Σ⁻¹ r.
    fn mul(&self, parts: &Parts, r: &DVector<f64>) -> DVector<f64> {
        let y = &self.g_inv * self.z.tr_mul(r);
        let mut out = -(&self.z * y);
        for (i, inv) in self.blocks.iter().enumerate() {
            let (start, p) = (parts.start(i), parts.of(i));
            let own = inv * r.rows(start, p);
            let mut rows = out.rows_mut(start, p);
            rows += &own;
        }
        out
    }

    /// Ride `i`'s block of Σ⁻¹.
    fn block(&self, parts: &Parts, i: usize) -> DMatrix<f64> {
        let zi = self.z.rows(parts.start(i), parts.of(i));
        &self.blocks[i] - zi * &self.g_inv * zi.transpose()
    }
}

/// The rides from which [`Campaign::whitening`] whitens by the covariance's structure.
pub const STRUCTURED_WHITENING_RIDES: usize = 64;

/// A whitening of a covariance Σ: `whiten(x)` = M x with M Σ Mᵀ = I, so that M r of a residual
/// r ~ N(0, Σ) is standard normal and |M r|² = rᵀ Σ⁻¹ r.
pub enum Whitening {
    /// M = L⁻¹, Σ = L Lᵀ.
    Dense(nalgebra::Cholesky<f64, nalgebra::Dyn>),
    /// By the structure Σ = B + V Vᵀ, over the parts of its rides.
    LowRank(LowRankWhitening, Parts),
}

impl Whitening {
    /// M x; `None` when the solve fails.
    pub fn whiten(&self, x: &DVector<f64>) -> Option<DVector<f64>> {
        match self {
            Whitening::Dense(chol) => chol.l().solve_lower_triangular(x),
            Whitening::LowRank(w, parts) => Some(w.whiten(parts, x)),
        }
    }
}

/// A whitening of Σ = B + V Vᵀ (B block-diagonal over the rides, V N × k): with B's blocks
/// Bᵢ = Lᵢ Lᵢᵀ and U = L_B⁻¹ V, Σ = L_B (I + U Uᵀ) L_Bᵀ, and M = (I + U Uᵀ)^(−1/2) L_B⁻¹, where
/// (I + U Uᵀ)^(−1/2) = I + U F Uᵀ with UᵀU = Q Λ Qᵀ and F = Q diag(((1 + λ)^(−1/2) − 1)/λ) Qᵀ
/// (on U's column space UUᵀ has the eigenvalues λ, and (1 + λf)²(1 + λ) = 1). O(N k) per
/// vector and O(N k²) to make, where a Cholesky factor of Σ costs O(N³).
pub struct LowRankWhitening {
    /// Lᵢ⁻¹, ride by ride.
    l_inv: Vec<DMatrix<f64>>,
    /// U = L_B⁻¹ V (N × k).
    u: DMatrix<f64>,
    /// F (k × k).
    f: DMatrix<f64>,
}

impl LowRankWhitening {
    /// From B's blocks (in the rides' order of `parts`) and V; `None` when a block is not
    /// positive definite.
    fn new(blocks: &[DMatrix<f64>], parts: &Parts, v: &DMatrix<f64>) -> Option<LowRankWhitening> {
        let mut u = DMatrix::zeros(v.nrows(), v.ncols());
        let mut l_inv = Vec::with_capacity(blocks.len());
        for (i, block) in blocks.iter().enumerate() {
            let (start, p) = (parts.start(i), parts.of(i));
            let li = lower_triangular_inverse(&block.clone().cholesky()?.l())?;
            u.rows_mut(start, p).copy_from(&(&li * v.rows(start, p)));
            l_inv.push(li);
        }
        let eig = u.tr_mul(&u).symmetric_eigen();
        let scale = eig.eigenvalues.map(|l| {
            let l = l.max(0.0);
            if l < 1e-12 {
                -0.5
            } else {
                ((1.0 + l).sqrt().recip() - 1.0) / l
            }
        });
        let q = &eig.eigenvectors;
        let f = q * DMatrix::from_diagonal(&scale) * q.transpose();
        f.iter()
            .all(|x| x.is_finite())
            .then_some(LowRankWhitening { l_inv, u, f })
    }

    /// M x.
    fn whiten(&self, parts: &Parts, x: &DVector<f64>) -> DVector<f64> {
        let mut y = DVector::zeros(x.len());
        for (i, li) in self.l_inv.iter().enumerate() {
            let (start, p) = (parts.start(i), parts.of(i));
            y.rows_mut(start, p).copy_from(&(li * x.rows(start, p)));
        }
        let c = &self.f * self.u.tr_mul(&y);
        y + &self.u * c
    }
}

/// The χ² of every ride but i, rᵀ Σ₋ᵢ⁻¹ r over the others' residuals, from the whole
/// campaign's: `q` = rᵀ S r (S = Σ⁻¹, r every ride's residual), `a` = (S r)ᵢ and
/// `block_inverse` = (Sᵢᵢ)⁻¹. Minimizing rᵀ S r over ride i's part leaves q − aᵀ (Sᵢᵢ)⁻¹ a,
/// the Schur complement, which is that χ² whatever ride i's own residual.
fn left_out_chi2(q: f64, a: &DVector<f64>, block_inverse: &DMatrix<f64>) -> f64 {
    (q - (block_inverse * a).dot(a)).max(0.0)
}

impl Subset<'_, '_> {
    /// rᵀ Σ⁻¹ r; infinite where the model has no weave.
    pub fn chi2(&self, effects: &[Effect], params: &[f64]) -> f64 {
        self.campaign
            .residuals(effects, params, &self.rides)
            .map_or(f64::INFINITY, |r| self.chi2_of(&r))
    }

    /// rᵀ Σ⁻¹ r of the subset's residuals `r` (its rides' parts in order); infinite when the
    /// solve fails.
    fn chi2_of(&self, r: &DVector<f64>) -> f64 {
        match &self.solve {
            Solve::Inverse => self.campaign.inverse().map_or(f64::INFINITY, |s| {
                r.dot(&s.mul(&self.campaign.parts, r)).max(0.0)
            }),
            Solve::Cholesky(chol) => chol
                .l_dirty()
                .solve_lower_triangular(r)
                .map_or(f64::INFINITY, |w| w.norm_squared()),
            Solve::LeaveOneOut {
                left_out,
                block_inverse,
            } => {
                let Some(s) = self.campaign.inverse() else {
                    return f64::INFINITY;
                };
                let parts = &self.campaign.parts;
                // Every ride's residual, zero for the one left out.
                let mut full = DVector::zeros(parts.total());
                let mut at = 0;
                for &i in &self.rides {
                    let p = parts.of(i);
                    full.rows_mut(parts.start(i), p).copy_from(&r.rows(at, p));
                    at += p;
                }
                let u = s.mul(parts, &full);
                let ui = u.rows(parts.start(*left_out), parts.of(*left_out));
                let chi2 = full.dot(&u) - (block_inverse * ui).dot(&ui);
                chi2.max(0.0)
            }
        }
    }

    pub fn len(&self) -> usize {
        self.rides.len()
    }

    pub fn is_empty(&self) -> bool {
        self.rides.is_empty()
    }
}

/// A fit of an effect (or a pair) to a subset of rides.
#[derive(Debug, Clone)]
pub struct EffectFit {
    pub params: Vec<f64>,
    pub chi2: f64,
}

/// Where Nelder–Mead stops: the simplex's extent as a share of each parameter's search range.
/// The smallest standard error of a fitted effect on `data/rides.toml` is 8 % of its range
/// (time_scale's 0.017 on 0.9–1.1), so 1e-4 moves an estimate by about a thousandth of its
/// error; 1e-6 spent a tenth of `bikeproc gap` on digits below the estimates' errors.
const SIMPLEX_TOLERANCE: f64 = 1e-4;

/// Minimizes `f` over the box `lo ≤ x ≤ hi` by Nelder–Mead from `start` (clamped to the box),
/// initial steps `step`; stops when the simplex spans less than `SIMPLEX_TOLERANCE` of the
/// box in every direction or after `max_evals`.
pub fn nelder_mead(
    f: &dyn Fn(&[f64]) -> f64,
    start: &[f64],
    step: &[f64],
    lo: &[f64],
    hi: &[f64],
    max_evals: usize,
) -> (Vec<f64>, f64) {
    let n = start.len();
    let clamp = |x: Vec<f64>| -> Vec<f64> {
        x.iter()
            .enumerate()
            .map(|(i, v)| v.clamp(lo[i], hi[i]))
            .collect()
    };
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    let x0 = clamp(start.to_vec());
    simplex.push((x0.clone(), f(&x0)));
    for i in 0..n {
        let mut x = x0.clone();
        x[i] = if x[i] + step[i] <= hi[i] {
            x[i] + step[i]
        } else {
            x[i] - step[i]
        };
        let x = clamp(x);
        let fx = f(&x);
        simplex.push((x, fx));
    }
    let mut evals = n + 1;
    while evals < max_evals {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let spread = (0..n).all(|i| {
            let (mn, mx) = simplex
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), s| {
                    (a.min(s.0[i]), b.max(s.0[i]))
                });
            mx - mn <= SIMPLEX_TOLERANCE * (hi[i] - lo[i])
        });
        if spread {
            break;
        }
        let centroid: Vec<f64> = (0..n)
            .map(|i| simplex[..n].iter().map(|s| s.0[i]).sum::<f64>() / n as f64)
            .collect();
        let worst = simplex[n].clone();
        let along = |t: f64| -> Vec<f64> {
            clamp(
                (0..n)
                    .map(|i| centroid[i] + t * (worst.0[i] - centroid[i]))
                    .collect(),
            )
        };
        let xr = along(-1.0);
        let fr = f(&xr);
        evals += 1;
        if fr < simplex[0].1 {
            let xe = along(-2.0);
            let fe = f(&xe);
            evals += 1;
            simplex[n] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[n - 1].1 {
            simplex[n] = (xr, fr);
        } else {
            let xc = along(0.5);
            let fc = f(&xc);
            evals += 1;
            if fc < worst.1 {
                simplex[n] = (xc, fc);
            } else {
                let best = simplex[0].0.clone();
                for s in simplex.iter_mut().skip(1) {
                    let x: Vec<f64> = (0..n).map(|i| best[i] + 0.5 * (s.0[i] - best[i])).collect();
                    s.1 = f(&x);
                    s.0 = x;
                    evals += 1;
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (x, fx) = simplex.swap_remove(0);
    (x, fx)
}

/// The points a parameter takes on [`fit_effects`]' grid from three parameters on (and on
/// the grid of a missing effect's in [`fit_effects_from_smaller`]).
const GRID_PER_PARAMETER: usize = 7;

/// Fits `effects` to `subset`: the best point of a grid over the bounds of the effects'
/// parameters (25 points for one parameter, 11 × 11 for two, 7 per parameter beyond; in a
/// study every condition's copy of a parameter at the same grid value), then Nelder–Mead over
/// every fitted element.
pub fn fit_effects(subset: &Subset<'_, '_>, effects: &[Effect]) -> EffectFit {
    let layout = subset.campaign.layout(effects);
    let compact = super::conditions::specs_of(effects, subset.campaign.conditions);
    let lo: Vec<f64> = compact.iter().map(|p| p.lo).collect();
    let hi: Vec<f64> = compact.iter().map(|p| p.hi).collect();
    let np = lo.len();
    let f = |x: &[f64]| subset.chi2(effects, &layout.expand(x));
    let per: usize = match np {
        1 => 25,
        2 => 11,
        _ => GRID_PER_PARAMETER,
    };
    let mut best = (lo.clone(), f64::INFINITY);
    let total = per.pow(np as u32);
    for k in 0..total {
        let mut rem = k;
        let x: Vec<f64> = (0..np)
            .map(|i| {
                let j = rem % per;
                rem /= per;
                lo[i] + (hi[i] - lo[i]) * j as f64 / (per - 1) as f64
            })
            .collect();
        let fx = f(&x);
        if fx < best.1 {
            best = (x, fx);
        }
    }
    let step: Vec<f64> = (0..np)
        .map(|i| (hi[i] - lo[i]) / (per - 1) as f64)
        .collect();
    refine(
        subset,
        effects,
        &layout.expand(&best.0),
        &layout.expand(&step),
        &[],
    )
}

/// Fits `effects` of three or more to `subset` from the fits of the candidates one effect
/// smaller (`smaller_fit`: each one's fitted elements, in its layout's order): each such fit
/// with the missing effect's parameters at "no effect" and on [`fit_effects`]' grid (7 points
/// a parameter), Nelder–Mead from the best of those starts with the grid's steps. With "no
/// effect" among the starts the fit is never worse than a smaller candidate's on `subset`.
/// `None` without a smaller fit to start from. Every three effects of a bicycle with a
/// controller are 1,771 fits; from their pairs each starts from 24 points instead of 7³.
pub fn fit_effects_from_smaller(
    subset: &Subset<'_, '_>,
    effects: &[Effect],
    smaller_fit: &dyn Fn(&[Effect]) -> Option<Vec<f64>>,
) -> Option<EffectFit> {
    const PER: usize = GRID_PER_PARAMETER;
    let layout = subset.campaign.layout(effects);
    let compact = super::conditions::specs_of(effects, subset.campaign.conditions);
    let none: Vec<f64> = compact.iter().map(|p| p.none).collect();
    let mut starts: Vec<Vec<f64>> = Vec::new();
    for m in 0..effects.len() {
        let smaller: Vec<Effect> = effects
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != m)
            .map(|(_, &e)| e)
            .collect();
        let Some(fitted) = smaller_fit(&smaller) else {
            continue;
        };
        // The missing effect's compact parameters: at "no effect", then on the grid.
        let own: Vec<usize> = (0..compact.len())
            .filter(|&k| (0..layout.len()).any(|e| layout.compact[e] == k && layout.effect[e] == m))
            .collect();
        starts.extend(layout.with_effect(m, &fitted, &none));
        for g in 0..PER.pow(own.len() as u32) {
            let mut at = none.clone();
            let mut rem = g;
            for &k in &own {
                let (lo, hi) = (compact[k].lo, compact[k].hi);
                at[k] = lo + (hi - lo) * (rem % PER) as f64 / (PER - 1) as f64;
                rem /= PER;
            }
            starts.extend(layout.with_effect(m, &fitted, &at));
        }
    }
    let best = starts
        .into_iter()
        .map(|x| {
            let fx = subset.chi2(effects, &x);
            (x, fx)
        })
        .filter(|(_, fx)| fx.is_finite())
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    let step: Vec<f64> = compact
        .iter()
        .map(|p| (p.hi - p.lo) / (PER - 1) as f64)
        .collect();
    Some(refine(subset, effects, &best.0, &layout.expand(&step), &[]))
}

/// Nelder–Mead from `start` with initial steps `step`, the elements of `held` kept at their
/// start.
pub fn refine(
    subset: &Subset<'_, '_>,
    effects: &[Effect],
    start: &[f64],
    step: &[f64],
    held: &[usize],
) -> EffectFit {
    let (lo, hi) = subset.campaign.layout(effects).bounds();
    let free: Vec<usize> = (0..start.len()).filter(|i| !held.contains(i)).collect();
    let full = |x: &[f64]| -> Vec<f64> {
        let mut out = start.to_vec();
        for (k, &i) in free.iter().enumerate() {
            out[i] = x[k];
        }
        out
    };
    let pick = |v: &[f64]| -> Vec<f64> { free.iter().map(|&i| v[i]).collect() };
    let f = |x: &[f64]| subset.chi2(effects, &full(x));
    let (x, chi2) = nelder_mead(&f, &pick(start), &pick(step), &pick(&lo), &pick(&hi), 400);
    EffectFit {
        params: full(&x),
        chi2,
    }
}

/// The rides from which a ride left out is refitted by an unchecked Newton step
/// ([`refit_near`]).
pub const TRUSTED_NEWTON_RIDES: usize = 64;

/// The minimum of `subset`'s χ² near `start` (a fit to more rides): one Newton step on the
/// χ² surface's central-difference gradient and Hessian (steps of 1e-3 of each range), clamped
/// to the bounds; failing that, the step with the bounds active at `start` held
/// (`active_bounds`); Nelder–Mead from `start` (steps `step`) when neither lowers χ². The
/// elements of `held` stay at their start (a condition's own parameters when its rides are left
/// out). Unchecked (`check` false: a ride left out of [`TRUSTED_NEWTON_RIDES`] or more), the
/// Newton step is taken without evaluating χ² at its end: one ride of so many moves the
/// minimum by a small fraction of its error, where χ² is quadratic (with no step, the checked
/// refit runs).
/// The measurements behind it: [docs/decisions/constants.md](../../docs/decisions/constants.md#refit_near).
pub fn refit_near(
    subset: &Subset<'_, '_>,
    cache: &ResidualCache<'_, '_>,
    start: &[f64],
    step: &[f64],
    held: &[usize],
    check: bool,
) -> EffectFit {
    let effects = cache.effects;
    let (lo, hi) = cache.campaign.layout(effects).bounds();
    let n = lo.len();
    let h: Vec<f64> = (0..n).map(|i| 1e-3 * (hi[i] - lo[i])).collect();
    // Central differences need room on both sides of the start.
    let x0: Vec<f64> = (0..n)
        .map(|i| start[i].clamp(lo[i] + h[i], hi[i] - h[i]))
        .collect();
    let f = |x: &[f64]| cache.chi2(subset, x);
    let f0 = f(&x0);
    let (grad, hess) = central_differences(&f, &x0, f0, &h);
    if f0.is_finite() && grad.iter().all(|g| g.is_finite()) {
        let keep: Vec<(usize, f64)> = held.iter().map(|&i| (i, start[i])).collect();
        let mut at_bounds = active_bounds(start, &grad, &lo, &hi, &h);
        at_bounds.retain(|(i, _)| !held.contains(i));
        at_bounds.extend(keep.iter().copied());
        // Unchecked, the step that holds an active bound where there is one: the box's clamp
        // would spoil the free step there.
        if !check {
            if let Some(x1) = newton_step(&x0, &grad, &hess, &lo, &hi, &at_bounds) {
                return EffectFit {
                    params: x1,
                    chi2: f64::NAN,
                };
            }
        }
        let steps = [
            newton_step(&x0, &grad, &hess, &lo, &hi, &keep),
            newton_step(&x0, &grad, &hess, &lo, &hi, &at_bounds),
        ];
        for x1 in steps.into_iter().flatten() {
            let f1 = f(&x1);
            if f1 <= f0 {
                return EffectFit {
                    params: x1,
                    chi2: f1,
                };
            }
        }
    }
    refine(subset, effects, start, step, held)
}

/// The parameters `start` (a fit to more rides) left at a bound of their box, within `h` of it,
/// where χ² still falls outward (`grad` > 0 at the lower bound, < 0 at the upper): the
/// constraint is active there, and a subset's fit keeps them at it. Each with its bound.
fn active_bounds(
    start: &[f64],
    grad: &DVector<f64>,
    lo: &[f64],
    hi: &[f64],
    h: &[f64],
) -> Vec<(usize, f64)> {
    (0..start.len())
        .filter_map(|i| {
            if start[i] <= lo[i] + h[i] && grad[i] > 0.0 {
                Some((i, lo[i]))
            } else if start[i] >= hi[i] - h[i] && grad[i] < 0.0 {
                Some((i, hi[i]))
            } else {
                None
            }
        })
        .collect()
}

/// One Newton step from `x0` on a quadratic model (gradient `grad`, Hessian `hess`) with the
/// parameters of `held` fixed at the values given (the free ones' gradient moved by the
/// Hessian's cross terms accordingly), clamped to the box; `None` when no parameter is free
/// to move beyond those held, or the free parameters' Hessian is not positive definite. With
/// nothing held, the plain Newton step x0 − H⁻¹g.
fn newton_step(
    x0: &[f64],
    grad: &DVector<f64>,
    hess: &DMatrix<f64>,
    lo: &[f64],
    hi: &[f64],
    held: &[(usize, f64)],
) -> Option<Vec<f64>> {
    let n = x0.len();
    let mut x1 = x0.to_vec();
    for &(i, v) in held {
        x1[i] = v;
    }
    let free: Vec<usize> = (0..n).filter(|i| held.iter().all(|h| h.0 != *i)).collect();
    if free.is_empty() {
        return (!held.is_empty()).then_some(x1);
    }
    let g = DVector::from_iterator(
        free.len(),
        free.iter().map(|&i| {
            grad[i]
                + held
                    .iter()
                    .map(|&(j, v)| hess[(i, j)] * (v - x0[j]))
                    .sum::<f64>()
        }),
    );
    let dx = hess
        .select_rows(free.iter())
        .select_columns(free.iter())
        .cholesky()?
        .solve(&g);
    for (k, &i) in free.iter().enumerate() {
        x1[i] = (x0[i] - dx[k]).clamp(lo[i], hi[i]);
    }
    Some(x1)
}

/// The gradient and Hessian of `f` at `x0` (where it is `f0`) by central differences with
/// steps `h`: 2n + 2n(n−1) evaluations (3 for one parameter with `f0`, 9 for two).
fn central_differences(
    f: &dyn Fn(&[f64]) -> f64,
    x0: &[f64],
    f0: f64,
    h: &[f64],
) -> (DVector<f64>, DMatrix<f64>) {
    let n = x0.len();
    let at = |d: &[(usize, f64)]| -> f64 {
        let mut x = x0.to_vec();
        for &(i, s) in d {
            x[i] += s * h[i];
        }
        f(&x)
    };
    let mut grad = DVector::zeros(n);
    let mut hess = DMatrix::zeros(n, n);
    for i in 0..n {
        let (fp, fm) = (at(&[(i, 1.0)]), at(&[(i, -1.0)]));
        grad[i] = (fp - fm) / (2.0 * h[i]);
        hess[(i, i)] = (fp - 2.0 * f0 + fm) / (h[i] * h[i]);
        for j in 0..i {
            let v = (at(&[(i, 1.0), (j, 1.0)])
                - at(&[(i, 1.0), (j, -1.0)])
                - at(&[(i, -1.0), (j, 1.0)])
                + at(&[(i, -1.0), (j, -1.0)]))
                / (4.0 * h[i] * h[j]);
            hess[(i, j)] = v;
            hess[(j, i)] = v;
        }
    }
    (grad, hess)
}

/// Standard errors of fitted parameters from the χ² curvature, `cov = 2 H⁻¹` (central
/// differences, steps of 1e-3 of each range), inflated by √(χ²/dof) when that exceeds 1 (the
/// scatter the covariance does not explain). `NaN` where the curvature is not positive, or
/// where the rides do not touch the parameter at all.
pub fn param_se(subset: &Subset<'_, '_>, effects: &[Effect], fit: &EffectFit) -> Vec<f64> {
    let (lo, hi) = subset.campaign.layout(effects).bounds();
    let n = lo.len();
    let h: Vec<f64> = (0..n).map(|i| 1e-3 * (hi[i] - lo[i])).collect();
    let f = |x: &[f64]| subset.chi2(effects, x);
    let (_, hess) = central_differences(&f, &fit.params, fit.chi2, &h);
    let dof = subset
        .campaign
        .parts
        .count(&subset.rides)
        .saturating_sub(n)
        .max(1) as f64;
    let birge = (fit.chi2 / dof).max(1.0);
    // A parameter the rides do not touch (a condition's own gain where none of its rides was
    // usable) has no curvature and no cross terms: it has no standard error, and the others'
    // come from the rest of the Hessian (the whole one is singular).
    let largest = (0..n).map(|i| hess[(i, i)].abs()).fold(0.0, f64::max);
    let touched: Vec<usize> = (0..n)
        .filter(|&i| hess[(i, i)].is_finite() && hess[(i, i)].abs() > 1e-12 * largest)
        .collect();
    let mut se = vec![f64::NAN; n];
    if let Some(inv) = (hess
        .select_rows(touched.iter())
        .select_columns(touched.iter())
        * 0.5)
        .try_inverse()
    {
        for (k, &i) in touched.iter().enumerate() {
            let v = inv[(k, k)] * birge;
            if v > 0.0 && v.is_finite() {
                se[i] = v.sqrt();
            }
        }
    }
    se
}

/// The standard errors that `fit`'s parameters owe to what the library assumes (the tyres'
/// camber stiffness, for candidates with tyres, [`Change::Tyres`]; zeros for the others): refitted
/// with the camber one standard deviation ([`super::effects::CAMBER_SE_PER_RAD`]) either side,
/// half the parameters' change. Added in quadrature to [`param_se`] they make the error of a
/// parameter fitted in place of an unknown one (Gauss's propagation through the fit's
/// implicit function, by a central difference a standard deviation wide).
pub fn assumed_se(campaign: &Campaign<'_>, effects: &[Effect], fit: &EffectFit) -> Vec<f64> {
    let n = fit.params.len();
    if !any_change(effects, |c| matches!(c, Change::Tyres)) {
        return vec![0.0; n];
    }
    let (lo, hi) = campaign.layout(effects).bounds();
    let step: Vec<f64> = (0..n).map(|i| 0.05 * (hi[i] - lo[i])).collect();
    let refit = |sign: f64| -> Option<Vec<f64>> {
        let shifted = Campaign {
            assumed: Assumed {
                camber_per_rad: campaign.assumed.camber_per_rad
                    + sign * super::effects::CAMBER_SE_PER_RAD,
            },
            inverse: std::sync::OnceLock::new(),
            ..campaign.clone()
        };
        let subset = shifted.subset((0..campaign.obs.len()).collect())?;
        let cache = ResidualCache::new(&shifted, effects);
        let f = refit_near(&subset, &cache, &fit.params, &step, &[], true);
        f.chi2.is_finite().then_some(f.params)
    };
    match (refit(1.0), refit(-1.0)) {
        (Some(up), Some(down)) => (0..n).map(|i| 0.5 * (up[i] - down[i]).abs()).collect(),
        _ => vec![f64::NAN; n],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// f(x) = (x₀ + 1)² + (x₁ − 0.5)² + 0.5 x₀x₁ on the box [0, 2]²: its minimum (−1.2, 0.8)
    /// lies outside, and the box's is x₀ = 0 (the bound active), x₁ = 0.5.
    fn quadratic(x: &[f64]) -> f64 {
        (x[0] + 1.0).powi(2) + (x[1] - 0.5).powi(2) + 0.5 * x[0] * x[1]
    }

    /// The held-out χ² from the whole campaign's S r against the χ² of the rides kept,
    /// factored afresh: three rides of four parts, a seeded covariance with every ride
    /// correlated with the others (as the model's parameters make them).
    #[test]
    fn a_left_out_chi2_is_the_kept_rides_own() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_xoshiro::Xoshiro256StarStar::seed_from_u64(29);
        let n = 12;
        let g = DMatrix::from_fn(n, n + 3, |_, _| rng.random::<f64>() - 0.5);
        let cov = &g * g.transpose() + DMatrix::identity(n, n) * 0.1;
        let r = DVector::from_fn(n, |_, _| rng.random::<f64>() - 0.5);
        let s = cov.clone().cholesky().unwrap().inverse();
        let sr = &s * &r;
        let q = r.dot(&sr);
        for i in 0..3 {
            let kept: Vec<usize> = (0..n).filter(|k| k / 4 != i).collect();
            let sub = cov.select_rows(kept.iter()).select_columns(kept.iter());
            let rk = r.select_rows(kept.iter());
            let direct = sub
                .cholesky()
                .unwrap()
                .l()
                .solve_lower_triangular(&rk)
                .unwrap()
                .norm_squared();
            let block = s.view((4 * i, 4 * i), (4, 4)).into_owned();
            let a = sr.rows(4 * i, 4).into_owned();
            let fast = left_out_chi2(q, &a, &block.cholesky().unwrap().inverse());
            assert!(
                (fast - direct).abs() < 1e-9 * direct,
                "{fast} against {direct}"
            );
        }
    }

    /// Ten rides of 4 and 2 parts, each ride's block a seeded SPD matrix (B: the blocks and
    /// the block-diagonal whole), and 7 common columns V, as the model's measured inputs and
    /// the experiment's shared parts add to a campaign's covariance.
    fn seeded_structure(seed: u64) -> (Parts, Vec<DMatrix<f64>>, DMatrix<f64>, DMatrix<f64>) {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_xoshiro::Xoshiro256StarStar::seed_from_u64(seed);
        let parts = Parts::new((0..10).map(|i| if i % 3 == 0 { 2 } else { 4 }).collect());
        let n = parts.total();
        let mut whole = DMatrix::zeros(n, n);
        let blocks: Vec<DMatrix<f64>> = (0..10)
            .map(|i| {
                let p = parts.of(i);
                let g = DMatrix::from_fn(p, p, |_, _| rng.random::<f64>() - 0.5);
                let b = &g * g.transpose() + DMatrix::identity(p, p) * 0.2;
                whole
                    .view_mut((parts.start(i), parts.start(i)), (p, p))
                    .copy_from(&b);
                b
            })
            .collect();
        let v = DMatrix::from_fn(n, 7, |_, _| rng.random::<f64>() - 0.5);
        (parts, blocks, whole, v)
    }

    /// The structured inverse against the sum inverted whole ([`seeded_structure`]): its
    /// products and blocks within 1e-10 of the dense inverse's.
    #[test]
    fn a_low_rank_inverse_is_the_sum_inverted() {
        use rand::{RngExt, SeedableRng};
        let (parts, blocks, mut whole, v) = seeded_structure(34);
        let n = parts.total();
        whole += &v * v.transpose();
        let dense = whole.cholesky().unwrap().inverse();
        let ours = LowRankInverse::new(blocks, &parts, &v).unwrap();
        let mut rng = rand_xoshiro::Xoshiro256StarStar::seed_from_u64(35);
        let r = DVector::from_fn(n, |_, _| rng.random::<f64>() - 0.5);
        let err = (ours.mul(&parts, &r) - &dense * &r).amax();
        assert!(err < 1e-10 * (&dense * &r).amax(), "product off by {err}");
        for i in 0..10 {
            let (start, p) = (parts.start(i), parts.of(i));
            let want = dense.view((start, start), (p, p));
            let err = (ours.block(&parts, i) - want).amax();
            assert!(err < 1e-10 * dense.amax(), "block {i} off by {err}");
        }
    }

    /// The structured whitening against the dense inverse: |M x|² = xᵀ Σ⁻¹ x and M Σ Mᵀ = I on
    /// [`seeded_structure`], one common column nearly null (its λ below the series' switch).
    #[test]
    fn a_low_rank_whitening_whitens() {
        use rand::{RngExt, SeedableRng};
        let (parts, blocks, mut whole, mut v) = seeded_structure(41);
        let n = parts.total();
        v.column_mut(6).scale_mut(1e-8);
        whole += &v * v.transpose();
        let mut rng = rand_xoshiro::Xoshiro256StarStar::seed_from_u64(42);
        let w = LowRankWhitening::new(&blocks, &parts, &v).unwrap();
        let m = DMatrix::from_columns(
            &(0..n)
                .map(|j| {
                    w.whiten(
                        &parts,
                        &DMatrix::<f64>::identity(n, n).column(j).into_owned(),
                    )
                })
                .collect::<Vec<_>>(),
        );
        let err = (&m * &whole * m.transpose() - DMatrix::identity(n, n)).amax();
        assert!(err < 1e-10, "M Σ Mᵀ off the identity by {err}");
        let r = DVector::from_fn(n, |_, _| rng.random::<f64>() - 0.5);
        let dense = r.dot(&(whole.clone().cholesky().unwrap().inverse() * &r));
        let ours = w.whiten(&parts, &r).norm_squared();
        assert!(
            (ours - dense).abs() < 1e-10 * dense,
            "{ours} against {dense}"
        );
    }

    /// Rides whitened together: their pieces' squares sum to rᵀ Σ⁻¹ r (nalgebra's inverse), and
    /// a residual along the measured parameters' error, r = c u in Σ = s² I + u uᵀ, counts by
    /// the Sherman–Morrison closed form c² |u|² / (s² + |u|²), where ride by ride (each ride's
    /// own block) it counts as though every ride's share were independent.
    #[test]
    fn rides_whitened_together_discount_the_shared_error() {
        let mut u01 = crate::testing::lcg_uniform(11);
        let n = 12;
        let u = DVector::from_fn(n, |_, _| 0.5 + u01());
        let s2 = 0.3;
        let cov = DMatrix::identity(n, n) * s2 + &u * u.transpose();
        let sizes = [4, 2, 4, 2];
        let c = 1.7;
        let r = &u * c;
        let pieces = whiten_jointly(&cov, &r, &sizes);
        assert_eq!(pieces.iter().map(Vec::len).collect::<Vec<_>>(), sizes);
        let joint: f64 = pieces.iter().flatten().map(|x| x * x).sum();
        let closed = c * c * u.norm_squared() / (s2 + u.norm_squared());
        assert!(
            (joint - closed).abs() < 1e-12 * closed,
            "{joint} vs {closed}"
        );
        let direct = r.dot(&(cov.clone().try_inverse().unwrap() * &r));
        assert!((joint - direct).abs() < 1e-10 * direct);
        // Ride by ride the same residual counts several times more.
        let mut at = 0;
        let by_ride: f64 = sizes
            .iter()
            .map(|&p| {
                let block = cov.view((at, at), (p, p)).into_owned();
                let ri = r.rows(at, p).into_owned();
                at += p;
                ri.dot(&(block.try_inverse().unwrap() * &ri))
            })
            .sum();
        assert!(by_ride > 3.0 * joint, "{by_ride} vs {joint}");
        // Not positive definite: every piece empty.
        let bad = DMatrix::from_element(n, n, 1.0);
        assert!(whiten_jointly(&bad, &r, &sizes).iter().all(Vec::is_empty));
    }

    /// The triangular inverse against nalgebra's general solve of the identity.
    #[test]
    fn a_triangular_inverse_is_the_solve_of_the_identity() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_xoshiro::Xoshiro256StarStar::seed_from_u64(33);
        let n = 37;
        let g = DMatrix::from_fn(n, n, |_, _| rng.random::<f64>() - 0.5);
        let l = (&g * g.transpose() + DMatrix::identity(n, n))
            .cholesky()
            .unwrap()
            .l();
        let ours = lower_triangular_inverse(&l).unwrap();
        let theirs = l.solve_lower_triangular(&DMatrix::identity(n, n)).unwrap();
        assert!(
            (&ours - &theirs).amax() < 1e-12 * theirs.amax(),
            "{}",
            (&ours - &theirs).amax()
        );
        assert!((&l * &ours - DMatrix::identity(n, n)).amax() < 1e-12);
        assert!(lower_triangular_inverse(&DMatrix::zeros(3, 3)).is_none());
    }

    #[test]
    fn a_newton_step_keeps_an_active_bound() {
        let (lo, hi, h) = ([0.0, 0.0], [2.0, 2.0], [0.002, 0.002]);
        let x0 = [0.002, 0.4];
        let (grad, hess) = central_differences(&quadratic, &x0, quadratic(&x0), &h);
        // Central differences are exact on a quadratic (to rounding).
        assert!((grad[0] - (2.0 * 1.002 + 0.5 * 0.4)).abs() < 1e-9, "{grad}");
        assert!((hess[(0, 1)] - 0.5).abs() < 1e-6, "{hess}");
        // The plain step leaves the box and is clamped to (0, 0.8): not the box's minimum.
        let plain = newton_step(&x0, &grad, &hess, &lo, &hi, &[]).unwrap();
        assert!(
            quadratic(&plain) > quadratic(&[0.0, 0.5]) + 0.05,
            "{plain:?}"
        );
        // x₀ starts at its lower bound with χ² falling outward: held there, x₁ to 0.5.
        let held = active_bounds(&x0, &grad, &lo, &hi, &h);
        assert_eq!(held, vec![(0, 0.0)]);
        let step = newton_step(&x0, &grad, &hess, &lo, &hi, &held).unwrap();
        assert_eq!(step[0], 0.0);
        assert!((step[1] - 0.5).abs() < 1e-6, "{step:?}");
        // Nothing free: the bound point itself; nothing held and nothing free: no step.
        let both = [(0, 0.0), (1, 2.0)];
        assert_eq!(
            newton_step(&x0, &grad, &hess, &lo, &hi, &both),
            Some(vec![0.0, 2.0])
        );
        assert_eq!(
            newton_step(
                &[],
                &DVector::zeros(0),
                &DMatrix::zeros(0, 0),
                &[],
                &[],
                &[]
            ),
            None
        );
    }
}
