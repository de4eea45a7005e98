//! A simulated farm: the real [`Scheduler`] driven in virtual time by
//! virtual workers, to see how the coordinator behaves at a scale no test
//! machine has (10 to 10,000 workers) without rendering a pixel.
//!
//! Each virtual worker has a number of threads and a speed drawn from a
//! seeded distribution (a few are 10× stragglers), and asks to hold
//! [`SimConfig::in_flight`] tiles. It renders them in one of two ways
//! ([`SimConfig::parallel_tiles`]): one tile per thread, each taking the
//! tile's cost divided by its speed (a tile whose sampler has state,
//! rendered pixel after pixel); or in turn, each on all its threads (a
//! stateless sampler's tile, whose pixels `Renderer::render_tile_parallel`
//! spreads over the pool; rayon's threads finish the work of the tile
//! they are on before they take the next). Messages take
//! [`SimConfig::latency`] each way. Tile costs come from a seeded distribution around a mean (or
//! from a list, e.g. a real render's per-tile times). Workers may die
//! (their session closes; the scheduler requeues their tiles) or stall
//! (they keep answering heartbeats but never finish a tile). Results are
//! real film tiles (of zeros, the tile's pixel bounds), so the scheduler's
//! checks and the ordered merge run as they do on a farm.
//!
//! Everything is deterministic: the same [`SimConfig`] gives the same
//! virtual timeline. Only [`SimReport::coordinator_seconds`], the real
//! time spent inside the scheduler's calls, depends on the machine.

mod timeline;

use farm_common::film::FilmGeometry;
use farm_common::geometry::{Bounds2i, Point2i, Vec2};
use farm_common::rng::Rng;
use std::time::Duration;
use timeline::{ns, Event, Sim, Worker};

/// What to simulate.
#[derive(Clone, Debug)]
pub struct SimConfig {
    /// Virtual workers.
    pub workers: usize,
    /// Threads of each.
    pub threads: u32,
    /// The frame's size in pixels.
    pub width: i32,
    /// The frame's height.
    pub height: i32,
    /// Mean thread-seconds of one tile at speed 1.
    pub mean_tile_seconds: f64,
    /// Per-tile costs in thread-seconds, in tile order, instead of the
    /// seeded distribution (e.g. a real render's; repeated if short).
    pub tile_costs: Option<Vec<f64>>,
    /// The fraction of workers that run 10× slower than drawn.
    pub stragglers: f64,
    /// The fraction of workers whose session ends at a random moment.
    pub deaths: f64,
    /// The fraction of workers that stop finishing tiles at a random
    /// moment but keep answering heartbeats.
    pub stalls: f64,
    /// Tiles a worker asks to hold at once; 0 for what a real worker asks
    /// (`farm_proto::default_in_flight`: 4 × threads + 2).
    pub in_flight: u32,
    /// Whether the job's tiles render on all of a worker's threads
    /// (`JobSpec::parallel_tiles`): the scheduler then lets each worker
    /// hold `SchedulerConfig::parallel_in_flight` of them, and the worker
    /// renders them in turn, each on all its threads. Otherwise a worker
    /// renders one tile per thread.
    pub parallel_tiles: bool,
    /// One-way delay of each message between coordinator and worker.
    pub latency: Duration,
    /// The seed of every draw.
    pub seed: u64,
    /// Virtual time after which the simulation gives up.
    pub give_up_after: Duration,
}

impl SimConfig {
    /// `workers` workers of `threads` threads on a `width`×`height` frame
    /// whose tiles take `mean_tile_seconds` on average: no stragglers, no
    /// faults.
    pub fn new(workers: usize, threads: u32, width: i32, height: i32, mean: f64) -> SimConfig {
        SimConfig {
            workers,
            threads,
            width,
            height,
            mean_tile_seconds: mean,
            tile_costs: None,
            stragglers: 0.0,
            deaths: 0.0,
            stalls: 0.0,
            in_flight: 0,
            parallel_tiles: false,
            latency: Duration::ZERO,
            seed: 1,
            give_up_after: Duration::from_secs(24 * 3600),
        }
    }

    /// Tiles each worker asks to hold.
    pub(super) fn in_flight_or_default(&self) -> u32 {
        if self.in_flight > 0 {
            self.in_flight
        } else {
            farm_proto::default_in_flight(self.threads as usize)
        }
    }
}

/// What a simulation measured.
#[derive(Clone, Debug, PartialEq)]
pub struct SimReport {
    /// Tiles in the frame.
    pub tiles: u32,
    /// Whether the job finished before [`SimConfig::give_up_after`].
    pub finished: bool,
    /// Virtual seconds from submission to the last tile merged.
    pub makespan: f64,
    /// Total tile work divided by the farm's total speed: the makespan of
    /// a perfect split.
    pub ideal: f64,
    /// Virtual seconds between the 99th percentile of tiles merged and
    /// the last.
    pub tail: f64,
    /// Tiles handed out (more than `tiles` after deaths).
    pub handed_out: u64,
    /// Real seconds spent in the scheduler's calls (machine-dependent).
    pub coordinator_seconds: f64,
}

impl SimReport {
    /// `ideal / makespan`: 1 when no thread ever waits.
    pub fn efficiency(&self) -> f64 {
        if self.makespan > 0.0 {
            self.ideal / self.makespan
        } else {
            0.0
        }
    }
}

/// A film of `width`×`height` with a box filter of radius 0.5.
fn frame(width: i32, height: i32) -> FilmGeometry {
    let res = Point2i::new(width, height);
    let crop = Bounds2i::new(Point2i::new(0, 0), res);
    FilmGeometry::new(res, crop, Vec2::splat(0.5), 1.0, f32::INFINITY, "sim.exr".into(), 35.0)
}

/// Runs one simulation.
pub fn simulate(config: &SimConfig) -> SimReport {
    let geometry = frame(config.width, config.height);
    let total = geometry.tile_count() as usize;
    let mut rng = Rng::new(config.seed);
    let costs = match &config.tile_costs {
        Some(c) if !c.is_empty() => (0..total).map(|i| c[i % c.len()]).collect(),
        // Log-normal-ish: the product of a few uniform factors around 1.
        _ => (0..total)
            .map(|_| {
                let f: f64 = (0..3).map(|_| 0.5 + f64::from(rng.uniform_f32())).product();
                config.mean_tile_seconds * f
            })
            .collect(),
    };
    let n = config.workers;
    let pick = |rng: &mut Rng, fraction: f64| f64::from(rng.uniform_f32()) < fraction;
    let mut workers = Vec::with_capacity(n);
    let mut faults = Vec::new();
    for w in 0..n as u32 {
        let mut speed = 0.6 + 0.8 * f64::from(rng.uniform_f32());
        if pick(&mut rng, config.stragglers) {
            speed /= 10.0;
        }
        let ideal_guess =
            config.mean_tile_seconds * total as f64 / (n as f64 * config.threads as f64);
        let when = ns(ideal_guess * f64::from(rng.uniform_f32()));
        if pick(&mut rng, config.deaths) {
            faults.push((when, Event::Dies { worker: w }));
        } else if pick(&mut rng, config.stalls) {
            faults.push((when, Event::Stalls { worker: w }));
        }
        workers.push(Worker::new(speed));
    }
    let mut sim = Sim::new(config.clone(), geometry, costs, workers);
    for (when, e) in faults {
        sim.at(when, e);
    }
    sim.run()
}
