//! Handing out tiles.

use super::job::JobState;
use super::{Assignment, Outbox, Record, Scheduler};
use farm_common::film::TILE_PARTS;
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
            .filter(|j| j.state.is_active() && j.film.is_some() && !j.pending.is_empty())
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
                    self.hand_out(*jid, tile, wid, HandOut::Holder, out);
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
    ///
    /// A job whose tiles render on all of a worker's threads (a stateless
    /// sampler's) hands out such a tile's parts instead, one to each of the
    /// next idle workers, so a costly tile left late on a slow worker is
    /// rendered again in a quarter of the time; the parts' films added in
    /// order are the tile's bits ([`Job::parts`]).
    fn speculate(&mut self, out: &mut impl Outbox) {
        if self.ready.is_empty() {
            return;
        }
        let mut order: Vec<JobId> = self
            .jobs
            .values()
            .filter(|j| {
                j.state.is_active()
                    && j.film.is_some()
                    && j.pending.is_empty()
                    && j.in_flight.len() > j.spares.len()
            })
            .map(|j| j.id)
            .collect();
        if order.is_empty() {
            return;
        }
        order.sort_by_key(|id| (-self.jobs[id].spec.priority, *id));
        let max_worker = self.config.max_worker_failures;
        // Per job in `order`, once a worker has looked at every hand-out of
        // a split job and found none: the slowest holder's pace among
        // them. A worker slower than four times that finds none either
        // (hand-outs only leave the line during this call), so it does not
        // look. With 10,000 idle workers, each looking at thousands of
        // hand-outs, this took up to a sixth of a coordinator's CPU.
        let mut slowest_holder: Vec<Option<f64>> = vec![None; order.len()];
        // Per job in `order`: the lowest pace of a worker that looked at
        // every hand-out of a split job and turned each down for pace
        // alone. A worker as slow or slower turns each down too, so it
        // does not look: with 10,000 idle workers of scattered paces,
        // each looking at thousands of hand-outs on every result, this
        // was a fifth of a coordinator's CPU.
        let mut too_slow_from: Vec<Option<f64>> = vec![None; order.len()];
        // The idle workers in id order. Most calls end at the first one
        // (nothing is left to speculate), and copying 10,000 idle workers'
        // ids on every result was the largest single cost of a tile at that
        // size; so the first is looked up alone, and the others copied only
        // once it is done with. Hand-outs only take the current worker out
        // of `ready`, so this visits the workers one copy made first would.
        let mut rest: Option<std::vec::IntoIter<WorkerId>> = None;
        loop {
            let next = match rest.as_mut() {
                Some(ids) => ids.next(),
                None => self.ready.first().copied(),
            };
            let Some(wid) = next else { break };
            let own_pace = self.workers.get(&wid).and_then(|w| w.pace.tile_seconds);
            while self.workers.get(&wid).is_some_and(|w| (w.in_flight.len() as u32) < self.slots(w))
            {
                let mut pick = None;
                for (o, jid) in order.iter().enumerate() {
                    let j = self.jobs.get_mut(jid).expect("active job");
                    if j.worker_failures.get(&wid).copied().unwrap_or(0) >= max_worker {
                        continue;
                    }
                    if let (Some(h), Some(w)) = (slowest_holder[o], own_pace) {
                        if w / f64::from(TILE_PARTS) > h {
                            continue;
                        }
                    }
                    if let (Some(m), Some(w)) = (too_slow_from[o], own_pace) {
                        if w >= m {
                            continue;
                        }
                    }
                    // The oldest hand-out nobody renders again, that this
                    // worker neither holds nor has failed. A split tile:
                    // the newest hand-out first (the likeliest to end
                    // last), and only to a worker that renders a part no
                    // slower than the holder renders a tile.
                    let split = j.spec.parallel_tiles;
                    // The slowest holder seen, while every one has a pace.
                    let mut slowest = Some(0.0f64);
                    // Whether a hand-out was turned down for this worker's
                    // own sake (it holds it, failed it, or holds a part).
                    let mut its_own = false;
                    let mut i = 0;
                    loop {
                        let at = if split { j.out_order.len().checked_sub(i + 1) } else { Some(i) };
                        let Some(at) = at else { break };
                        let Some(&t) = j.out_order.get(at) else { break };
                        let free = if split {
                            j.parts.get(&t).map_or(Some(0), |p| p.free())
                        } else {
                            Some(0)
                        };
                        if !j.in_flight.contains_key(&t)
                            || j.spares.contains_key(&t)
                            || free.is_none()
                        {
                            j.out_order.remove(at);
                            continue;
                        }
                        let holder = j.in_flight[&t].0;
                        let failed_here =
                            j.failures.get(&t).is_some_and(|f| f.iter().any(|(fw, _)| *fw == wid));
                        let holder_pace =
                            self.workers.get(&holder).and_then(|w| w.pace.tile_seconds);
                        slowest = slowest.zip(holder_pace).map(|(s, h)| s.max(h));
                        let sooner = match (holder_pace, own_pace) {
                            (Some(h), Some(w)) if split => w / f64::from(TILE_PARTS) <= h,
                            _ => true,
                        };
                        let mine = holder == wid || failed_here || j.holds_part(t, wid, None);
                        its_own |= mine;
                        if !mine && sooner {
                            // A split tile stays in line until its last
                            // part is out.
                            let last = !split
                                || j.parts.get(&t).map_or(TILE_PARTS, |p| p.free_count()) <= 1;
                            if last {
                                j.out_order.remove(at);
                            }
                            pick = Some((*jid, t, free.filter(|_| split)));
                            break;
                        }
                        i += 1;
                    }
                    if pick.is_none() && split {
                        slowest_holder[o] = slowest;
                        if let Some(w) = own_pace.filter(|_| !its_own) {
                            too_slow_from[o] = Some(too_slow_from[o].map_or(w, |m| m.min(w)));
                        }
                    }
                    if pick.is_some() {
                        break;
                    }
                }
                match pick {
                    Some((jid, tile, None)) => self.hand_out(jid, tile, wid, HandOut::Spare, out),
                    Some((jid, tile, Some(k))) => {
                        self.hand_out(jid, tile, wid, HandOut::Part(k), out)
                    }
                    // Once no job has a tile left to speculate, no other
                    // idle worker can get one either.
                    None if order.iter().all(|id| self.jobs[id].out_order.is_empty()) => return,
                    None => break,
                }
            }
            if rest.is_none() {
                rest = Some(self.ready_after(wid).into_iter());
            }
        }
    }

    /// Hands `tile` of `job` to worker `wid`, `how`. Journals it and sends
    /// it.
    fn hand_out(
        &mut self,
        job: JobId,
        tile: u32,
        wid: WorkerId,
        how: HandOut,
        out: &mut impl Outbox,
    ) {
        let now = self.now();
        let j = self.jobs.get_mut(&job).expect("active job");
        let attempt = {
            let a = j.attempts.entry(tile).or_insert(0);
            *a += 1;
            *a - 1
        };
        let speculative = how != HandOut::Holder;
        let retry = !speculative && !j.handed.insert(tile);
        j.retries += u32::from(retry);
        j.speculated += u32::from(speculative);
        match how {
            HandOut::Holder => {
                j.in_flight.insert(tile, (wid, attempt));
                j.out_order.push_back(tile);
                j.handed_at.insert(tile, now);
            }
            HandOut::Spare => {
                j.spares.insert(tile, (wid, attempt));
            }
            HandOut::Part(k) => {
                j.parts.entry(tile).or_default().held[k as usize] = Some((wid, attempt));
            }
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
            part: match how {
                HandOut::Part(k) => Some(k),
                _ => None,
            },
        };
        self.workers.get_mut(&wid).expect("worker").in_flight.insert((job, tile));
        self.refresh_ready(wid);
        out.assign(wid, a);
    }
}

/// How a tile goes out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum HandOut {
    /// To its holder, from the queue.
    Holder,
    /// A second hand-out of a tile still out (speculation).
    Spare,
    /// One part of a tile still out (speculation, split).
    Part(u32),
}
