//! `cargo bench -p farm-tests --bench farm_sim_real`: the simulated farm
//! (`farm_coordinator::sim`) on a real render's tile costs rather than
//! drawn ones.
//!
//! For each shared scene (FARM_SCENE picks one), every tile is rendered on
//! one thread and timed. The cost map is stretched over a 4K frame's
//! 240×135 tiles (each 4K tile takes the cost of the scene's tile under
//! its centre) and scaled to a mean of 1.2 thread-seconds, a 4K frame at
//! 64 spp on the shared machines. So the costs keep the scene's spatial
//! structure: the costly tiles come together, where the objects are, in
//! the rows the scheduler hands out in turn. Then the real scheduler runs
//! 100 and 1,000 virtual workers of 16 threads on it, rendering a tile per
//! thread or each tile on all their threads in turn, with and without 1%
//! of 10× stragglers (messages take 1 ms each way).

use farm_common::ids::TileId;
use farm_coordinator::sim::{simulate, SimConfig};
use farm_render::{RenderOptions, Renderer};
use farm_tests::{reference_scenes, shared_dir};
use std::time::{Duration, Instant};

const WIDTH: i32 = 3840;
const HEIGHT: i32 = 2160;
const MEAN: f64 = 1.2;

/// Seconds of each tile of the scene's film on this thread, with the
/// film's tiles across and down.
fn tile_seconds(r: &Renderer) -> (Vec<f64>, i32, i32) {
    let n = r.film.tile_count();
    // Once untimed, so first-touch page faults are not counted.
    for t in 0..n {
        r.render_tile(TileId(t));
    }
    let times = (0..n)
        .map(|t| {
            let start = Instant::now();
            std::hint::black_box(r.render_tile(TileId(t)));
            start.elapsed().as_secs_f64()
        })
        .collect();
    (times, r.film.n_tiles.x, r.film.n_tiles.y)
}

/// The costs of a 4K frame's tiles, in tile order: each takes the cost of
/// the scene's tile under its centre, scaled to a mean of `MEAN`.
fn stretched(times: &[f64], nx: i32, ny: i32) -> Vec<f64> {
    let (tx, ty) = ((WIDTH + 15) / 16, (HEIGHT + 15) / 16);
    let mut costs = Vec::with_capacity((tx * ty) as usize);
    for row in 0..ty {
        for col in 0..tx {
            let sx = ((f64::from(col) + 0.5) / f64::from(tx) * f64::from(nx)) as i32;
            let sy = ((f64::from(row) + 0.5) / f64::from(ty) * f64::from(ny)) as i32;
            costs.push(times[(sy.min(ny - 1) * nx + sx.min(nx - 1)) as usize]);
        }
    }
    let mean = costs.iter().sum::<f64>() / costs.len() as f64;
    costs.iter().map(|c| c * MEAN / mean.max(1e-12)).collect()
}

fn main() {
    let Some(shared) = shared_dir() else {
        eprintln!("SKIPPED: ../shared (pbrt-v3 scenes) is not present");
        return;
    };
    let only = std::env::var("FARM_SCENE").ok();
    println!(
        "simulated farm on real tile costs: 3840×2160, 16 threads a worker, mean tile 1.2 thread-s"
    );
    println!(
        "{:<30} {:>8} {:>7} {:>10} {:>11} {:>8} {:>8} {:>7} {:>7}",
        "scene", "max/mean", "workers", "tiles", "case", "makespan", "ideal", "effic.", "tail s"
    );
    for s in reference_scenes(&shared) {
        if only.as_deref().is_some_and(|o| o != s.scene) {
            continue;
        }
        let path = shared.join("scenes").join(&s.scene).join(&s.file);
        let built = farm_scene::parse_file(&path).map_err(|e| e.to_string()).and_then(|(d, _)| {
            Renderer::new(d, &RenderOptions::default()).map_err(|e| e.to_string())
        });
        let r = match built {
            Ok((r, _)) => r,
            Err(e) => {
                println!("{:<30} failed: {e}", s.scene);
                continue;
            }
        };
        let (times, nx, ny) = tile_seconds(&r);
        let costs = stretched(&times, nx, ny);
        let peak = costs.iter().copied().fold(0.0, f64::max) / MEAN;
        for workers in [100usize, 1000] {
            for (mode, case) in ["per-thread", "parallel"]
                .into_iter()
                .flat_map(|m| ["plain", "stragglers"].map(|c| (m, c)))
            {
                let mut c = SimConfig::new(workers, 16, WIDTH, HEIGHT, MEAN);
                c.tile_costs = Some(costs.clone());
                c.latency = Duration::from_millis(1);
                c.give_up_after = Duration::from_secs(600);
                c.parallel_tiles = mode == "parallel";
                if case == "stragglers" {
                    c.stragglers = 0.01;
                }
                let rep = simulate(&c);
                println!(
                    "{:<30} {:>8.2} {:>7} {:>10} {:>11} {:>7.2}s {:>7.2}s {:>7.3} {:>7.2}",
                    s.scene,
                    peak,
                    workers,
                    mode,
                    case,
                    rep.makespan,
                    rep.ideal,
                    rep.efficiency(),
                    rep.tail
                );
            }
        }
    }
}
