//! `cargo bench -p farm-tests --bench scenes`: renders every shared pbrt-v3
//! scene at its file's settings and prints wall and CPU seconds, start-up
//! time and rays per second next to pbrt-v3's numbers from the reference
//! README. Set FARM_SCENE to run one scene, FARM_THREADS to pick the thread count.

use farm_cli::bench::cpu_seconds;
use farm_cli::embedded::{self as submit, SubmitOptions};
use farm_tests::{reference_scenes, shared_dir};
use std::time::Instant;

fn main() {
    let Some(shared) = shared_dir() else {
        eprintln!("SKIPPED: ../shared (pbrt-v3 scenes) is not present");
        return;
    };
    let only = std::env::var("FARM_SCENE").ok();
    let threads = std::env::var("FARM_THREADS").ok().and_then(|t| t.parse().ok()).unwrap_or(0);
    println!(
        "{:<32} {:>8} {:>8} {:>9} {:>10} {:>10} {:>9}",
        "scene", "wall s", "CPU s", "start s", "Mrays", "Mrays/s", "spp"
    );
    for s in reference_scenes(&shared) {
        if only.as_deref().is_some_and(|o| o != s.scene) {
            continue;
        }
        let path = shared.join("scenes").join(&s.scene).join(&s.file);
        let cpu0 = cpu_seconds();
        let t = Instant::now();
        let opts = SubmitOptions { threads, ..Default::default() };
        match submit::render(&path, &opts, |_| {}) {
            Ok(r) => {
                let wall = t.elapsed().as_secs_f64();
                let cpu = cpu_seconds() - cpu0;
                let rays = r.stats.total_rays() as f64;
                println!(
                    "{:<32} {:>8.2} {:>8.2} {:>9.3} {:>10.2} {:>10.2} {:>9}",
                    s.scene,
                    wall,
                    cpu,
                    r.startup_seconds,
                    rays / 1e6,
                    rays / r.render_seconds / 1e6,
                    r.spp
                );
            }
            Err(e) => println!("{:<32} failed: {e}", s.scene),
        }
    }
}
