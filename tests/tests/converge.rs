//! `farm converge` on shared pbrt-v3 scenes under every pbrt-v3 sampler: a
//! render's estimate of its own relMSE, made without a reference, stays
//! within a factor of 2 of its true relMSE against pbrt-v3's ground truth
//! wherever it is claimed to (4, 16 and 64 spp); where it is not, the
//! render says why (fireflies, or a sampler's caveat).

use farm_cli::converge::{self, Against, ConvergeOptions};
use farm_cli::passes::caveat;
use farm_common::film::SamplerKind;
use farm_tests::shared_dir;

const SAMPLERS: [&str; 6] = ["halton", "sobol", "02sequence", "maxmindist", "stratified", "random"];

#[test]
fn the_self_estimate_is_within_twice_the_true_error_wherever_it_is_claimed() {
    let Some(shared) = shared_dir() else {
        eprintln!("SKIPPED: ../shared (pbrt-v3 scenes and references) is not present");
        return;
    };
    let counts = [4, 16, 64];
    let (mut failures, mut claimed, mut caveats) = (Vec::new(), 0, 0);
    for (scene, file) in [
        ("cornell-box", "cornell-box-whitted.pbrt"),
        ("teapot-area-light", "teapot-area-light-whitted.pbrt"),
        ("instances", "instances-whitted.pbrt"),
    ] {
        let reference = shared.join("reference").join(scene).join("whitted-gt256.exr");
        let path = shared.join("scenes").join(scene).join(file);
        for sampler in SAMPLERS {
            let opts = ConvergeOptions {
                spp: counts.to_vec(),
                reference: Some(reference.clone()),
                threads: 0,
                sampler: Some(sampler.to_string()),
            };
            let series = converge::run(&path, &opts, |_, _| {}).expect("series renders");
            assert_eq!(series.against, Against::Reference(reference.clone()));
            let spp: Vec<u32> = series.rows.iter().map(|r| r.spp).collect();
            assert_eq!(spp, counts, "{scene} {sampler}");
            for r in &series.rows {
                let (truth, est) = (r.rel_mse.expect("measured"), r.estimate.expect("estimated"));
                assert!(r.rays > 0 && r.ns_per_sample > 0.0);
                let ratio = est / truth;
                let why = caveat(SamplerKind::of(sampler), true);
                // Claimed exactly when neither fireflies nor the sampler
                // make it a lower bound or doubtful.
                assert_eq!(r.claimed, r.upper.is_none() && why.is_none(), "{scene} {sampler}");
                if r.claimed {
                    claimed += 1;
                    if !(0.5..=2.0).contains(&ratio) {
                        failures.push(format!(
                            "{scene} {sampler} at {} spp: estimate {est:e}, true {truth:e}",
                            r.spp
                        ));
                    }
                } else {
                    caveats += 1;
                    // A lower bound's upper value lies above the estimate.
                    if let Some(upper) = r.upper {
                        assert!(upper >= est, "{scene} {sampler}: {upper} < {est}");
                    }
                }
            }
            // Error falls with samples: the series is a convergence curve.
            let first = series.rows[0].rel_mse.unwrap();
            let last = series.rows.last().unwrap().rel_mse.unwrap();
            assert!(last < first / 4.0, "{scene} {sampler}: {first:e} → {last:e}");
        }
    }
    eprintln!("{claimed} estimates claimed, {caveats} with a caveat or a lower bound");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // 36 of the 54 when this was written: every count of every sampler
    // without a caveat; none lost to fireflies on these scenes.
    assert!(claimed >= 32, "only {claimed} estimates were claimed");
}

/// The project's own scenes for the estimate (`scenes/estimate/`), with
/// C++ pbrt-v3's ground truth of `name`.
fn project_scene(name: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/estimate");
    (dir.join(format!("{name}.pbrt")), dir.join(format!("reference/{name}-gt.exr")))
}

/// `scenes/estimate/room.pbrt` (a room lit by 32 small ceiling lights) at
/// 8 spp with the (0,2)-sequence, the issue's own case: most of the error
/// is at the lights' edges, where one sample in eight found a light that
/// covers a pixel by a few percent and most pixels found none. The halves
/// see a fifth of it; the render must say its estimate is a lower bound,
/// and its upper value must hold the true error (against pbrt-v3's ground
/// truth).
#[test]
fn a_small_lights_edges_make_the_estimate_a_lower_bound_whose_upper_value_holds_the_error() {
    let (path, reference) = project_scene("room");
    let opts = ConvergeOptions {
        spp: vec![8],
        reference: Some(reference),
        threads: 0,
        sampler: Some("02sequence".into()),
    };
    let series = converge::run(&path, &opts, |_, _| {}).expect("series renders");
    let r = &series.rows[0];
    assert_eq!(r.spp, 8);
    let (truth, est) = (r.rel_mse.expect("measured"), r.estimate.expect("estimated"));
    let upper = r.upper.expect("a lower bound, with an upper value");
    eprintln!("room at 8 spp: estimate {est:e}, upper {upper:e}, true {truth:e}");
    assert!(!r.claimed);
    assert!(est < truth / 2.0, "the halves alone: {est:e} against {truth:e}");
    assert!((truth..=4.0 * truth).contains(&upper), "upper {upper:e} against {truth:e}");
}

/// `scenes/estimate/motion.pbrt` (moving objects lit by a sky whose small
/// sun carries most of the light) at 64 spp: a rough metal box is
/// speckled, each pixel's few bright samples far above the rest. Against
/// each pixel's own value the estimate saw a third of the true error with
/// Halton samples; against its neighbourhood's level it must be within 2×
/// of pbrt-v3's ground truth, and claimed.
#[test]
fn speckle_under_a_small_sun_is_estimated_within_twice_the_true_error() {
    let (path, reference) = project_scene("motion");
    for sampler in ["halton", "random"] {
        let opts = ConvergeOptions {
            spp: vec![64],
            reference: Some(reference.clone()),
            threads: 0,
            sampler: Some(sampler.into()),
        };
        let series = converge::run(&path, &opts, |_, _| {}).expect("series renders");
        let r = &series.rows[0];
        let (truth, est) = (r.rel_mse.expect("measured"), r.estimate.expect("estimated"));
        eprintln!("motion, {sampler} at 64 spp: estimate {est:e}, true {truth:e}");
        assert!(r.claimed, "{sampler}: claimed");
        assert!((0.5..=2.0).contains(&(est / truth)), "{sampler}: {est:e} against {truth:e}");
    }
}
