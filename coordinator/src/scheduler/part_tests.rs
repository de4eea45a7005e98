//! A late tile of a job whose tiles render on all of a worker's threads is
//! shared by idle workers in parts, whose films the scheduler adds in part
//! order: the image has the bits it has when the tile comes back whole.

use super::tests::{geometry, render, spec, Recorder};
use super::*;
use farm_common::film::{FilmGeometry, FilmTile, TILE_PARTS};
use farm_common::ids::TileId;
use farm_common::stats::RayStats;
use std::collections::HashSet;
use std::time::Instant;

/// Part `k` of a tile as a worker would send it: the tile's sums, each part
/// at its own scale, so adding them in another order gives other bits.
fn part(g: &FilmGeometry, tile: TileId, k: u32) -> FilmTile {
    let scale = [1.0f32, 3.1e-3, 7.7, 1.3e4][k as usize];
    let mut t = render(g, tile);
    for p in &mut t.pixels {
        *p = farm_common::film::Pixel::from_array(p.to_array().map(|v| v * scale));
    }
    t
}

/// The parts added in part order into a zero film: the tile's film.
fn whole(g: &FilmGeometry, tile: TileId) -> FilmTile {
    let mut t = FilmTile::new(g.tile_pixel_bounds(tile));
    for k in 0..TILE_PARTS {
        t.merge(&part(g, tile, k));
    }
    t
}

fn parallel() -> JobSpec {
    JobSpec { parallel_tiles: true, ..spec(0) }
}

/// Answers every hand-out in turn, but worker 1's first tile (never
/// answered) and its parts, until nothing is left to answer: returns that
/// tile and the parts of it handed out.
fn all_but_the_late_tile(
    s: &mut Scheduler,
    out: &mut Recorder,
    g: &FilmGeometry,
) -> (Assignment, Vec<(WorkerId, Assignment)>) {
    let (mut late, mut parts) = (None, Vec::new());
    let mut queue = out.take();
    while !queue.is_empty() {
        let (w, a) = queue.remove(0);
        let is_late = late.as_ref().is_some_and(|l: &Assignment| l.tile == a.tile);
        match (w, a.part) {
            (WorkerId(1), None) if late.is_none() => late = Some(a),
            (_, Some(_)) if is_late => parts.push((w, a)),
            // A part of another tile, answered after its holder's tile
            // (ignored, but its worker is free again).
            (_, Some(k)) => s.tile_done(w, a.key(), part(g, a.tile, k), RayStats::default(), out),
            _ => s.tile_done(w, a.key(), render(g, a.tile), RayStats::default(), out),
        }
        queue.extend(out.take());
    }
    (late.expect("worker 1 got a tile"), parts)
}

#[test]
fn idle_workers_share_a_late_tile_in_parts_with_the_tiles_bits() {
    let g = geometry();
    let now = Instant::now();
    // Worker 1 holds one tile and never answers; four others render the
    // rest, then share its tile in parts, answered last part first.
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Recorder::default();
    s.worker_joined(WorkerId(1), "late".into(), 4, 1, now, &mut out);
    for w in 2..=5 {
        s.worker_joined(WorkerId(w), format!("w{w}"), 4, 2, now, &mut out);
    }
    let job = s.submit(parallel(), &mut out);
    let (late, parts) = all_but_the_late_tile(&mut s, &mut out, &g);
    assert_eq!(s.job_state(job), Some(&JobState::Running));
    let mut got: Vec<u32> = parts.iter().map(|(_, a)| a.part.unwrap()).collect();
    got.sort_unstable();
    assert_eq!(got, (0..TILE_PARTS).collect::<Vec<_>>(), "every part out once");
    assert!(parts.iter().all(|(_, a)| a.tile == late.tile && a.speculative));
    let holders: HashSet<WorkerId> = parts.iter().map(|(w, _)| *w).collect();
    assert_eq!(holders.len(), 4, "each part to another idle worker");
    assert!(!holders.contains(&WorkerId(1)), "never to the tile's holder");
    for (w, a) in parts.into_iter().rev() {
        let k = a.part.unwrap();
        s.tile_done(w, a.key(), part(&g, a.tile, k), RayStats::default(), &mut out);
    }
    assert_eq!(s.job_state(job), Some(&JobState::Done));
    assert!(s.workers[&WorkerId(1)].in_flight.is_empty(), "the holder's slot is free");
    // Its late whole answer is ignored.
    s.tile_done(WorkerId(1), late.key(), render(&g, late.tile), RayStats::default(), &mut out);
    let image = out.image(job).expect("finished");

    // The same job with that tile's film sent whole.
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Recorder::default();
    s.worker_joined(WorkerId(1), "one".into(), 4, 2, now, &mut out);
    let job = s.submit(parallel(), &mut out);
    let mut queue = out.take();
    while !queue.is_empty() {
        let (w, a) = queue.remove(0);
        let film = if a.tile == late.tile { whole(&g, a.tile) } else { render(&g, a.tile) };
        s.tile_done(w, a.key(), film, RayStats::default(), &mut out);
        queue.extend(out.take());
    }
    assert!(out.image(job) == Some(image), "the parts give the whole tile's bits");
}

#[test]
fn a_part_whose_worker_leaves_goes_to_another_and_a_whole_answer_still_wins() {
    let g = geometry();
    let now = Instant::now();
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Recorder::default();
    s.worker_joined(WorkerId(1), "late".into(), 4, 1, now, &mut out);
    for w in 2..=4 {
        s.worker_joined(WorkerId(w), format!("w{w}"), 4, 2, now, &mut out);
    }
    let job = s.submit(parallel(), &mut out);
    let (late, mut parts) = all_but_the_late_tile(&mut s, &mut out, &g);
    // Three idle workers: three parts out, the fourth waits.
    assert_eq!(parts.len(), 3);
    let (gone, lost) = parts.remove(0);
    s.worker_left(gone, &mut out);
    assert!(out.take().is_empty(), "the others each hold a part");
    // One answers its part; it is free again and takes a part still out of
    // anyone's hands: the lost one or the fourth.
    let (w, a) = parts.remove(0);
    s.tile_done(w, a.key(), part(&g, a.tile, a.part.unwrap()), RayStats::default(), &mut out);
    let again = out.take();
    assert_eq!(again.len(), 1, "{again:?}");
    let k = again[0].1.part.expect("a part");
    assert!(again[0].0 == w && again[0].1.tile == late.tile);
    assert!(k == lost.part.unwrap() || !parts.iter().any(|(_, a)| a.part == Some(k)), "{k}");
    // The holder answers first: its tile wins, and the parts' slots free.
    s.tile_done(WorkerId(1), late.key(), whole(&g, late.tile), RayStats::default(), &mut out);
    assert_eq!(s.job_state(job), Some(&JobState::Done));
    assert!((2..=4).all(|w| s.workers.get(&WorkerId(w)).is_none_or(|w| w.in_flight.is_empty())));
    // A part's answer after that is ignored.
    let (w, a) = parts.remove(0);
    s.tile_done(w, a.key(), part(&g, a.tile, a.part.unwrap()), RayStats::default(), &mut out);
    assert_eq!(s.job_state(job), Some(&JobState::Done));
}

/// A worker whose tile another finished first is still rendering it: its
/// slot stays taken, so it is not sent more work to queue behind the moot
/// tile, until it answers (the answer is ignored).
#[test]
fn a_hand_out_finished_elsewhere_keeps_its_slot_until_it_answers() {
    let g = geometry();
    let now = Instant::now();
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Recorder::default();
    for w in 1..=3 {
        s.worker_joined(WorkerId(w), format!("w{w}"), 1, 1, now, &mut out);
    }
    let job = s.submit(spec(0), &mut out);
    // Workers 1 and 3 keep their first tiles; worker 2 renders the rest,
    // then worker 1's tile again (the oldest hand-out), and answers it.
    let mut held = Vec::new();
    let mut queue = out.take();
    let mut spare_of_1 = None;
    while !queue.is_empty() {
        let (w, a) = queue.remove(0);
        if w != WorkerId(2) {
            held.push((w, a));
        } else if a.speculative && spare_of_1.is_none() {
            spare_of_1 = Some(a.tile);
            s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), &mut out);
            break;
        } else {
            s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), &mut out);
        }
        queue.extend(out.take());
    }
    let (w1, a1) = held.iter().find(|(w, _)| *w == WorkerId(1)).cloned().expect("worker 1's tile");
    assert_eq!(spare_of_1, Some(a1.tile));
    assert_eq!(s.job_state(job), Some(&JobState::Running));
    assert_eq!(s.workers[&w1].in_flight.len(), 1, "still rendering the moot tile");
    assert!(out.take().iter().all(|(w, _)| *w != w1), "nothing queued behind it");
    s.tile_done(w1, a1.key(), render(&g, a1.tile), RayStats::default(), &mut out);
    assert!(s.workers[&w1].in_flight.is_empty(), "its answer frees the slot");
}
