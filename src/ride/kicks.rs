//! The kicks of a long recording: where each push at the saddle is, and the free decay after
//! it (where it starts, where the free motion ends), from the roll rate alone.
//!
//! In: a [`KickSeries`] (each row's time, roll rate, and whether the wheel turns), as the CSV
//! reader ([`super::csv`]) makes it in its first pass. Out: every [`Kick`], its window and why
//! it starts and ends there. The tuning constants below are the finder's whole policy.

/// A kick found in a long recording, and the free decay after it.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Kick {
    /// The roll rate's peak (s) of the kick's first swing: the push.
    pub at_s: f64,
    pub peak_roll_rate_rad_per_s: f64,
    /// The free decay, from where the push has ended ([`DecayStart`]) to where the free motion
    /// ends ([`DecayEnd`]).
    pub window_s: (f64, f64),
    pub starts: DecayStart,
    pub ends: DecayEnd,
}

/// Where a kick's free decay starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DecayStart {
    /// At the push's own peak: the swing rose in less than [`FORCED_RISE_QUARTERS`] of a
    /// quarter of the weave's period (an impulse, over by the peak).
    AtPeak,
    /// At the peak of the swing back: the push's swing rose as slowly as a free one or slower
    /// (a hand pushing through it), so that swing is forced.
    SwingBack,
    /// Where the user's window (or the short record) begins.
    Given,
}

/// Why a kick's free decay ends where it does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DecayEnd {
    /// A half-swing larger than the one before it: a new push (a hand, the harness). Ends where
    /// that half-swing begins.
    Grows,
    /// A half-swing lasting more than [`STALL_RATIO`] times the one before it: the swinging
    /// stops (the bicycle held, leaning on the harness, drifting). Ends where that half-swing
    /// should have turned (half the previous one's length after it began) when it follows the
    /// decay that far (`FOLLOWS_DECAY`), else where it begins.
    Stalls,
    /// A half-swing within the bicycle's own sway (the noise floor): ends where it begins.
    NoiseFloor,
    /// The next kick.
    NextKick,
    /// The recording's end.
    RecordEnds,
    /// [`DECAY_MAX_S`] after the start, still swinging freely.
    Longest,
    /// Where the user's window (or the short record) ends.
    Given,
}

impl DecayStart {
    pub fn words(self) -> &'static str {
        match self {
            DecayStart::AtPeak => "at the push's peak (an impulse)",
            DecayStart::SwingBack => "at the swing back (the push's own swing is forced)",
            DecayStart::Given => "where the window given begins",
        }
    }
}

impl DecayStart {
    /// The same in two words, for a table.
    pub fn short(self) -> &'static str {
        match self {
            DecayStart::AtPeak => "push's peak",
            DecayStart::SwingBack => "swing back",
            DecayStart::Given => "given",
        }
    }
}

impl DecayEnd {
    /// The same in two words, for a table.
    pub fn short(self) -> &'static str {
        match self {
            DecayEnd::Grows => "a swing grows",
            DecayEnd::Stalls => "swinging stops",
            DecayEnd::NoiseFloor => "background",
            DecayEnd::NextKick => "next kick",
            DecayEnd::RecordEnds => "record ends",
            DecayEnd::Longest => "longest window",
            DecayEnd::Given => "given",
        }
    }

    pub fn words(self) -> &'static str {
        match self {
            DecayEnd::Grows => "where a swing grows (a new push)",
            DecayEnd::Stalls => "where a swing stalls (held or drifting)",
            DecayEnd::NoiseFloor => "where the swings sink into the background sway",
            DecayEnd::NextKick => "at the next kick",
            DecayEnd::RecordEnds => "at the recording's end",
            DecayEnd::Longest => "at the longest window taken",
            DecayEnd::Given => "where the window given ends",
        }
    }
}

/// A kick's peak roll rate is at least this many times the recording's background (the
/// median |roll rate| of its quiet stretches, from the lower quartile of |roll rate| while the
/// wheel turns at over [`MOVING_MPS`], or over the whole record without a wheel-speed column):
/// a riderless bicycle on a treadmill sways at the background level, a kick stands out by an
/// order of magnitude.
pub const KICK_OVER_BACKGROUND: f64 = 8.0;
/// Two peaks closer than this (s) are one kick.
pub const KICK_SEPARATION_S: f64 = 1.5;
/// A kick's peak is more than this many times the largest swing of the second before its push.
pub const KICK_OVER_SWING: f64 = 2.0;
/// How long before its roll-rate peak a kick's motion may start (s): a hand's push lasts
/// 0.1–0.5 s and may swing the bicycle one way before the largest swing back (the real
/// recording's kicks at 141.3 and 154.0 s: a half-swing of 0.6 rad/s, then the peak 0.4 s on).
const PUSH_S: f64 = 1.0;
/// The longest free decay taken after a kick (s): a bound on the work, far beyond a stable
/// weave's decay to the background.
pub const DECAY_MAX_S: f64 = 10.0;
/// The shortest (s): less is not a decay to fit. A controller that damps the weave hard leaves
/// little: that lab marked 9 of its 63 controlled decays shorter than 0.8 s, the shortest 0.49 s
/// (gain 10 at 6 km/h); 0.45 s is half a cycle of a 7 rad/s weave, the least
/// [`crate::fit::fit_short_decay`] resolves.
pub const DECAY_MIN_S: f64 = 0.45;
/// A half-swing lasting more than this times the one before it has stopped swinging: a free
/// decay's half-swings last half its period each (a fifth longer at most where the damping is
/// heavy and the amplitude-dependent frequency drifts).
pub const STALL_RATIO: f64 = 1.4;
/// A swing that grows is the weave's own growth, not a new push, where the swing after it
/// grows by its ratio within this factor (`find_kicks_in`).
pub const GROWTH_STEADY: f64 = 1.5;

/// A stalled half-swing still follows the free decay to its due turning point when it has
/// reached this fraction of the size the decay predicts there.
const FOLLOWS_DECAY: f64 = 2.0 / 3.0;
/// A push whose swing rises over at least this fraction of its fall (peak to crossing, free:
/// a quarter period) is still pushing at its peak: a free swing rises as long as it falls, an
/// impulse in its own length (0.1 s against 0.15–0.3 s).
pub const FORCED_RISE_QUARTERS: f64 = 0.75;
/// Below this wheel speed (m/s) the bicycle is not riding.
pub const MOVING_MPS: f64 = 0.5;

/// Rows per block of [`Times`].
const TIME_BLOCK: usize = 1024;

/// A recording's times (s) in 4 bytes a row: each block of [`TIME_BLOCK`] rows as its first
/// time and every row's offset from it (an f32 offset of at most a block's span: microseconds
/// at 100 Hz).
#[derive(Debug, Default, PartialEq)]
pub(super) struct Times {
    base: Vec<f64>,
    offset: Vec<f32>,
}

impl Times {
    pub(super) fn push(&mut self, t: f64) {
        if self.offset.len() % TIME_BLOCK == 0 {
            self.base.push(t);
        }
        let base = self.base[self.base.len() - 1];
        self.offset.push((t - base) as f32);
    }

    pub(super) fn at(&self, i: usize) -> f64 {
        self.base[i / TIME_BLOCK] + f64::from(self.offset[i])
    }

    pub(super) fn len(&self) -> usize {
        self.offset.len()
    }
}

/// What kicks are found in, 9 bytes a row: the times, the roll rate (its column, or the roll's
/// central difference) and whether the wheel turns at over [`MOVING_MPS`] (every row when the
/// file has no wheel speed). A day at 100 Hz in under 80 MB.
#[derive(Debug, Default, PartialEq)]
pub struct KickSeries {
    pub(super) times: Times,
    pub(super) rate: Vec<f32>,
    pub(super) moving: Vec<bool>,
}

impl KickSeries {
    pub(crate) fn push(&mut self, t: f64, value: f64, moving: bool) {
        self.times.push(t);
        self.rate.push(value as f32);
        self.moving.push(moving);
    }

    /// The roll (held in `rate`) replaced by its central difference, in place.
    pub(crate) fn differentiate(&mut self) {
        let n = self.rate.len();
        let mut before = self.rate.first().copied().unwrap_or(0.0);
        for i in 0..n {
            let here = self.rate[i];
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let next = self.rate[b];
            let dt = self.times.at(b) - self.times.at(a);
            let previous = if a == i { here } else { before };
            self.rate[i] = if b > a && dt > 0.0 {
                ((f64::from(next) - f64::from(previous)) / dt) as f32
            } else {
                0.0
            };
            before = here;
        }
    }

    pub(super) fn t(&self, i: usize) -> f64 {
        self.times.at(i)
    }

    pub(super) fn rate(&self, i: usize) -> f64 {
        f64::from(self.rate[i])
    }

    pub(crate) fn len(&self) -> usize {
        self.times.len()
    }
}

/// One half-swing of the smoothed roll rate: from the zero crossing that begins it to the one
/// that ends it (sample indices), its peak and |peak|.
#[derive(Debug, Clone, Copy)]
struct HalfSwing {
    begin: usize,
    peak: usize,
    end: usize,
    amplitude: f64,
}

/// The half-swings of `s` from sample `from` (inside the first) to `until`: a swing changes
/// sides where `s` passes `level` beyond zero on the other side (noise about a crossing is no
/// swing), the crossing taken at the last sign change before. The last one ends at `until`
/// when it does not change sides.
fn half_swings(s: impl Fn(usize) -> f64, from: usize, until: usize, level: f64) -> Vec<HalfSwing> {
    let mut swings = Vec::new();
    let mut side = s(from).signum();
    let mut begin = (0..=from).rev().find(|&i| s(i) * side <= 0.0).unwrap_or(0);
    let mut crossing = None;
    let mut peak = from;
    for i in from..until {
        if s(i) * side <= 0.0 && crossing.is_none() {
            crossing = Some(i);
        } else if s(i) * side > 0.0 {
            crossing = None;
        }
        if s(i) * side < -level {
            let end = crossing.unwrap_or(i);
            swings.push(HalfSwing {
                begin,
                peak,
                end,
                amplitude: s(peak).abs(),
            });
            side = -side;
            begin = end;
            peak = i;
            crossing = None;
        }
        if s(i) * side > s(peak) * side {
            peak = i;
        }
    }
    swings.push(HalfSwing {
        begin,
        peak,
        end: until,
        amplitude: s(peak).abs(),
    });
    swings
}

/// The background's median |roll rate| from the lower quartile of `x` (|roll rate| while the
/// wheel turns): for a background of normal noise the median of |x| is 2.113 times its lower
/// quartile (0.6745 against 0.3186 standard deviations), and the quartile stays the
/// background's while kicks' motion fills up to three quarters of the time, where the median
/// becomes the motion's (a weave that grows for seconds after each kick).
fn background_f32(x: &mut [f32]) -> f64 {
    let (_, &mut quartile, _) = x.select_nth_unstable_by(x.len() / 4, f32::total_cmp);
    BACKGROUND_MEDIAN_OVER_QUARTILE * f64::from(quartile)
}

/// The median of a normal variable's absolute value over its lower quartile.
const BACKGROUND_MEDIAN_OVER_QUARTILE: f64 = 0.674_489_750_196_081_7 / 0.318_639_363_964_375_1;

/// [`find_kicks`] on a recording's [`KickSeries`].
pub(super) fn find_kicks_in(series: &KickSeries) -> Vec<Kick> {
    let n = series.len();
    let t = |i: usize| series.t(i);
    let rate = |i: usize| series.rate(i);
    let mut moving: Vec<f32> = (0..n)
        .filter(|&i| series.moving[i])
        .map(|i| series.rate[i].abs())
        .collect();
    if moving.len() < super::modal::MIN_SAMPLES {
        return Vec::new();
    }
    let background = background_f32(&mut moving);
    drop(moving);
    let threshold = KICK_OVER_BACKGROUND * background.max(f64::MIN_POSITIVE);
    // The swings from the rate's moving mean over about 0.1 s (a sensor's spikes are no swing).
    let dt = (t(n - 1) - t(0)) / (n - 1) as f64;
    let half = ((0.05 / dt).round() as usize).max(1);
    let s = |i: usize| -> f64 {
        let (a, b) = (i.saturating_sub(half), (i + half + 1).min(n));
        series.rate[a..b].iter().map(|&x| f64::from(x)).sum::<f64>() / (b - a) as f64
    };
    // Each kick's first and largest peaks over the threshold: a peak within KICK_SEPARATION_S
    // of the last one over it belongs to the same kick.
    let mut groups: Vec<(usize, usize)> = Vec::new();
    let mut last_over: Option<usize> = None;
    for i in 1..n.saturating_sub(1) {
        let a = rate(i).abs();
        if a <= threshold || a < rate(i - 1).abs() || a < rate(i + 1).abs() {
            continue;
        }
        match groups.last_mut() {
            Some((_, largest)) if last_over.is_some_and(|p| t(i) - t(p) < KICK_SEPARATION_S) => {
                if a > rate(*largest).abs() {
                    *largest = i;
                }
            }
            _ => groups.push((i, i)),
        }
        last_over = Some(i);
    }
    // A kick arrives on a bicycle that is not already swinging at its size: a kick whose
    // largest peak is no more than KICK_OVER_SWING times the largest swing of the second
    // before its motion began (PUSH_S before its first peak over the threshold) is part of a
    // motion under way (a decay's late swings, the capsize's drift). From the first peak, not
    // the largest: a weave that grows after its kick (below the weave speed) has its largest
    // swings seconds on, where the second before is the growth itself.
    groups.retain(|&(first, largest)| {
        let before = (0..first)
            .rev()
            .take_while(|&i| t(first) - t(i) <= 1.0 + PUSH_S)
            .filter(|&i| t(first) - t(i) >= PUSH_S)
            .map(|i| s(i).abs())
            .fold(0.0f64, f64::max);
        rate(largest).abs() > KICK_OVER_SWING * before
    });
    let firsts: Vec<usize> = groups.iter().map(|g| g.0).collect();
    let mut kicks = Vec::new();
    for (k, &p) in firsts.iter().enumerate() {
        // The next kick's motion begins where its first swing crossed zero.
        let (limit_t, limit_end) = match firsts.get(k + 1) {
            Some(&q) => {
                let begins = (p..q).rev().find(|&i| s(i) * s(q) <= 0.0).unwrap_or(q);
                (t(begins), DecayEnd::NextKick)
            }
            None => (t(n - 1), DecayEnd::RecordEnds),
        };
        let until = (p..n).find(|&i| t(i) >= limit_t).unwrap_or(n - 1);
        // The background sway's level, not a share of the kick's size, for the three things
        // it sets: where the push's rise began, which swings change sides, where the decay
        // sinks. With a tenth of the peak, a push lasting a third of a fast weave's period (a
        // controller's, ω 13–14 rad/s at 1.7–3.3 m/s) rose from that tenth in under three
        // quarters of its fall and was taken for an impulse, the swing back nearly as large
        // then ended the decay at once; and a decay of σ −1.4 to −2.9 /s sank under the tenth
        // within 0.5 s while its swings stood ten times over the gyro's noise.
        let level = 2.0 * background;
        let swings = half_swings(s, p, until, level);
        if swings.len() < 2 {
            continue;
        }
        // The push's swing: its rise from where it left the background (`level`) to its peak,
        // less the moving mean's half-width (which starts a sharp rise that much early),
        // against its fall from the peak to the crossing, free: a quarter period.
        let push = swings[0];
        let sign = s(push.peak).signum();
        let rise_from = (0..push.peak)
            .rev()
            .find(|&i| s(i) * sign < level)
            .unwrap_or(0);
        let rise_s = t(push.peak) - t(rise_from) - half as f64 * dt;
        let quarter_s = t(push.end) - t(push.peak);
        // A swing larger than the one before is a new push unless the growth goes on at its
        // rate (within a factor GROWTH_STEADY from one half-swing to the next): a weave below
        // its weave speed grows by e^{σ T/2} a half-swing, a push by a step.
        let steady_growth = |w: usize| {
            swings.get(w + 1).is_some_and(|next| {
                let (now, then) = (
                    swings[w].amplitude / swings[w - 1].amplitude,
                    next.amplitude / swings[w].amplitude,
                );
                then > 1.0 && (then / now).ln().abs() < GROWTH_STEADY.ln()
            })
        };
        // A push that rose like an impulse but whose swing back is larger, not growing on at
        // its rate, was still pushing: its own swing is forced, as a slow push's is.
        let forced_on =
            swings.len() > 2 && swings[1].amplitude > swings[0].amplitude && !steady_growth(1);
        let (first, starts) = if rise_s < FORCED_RISE_QUARTERS * quarter_s && !forced_on {
            (0, DecayStart::AtPeak)
        } else {
            (1, DecayStart::SwingBack)
        };
        let start = swings[first].peak;
        let mut end = (t(until), limit_end);
        for w in first + 1..swings.len() {
            let (prev, this) = (swings[w - 1], swings[w]);
            // A push's own swing (an impulse's) is no free half-swing: its fall, doubled, is.
            let prev_s = if w == 1 && starts == DecayStart::AtPeak {
                2.0 * (t(prev.end) - t(prev.peak))
            } else {
                t(prev.end) - t(prev.begin)
            };
            let complete = w + 1 < swings.len();
            // The last half-swing changes sides no more: where it sinks under `level` after its
            // peak the free motion has reached the background (a hard-damped weave's second
            // half-swing, a sixth of the first, does so before it would end); its length so far
            // is its length.
            let sinks = (!complete)
                .then(|| (this.peak..this.end).find(|&i| s(i).abs() < level))
                .flatten();
            let this_s = t(sinks.unwrap_or(this.end)) - t(this.begin);
            let grows = this.amplitude > prev.amplitude;
            if grows && steady_growth(w) {
                continue;
            } else if grows && complete {
                end = (t(this.begin), DecayEnd::Grows);
            } else if this_s > STALL_RATIO * prev_s && prev_s > 0.0 {
                // The free motion runs into the stalled swing as far as it follows the decay:
                // to the swing's due turning point where it has reached FOLLOWS_DECAY of the
                // size the decay predicts by then (the last two swings' ratio; the last's
                // size where there is one only), else not past its beginning.
                let ratio = if w >= first + 2 {
                    prev.amplitude / swings[w - 2].amplitude
                } else {
                    1.0
                };
                let due_t = t(this.begin) + 0.5 * prev_s;
                let due = (this.begin..=this.end)
                    .find(|&i| t(i) >= due_t)
                    .unwrap_or(this.end);
                let reached = s(due) * s(this.peak).signum();
                let at = if reached >= FOLLOWS_DECAY * ratio * prev.amplitude {
                    due_t
                } else {
                    t(this.begin)
                };
                end = (at, DecayEnd::Stalls);
            } else if this.amplitude < level {
                end = (t(this.begin), DecayEnd::NoiseFloor);
            } else if let Some(i) = sinks {
                end = (t(i), DecayEnd::NoiseFloor);
            } else {
                continue;
            }
            break;
        }
        if end.0 - t(start) > DECAY_MAX_S {
            end = (t(start) + DECAY_MAX_S, DecayEnd::Longest);
        }
        let end_t = end.0.min(t(until));
        if end_t - t(start) >= DECAY_MIN_S {
            kicks.push(Kick {
                at_s: t(p),
                peak_roll_rate_rad_per_s: rate(p),
                window_s: (t(start), end_t),
                starts,
                ends: end.1,
            });
        }
    }
    kicks
}
