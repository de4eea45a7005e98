//! Jobs that render in passes (`farm submit --target-error`,
//! `--time-limit`; `farm_common::film::PassPlan`): what happens when every
//! tile of a pass is merged.

use super::{JobUpdate, Outbox, Scheduler};
use crate::merge::Film;
use farm_common::film::PassEnd;
use farm_common::ids::JobId;
use tracing::info;

impl Scheduler {
    /// Every tile of the pass under way is merged. A job without passes is
    /// done. One with passes has its film's estimate worked out
    /// ([`Outbox::estimate_pass`], at once or later, meanwhile the job has
    /// no film); then it notes the pass's estimate and time, and stops if
    /// its plan says so, or else starts its next pass: the film keeps its
    /// sums and starts a new second half, and every tile is queued again
    /// for the next samples.
    pub(super) fn end_pass(&mut self, job: JobId, out: &mut impl Outbox) {
        let now = self.now();
        let Some(j) = self.jobs.get_mut(&job) else { return };
        let Some(plan) = j.spec.passes.as_ref() else { return self.finish(job, out) };
        let spp = plan.totals[j.pass as usize];
        let Some(film) = j.lend_film() else { return };
        let seconds = j.started.map_or(0.0, |s| now.duration_since(s).as_secs_f64());
        j.estimating = Some(seconds);
        if let Some((film, estimate)) = out.estimate_pass(job, film, spp) {
            self.next_pass(job, film, estimate, out);
        }
    }

    /// The film of `job`'s pass back from [`Outbox::estimate_pass`] with its
    /// estimate: the job stops if its plan says so, or else starts its
    /// next pass, whose tiles go to the free slots. Ignored if the job was
    /// cancelled (or forgotten) meanwhile.
    pub fn pass_estimated(
        &mut self,
        job: JobId,
        film: Film,
        estimate: Option<f64>,
        out: &mut impl Outbox,
    ) {
        self.next_pass(job, film, estimate, out);
        self.fill(out);
    }

    /// [`Scheduler::pass_estimated`] without handing out tiles (its caller
    /// does).
    fn next_pass(
        &mut self,
        job: JobId,
        mut film: Film,
        estimate: Option<f64>,
        out: &mut impl Outbox,
    ) {
        let Some(j) = self.jobs.get_mut(&job) else { return };
        let Some(seconds) = j.estimating.take() else { return };
        let Some(plan) = j.spec.passes.as_ref().filter(|_| j.state.is_active()) else { return };
        let pass = j.pass as usize;
        let spp = plan.totals[pass];
        j.pass_ends.push(PassEnd { spp, estimate, seconds });
        if let Some(why) = plan.stop_after(pass, estimate, seconds) {
            info!(job = job.0, pass, spp, ?estimate, seconds, ?why, "last pass done");
            j.stopped = Some(why);
            j.film = Some(film);
            return self.finish(job, out);
        }
        info!(job = job.0, pass, spp, ?estimate, seconds, "pass done; the next one starts");
        film.next_pass();
        j.film = Some(film);
        j.pass += 1;
        j.done_tiles = 0;
        // The pass's last tile counted no holder; the next pass counts afresh.
        j.holders_counted = None;
        let total = j.spec.geometry.tile_count();
        j.pending = (0..total).collect();
        j.out_order.clear();
        j.handed.clear();
        let update =
            JobUpdate::Progress { done: 0, total, workers: j.holder_count(), stats: j.stats };
        out.notify(job, update);
    }
}
