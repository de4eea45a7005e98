//! The simulated farm (`farm_coordinator::sim`) at scale: the real
//! scheduler in virtual time with 10 to 10,000 workers of 16 threads on a
//! 4K frame: as drawn, with 1% stragglers (10× slower), with 1% of the
//! workers dying and with 0.5% stalling (holding their tiles while
//! answering heartbeats). Prints a table; a case that has not finished
//! after 600 virtual seconds says so.
//!
//! Each case runs in two ways: `per-thread`, a tile per thread, as a
//! sampler with state renders (66 tiles held, what a worker of 16 threads
//! asks for); and `parallel`, each tile on all of a worker's threads in
//! turn, as Halton and Sobol' render (`Renderer::render_tile_parallel`;
//! the scheduler lets a worker hold 2 such tiles). Messages take 1 ms
//! each way.
//!
//! ```sh
//! cargo bench -p farm-coordinator --bench farm_sim
//! FARM_SIM_MAX=1000 cargo bench -p farm-coordinator --bench farm_sim   # skip 10,000
//! ```
//!
//! A tile's mean cost is 1.2 thread-seconds (a 4K frame at 64 spp on the
//! shared machines renders about 0.3 µs a sample-bounce); the table's
//! efficiency is the ideal makespan (total work ÷ total speed) over the
//! simulated one, the tail the time from the 99th percentile of merged
//! tiles to the last, and the coordinator's time the real time spent in
//! the scheduler's calls, per tile handed out.

use farm_coordinator::sim::{simulate, SimConfig};

fn main() {
    let max: usize =
        std::env::var("FARM_SIM_MAX").ok().and_then(|v| v.parse().ok()).unwrap_or(10_000);
    println!("simulated farm: 3840×2160 frame, 16 threads a worker, mean tile 1.2 thread-s");
    println!(
        "{:>7} {:>10} {:>11} {:>9} {:>10} {:>10} {:>7} {:>9} {:>9} {:>13}",
        "workers",
        "tiles",
        "case",
        "finished",
        "makespan",
        "ideal",
        "effic.",
        "tail s",
        "handed",
        "coord µs/tile"
    );
    for workers in [10usize, 100, 1000, 10_000] {
        if workers > max {
            continue;
        }
        for (mode, case) in ["per-thread", "parallel"]
            .into_iter()
            .flat_map(|m| ["plain", "stragglers", "deaths", "stalls"].map(|c| (m, c)))
        {
            let mut c = SimConfig::new(workers, 16, 3840, 2160, 1.2);
            c.latency = std::time::Duration::from_millis(1);
            c.parallel_tiles = mode == "parallel";
            // Long enough for the slowest case to end, or to show it will not.
            c.give_up_after = std::time::Duration::from_secs(600);
            match case {
                "stragglers" => c.stragglers = 0.01,
                "deaths" => c.deaths = 0.01,
                "stalls" => c.stalls = 0.005,
                _ => {}
            }
            let r = simulate(&c);
            println!(
                "{:>7} {:>10} {:>11} {:>9} {:>9.2}s {:>9.2}s {:>7.3} {:>9.2} {:>9} {:>13.2}",
                workers,
                mode,
                case,
                r.finished,
                r.makespan,
                r.ideal,
                r.efficiency(),
                r.tail,
                r.handed_out,
                r.coordinator_seconds * 1e6 / r.handed_out.max(1) as f64
            );
        }
    }
}
