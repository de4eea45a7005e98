//! The simulation's timeline: events in virtual time, the virtual
//! workers that render what the scheduler hands them, and the calls into
//! the real [`Scheduler`].

use super::{SimConfig, SimReport};
use crate::scheduler::{Assignment, JobSpec, JobUpdate, Outbox, Owner, Scheduler, SchedulerConfig};
use farm_common::film::{FilmGeometry, FilmTile, TILE_PARTS};
use farm_common::ids::{JobId, WorkerId};
use farm_common::stats::RayStats;
use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap, HashSet, VecDeque};
use std::time::{Duration, Instant};

/// What happens next in virtual time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum Event {
    /// A worker finished a tile it holds (one tile per thread).
    Done { worker: u32, job: u64, tile: u32, attempt: u32 },
    /// A worker rendering its tiles in turn finished the first: stale
    /// unless `version` is still the worker's.
    TurnDone { worker: u32, version: u64 },
    /// A finished tile reaches the coordinator.
    Arrives { worker: u32, job: u64, tile: u32, attempt: u32 },
    /// A hand-out (index into `Sim::in_transit`) reaches its worker.
    Delivered { worker: u32, index: u64 },
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

pub(super) struct Worker {
    speed: f64,
    busy_threads: u32,
    /// Tiles held but not started (all threads busy).
    queued: VecDeque<Assignment>,
    /// With parallel tiles: the tiles held, in the order they came, the
    /// first rendering on every thread; each with the work left in
    /// thread-seconds at speed 1 (the first's as of `updated`).
    turns: VecDeque<(Assignment, f64)>,
    updated: u64,
    /// Bumped whenever `turns` changes, to drop stale `TurnDone` events.
    version: u64,
    dead: bool,
    stalled: bool,
}

pub(super) struct Sim {
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
    /// Part hand-outs on their way or rendering: (job, tile, attempt).
    parts_out: HashSet<(u64, u32, u32)>,
    /// Parts in, per (job, tile).
    parts_in: HashMap<(u64, u32), u32>,
    handed_out: u64,
    in_transit: HashMap<u64, Assignment>,
    next_transit: u64,
}

pub(super) fn ns(seconds: f64) -> u64 {
    (seconds.max(0.0) * 1e9).round() as u64
}

impl Worker {
    /// A live worker of `speed`, holding nothing.
    pub(super) fn new(speed: f64) -> Worker {
        Worker {
            speed,
            busy_threads: 0,
            queued: VecDeque::new(),
            turns: VecDeque::new(),
            updated: 0,
            version: 0,
            dead: false,
            stalled: false,
        }
    }
}

impl Sim {
    /// A simulation of `config` on `geometry` whose tiles cost `costs`.
    pub(super) fn new(
        config: SimConfig,
        geometry: FilmGeometry,
        costs: Vec<f64>,
        workers: Vec<Worker>,
    ) -> Sim {
        let total = costs.len();
        Sim {
            config,
            geometry,
            costs,
            sched: Scheduler::new(SchedulerConfig::default()),
            out: Recorder::default(),
            workers,
            events: BinaryHeap::new(),
            seq: 0,
            now: 0,
            base: Instant::now(),
            in_scheduler: Duration::ZERO,
            merged_at: Vec::with_capacity(total),
            parts_out: HashSet::new(),
            parts_in: HashMap::new(),
            handed_out: 0,
            in_transit: HashMap::new(),
            next_transit: 0,
        }
    }

    pub(super) fn at(&mut self, when: u64, e: Event) {
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
        let delay = ns(self.config.latency.as_secs_f64());
        for (w, a) in std::mem::take(&mut self.out.assigned) {
            self.handed_out += 1;
            if delay == 0 {
                self.receive(w.0 as u32, a);
            } else {
                let index = self.next_transit;
                self.next_transit += 1;
                self.in_transit.insert(index, a);
                self.at(self.now + delay, Event::Delivered { worker: w.0 as u32, index });
            }
        }
    }

    /// A hand-out reaches its worker.
    fn receive(&mut self, w: u32, a: Assignment) {
        if self.config.parallel_tiles {
            let mut cost = self.costs[a.tile.0 as usize];
            if a.part.is_some() {
                // A part is a quarter of the tile's samples.
                cost /= f64::from(TILE_PARTS);
                self.parts_out.insert((a.job.0, a.tile.0, a.attempt));
            }
            let wk = &mut self.workers[w as usize];
            if wk.dead || wk.stalled {
                return;
            }
            wk.turns.push_back((a, cost));
            if wk.turns.len() == 1 {
                wk.updated = self.now;
                self.next_turn(w);
            }
        } else {
            self.workers[w as usize].queued.push_back(a);
            self.start(w);
        }
    }

    /// Schedules the end of a parallel worker's current tile, started (or
    /// last updated) at `updated`.
    fn next_turn(&mut self, w: u32) {
        let rate = self.config.threads as f64;
        let wk = &mut self.workers[w as usize];
        wk.version += 1;
        let version = wk.version;
        if let Some((_, left)) = wk.turns.front() {
            let when = wk.updated + ns(left / (rate * wk.speed));
            self.at(when, Event::TurnDone { worker: w, version });
        }
    }

    /// A worker finished a tile: the coordinator hears of it a latency later.
    fn finished(&mut self, worker: u32, job: u64, tile: u32, attempt: u32) {
        let delay = ns(self.config.latency.as_secs_f64());
        if delay == 0 {
            self.arrives(worker, job, tile, attempt);
        } else {
            self.at(self.now + delay, Event::Arrives { worker, job, tile, attempt });
        }
    }

    fn arrives(&mut self, worker: u32, job: u64, tile: u32, attempt: u32) {
        if self.workers[worker as usize].dead {
            return;
        }
        let key = farm_common::ids::TileAttempt {
            job: JobId(job),
            tile: farm_common::ids::TileId(tile),
            attempt,
        };
        let ft = FilmTile::new(self.geometry.tile_pixel_bounds(key.tile));
        let now = self.now;
        // A tile is in when its whole film or its last part arrives.
        if self.parts_out.remove(&(job, tile, attempt)) {
            let n = self.parts_in.entry((job, tile)).or_default();
            *n += 1;
            if *n == TILE_PARTS {
                self.merged_at.push(now);
            }
        } else {
            self.merged_at.push(now);
        }
        self.call(|s, out, at| {
            s.heard_from(WorkerId(u64::from(worker)), at);
            s.tile_done(WorkerId(u64::from(worker)), key, ft, RayStats::default(), out)
        });
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

    pub(super) fn run(mut self) -> SimReport {
        let total = self.geometry.tile_count();
        let threads = self.config.threads;
        let in_flight = self.config.in_flight_or_default();
        for w in 0..self.workers.len() {
            self.call(|s, out, now| {
                let id = WorkerId(w as u64);
                s.worker_joined(id, format!("w{w}"), threads, in_flight, now, out)
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
            parallel_tiles: self.config.parallel_tiles,
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
                self.finished(worker, job, tile, attempt);
                self.start(worker);
            }
            Event::TurnDone { worker, version } => {
                let now = self.now;
                let wk = &mut self.workers[worker as usize];
                if wk.dead || wk.stalled || wk.version != version {
                    return;
                }
                let Some((a, _)) = wk.turns.pop_front() else { return };
                wk.updated = now;
                self.next_turn(worker);
                self.finished(worker, a.job.0, a.tile.0, a.attempt);
            }
            Event::Arrives { worker, job, tile, attempt } => {
                self.arrives(worker, job, tile, attempt)
            }
            Event::Delivered { worker, index } => {
                if let Some(a) = self.in_transit.remove(&index) {
                    self.receive(worker, a);
                }
            }
            Event::Dies { worker } => {
                let wk = &mut self.workers[worker as usize];
                wk.dead = true;
                wk.queued.clear();
                wk.turns.clear();
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
