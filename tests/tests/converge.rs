//! `farm converge` on shared pbrt-v3 scenes: a render's estimate of its own
//! relMSE, made without a reference, stays within a factor of 2 of its true
//! relMSE against pbrt-v3's ground truth at every sample count from 4 up:
//! on two Halton scenes and two (0,2)-sequence scenes.

use farm_cli::converge::{self, Against, ConvergeOptions};
use farm_tests::shared_dir;

#[test]
fn the_self_estimate_is_within_twice_the_true_error_from_4_spp_up() {
    let Some(shared) = shared_dir() else {
        eprintln!("SKIPPED: ../shared (pbrt-v3 scenes and references) is not present");
        return;
    };
    let mut failures = Vec::new();
    for (scene, file, counts) in [
        ("cornell-box", "cornell-box-whitted.pbrt", &[4, 8, 16, 32][..]),
        ("killeroo-simple", "killeroo-simple-whitted.pbrt", &[4, 8, 16, 32]),
        ("teapot-area-light", "teapot-area-light-whitted.pbrt", &[4, 8, 16, 32]),
        (
            "spheres-differentials-texfilt",
            "spheres-differentials-texfilt-whitted.pbrt",
            &[4, 8, 16],
        ),
    ] {
        let reference = shared.join("reference").join(scene).join("whitted-gt256.exr");
        let opts = ConvergeOptions {
            spp: counts.to_vec(),
            reference: Some(reference.clone()),
            threads: 0,
            sampler: None,
        };
        let path = shared.join("scenes").join(scene).join(file);
        let series = converge::run(&path, &opts, |_, _| {}).expect("series renders");
        assert_eq!(series.against, Against::Reference(reference));
        let spp: Vec<u32> = series.rows.iter().map(|r| r.spp).collect();
        assert_eq!(spp, counts);
        println!("{}", series.csv());
        for r in &series.rows {
            let (truth, est) = (r.rel_mse.expect("measured"), r.estimate.expect("estimated"));
            assert!(r.rays > 0 && r.ns_per_sample > 0.0);
            let ratio = est / truth;
            if !(0.5..=2.0).contains(&ratio) {
                failures
                    .push(format!("{scene} at {} spp: estimate {est:e}, true {truth:e}", r.spp));
            }
        }
        // Error falls with samples: the series is a convergence curve.
        let first = series.rows[0].rel_mse.unwrap();
        let last = series.rows.last().unwrap().rel_mse.unwrap();
        assert!(last < first / 4.0, "{scene}: {first:e} → {last:e}");
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
