//! Handing out tiles.

use super::job::JobState;
use super::{Assignment, Outbox, Record, Scheduler};
use farm_common::ids::{JobId, TileId, WorkerId};

impl Scheduler {
    /// Hands out tiles: round-robin over workers with free slots, each
    /// taking the next tile of the first job (by priority, then submission)
    /// it may work on.
    pub(super) fn fill(&mut self, out: &mut impl Outbox) {
        self.refresh_slots();
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
            self.speculate(out);
            return;
        }
        let max_worker = self.config.max_worker_failures;
        let now = self.now();
        loop {
            let mut assigned = false;
            let ids: Vec<WorkerId> = self.ready.iter().copied().collect();
            for wid in ids {
                let Some(w) = self.workers.get(&wid) else { continue };
                if w.in_flight.len() as u32 >= self.slots(w) {
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
                    if j.state == JobState::Queued {
                        j.state = JobState::Running;
                        j.started = Some(now);
                    }
                    self.hand_out(*jid, tile, wid, false, out);
                    assigned = true;
                    break;
                }
            }
            if !assigned {
                break;
            }
        }
        self.speculate(out);
    }

    /// Once a job has no tile left to hand out, a worker with a free slot
    /// renders again the tile out longest that nobody else is rendering
    /// again, so a slow or stalled worker does not hold up the end of the
    /// frame. The first result wins ([`Scheduler::tile_done`]); both are
    /// the same bits. A worker never gets a tile it holds or has failed.
    fn speculate(&mut self, out: &mut impl Outbox) {
        if self.ready.is_empty() {
            return;
        }
        let mut order: Vec<JobId> = self
            .jobs
            .values()
            .filter(|j| {
                j.state.is_active() && j.pending.is_empty() && j.in_flight.len() > j.spares.len()
            })
            .map(|j| j.id)
            .collect();
        if order.is_empty() {
            return;
        }
        order.sort_by_key(|id| (-self.jobs[id].spec.priority, *id));
        let max_worker = self.config.max_worker_failures;
        let ids: Vec<WorkerId> = self.ready.iter().copied().collect();
        for wid in ids {
            while self.workers.get(&wid).is_some_and(|w| (w.in_flight.len() as u32) < self.slots(w))
            {
                let mut pick = None;
                for jid in &order {
                    let j = self.jobs.get_mut(jid).expect("active job");
                    if j.worker_failures.get(&wid).copied().unwrap_or(0) >= max_worker {
                        continue;
                    }
                    // The oldest hand-out nobody renders again, that this
                    // worker neither holds nor has failed.
                    let mut i = 0;
                    while let Some(&t) = j.out_order.get(i) {
                        if !j.in_flight.contains_key(&t) || j.spares.contains_key(&t) {
                            j.out_order.remove(i);
                            continue;
                        }
                        let holder = j.in_flight[&t].0;
                        let failed_here =
                            j.failures.get(&t).is_some_and(|f| f.iter().any(|(fw, _)| *fw == wid));
                        if holder != wid && !failed_here {
                            j.out_order.remove(i);
                            pick = Some((*jid, t));
                            break;
                        }
                        i += 1;
                    }
                    if pick.is_some() {
                        break;
                    }
                }
                let Some((jid, tile)) = pick else { break };
                self.hand_out(jid, tile, wid, true, out);
            }
        }
    }

    /// Hands `tile` of `job` to worker `wid`: as the tile's holder, or as
    /// its spare when `speculative`. Journals it and sends it.
    fn hand_out(
        &mut self,
        job: JobId,
        tile: u32,
        wid: WorkerId,
        speculative: bool,
        out: &mut impl Outbox,
    ) {
        let j = self.jobs.get_mut(&job).expect("active job");
        let attempt = {
            let a = j.attempts.entry(tile).or_insert(0);
            *a += 1;
            *a - 1
        };
        let retry = !speculative && !j.handed.insert(tile);
        j.retries += u32::from(retry);
        if speculative {
            j.spares.insert(tile, (wid, attempt));
            j.speculated += 1;
        } else {
            j.in_flight.insert(tile, (wid, attempt));
            j.out_order.push_back(tile);
        }
        out.record(Record::HandedOut { job, tile: TileId(tile), n: attempt + 1 });
        let a = Assignment {
            job,
            tile: TileId(tile),
            attempt,
            scene_hash: j.spec.scene_hash.clone(),
            spp: j.spec.spp_override,
            speculative,
            retry,
            samples: j.samples(),
        };
        self.workers.get_mut(&wid).expect("worker").in_flight.insert((job, tile));
        self.refresh_ready(wid);
        out.assign(wid, a);
    }
}
