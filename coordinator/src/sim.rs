//! A simulated farm: the real [`Scheduler`] driven in virtual time by
//! virtual workers, to see how the coordinator behaves at a scale no test
//! machine has (10 to 10,000 workers) without rendering a pixel.
//!
//! Each virtual worker has a number of threads and a speed drawn from a
//! seeded distribution (a few are 10× stragglers); it renders up to one
//! tile per thread at once, each taking the tile's cost divided by its
//! speed. Tile costs come from a seeded distribution around a mean (or
//! from a list, e.g. a real render's per-tile times). Workers may die
//! (their session closes; the scheduler requeues their tiles) or stall
//! (they keep answering heartbeats but never finish a tile). Results are
//! real film tiles (of zeros, the tile's pixel bounds), so the scheduler's
//! checks and the ordered merge run as they do on a farm.
//!
//! Everything is deterministic: the same [`SimConfig`] gives the same
//! virtual timeline. Only [`SimReport::coordinator_seconds`], the real
//! time spent inside the scheduler's calls, depends on the machine.

use crate::scheduler::{Assignment, JobSpec, JobUpdate, Outbox, Owner, Scheduler, SchedulerConfig};
use farm_common::film::{FilmGeometry, FilmTile};
use farm_common::geometry::{Bounds2i, Point2i, Vec2};
use farm_common::ids::{JobId, WorkerId};
use farm_common::rng::Rng;
use farm_common::stats::RayStats;
use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};
use std::time::{Duration, Instant};

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
            seed: 1,
            give_up_after: Duration::from_secs(24 * 3600),
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

/// What happens next in virtual time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Event {
    /// A worker finished a tile it holds.
    Done { worker: u32, job: u64, tile: u32, attempt: u32 },
    /// A worker's session ends.
    Dies { worker: u32 },
    /// A worker stops finishing tiles.
    Stalls { worker: u32 },
    /// Heartbeats from every live worker, and the scheduler's tick.
    Tick,
}

#[derive(Default)]
struct Recorder {
    assigned: Vec<(WorkerId, Assignment)>,
    finished: bool,
    failed: Option<String>,
}

impl Outbox for Recorder {
    fn assign(&mut self, worker: WorkerId, a: Assignment) {
        self.assigned.push((worker, a));
    }
    fn cancel(&mut self, _: WorkerId, _: JobId) {}
    fn disconnect(&mut self, _: WorkerId) {}
    fn notify(&mut self, _: JobId, update: JobUpdate) {
        match update {
            JobUpdate::Finished(_) => self.finished = true,
            JobUpdate::Failed(why) => self.failed = Some(why),
            JobUpdate::Progress { .. } => {}
        }
    }
}

struct Worker {
    speed: f64,
    busy_threads: u32,
    /// Tiles held but not started (all threads busy).
    queued: VecDeque<Assignment>,
    dead: bool,
    stalled: bool,
}

struct Sim {
    config: SimConfig,
    geometry: FilmGeometry,
    costs: Vec<f64>,
    sched: Scheduler,
    out: Recorder,
    workers: Vec<Worker>,
    events: BinaryHeap<Reverse<(u64, u64, Event)>>,
    seq: u64,
    /// Virtual nanoseconds.
    now: u64,
    base: Instant,
    in_scheduler: Duration,
    merged_at: Vec<u64>,
    handed_out: u64,
}

fn ns(seconds: f64) -> u64 {
    (seconds.max(0.0) * 1e9).round() as u64
}

impl Sim {
    fn at(&mut self, when: u64, e: Event) {
        self.seq += 1;
        self.events.push(Reverse((when, self.seq, e)));
    }

    /// Runs `f` on the scheduler at the current virtual time, timing it,
    /// then starts whatever it handed out.
    fn call(&mut self, f: impl FnOnce(&mut Scheduler, &mut Recorder, Instant)) {
        let now = self.base + Duration::from_nanos(self.now);
        self.sched.set_virtual_time(now);
        let t = Instant::now();
        f(&mut self.sched, &mut self.out, now);
        self.in_scheduler += t.elapsed();
        for (w, a) in std::mem::take(&mut self.out.assigned) {
            self.handed_out += 1;
            let wk = &mut self.workers[w.0 as usize];
            wk.queued.push_back(a);
            self.start(w.0 as u32);
        }
    }

    /// Starts queued tiles on a worker's free threads.
    fn start(&mut self, w: u32) {
        let threads = self.config.threads;
        loop {
            let wk = &mut self.workers[w as usize];
            if wk.dead || wk.stalled || wk.busy_threads >= threads {
                return;
            }
            let Some(a) = wk.queued.pop_front() else { return };
            wk.busy_threads += 1;
            let cost = self.costs[a.tile.0 as usize] / wk.speed;
            let e = Event::Done { worker: w, job: a.job.0, tile: a.tile.0, attempt: a.attempt };
            self.at(self.now + ns(cost), e);
        }
    }

    fn run(mut self) -> SimReport {
        let total = self.geometry.tile_count();
        let threads = self.config.threads;
        for w in 0..self.workers.len() {
            self.call(|s, out, now| {
                let id = WorkerId(w as u64);
                s.worker_joined(id, format!("w{w}"), threads, threads, now, out)
            });
        }
        let spec = JobSpec {
            name: "simulated".into(),
            priority: 0,
            scene_hash: vec![0; 32],
            spp_override: 0,
            spp: 64,
            geometry: self.geometry.clone(),
            owner: Owner::default(),
            detach: true,
            blobs: Vec::new(),
            shot: None,
            passes: None,
        };
        self.call(|s, out, _| {
            s.submit(spec, out);
        });
        self.at(ns(1.0), Event::Tick);
        let give_up = self.config.give_up_after.as_nanos() as u64;
        while let Some(Reverse((when, _, e))) = self.events.pop() {
            if self.out.finished || self.out.failed.is_some() || when > give_up {
                break;
            }
            self.now = when;
            self.handle(e);
        }
        let finished = self.out.finished;
        let makespan = self.merged_at.iter().copied().max().unwrap_or(0) as f64 * 1e-9;
        let mut times = self.merged_at.clone();
        times.sort_unstable();
        let p99 = times.get((times.len() * 99 / 100).min(times.len().saturating_sub(1)));
        let tail = makespan - p99.copied().unwrap_or(0) as f64 * 1e-9;
        let speed: f64 = self.workers.iter().map(|w| w.speed * f64::from(threads)).sum();
        let work: f64 = self.costs.iter().sum();
        SimReport {
            tiles: total,
            finished,
            makespan,
            ideal: work / speed,
            tail,
            handed_out: self.handed_out,
            coordinator_seconds: self.in_scheduler.as_secs_f64(),
        }
    }

    fn handle(&mut self, e: Event) {
        match e {
            Event::Done { worker, job, tile, attempt } => {
                let wk = &mut self.workers[worker as usize];
                if wk.dead || wk.stalled {
                    return;
                }
                wk.busy_threads -= 1;
                let key = farm_common::ids::TileAttempt {
                    job: JobId(job),
                    tile: farm_common::ids::TileId(tile),
                    attempt,
                };
                let ft = FilmTile::new(self.geometry.tile_pixel_bounds(key.tile));
                let now = self.now;
                self.merged_at.push(now);
                self.call(|s, out, at| {
                    s.heard_from(WorkerId(u64::from(worker)), at);
                    s.tile_done(WorkerId(u64::from(worker)), key, ft, RayStats::default(), out)
                });
                self.start(worker);
            }
            Event::Dies { worker } => {
                let wk = &mut self.workers[worker as usize];
                wk.dead = true;
                wk.queued.clear();
                self.call(|s, out, _| s.worker_left(WorkerId(u64::from(worker)), out));
            }
            Event::Stalls { worker } => self.workers[worker as usize].stalled = true,
            Event::Tick => {
                let alive: Vec<u64> = (0..self.workers.len() as u64)
                    .filter(|&w| !self.workers[w as usize].dead)
                    .collect();
                self.call(|s, out, now| {
                    for w in alive {
                        s.heard_from(WorkerId(w), now);
                    }
                    s.tick(now, out);
                });
                self.at(self.now + ns(1.0), Event::Tick);
            }
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
        let queued = VecDeque::new();
        workers.push(Worker { speed, busy_threads: 0, queued, dead: false, stalled: false });
    }
    let scheduler =
        SchedulerConfig { max_in_flight: config.threads.max(1), ..SchedulerConfig::default() };
    let mut sim = Sim {
        config: config.clone(),
        geometry,
        costs,
        sched: Scheduler::new(scheduler),
        out: Recorder::default(),
        workers,
        events: BinaryHeap::new(),
        seq: 0,
        now: 0,
        base: Instant::now(),
        in_scheduler: Duration::ZERO,
        merged_at: Vec::with_capacity(total),
        handed_out: 0,
    };
    for (when, e) in faults {
        sim.at(when, e);
    }
    sim.run()
}
