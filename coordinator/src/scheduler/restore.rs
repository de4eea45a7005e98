//! Putting jobs back from the journal when the coordinator starts again,
//! and forgetting them after their retention period.

use super::job::{Job, JobState};
use super::{Outbox, Scheduler};
use crate::merge::{Accepted, Film};
use farm_common::film::PassEnd;
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
            for (key, ft, stats) in saved.tiles {
                // A job in passes journals pass × tiles + tile; a pass's
                // tiles come only once the pass before is merged whole.
                let (pass, tile) = (key / total.max(1), key % total.max(1));
                while pass > job.pass && film.is_complete() && job.has_pass_after() {
                    let spp = job.samples().map_or(job.spec.spp, |r| r.end);
                    let estimate = film.pass_estimate(spp);
                    job.pass_ends.push(PassEnd { spp, estimate, seconds: 0.0 });
                    film.next_pass();
                    job.pass += 1;
                    job.done_tiles = 0;
                }
                if pass != job.pass {
                    warn!(
                        job = id.0,
                        pass,
                        tile,
                        "a journalled tile is not of the pass under way: it renders again"
                    );
                    continue;
                }
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
            // A tile handed out more often than there were passes before
            // this one was handed out in it; its next hand-out is a retry.
            let before = job.pass;
            job.handed =
                job.attempts.iter().filter(|(_, a)| **a > before).map(|(t, _)| *t).collect();
            job.retries = job.attempts.values().map(|a| a.saturating_sub(before + 1)).sum();
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
            self.end_pass(id, out);
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
