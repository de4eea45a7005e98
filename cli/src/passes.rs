//! What a render in passes (`--target-error`, `--time-limit`) prints: each
//! pass's samples, estimate and time, and why it stopped; and what any
//! render prints when its estimate is only a lower bound.

use farm_common::film::{PassEnd, PassStop, SamplerKind};
use farm_coordinator::estimate::Fireflies;

/// Why a render's estimate cannot be trusted to within 2× with `sampler`,
/// rendered in passes or in one: `None` when it can (measured within 2×
/// of the true relMSE from 4 spp up on the shared scenes, fireflies aside).
pub fn caveat(sampler: SamplerKind, in_passes: bool) -> Option<&'static str> {
    match sampler {
        SamplerKind::Sobol => Some(
            "the estimate may be far off: pbrt-v3's Sobol' samples are not randomized, and their error falls unevenly from one sample count to the next, which no split of the samples can see",
        ),
        SamplerKind::MaxMinDist => Some(
            "the estimate may be far too low: the maxmindist sampler puts the samples of every pixel at the same film positions, so aliasing of small bright features, which all of them share, does not show",
        ),
        SamplerKind::ZeroTwoSequence | SamplerKind::Stratified if !in_passes => Some(
            "the estimate may be a few times too high: in one pass this sampler's two halves are not sets of their own; with --target-error or --time-limit it renders in passes, where they are",
        ),
        _ => None,
    }
}

/// Why a render's estimate is a lower bound, and what counting the pixels
/// it cannot measure gives (not a bound: where no sample found a light,
/// nothing can count what is missing).
pub fn fireflies(f: &Fireflies) -> String {
    format!(
        "the estimate is a lower bound: {} pixels rest on rare bright samples (fireflies, or the edges of small lights that few samples found), whose error it cannot measure; counting their error as those samples show it gives {:.3e}, and the true error may be higher still where a light was found by few samples or none; the brightest is at ({}, {})",
        f.pixels, f.rel_mse, f.brightest.0, f.brightest.1
    )
}

/// The lines that describe a render's passes (none for a render without).
pub fn describe(passes: &[PassEnd], stopped: Option<PassStop>, target: Option<f64>) -> Vec<String> {
    if passes.is_empty() {
        return Vec::new();
    }
    let mut lines = vec!["  pass    spp  estimated relMSE   seconds".to_string()];
    for (i, p) in passes.iter().enumerate() {
        let est = p.estimate.map_or("-".to_string(), |e| format!("{e:.3e}"));
        lines.push(format!("  {:>4} {:>6}  {est:>16} {:>9.2}", i + 1, p.spp, p.seconds));
    }
    let last = passes[passes.len() - 1];
    let why = match stopped {
        Some(PassStop::TargetReached) => {
            format!("stopped: the estimate is at most the target error {:.3e}", target.unwrap_or(0.0))
        }
        Some(PassStop::TimeLimit) => "stopped: the pass ended past the time limit".to_string(),
        Some(PassStop::Cap) => match target.zip(last.estimate) {
            Some((t, e)) if e > t => format!(
                "stopped at the last pass ({} spp) without reaching the target error {t:.3e}: raise --spp",
                last.spp
            ),
            _ => format!("stopped at the last pass ({} spp)", last.spp),
        },
        None => "stopped".to_string(),
    };
    lines.push(why);
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samplers_whose_estimate_is_not_trusted_say_why() {
        assert!(caveat(SamplerKind::Halton, false).is_none());
        assert!(caveat(SamplerKind::Random, false).is_none());
        assert!(caveat(SamplerKind::Stratified, true).is_none());
        assert!(caveat(SamplerKind::Stratified, false).unwrap().contains("passes"));
        assert!(caveat(SamplerKind::Sobol, true).unwrap().contains("Sobol'"));
        assert!(caveat(SamplerKind::MaxMinDist, true).unwrap().contains("maxmindist"));
    }

    #[test]
    fn fireflies_say_the_estimate_is_a_lower_bound_and_where_they_are() {
        let f = Fireflies { pixels: 209, rel_mse: 0.52, brightest: (168, 348) };
        let line = fireflies(&f);
        for part in ["lower bound", "209 pixels", "gives 5.200e-1", "higher still", "(168, 348)"] {
            assert!(line.contains(part), "{line}");
        }
    }

    #[test]
    fn passes_are_listed_with_why_they_stopped() {
        let p = |spp, estimate, seconds| PassEnd { spp, estimate, seconds };
        assert!(describe(&[], None, None).is_empty());
        let passes = [p(4, Some(2e-3), 0.5), p(8, Some(9e-4), 1.25)];
        let lines = describe(&passes, Some(PassStop::TargetReached), Some(1e-3));
        assert_eq!(lines.len(), 4, "{lines:?}");
        assert!(lines[1].contains("2.000e-3") && lines[1].contains("0.50"), "{lines:?}");
        assert!(lines[2].contains(" 8 ") && lines[2].contains("9.000e-4"), "{lines:?}");
        assert!(lines[3].contains("target error 1.000e-3"), "{lines:?}");
        let capped = describe(&passes, Some(PassStop::Cap), Some(1e-4));
        assert!(
            capped[3].contains("without reaching") && capped[3].contains("--spp"),
            "{capped:?}"
        );
        let timed = describe(&passes, Some(PassStop::TimeLimit), None);
        assert!(timed[3].contains("time limit"), "{timed:?}");
    }
}
