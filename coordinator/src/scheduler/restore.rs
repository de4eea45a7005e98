//! Putting jobs back from the journal when the coordinator starts again,
//! and forgetting them after their retention period.

use super::job::{Job, JobState};
use super::{Outbox, Scheduler};
use crate::merge::{Accepted, Film};
use farm_common::ids::{JobId, TileId};
use std::time::Duration;
use tracing::{info, warn};

impl Scheduler {
    /// The id the next submitted job gets (after a restart: past every job
    /// the journal has seen).
    pub fn set_next_job(&mut self, next: u64) {
        self.next_job = self.next_job.max(next);
    }

    /// Puts back a job read from the journal: an ended one as it ended; an
    /// active one with its accepted tiles merged again in tile order (so
    /// the image is bit-identical to an uninterrupted render) and every
    /// other tile queued.
    pub fn restore(&mut self, saved: crate::state::SavedJob, out: &mut impl Outbox) {
        use crate::state::Ending;
        let id = JobId(saved.id);
        let total = saved.spec.geometry.tile_count();
        let state = match saved.ending {
            Some(Ending::Done) => JobState::Done,
            Some(Ending::Failed(m)) => JobState::Failed(m),
            Some(Ending::Cancelled) => JobState::Cancelled,
            None if saved.attempts.is_empty() => JobState::Queued,
            None => JobState::Running,
        };
        let now = self.now();
        let mut job = Job::new(id, saved.spec, state, now);
        job.attempts = saved.attempts.into_iter().collect();
        job.ended_at = saved.ended_at;
        if job.state == JobState::Done {
            job.done_tiles = total;
        }
        if job.state.is_active() {
            let mut film = Film::new(job.spec.geometry.clone());
            for (tile, ft, stats) in saved.tiles {
                match film.check(TileId(tile), &ft) {
                    Ok(Accepted::New) => {
                        film.insert(TileId(tile), ft);
                        job.stats.add(&stats);
                        job.done_tiles += 1;
                    }
                    Ok(Accepted::Duplicate) => {}
                    Err(e) => {
                        warn!(job = id.0, tile, error = %e, "a journalled tile is refused: it renders again")
                    }
                }
            }
            job.pending = (0..total).filter(|t| !film.has(TileId(*t))).collect();
            job.film = Some(film);
            if job.state == JobState::Running {
                job.started = Some(now);
            }
            info!(job = id.0, done = job.done_tiles, total, "job resumed");
        }
        self.next_job = self.next_job.max(id.0 + 1);
        let complete = job.film.as_ref().is_some_and(|f| f.is_complete());
        self.jobs.insert(id, job);
        if complete {
            self.finish(id, out);
        }
        self.fill(out);
    }

    /// Forgets the jobs that ended more than `keep` before `now` (seconds
    /// since the epoch) and returns them, for the journal to purge.
    pub fn expire(&mut self, now: i64, keep: Duration) -> Vec<JobId> {
        let keep = keep.as_secs() as i64;
        let old: Vec<JobId> = self
            .jobs
            .values()
            .filter(|j| {
                !j.state.is_active() && j.ended_at.is_some_and(|t| t.saturating_add(keep) <= now)
            })
            .map(|j| j.id)
            .collect();
        for id in &old {
            self.jobs.remove(id);
            info!(job = id.0, "finished job purged after its retention period");
        }
        old
    }
}
