//! What a render in passes (`--target-error`, `--time-limit`) prints: each
//! pass's samples, estimate and time, and why it stopped.

use farm_common::film::{PassEnd, PassStop};

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
