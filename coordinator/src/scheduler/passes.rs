//! Jobs that render in passes (`farm submit --target-error`,
//! `--time-limit`; `farm_common::film::PassPlan`): what happens when every
//! tile of a pass is merged.

use super::{JobUpdate, Outbox, Scheduler};
use farm_common::film::PassEnd;
use farm_common::ids::JobId;
use std::collections::HashSet;
use tracing::info;

impl Scheduler {
    /// Every tile of the pass under way is merged. A job without passes is
    /// done. One with passes notes the pass's estimate and time, then stops
    /// if its plan says so, or else starts its next pass: the film keeps
    /// its sums and starts a new second half, and every tile is queued
    /// again for the next samples.
    pub(super) fn end_pass(&mut self, job: JobId, out: &mut impl Outbox) {
        let now = self.now();
        let Some(j) = self.jobs.get_mut(&job) else { return };
        let Some(plan) = j.spec.passes.as_ref() else { return self.finish(job, out) };
        let Some(film) = j.film.as_mut() else { return };
        let pass = j.pass as usize;
        let spp = plan.totals[pass];
        let estimate = film.pass_estimate(spp);
        let seconds = j.started.map_or(0.0, |s| now.duration_since(s).as_secs_f64());
        j.pass_ends.push(PassEnd { spp, estimate, seconds });
        if let Some(why) = plan.stop_after(pass, estimate, seconds) {
            info!(job = job.0, pass, spp, ?estimate, seconds, ?why, "last pass done");
            j.stopped = Some(why);
            return self.finish(job, out);
        }
        info!(job = job.0, pass, spp, ?estimate, seconds, "pass done; the next one starts");
        film.next_pass();
        j.pass += 1;
        j.done_tiles = 0;
        let total = j.spec.geometry.tile_count();
        j.pending = (0..total).collect();
        j.out_order.clear();
        j.handed.clear();
        let workers: HashSet<_> = j.in_flight.values().map(|(w, _)| *w).collect();
        let update =
            JobUpdate::Progress { done: 0, total, workers: workers.len() as u32, stats: j.stats };
        out.notify(job, update);
    }
}
