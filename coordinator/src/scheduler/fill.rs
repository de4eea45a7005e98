//! Handing out tiles.

use super::jobs::JobState;
use super::{Assignment, Outbox, Record, Scheduler};
use farm_common::ids::{JobId, TileId, WorkerId};

impl Scheduler {
    /// Hands out tiles: round-robin over workers with free slots, each
    /// taking the next tile of the first job (by priority, then submission)
    /// it may work on.
    pub(super) fn fill(&mut self, out: &mut impl Outbox) {
        if self.ready.is_empty() {
            return;
        }
        // Only jobs with tiles to hand out: once the last are out, a result
        // costs nothing here however many workers wait idle.
        let mut order: Vec<JobId> = self
            .jobs
            .values()
            .filter(|j| j.state.is_active() && !j.pending.is_empty())
            .map(|j| j.id)
            .collect();
        order.sort_by_key(|id| (-self.jobs[id].spec.priority, *id));
        if order.is_empty() {
            return;
        }
        let max_worker = self.config.max_worker_failures;
        let now = self.now();
        loop {
            let mut assigned = false;
            let ids: Vec<WorkerId> = self.ready.iter().copied().collect();
            for wid in ids {
                let Some(w) = self.workers.get(&wid) else { continue };
                if w.in_flight.len() as u32 >= w.max_in_flight {
                    continue;
                }
                for jid in &order {
                    let j = self.jobs.get_mut(jid).expect("active job");
                    if j.worker_failures.get(&wid).copied().unwrap_or(0) >= max_worker {
                        continue;
                    }
                    // Prefer a tile this worker has not failed before.
                    let failed_here = |t: &u32| {
                        j.failures.get(t).is_some_and(|f| f.iter().any(|(fw, _)| *fw == wid))
                    };
                    let Some(pos) = j
                        .pending
                        .iter()
                        .position(|t| !failed_here(t))
                        .or((!j.pending.is_empty()).then_some(0))
                    else {
                        continue;
                    };
                    let tile = j.pending.remove(pos).expect("position in range");
                    let attempt = {
                        let a = j.attempts.entry(tile).or_insert(0);
                        *a += 1;
                        *a - 1
                    };
                    j.in_flight.insert(tile, (wid, attempt));
                    out.record(Record::HandedOut { job: *jid, tile: TileId(tile), n: attempt + 1 });
                    if j.state == JobState::Queued {
                        j.state = JobState::Running;
                        j.started = Some(now);
                    }
                    let a = Assignment {
                        job: *jid,
                        tile: TileId(tile),
                        attempt,
                        scene_hash: j.spec.scene_hash.clone(),
                        spp: j.spec.spp_override,
                    };
                    self.workers.get_mut(&wid).expect("worker").in_flight.insert((*jid, tile));
                    self.refresh_ready(wid);
                    out.assign(wid, a);
                    assigned = true;
                    break;
                }
            }
            if !assigned {
                break;
            }
        }
    }
}
