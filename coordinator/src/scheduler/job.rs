//! A job and its tiles: what it is (its spec, owner and state), and the
//! scheduler's books on it (queue, hand-outs, failures, film).

use super::{FinishedJob, JobUpdate};
use crate::merge::Film;
use farm_common::film::{
    FilmGeometry, FilmTile, PassEnd, PassPlan, PassStop, SampleRange, TILE_PARTS,
};
use farm_common::ids::{JobId, WorkerId};
use farm_common::stats::RayStats;
use std::collections::{HashMap, HashSet, VecDeque};
use std::time::Instant;

/// Where a job is in its life.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum JobState {
    /// No tile handed out yet.
    Queued,
    /// Tiles are out.
    Running,
    /// Image complete.
    Done,
    /// Failed, with the reason.
    Failed(String),
    /// Cancelled by a client.
    Cancelled,
}

impl JobState {
    /// Lower-case name for listings.
    pub fn name(&self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Done => "done",
            JobState::Failed(_) => "failed",
            JobState::Cancelled => "cancelled",
        }
    }
    pub(super) fn is_active(&self) -> bool {
        matches!(self, JobState::Queued | JobState::Running)
    }
}

/// A job as submitted.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct JobSpec {
    /// A name for listings.
    pub name: String,
    /// Higher first; ties in submission order.
    pub priority: i32,
    /// Hash of the scene manifest.
    pub scene_hash: Vec<u8>,
    /// Samples per pixel override (0 = the scene's).
    pub spp_override: u32,
    /// Samples per pixel actually used.
    pub spp: u32,
    /// The film layout.
    pub geometry: FilmGeometry,
    /// Who submitted it.
    pub owner: Owner,
    /// Whether it runs on when no client is watching it (`farm submit
    /// --detach`); otherwise a client gone for longer than the grace
    /// period cancels it.
    pub detach: bool,
    /// The blobs it needs: its manifest and assets (kept while it is).
    pub blobs: Vec<[u8; 32]>,
    /// The shot it is a frame of (journalled in a table of its own, so a
    /// journal written before shots existed still decodes).
    #[serde(skip)]
    pub shot: Option<ShotFrame>,
    /// Its passes, when it renders in passes (`--target-error`,
    /// `--time-limit`; journalled in a table of its own, as `shot`).
    #[serde(skip)]
    pub passes: Option<PassPlan>,
    /// Whether its tiles render on all of a worker's threads (a stateless
    /// sampler's, `Renderer::render_tile_parallel`), so a worker may hold
    /// fewer of them ([`super::SchedulerConfig::parallel_in_flight`]).
    /// Journalled in a table of its own, as `shot`.
    #[serde(skip)]
    pub parallel_tiles: bool,
}

/// A job's place in a shot (`farm submit` of several scenes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShotFrame {
    /// The shot: the id of its first frame's job.
    pub shot: JobId,
    /// The frame's number.
    pub frame: u32,
    /// How many frames its client was given.
    pub frames: u32,
}

/// Who submitted a job: a token's id and name.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Owner {
    /// The token's id.
    pub id: String,
    /// The token's name.
    pub name: String,
}

pub(super) struct Job {
    pub(super) id: JobId,
    pub(super) spec: JobSpec,
    pub(super) state: JobState,
    pub(super) film: Option<Film>,
    pub(super) pending: VecDeque<u32>,
    pub(super) in_flight: HashMap<u32, (WorkerId, u32)>,
    /// Tiles in the order they were handed out (some since merged or
    /// handed out again: those are skipped and dropped when met), so the
    /// tile out longest is found without a search.
    pub(super) out_order: VecDeque<u32>,
    /// A second hand-out of a tile in flight, to an idle worker once no
    /// tile is left to hand out (speculation): the first result wins, and
    /// both render the same bits (a tile's samples depend on its index
    /// only).
    pub(super) spares: HashMap<u32, (WorkerId, u32)>,
    /// Spare hand-outs of a tile in flight split into its parts, for a job
    /// whose tiles render on all of a worker's threads (a stateless
    /// sampler's): idle workers each take a part, and once every part is
    /// in, the parts' films added in order are the tile's, bit for bit.
    /// The first of the tile's holder and its parts to finish wins.
    pub(super) parts: HashMap<u32, Parts>,
    /// When each tile in flight was handed to its holder.
    pub(super) handed_at: HashMap<u32, Instant>,
    /// Hand-outs (worker, tile, attempt) of tiles another hand-out
    /// finished first: their workers are still rendering them, so their
    /// slots stay taken until they answer (the answer is ignored) or the
    /// pass ends.
    pub(super) superseded: HashSet<(WorkerId, u32, u32)>,
    /// Spares handed out so far (each part counts).
    pub(super) speculated: u32,
    pub(super) attempts: HashMap<u32, u32>,
    pub(super) failures: HashMap<u32, Vec<(WorkerId, String)>>,
    pub(super) worker_failures: HashMap<WorkerId, u32>,
    pub(super) stats: RayStats,
    pub(super) started: Option<Instant>,
    pub(super) done_tiles: u32,
    pub(super) last_progress: Instant,
    /// The workers holding its tiles when last counted, and when. The
    /// count walks every tile out (10,000 with as many workers), so the
    /// progress events sent every 0.5% of the tiles count again at most
    /// every `PROGRESS_EVERY` and report the last count meanwhile.
    pub(super) holders_counted: Option<(u32, Instant)>,
    pub(super) finished: Option<std::sync::Arc<FinishedJob>>,
    /// A complete film being ended ([`super::Outbox::end_film`]): the
    /// samples per pixel and render seconds its image will carry.
    pub(super) ending: Option<(u32, f64)>,
    /// A pass's film being estimated ([`super::Outbox::estimate_pass`]):
    /// the seconds from the job's start to the pass's end.
    pub(super) estimating: Option<f64>,
    /// When it ended (seconds since the epoch), for its retention.
    pub(super) ended_at: Option<i64>,
    /// A finished job's estimate of its own relMSE.
    pub(super) rel_mse: Option<f64>,
    /// The pass under way (0 for a job without passes).
    pub(super) pass: u32,
    /// What each pass done so far left.
    pub(super) pass_ends: Vec<PassEnd>,
    /// Why its passes stopped.
    pub(super) stopped: Option<PassStop>,
    /// Tiles handed out in the pass under way: a tile's next hand-out
    /// (speculation aside) is a retry.
    pub(super) handed: HashSet<u32>,
    /// Retries so far.
    pub(super) retries: u32,
}

impl Job {
    /// The workers holding its tiles (walks every tile out).
    pub(super) fn holder_count(&self) -> u32 {
        let holders: HashSet<WorkerId> = self.in_flight.values().map(|(w, _)| *w).collect();
        holders.len() as u32
    }

    /// A job with no film, no tiles queued and nothing counted yet.
    pub(super) fn new(id: JobId, spec: JobSpec, state: JobState, now: Instant) -> Job {
        Job {
            id,
            spec,
            state,
            film: None,
            pending: VecDeque::new(),
            in_flight: HashMap::new(),
            out_order: VecDeque::new(),
            spares: HashMap::new(),
            parts: HashMap::new(),
            handed_at: HashMap::new(),
            superseded: HashSet::new(),
            speculated: 0,
            attempts: HashMap::new(),
            failures: HashMap::new(),
            worker_failures: HashMap::new(),
            stats: RayStats::default(),
            started: None,
            done_tiles: 0,
            last_progress: now,
            holders_counted: None,
            finished: None,
            ending: None,
            estimating: None,
            ended_at: None,
            rel_mse: None,
            pass: 0,
            pass_ends: Vec::new(),
            stopped: None,
            handed: HashSet::new(),
            retries: 0,
        }
    }
}

impl Job {
    /// Whether its film is lent out, being ended or a pass's estimated.
    pub(super) fn film_lent(&self) -> bool {
        self.ending.is_some() || self.estimating.is_some()
    }

    /// Takes its film to lend it out: every tile of the pass is in, so none
    /// is left to hand out meanwhile (a tile put back after its holder
    /// failed, whose parts came back first, may still be queued).
    pub(super) fn lend_film(&mut self) -> Option<Film> {
        let film = self.film.take()?;
        self.pending.clear();
        self.out_order.clear();
        Some(film)
    }

    /// The samples each pixel gets in the pass under way, when the job
    /// renders in passes.
    pub(super) fn samples(&self) -> Option<SampleRange> {
        self.spec.passes.as_ref().map(|p| p.range(self.pass as usize))
    }

    /// Whether the job has a pass after the one under way.
    pub(super) fn has_pass_after(&self) -> bool {
        self.spec.passes.as_ref().is_some_and(|p| self.pass as usize + 1 < p.totals.len())
    }

    /// Forgets every hand-out of `tile`, its parts' too; returns them
    /// (worker, attempt).
    pub(super) fn drop_holders(&mut self, tile: u32) -> Vec<(WorkerId, u32)> {
        let spare = self.spares.remove(&tile);
        self.handed_at.remove(&tile);
        let parts = self.parts.remove(&tile).map(|p| p.held).unwrap_or_default();
        let parts = parts.into_iter().flatten();
        self.in_flight.remove(&tile).into_iter().chain(spare).chain(parts).collect()
    }

    /// Takes part `k` of `tile`'s film (checked by the film); once every
    /// part is in, returns their films added in part order into a zero
    /// film, the tile's bits, and their rays.
    pub(super) fn part_done(
        &mut self,
        tile: u32,
        k: usize,
        film: FilmTile,
        stats: RayStats,
    ) -> Option<(FilmTile, RayStats)> {
        let p = self.parts.get_mut(&tile)?;
        p.held[k] = None;
        p.films[k] = Some(film);
        p.stats.add(&stats);
        if p.films.iter().any(Option::is_none) {
            return None;
        }
        let p = self.parts.remove(&tile)?;
        let mut whole = FilmTile::new(p.films[0].as_ref()?.pixel_bounds);
        for f in p.films.iter().flatten() {
            whole.merge(f);
        }
        Some((whole, p.stats))
    }

    /// Whether `worker` holds a part of `tile`, as hand-out `attempt` if
    /// given.
    pub(super) fn holds_part(&self, tile: u32, worker: WorkerId, attempt: Option<u32>) -> bool {
        self.parts.get(&tile).is_some_and(|p| {
            p.held.iter().flatten().any(|&(w, a)| w == worker && attempt.is_none_or(|x| x == a))
        })
    }

    /// Forgets `worker`'s hand-out of `tile`; returns whether another
    /// worker still holds the whole tile (it becomes the tile's holder).
    /// A part's hand-out frees its part for another idle worker.
    pub(super) fn drop_holder(&mut self, tile: u32, worker: WorkerId) -> bool {
        if let Some(p) = self.parts.get_mut(&tile) {
            for h in &mut p.held {
                if h.is_some_and(|(w, _)| w == worker) {
                    *h = None;
                    if !self.out_order.contains(&tile) {
                        self.out_order.push_front(tile);
                    }
                    return self.in_flight.contains_key(&tile);
                }
            }
        }
        if self.spares.get(&tile).is_some_and(|(w, _)| *w == worker) {
            self.spares.remove(&tile);
        } else if self.in_flight.get(&tile).is_some_and(|(w, _)| *w == worker) {
            self.in_flight.remove(&tile);
            if let Some(spare) = self.spares.remove(&tile) {
                self.in_flight.insert(tile, spare);
            }
        }
        self.in_flight.contains_key(&tile)
    }
}

/// A tile's parts out as spares ([`Job::parts`]).
#[derive(Debug, Default)]
pub(super) struct Parts {
    /// Each part's hand-out (worker, attempt) while it renders.
    pub held: [Option<(WorkerId, u32)>; TILE_PARTS as usize],
    /// Each part's film once in.
    pub films: [Option<FilmTile>; TILE_PARTS as usize],
    /// The rays of the parts in.
    pub stats: RayStats,
}

impl Parts {
    /// Whether part `k` is neither held nor in.
    fn is_free(&self, k: u32) -> bool {
        self.held[k as usize].is_none() && self.films[k as usize].is_none()
    }

    /// The first part neither held nor in.
    pub fn free(&self) -> Option<u32> {
        (0..TILE_PARTS).find(|&k| self.is_free(k))
    }

    /// How many parts are neither held nor in.
    pub fn free_count(&self) -> u32 {
        (0..TILE_PARTS).filter(|&k| self.is_free(k)).count() as u32
    }
}

/// What a new watcher of a job is told first.
#[derive(Clone, Debug, PartialEq)]
pub enum Snapshot {
    /// This update.
    Update(JobUpdate),
    /// The job is done and its image is in the journal.
    Stored,
}

/// A row of `farm status`.
#[derive(Clone, Debug, PartialEq)]
pub struct JobRow {
    /// Id.
    pub id: JobId,
    /// Name.
    pub name: String,
    /// State name.
    pub state: &'static str,
    /// Tiles in.
    pub done: u32,
    /// All tiles.
    pub total: u32,
    /// Priority.
    pub priority: i32,
    /// Who submitted it.
    pub owner: Owner,
    /// Tile hand-outs so far.
    pub attempts: u32,
    /// Hand-outs of a tile after its first, speculation aside.
    pub retries: u32,
    /// Speculative second hand-outs.
    pub speculated: u32,
    /// The shot it is a frame of.
    pub shot: Option<ShotFrame>,
}
