//! The scheduler's way out, and what goes through it: tiles to workers and
//! updates to a job's watchers.

use super::job::{JobSpec, JobState};
use crate::estimate::ErrorEstimate;
use crate::merge::Film;
use farm_common::film::{FilmTile, PassEnd, PassStop, SampleRange};
use farm_common::ids::{JobId, TileAttempt, TileId, WorkerId};
use farm_common::image::RgbImage;
use farm_common::stats::RayStats;
use std::sync::Arc;

/// One tile handed to a worker.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Assignment {
    /// The job.
    pub job: JobId,
    /// The tile.
    pub tile: TileId,
    /// Earlier hand-outs of this tile.
    pub attempt: u32,
    /// Hash of the job's scene manifest.
    pub scene_hash: Vec<u8>,
    /// Samples per pixel override (0 = the scene's).
    pub spp: u32,
    /// A second hand-out of a tile still out (speculation).
    pub speculative: bool,
    /// A hand-out of a tile after its first in this pass (speculation aside).
    pub retry: bool,
    /// The samples of each pixel to take, when the job renders in passes;
    /// `None`: all of them.
    pub samples: Option<SampleRange>,
    /// One part of the tile (below `farm_common::film::TILE_PARTS`) rather
    /// than all of it: a spare hand-out of a tile whose sampler is
    /// stateless, shared by idle workers at the end of a pass. Its result
    /// is that part's film (`Renderer::render_part`).
    pub part: Option<u32>,
}

impl Assignment {
    /// The hand-out a result must answer.
    pub fn key(&self) -> TileAttempt {
        TileAttempt { job: self.job, tile: self.tile, attempt: self.attempt }
    }
}

/// What watchers of a job hear.
#[derive(Clone, Debug, PartialEq)]
pub enum JobUpdate {
    /// More tiles are in.
    Progress {
        /// Tiles merged or waiting to merge.
        done: u32,
        /// All tiles.
        total: u32,
        /// Workers holding tiles of the job.
        workers: u32,
        /// Rays so far.
        stats: RayStats,
    },
    /// The image is complete.
    Finished(std::sync::Arc<FinishedJob>),
    /// The job failed or was cancelled.
    Failed(String),
}

/// A completed job's image and facts.
#[derive(Clone, Debug, PartialEq)]
pub struct FinishedJob {
    /// The job's name as submitted.
    pub name: String,
    /// The image.
    pub image: RgbImage,
    /// Samples per pixel.
    pub spp: u32,
    /// Seconds from the first assignment to the last tile.
    pub render_seconds: f64,
    /// Rays traced.
    pub stats: RayStats,
    /// The render's estimate of its own error.
    pub error: Option<ErrorEstimate>,
    /// A render in passes: what each pass left, and why it stopped.
    pub passes: Vec<PassEnd>,
    /// Why a render in passes stopped where it did.
    pub stopped: Option<PassStop>,
}

/// What a complete film leaves: its image and its estimate of its own
/// error. Working them out takes a few tens of nanoseconds a pixel (about
/// 0.16 s for a 2048² film), which the server's outbox spends off its
/// event loop ([`Outbox::end_film`]).
#[derive(Debug)]
pub struct EndedFilm {
    /// The image.
    pub image: RgbImage,
    /// Its estimate of its own error (`None` at one sample per pixel).
    pub error: Option<ErrorEstimate>,
}

impl EndedFilm {
    /// Ends `film`, whose pixels have `spp` samples.
    pub fn of(mut film: Film, spp: u32) -> EndedFilm {
        // The estimate first: its working buffers (12 bytes a pixel) are
        // freed before the image's 12 are allocated, and the film's copy
        // of its map (4) with them, so they are never alive together
        // beside the film.
        let error = film.error_estimate(spp);
        EndedFilm { image: film.into_image(), error }
    }
}

/// A change the scheduler asks to be made durable, so that a restarted
/// coordinator resumes where it was.
#[derive(Debug)]
pub enum Record<'a> {
    /// A job was accepted.
    Submitted {
        /// Its id.
        job: JobId,
        /// Its spec.
        spec: &'a JobSpec,
    },
    /// A tile was handed out for the `n`th time.
    HandedOut {
        /// The job.
        job: JobId,
        /// The tile.
        tile: TileId,
        /// Hand-outs so far.
        n: u32,
    },
    /// A tile's result was accepted (merged now or waiting for its turn).
    Merged {
        /// The job.
        job: JobId,
        /// The tile's index in the job's passes: pass × tiles + tile (the
        /// tile itself for a job without passes).
        tile: TileId,
        /// Its sums, shared with the film (and the journal, which encodes
        /// them on its own thread).
        film_tile: &'a Arc<FilmTile>,
        /// Its rays.
        stats: &'a RayStats,
    },
    /// A job ended: done (with its image), failed or cancelled.
    Ended {
        /// The job.
        job: JobId,
        /// How.
        state: &'a JobState,
        /// The image of a finished job, shared with its watchers.
        image: Option<&'a std::sync::Arc<FinishedJob>>,
    },
}

/// The scheduler's way out: messages to workers and to a job's watchers.
pub trait Outbox {
    /// Send a tile to a worker.
    fn assign(&mut self, worker: WorkerId, a: Assignment);
    /// Tell a worker to drop a job's tiles.
    fn cancel(&mut self, worker: WorkerId, job: JobId);
    /// Drop the connection to a worker declared lost.
    fn disconnect(&mut self, worker: WorkerId);
    /// Tell a job's watchers something happened.
    fn notify(&mut self, job: JobId, update: JobUpdate);
    /// Make a change durable (nothing, unless the outbox keeps a journal).
    fn record(&mut self, _change: Record<'_>) {}
    /// Whether changes are kept across restarts: then a finished job's image
    /// is read back from the journal rather than kept in memory, and a
    /// shutdown leaves active jobs to resume.
    fn durable(&self) -> bool {
        false
    }
    /// Ends the complete film of `job` ([`EndedFilm::of`]). Here at once,
    /// returning it; an outbox that returns `None` works it out elsewhere
    /// and hands it to [`super::Scheduler::film_ended`] later, in which time
    /// the scheduler goes on with other jobs and workers.
    fn end_film(&mut self, _job: JobId, film: Film, spp: u32) -> Option<EndedFilm> {
        Some(EndedFilm::of(film, spp))
    }
    /// Works out the estimate of `job`'s film after a pass of `spp` samples
    /// per pixel ([`Film::pass_estimate`]), here at once, returning the
    /// film with it; an outbox that returns `None` hands them to
    /// [`super::Scheduler::pass_estimated`] later.
    fn estimate_pass(
        &mut self,
        _job: JobId,
        mut film: Film,
        spp: u32,
    ) -> Option<(Film, Option<f64>)> {
        let estimate = film.pass_estimate(spp);
        Some((film, estimate))
    }
}
