//! `cargo bench -p farm-coordinator --bench journal`: what the journal costs
//! a merged tile. Writes the records of a 2048×2048 job (16,384 tiles of
//! 16×16 pixels: a hand-out and a merged tile each) to a journal in a
//! temporary directory, as fast as they come, and prints wall and CPU
//! microseconds per tile (this process's CPU: the journal's writer thread
//! does the work, encoding each tile too) and the bytes per tile on disk (database, WAL and tile
//! logs). Then it ends the job with a 2048² image and its error map, as
//! the coordinator does, and prints the CPU and wall milliseconds until
//! that ending is committed. Each run does this for two jobs on one
//! journal: the first meets a fresh journal, the next one the journal the
//! first left (its rows, its image file, the page cache its files used).
//! Medians of 5 runs; the disk bytes are the first job's.

use farm_common::film::{FilmTile, Pixel};
use farm_common::geometry::{Bounds2i, Point2i};
use farm_common::image::RgbImage;
use farm_common::stats::RayStats;
use farm_coordinator::estimate::ErrorEstimate;
use farm_coordinator::scheduler::FinishedJob;
use farm_coordinator::state::{encode_tile, Command, Ending, Journal};
use std::time::Instant;

const TILES: u32 = 16_384;
const RUNS: usize = 5;

/// User + system CPU seconds of this process, from /proc (Linux).
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let rest = stat.rfind(')').map_or("", |i| &stat[i + 2..]);
    let f: Vec<f64> = rest.split_whitespace().filter_map(|v| v.parse().ok()).collect();
    f.get(11).zip(f.get(12)).map_or(0.0, |(u, s)| (u + s) / 100.0)
}

/// Bytes of the files under `dir` (the database, its WAL and the tile logs).
fn disk_bytes(dir: &std::path::Path) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir) else { return 0 };
    entries
        .flatten()
        .map(|e| match e.metadata() {
            Ok(m) if m.is_dir() => disk_bytes(&e.path()),
            Ok(m) => m.len(),
            Err(_) => 0,
        })
        .sum()
}

fn main() {
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().expect("runtime");
    let bounds = Bounds2i::new(Point2i::new(0, 0), Point2i::new(16, 16));
    let pixel = Pixel {
        contrib: [0.5, 0.25, 0.125],
        weight: 1.0,
        second_contrib: [0.25, 0.125, 0.0625],
        second_weight: 0.5,
    };
    let tile = FilmTile { pixel_bounds: bounds, pixels: vec![pixel; bounds.area()] };
    let size = encode_tile(&tile, &RayStats::default()).len();
    // The film's tile, shared with the journal as the event loop shares it.
    let tile = std::sync::Arc::new(tile);
    // Per job of a run: the first on a fresh journal, the next on the same.
    let mut wall = [Vec::new(), Vec::new()];
    let mut cpu = [Vec::new(), Vec::new()];
    let mut end_wall = [Vec::new(), Vec::new()];
    let mut end_cpu = [Vec::new(), Vec::new()];
    let mut bytes = 0u64;
    let side = 2048usize;
    let finished = std::sync::Arc::new(FinishedJob {
        name: "bench.pbrt".into(),
        image: RgbImage {
            width: side,
            height: side,
            pixels: (0..side * side).map(|i| [i as f32, 0.5, 0.25]).collect(),
        },
        spp: 16,
        render_seconds: 1.0,
        stats: RayStats::default(),
        error: Some(ErrorEstimate {
            fireflies: None,
            width: side,
            height: side,
            per_pixel: (0..side * side).map(|i| i as f32 * 1e-9).collect(),
            rel_mse: 1e-3,
        }),
        passes: Vec::new(),
        stopped: None,
    });
    for run in 0..RUNS {
        let dir =
            std::env::temp_dir().join(format!("farm-journal-bench-{}-{run}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let db = dir.join("farm.db");
        let (journal, _) = Journal::open(Some(&db)).expect("journal");
        for (k, job) in [1, 2].into_iter().enumerate() {
            let (t, c) = (Instant::now(), cpu_seconds());
            for t in 0..TILES {
                journal.send(Command::HandedOut { job, tile: t, n: 1 });
                let (film_tile, stats) = (tile.clone(), RayStats::default());
                journal.send(Command::Merged { job, tile: t, film_tile, stats });
            }
            rt.block_on(journal.flush());
            wall[k].push(t.elapsed().as_secs_f64());
            cpu[k].push(cpu_seconds() - c);
            if k == 0 {
                bytes = disk_bytes(&dir);
            }
            let (t, c) = (Instant::now(), cpu_seconds());
            let image = Some(finished.clone());
            journal.send(Command::Ended { job, ending: Ending::Done, image });
            rt.block_on(journal.flush());
            end_wall[k].push(t.elapsed().as_secs_f64());
            end_cpu[k].push(cpu_seconds() - c);
        }
        drop(journal);
        let _ = std::fs::remove_dir_all(&dir);
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let per_tile = |s: f64| 1e6 * s / TILES as f64;
    println!("journal: {TILES} tiles of {size} bytes each, median of {RUNS} runs");
    println!(
        "{:>9} {:>12} {:>12} {:>14} | {:>10} {:>10}",
        "job", "wall µs/tile", "CPU µs/tile", "disk bytes/tile", "end wall", "end CPU"
    );
    for (k, name) in ["first", "next"].into_iter().enumerate() {
        // The next job's folder also holds the first one's image.
        let disk = if k == 0 { format!("{:.0}", bytes as f64 / TILES as f64) } else { "-".into() };
        println!(
            "{name:>9} {:>12.1} {:>12.1} {disk:>14} | {:>10.0} {:>10.0}",
            per_tile(median(&mut wall[k])),
            per_tile(median(&mut cpu[k])),
            1e3 * median(&mut end_wall[k]),
            1e3 * median(&mut end_cpu[k])
        );
    }
    println!(
        "first = a job on a fresh journal, next = the job after it on the same journal; \
         end = ending the job with its {side}×{side} image, ms until committed"
    );
}
