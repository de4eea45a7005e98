//! `cargo bench -p farm-tests --bench features`: what the scene analysis
//! saves. Renders each shared scene that needs no ray differentials (static,
//! untextured) with the analysis (differentials skipped) and without it
//! (`all_paths`: every camera ray carries differentials and every hit
//! computes them), alternating the two, and prints render seconds and CPU
//! seconds, best and median of FARM_RUNS runs (default 5). Set FARM_SCENE
//! to run one scene.

use farm_cli::bench::cpu_seconds;
use farm_cli::embedded::{self as submit, SubmitOptions};
use farm_tests::{reference_scenes, shared_dir};

fn best_and_median(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[0], v[v.len() / 2])
}

fn main() {
    let Some(shared) = shared_dir() else {
        eprintln!("SKIPPED: ../shared (pbrt-v3 scenes) is not present");
        return;
    };
    let only = std::env::var("FARM_SCENE").ok();
    let runs: usize = std::env::var("FARM_RUNS").ok().and_then(|r| r.parse().ok()).unwrap_or(5);
    println!(
        "{:<20} {:>21} {:>21} {:>11} {:>14}",
        "scene", "analysed s best/med", "all paths s best/med", "ratio best", "CPU ratio med"
    );
    for s in reference_scenes(&shared) {
        if only.as_deref().is_some_and(|o| o != s.scene) {
            continue;
        }
        let path = shared.join("scenes").join(&s.scene).join(&s.file);
        let (mut lean, mut full) = ((Vec::new(), Vec::new()), (Vec::new(), Vec::new()));
        let mut skip = false;
        for _ in 0..runs {
            for all_paths in [false, true] {
                let opts = SubmitOptions { all_paths, ..Default::default() };
                let cpu0 = cpu_seconds();
                let r = match submit::render(&path, &opts, |_| {}) {
                    Ok(r) => r,
                    Err(e) => {
                        println!("{:<20} failed: {e}", s.scene);
                        skip = true;
                        break;
                    }
                };
                if r.features.needs_differentials() {
                    skip = true;
                    break;
                }
                let out = if all_paths { &mut full } else { &mut lean };
                out.0.push(r.render_seconds);
                out.1.push(cpu_seconds() - cpu0 - r.startup_seconds);
            }
            if skip {
                break;
            }
        }
        if skip {
            continue;
        }
        let (lb, lm) = best_and_median(lean.0);
        let (fb, fm) = best_and_median(full.0);
        let (_, lc) = best_and_median(lean.1);
        let (_, fc) = best_and_median(full.1);
        println!(
            "{:<20} {:>10.3} / {:<8.3} {:>10.3} / {:<8.3} {:>11.3} {:>14.3}",
            s.scene,
            lb,
            lm,
            fb,
            fm,
            lb / fb,
            lc / fc
        );
    }
}
