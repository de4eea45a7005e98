//! What the dashboard and the metrics see of the scheduler: richer rows
//! than `farm status`, the gauges, and the priority action.

use super::job::Job;
use super::{Outbox, Record, Scheduler};
use farm_common::ids::JobId;
use serde::Serialize;
use std::collections::BTreeMap;
use std::time::Instant;

/// A job as the dashboard lists it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JobView {
    /// Id.
    pub id: u64,
    /// Name.
    pub name: String,
    /// The submitting token's name.
    pub owner: String,
    /// The submitting token's id (for the ownership check; not shown).
    #[serde(skip)]
    pub owner_id: String,
    /// State name.
    pub state: &'static str,
    /// Why it failed, if it did.
    pub message: Option<String>,
    /// Tiles in.
    pub tiles_done: u32,
    /// All tiles.
    pub tiles_total: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Priority.
    pub priority: i32,
    /// Image size.
    pub width: i32,
    /// Image size.
    pub height: i32,
    /// Seconds since its first hand-out (while it runs).
    pub elapsed_seconds: Option<f64>,
    /// Seconds left at the rate so far (while it runs).
    pub eta_seconds: Option<f64>,
    /// The render's estimate of its own relMSE (so far, or final).
    pub rel_mse: Option<f64>,
    /// Workers holding its tiles.
    pub workers: u32,
    /// Hand-outs and retries.
    pub attempts: u32,
    /// Hand-outs of a tile after its first, speculation aside.
    pub retries: u32,
    /// Speculative second hand-outs.
    pub speculated: u32,
}

/// A worker as the dashboard lists it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WorkerView {
    /// Id.
    pub id: u64,
    /// Its name (the host's, by default).
    pub name: String,
    /// Render threads.
    pub threads: u32,
    /// Tiles held.
    pub in_flight: u32,
    /// Tiles returned.
    pub tiles_done: u64,
    /// Tiles returned per second since it joined.
    pub tiles_per_second: f64,
    /// Tiles it failed (or sent back malformed).
    pub failures: u64,
    /// Jobs it may take no more tiles of, having failed too many.
    pub blocklisted: Vec<u64>,
}

/// The scheduler's state as gauges.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Gauges {
    /// Jobs by state name.
    pub jobs: BTreeMap<&'static str, i64>,
    /// Tiles of active jobs waiting for a worker.
    pub queue_depth: i64,
    /// Workers with a session.
    pub workers: i64,
}

impl Scheduler {
    /// Every job and worker as the dashboard shows them; `rel_mse(job)`
    /// gives a running job's estimate so far (see `Film::running_estimate`).
    pub fn views(
        &self,
        now: Instant,
        mut rel_mse: impl FnMut(JobId) -> Option<f64>,
    ) -> (Vec<JobView>, Vec<WorkerView>) {
        let max_fail = self.config.max_worker_failures;
        let jobs = self.jobs.values().map(|j| job_view(j, now, &mut rel_mse)).collect();
        let workers = self
            .workers
            .iter()
            .map(|(id, w)| {
                let up = (now - w.joined).as_secs_f64().max(1e-3);
                WorkerView {
                    id: id.0,
                    name: w.name.clone(),
                    threads: w.threads,
                    in_flight: w.in_flight.len() as u32,
                    tiles_done: w.tiles_done,
                    tiles_per_second: w.tiles_done as f64 / up,
                    failures: w.failures,
                    blocklisted: self
                        .jobs
                        .values()
                        .filter(|j| j.state.is_active())
                        .filter(|j| j.worker_failures.get(id).copied().unwrap_or(0) >= max_fail)
                        .map(|j| j.id.0)
                        .collect(),
                }
            })
            .collect();
        (jobs, workers)
    }

    /// One job as [`Scheduler::views`] shows it.
    pub fn view(
        &self,
        job: JobId,
        now: Instant,
        mut rel_mse: impl FnMut(JobId) -> Option<f64>,
    ) -> Option<JobView> {
        self.jobs.get(&job).map(|j| job_view(j, now, &mut rel_mse))
    }

    /// Jobs by state, queue depth and workers, for the metrics.
    pub fn gauges(&self) -> Gauges {
        let mut g = Gauges::default();
        for j in self.jobs.values() {
            *g.jobs.entry(j.state.name()).or_default() += 1;
            if j.state.is_active() {
                g.queue_depth += j.pending.len() as i64;
            }
        }
        g.workers = self.workers.len() as i64;
        g
    }

    /// Changes an active job's priority (higher runs first; tiles already
    /// out stay out). Returns whether the job was active.
    pub fn set_priority(&mut self, job: JobId, priority: i32, out: &mut impl Outbox) -> bool {
        let Some(j) = self.jobs.get_mut(&job) else { return false };
        if !j.state.is_active() {
            return false;
        }
        j.spec.priority = priority;
        // The spec is journalled again, so a restart keeps the new priority.
        out.record(Record::Submitted { job, spec: &j.spec });
        tracing::info!(job = job.0, priority, "job priority changed");
        self.fill(out);
        true
    }
}

/// A job's row; `rel_mse(job)` gives a running job's estimate so far.
fn job_view(j: &Job, now: Instant, rel_mse: &mut impl FnMut(JobId) -> Option<f64>) -> JobView {
    let total = j.spec.geometry.tile_count();
    let running = j.state.is_active();
    let elapsed = j.started.filter(|_| running).map(|s| (now - s).as_secs_f64());
    let eta = elapsed
        .filter(|_| j.done_tiles > 0)
        .map(|e| e * f64::from(total - j.done_tiles.min(total)) / f64::from(j.done_tiles));
    // A film lent off the loop is still running: its caller knows the
    // estimate it last showed.
    let estimate = match &j.film {
        Some(_) if j.done_tiles > 0 => rel_mse(j.id),
        None if running => rel_mse(j.id),
        _ => j.rel_mse,
    };
    let b = j.spec.geometry.cropped_pixel_bounds;
    JobView {
        id: j.id.0,
        name: j.spec.name.clone(),
        owner: j.spec.owner.name.clone(),
        owner_id: j.spec.owner.id.clone(),
        state: j.state.name(),
        message: match &j.state {
            super::JobState::Failed(m) => Some(m.clone()),
            _ => None,
        },
        tiles_done: j.done_tiles,
        tiles_total: total,
        spp: j.spec.spp,
        priority: j.spec.priority,
        width: b.width(),
        height: b.height(),
        elapsed_seconds: elapsed,
        eta_seconds: eta,
        rel_mse: estimate,
        workers: j.holder_count(),
        attempts: j.attempts.values().sum(),
        retries: j.retries,
        speculated: j.speculated,
    }
}
