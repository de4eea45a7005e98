//! Renders in passes (`farm submit --target-error E`, `--time-limit S`).
//!
//! A job of N samples per pixel (its cap) can render in passes: the first
//! pass takes each pixel's first [`FIRST_PASS_SPP`] samples, each later
//! pass takes the count about √2 times higher ([`PassPlan::new`]), and the
//! last stops at N. After each pass the
//! scheduler asks the film for its error estimate and stops once it is at
//! most E, or once a pass ends past S seconds. The plan depends only on N,
//! E and S, so which passes render depends on the scene and E alone (S is
//! a deadline, and so depends on the farm by design).
//!
//! Halton and Sobol' samples depend only on (pixel, sample index), so a
//! pass continues each pixel's sequence: a job stopped after the pass that
//! reached n samples has traced exactly the rays of a one-shot n-sample
//! render. Their image differs from the one-shot image only in the order
//! of the float additions (each pass's sums are added to the film as a
//! whole), bounded by [`sum_order_bound`]. The other samplers draw from a
//! generator per tile whose state after a pixel depends on every sample
//! drawn before it; their passes are each a set of their own size, drawn
//! on a stream of their own, as a one-shot render of that size would be.

use super::SamplerKind;
use serde::{Deserialize, Serialize};

/// Samples per pixel of a plan's first pass.
pub const FIRST_PASS_SPP: u32 = 4;

/// The samples per pixel a render in passes may reach when the command
/// line gives no `--spp`.
pub const DEFAULT_PASS_CAP: u32 = 1024;

/// The samples of each pixel a tile render takes: indices `first..end` of
/// the pixel's sequence, those from `second_from` on counting towards the
/// second half-image of the error estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SampleRange {
    /// The first sample's index.
    pub first: u32,
    /// One past the last sample's index.
    pub end: u32,
    /// The first index of the second half.
    pub second_from: u32,
    /// Whether the sampler's own halves (`Halves`) split the samples
    /// instead: the first pass of a sampler with state, one set of its own.
    pub own_halves: bool,
}

impl SampleRange {
    /// Samples a pixel gets.
    pub fn len(&self) -> u32 {
        self.end.saturating_sub(self.first)
    }

    /// Whether no sample is taken.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Why the range cannot be rendered by a sampler of `spp` samples per
    /// pixel, if it cannot (a worker checks what a coordinator sends).
    pub fn check(&self, spp: u32) -> Result<(), String> {
        if self.first >= self.end || self.end > spp {
            return Err(format!(
                "samples {}..{} are not within the job's {spp} samples per pixel",
                self.first, self.end
            ));
        }
        if self.second_from < self.first || self.second_from > self.end {
            return Err(format!(
                "the second half's first sample {} is outside samples {}..{}",
                self.second_from, self.first, self.end
            ));
        }
        Ok(())
    }
}

/// A job's passes and when to stop them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PassPlan {
    /// Samples per pixel reached at the end of each pass (increasing; the
    /// last is the job's cap).
    pub totals: Vec<u32>,
    /// Stop after the first pass whose estimated relMSE is at most this.
    pub target_error: Option<f64>,
    /// Stop after the first pass that ends this many seconds or more after
    /// the render started.
    pub time_limit: Option<f64>,
    /// Whether the first pass splits its samples by the sampler's own
    /// halves (a sampler with state: its first pass is one set).
    pub own_first_halves: bool,
}

/// Why a planned render stopped where it did.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum PassStop {
    /// The estimate reached the target.
    TargetReached,
    /// The time limit passed.
    TimeLimit,
    /// The last pass (the cap) is done.
    Cap,
}

impl PassPlan {
    /// The plan for a job of `cap` samples per pixel: [`FIRST_PASS_SPP`]
    /// (or `cap`, if fewer), then about √2 times as many each pass (4, 6,
    /// 8, 11, 16, 23, 32, …: every other count a power of two), then `cap`.
    /// A pass's error is then at most about twice the next one's, so a
    /// render that stops at its target's first pass does not overshoot it
    /// far.
    pub fn new(cap: u32, target_error: Option<f64>, time_limit: Option<f64>) -> PassPlan {
        let cap = cap.max(1);
        let mut totals = Vec::new();
        let mut n = u64::from(FIRST_PASS_SPP.min(cap));
        while n < u64::from(cap) {
            totals.push(n as u32);
            let between = (n as f64 * std::f64::consts::SQRT_2).round() as u64;
            totals.extend(Some(between).filter(|&b| b > n && b < u64::from(cap)).map(|b| b as u32));
            n *= 2;
        }
        totals.push(cap);
        PassPlan { totals, target_error, time_limit, own_first_halves: false }
    }

    /// The plan of a job of `spp` samples per pixel of sampler `kind` that
    /// stops at `target_error` or `time_limit`; `None` when neither is
    /// given (the job renders in one pass).
    pub fn for_job(
        kind: SamplerKind,
        spp: u32,
        target_error: Option<f64>,
        time_limit: Option<f64>,
    ) -> Option<PassPlan> {
        if target_error.is_none() && time_limit.is_none() {
            return None;
        }
        Some(PassPlan::new(spp, target_error, time_limit).for_sampler(kind))
    }

    /// The plan, for sampler `kind`. A sampler with state renders each pass
    /// as a set of its own: its first pass splits by the sampler's own
    /// halves, as a one-shot render does, and the film treats the later
    /// passes' halves as independent sets (`Film::next_pass`).
    /// The (0,2)-sequence and maxmindist samplers take a power of two
    /// samples a set, so their passes end at powers of two (and the cap).
    pub fn for_sampler(mut self, kind: SamplerKind) -> PassPlan {
        self.own_first_halves = !kind.continues_sequence();
        if matches!(kind, SamplerKind::ZeroTwoSequence | SamplerKind::MaxMinDist) {
            let cap = self.totals.last().copied();
            self.totals.retain(|&n| n.is_power_of_two() || Some(n) == cap);
        }
        self
    }

    /// Why the values cannot make a plan, if they cannot.
    pub fn check(&self) -> Result<(), String> {
        if self.totals.is_empty()
            || self.totals[0] == 0
            || self.totals.windows(2).any(|w| w[0] >= w[1])
        {
            return Err(format!("pass totals {:?} do not increase from 1 up", self.totals));
        }
        if let Some(e) = self.target_error.filter(|e| !(e.is_finite() && *e >= 0.0)) {
            return Err(format!("target error {e} is not a finite number ≥ 0"));
        }
        if let Some(s) = self.time_limit.filter(|s| !(s.is_finite() && *s >= 0.0)) {
            return Err(format!("time limit {s} is not a finite number of seconds ≥ 0"));
        }
        Ok(())
    }

    /// Pass `pass`'s samples: after the first, each pass's samples are the
    /// second half of the render it completes (the first's second half is
    /// its own second half).
    pub fn range(&self, pass: usize) -> SampleRange {
        let end = self.totals[pass];
        let first = if pass == 0 { 0 } else { self.totals[pass - 1] };
        let second_from = if pass == 0 { end / 2 } else { first };
        SampleRange { first, end, second_from, own_halves: pass == 0 && self.own_first_halves }
    }

    /// Whether to stop after pass `pass`, given the estimate it left and
    /// the seconds since the render started; `None` to go on.
    pub fn stop_after(&self, pass: usize, estimate: Option<f64>, seconds: f64) -> Option<PassStop> {
        if pass + 1 >= self.totals.len() {
            Some(PassStop::Cap)
        } else if self.target_error.zip(estimate).is_some_and(|(e, est)| est <= e) {
            Some(PassStop::TargetReached)
        } else if self.time_limit.is_some_and(|s| seconds >= s) {
            Some(PassStop::TimeLimit)
        } else {
            None
        }
    }
}

/// What one pass of a planned render left.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PassEnd {
    /// Samples per pixel reached.
    pub spp: u32,
    /// The estimated relMSE after it, if there is one: the value the plan
    /// decides by, which counts the error of fireflies when the render has
    /// them (the estimate is then a lower bound, and this an upper value).
    pub estimate: Option<f64>,
    /// Seconds from the render's start to the pass's end.
    pub seconds: f64,
}

/// The most two f32 sums of the same `n` terms, added in different orders
/// or groupings, can differ by: each is within γ(n−1)·Σ|term| of the exact
/// sum (Higham, *Accuracy and Stability of Numerical Algorithms*, §4.2),
/// with γ(k) = k·u/(1 − k·u) and u = 2⁻²⁴, so they are within twice that of
/// each other. `abs_sum` is Σ|term|.
pub fn sum_order_bound(n: u64, abs_sum: f64) -> f64 {
    let ku = n.saturating_sub(1) as f64 * f64::from(f32::EPSILON) / 2.0;
    2.0 * ku / (1.0 - ku) * abs_sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_start_at_four_samples_and_grow_by_about_root_two_up_to_the_cap() {
        assert_eq!(PassPlan::new(64, None, None).totals, vec![4, 6, 8, 11, 16, 23, 32, 45, 64]);
        assert_eq!(
            PassPlan::new(100, None, None).totals,
            vec![4, 6, 8, 11, 16, 23, 32, 45, 64, 91, 100]
        );
        assert_eq!(PassPlan::new(11, None, None).totals, vec![4, 6, 8, 11]);
        assert_eq!(PassPlan::new(5, None, None).totals, vec![4, 5]);
        assert_eq!(PassPlan::new(2, None, None).totals, vec![2]);
        assert_eq!(PassPlan::new(0, None, None).totals, vec![1]);
        let p = PassPlan::new(u32::MAX, None, None);
        assert_eq!(*p.totals.last().unwrap(), u32::MAX);
        assert!(p.check().is_ok());
    }

    #[test]
    fn each_later_pass_is_the_second_half_of_the_render_it_completes() {
        let p = PassPlan::new(32, None, None);
        assert_eq!(p.range(0), SampleRange { first: 0, end: 4, second_from: 2, own_halves: false });
        assert_eq!(p.range(1), SampleRange { first: 4, end: 6, second_from: 4, own_halves: false });
        assert_eq!(
            p.range(6),
            SampleRange { first: 23, end: 32, second_from: 23, own_halves: false }
        );
        let covered: u32 = (0..p.totals.len()).map(|k| p.range(k).len()).sum();
        assert_eq!(covered, 32);
    }

    #[test]
    fn a_plan_stops_at_the_target_the_time_limit_or_the_cap() {
        let p = PassPlan::new(64, Some(1e-3), Some(10.0));
        assert_eq!(p.stop_after(0, Some(2e-3), 1.0), None);
        assert_eq!(p.stop_after(0, None, 1.0), None);
        assert_eq!(p.stop_after(1, Some(1e-3), 1.0), Some(PassStop::TargetReached));
        assert_eq!(p.stop_after(1, Some(5e-3), 10.0), Some(PassStop::TimeLimit));
        assert_eq!(p.stop_after(8, Some(5e-3), 1.0), Some(PassStop::Cap));
        // A target of 0 is never reached before the cap (a zero estimate aside).
        let all = PassPlan::new(64, Some(0.0), None);
        assert_eq!(all.stop_after(2, Some(1e-9), 1.0), None);
    }

    #[test]
    fn a_sampler_with_state_splits_its_first_pass_by_its_own_halves() {
        for (kind, own) in [
            (SamplerKind::Halton, false),
            (SamplerKind::Sobol, false),
            (SamplerKind::Stratified, true),
            (SamplerKind::Random, true),
        ] {
            let p = PassPlan::for_job(kind, 64, Some(1e-3), None).unwrap();
            assert_eq!((p.range(0).own_halves, p.range(1).own_halves), (own, false), "{kind:?}");
            assert_eq!(p.totals, [4, 6, 8, 11, 16, 23, 32, 45, 64]);
        }
        for kind in [SamplerKind::ZeroTwoSequence, SamplerKind::MaxMinDist] {
            let p = PassPlan::for_job(kind, 64, Some(1e-3), None).unwrap();
            assert_eq!(p.totals, [4, 8, 16, 32, 64], "{kind:?}: powers of two");
        }
        assert_eq!(PassPlan::for_job(SamplerKind::Random, 64, None, None), None);
    }

    #[test]
    fn plans_and_ranges_from_the_wire_are_checked() {
        let bad = |totals: Vec<u32>, e: Option<f64>, s: Option<f64>| {
            PassPlan { totals, target_error: e, time_limit: s, own_first_halves: false }
                .check()
                .is_err()
        };
        assert!(bad(vec![], None, None));
        assert!(bad(vec![0, 4], None, None));
        assert!(bad(vec![4, 4], None, None));
        assert!(bad(vec![4, 8], Some(f64::NAN), None));
        assert!(bad(vec![4, 8], Some(-1.0), None));
        assert!(bad(vec![4, 8], None, Some(f64::INFINITY)));
        assert!(!bad(vec![4, 8], Some(0.0), Some(0.0)));
        let r =
            |first, end, second_from| SampleRange { first, end, second_from, own_halves: false };
        assert!(r(0, 4, 2).check(4).is_ok());
        assert!(r(0, 5, 2).check(4).is_err());
        assert!(r(4, 4, 4).check(8).is_err());
        assert!(r(4, 8, 3).check(8).is_err());
        assert!(r(4, 8, 9).check(8).is_err());
    }

    #[test]
    fn the_sum_order_bound_covers_a_reordered_sum() {
        // Terms whose sums round differently in different orders.
        let terms: Vec<f32> = (0..1000).map(|i| 1.0 / (1.0 + i as f32 * 0.37)).collect();
        let forward: f32 = terms.iter().sum();
        let backward: f32 = terms.iter().rev().sum();
        let grouped: f32 = terms.chunks(7).map(|c| c.iter().sum::<f32>()).sum();
        let abs: f64 = terms.iter().map(|t| f64::from(t.abs())).sum();
        let bound = sum_order_bound(terms.len() as u64, abs);
        assert!(
            forward != backward || forward != grouped,
            "the test needs a reordering that rounds"
        );
        assert!(f64::from((forward - backward).abs()) <= bound);
        assert!(f64::from((forward - grouped).abs()) <= bound);
        assert!(bound < 1e-3 * abs);
    }
}
