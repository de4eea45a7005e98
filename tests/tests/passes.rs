//! Renders in passes (`--target-error`, `--time-limit`): a job stopped
//! after the pass that reached n samples per pixel gives the image of a
//! one-shot n-sample render, within the bound that adding the same terms in
//! another grouping allows (Halton and Sobol'), and a sampler with state
//! renders its first pass as a one-shot render of that size.

use farm_cli::embedded::{self as submit, RenderSummary, SubmitOptions};
use farm_common::film::{sum_order_bound, PassStop};
use farm_common::image::RgbImage;
use farm_tests::bits;
use std::path::{Path, PathBuf};

/// The project's example scene, small, with `sampler` and without the
/// floor's texture (whose filtering depends on the job's sample count);
/// the filter stays the 2-pixel Gaussian, so samples reach 25 pixels.
/// The scene's folder goes when the returned guard is dropped.
fn scene(sampler: &str) -> (tempfile::TempDir, PathBuf) {
    let text = farm_tests::small_example(120, 80, sampler).replace(
        "Material \"matte\" \"texture Kd\" \"checks\"",
        "Material \"matte\" \"rgb Kd\" [ 0.5 0.5 0.5 ]",
    );
    let dir = tempfile::Builder::new().prefix("farm-passes-").tempdir().unwrap();
    let path = dir.path().join(format!("{sampler}.pbrt"));
    std::fs::write(&path, text).unwrap();
    (dir, path)
}

fn render(
    path: &Path,
    spp: u32,
    target_error: Option<f64>,
    time_limit: Option<f64>,
) -> RenderSummary {
    let opts = SubmitOptions {
        spp: Some(spp),
        threads: 2,
        target_error,
        time_limit,
        ..Default::default()
    };
    submit::render(path, &opts, |_| {}).expect("render")
}

/// Every channel of `a` and `b` within `rel` of each other; returns how
/// many pixels are bit-identical and the largest relative difference.
fn within(a: &RgbImage, b: &RgbImage, rel: f64, what: &str) -> (usize, f64) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let (mut same, mut worst) = (0, 0.0f64);
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        same += usize::from(p.map(f32::to_bits) == q.map(f32::to_bits));
        for c in 0..3 {
            let (x, y) = (f64::from(p[c]), f64::from(q[c]));
            let size = x.abs().max(y.abs());
            assert!(
                (x - y).abs() <= rel * size + 1e-30,
                "{what}: pixel {i} channel {c}: {x} against {y}, over the bound {rel:e}"
            );
            if size > 0.0 {
                worst = worst.max((x - y).abs() / size);
            }
        }
    }
    (same, worst)
}

#[test]
fn four_passes_give_the_one_shot_image_within_the_float_bound() {
    // Halton at 11 spp renders in 4 passes; Sobol' rounds up to 16, in 5.
    for (sampler, spp, reached) in
        [("halton", 11, &[4, 6, 8, 11][..]), ("sobol", 16, &[4, 6, 8, 11, 16][..])]
    {
        let (_dir, path) = scene(sampler);
        // A target of 0 is never reached: every pass renders.
        let passes = render(&path, spp, Some(0.0), None);
        let once = render(&path, spp, None, None);
        let ends: Vec<u32> = passes.passes.iter().map(|p| p.spp).collect();
        assert_eq!(ends, reached, "{sampler}");
        assert_eq!(passes.stopped, Some(PassStop::Cap));
        assert_eq!(passes.stats.camera_rays, once.stats.camera_rays, "{sampler}: the same samples");
        assert_eq!(passes.stats.total_rays(), once.stats.total_rays(), "{sampler}: the same rays");
        // Each of Σw·c and Σw is the same sum of non-negative terms (a
        // Gaussian filter, no negative radiance), at most spp × 5 × 5 of
        // them, grouped by pass and tile instead of added in one run. The
        // image divides the two, and that division rounds once more.
        let terms = u64::from(spp) * 25;
        let sum = 1.0 + 1e-6;
        let rel = 2.0 * sum_order_bound(terms, sum) + f64::from(f32::EPSILON);
        let (same, worst) = within(&passes.image, &once.image, rel, sampler);
        eprintln!(
            "{sampler}: {} passes; {same} of {} pixels bit-identical; largest difference {worst:.2e} of the value, bound {rel:.2e}",
            ends.len(),
            once.image.pixels.len()
        );
        // Their estimates split the samples differently (the last pass
        // against the rest; the first half against the second).
        let (e1, e2) = (passes.error.unwrap().rel_mse, once.error.unwrap().rel_mse);
        assert!((0.5..=2.0).contains(&(e1 / e2)), "{sampler}: estimates {e1} and {e2}");
    }
}

#[test]
fn a_sampler_with_state_renders_its_first_pass_as_a_one_shot_render() {
    for sampler in ["stratified", "random", "02sequence", "maxmindist"] {
        let (_dir, path) = scene(sampler);
        // Any estimate meets this target: the render stops after pass 1.
        let first = render(&path, 32, Some(f64::MAX), None);
        assert_eq!((first.spp, first.stopped), (4, Some(PassStop::TargetReached)), "{sampler}");
        let once = render(&path, 4, None, None);
        assert!(
            bits(&first.image) == bits(&once.image),
            "{sampler}: first pass differs from 4 spp"
        );
        // Its halves too: the estimates are the same.
        assert_eq!(first.error.map(|e| e.rel_mse), once.error.map(|e| e.rel_mse), "{sampler}");
        // Later passes draw on streams of their own: 8 samples in passes
        // after the first are not the one-shot 8-sample set, but as good.
        let passes = render(&path, 8, Some(0.0), None);
        let reached: Vec<u32> = passes.passes.iter().map(|p| p.spp).collect();
        let want: &[u32] = if sampler.ends_with("sequence") || sampler == "maxmindist" {
            &[4, 8]
        } else {
            &[4, 6, 8]
        };
        assert_eq!(reached, want, "{sampler}");
        let eight = render(&path, 8, None, None);
        assert!(bits(&passes.image) != bits(&eight.image), "{sampler}");
    }
}

#[test]
fn a_time_limit_stops_after_the_pass_that_ends_past_it() {
    let (_dir, path) = scene("halton");
    let r = render(&path, 64, None, Some(0.0));
    assert_eq!((r.spp, r.stopped, r.passes.len()), (4, Some(PassStop::TimeLimit), 1));
    let r = render(&path, 64, None, Some(1e9));
    assert_eq!((r.spp, r.stopped, r.passes.len()), (64, Some(PassStop::Cap), 9));
    let secs: Vec<f64> = r.passes.iter().map(|p| p.seconds).collect();
    assert!(secs.windows(2).all(|w| w[0] <= w[1]), "{secs:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn passes_on_two_workers_match_the_embedded_passes_bit_for_bit() {
    use farm_cli::client::{self, Remote, RemoteOptions};
    let (_dir, path) = scene("halton");
    let embedded = render(&path, 16, Some(0.0), None);
    let cluster =
        farm_tests::cluster::TestCluster::start(2, std::time::Duration::from_millis(500)).await;
    let remote = Remote::insecure(&cluster.url);
    let opts = RemoteOptions { spp: Some(16), target_error: Some(0.0), ..Default::default() };
    let farm = client::submit(&remote, &path, &opts, |_, _| {}).await.expect("farm render");
    assert!(bits(&farm.image) == bits(&embedded.image), "image differs");
    let spp = |s: &RenderSummary| s.passes.iter().map(|p| (p.spp, p.estimate)).collect::<Vec<_>>();
    assert_eq!(spp(&farm), spp(&embedded));
    assert_eq!(farm.stopped, Some(PassStop::Cap));
    // A plan that cannot be is refused before anything renders.
    for (e, s) in [(Some(f64::NAN), None), (Some(-1.0), None), (None, Some(f64::INFINITY))] {
        let bad = RemoteOptions { target_error: e, time_limit: s, ..opts.clone() };
        let err = client::submit(&remote, &path, &bad, |_, _| {}).await.expect_err("refused");
        assert!(err.to_string().contains("passes:"), "{err}");
    }
    cluster.stop().await;
}
