//! Progress events: how many workers hold a job's tiles, counted again at
//! most every `PROGRESS_EVERY` (the count walks every tile out).

use super::pass_tests::{in_passes, run, three};
use super::tests::{geometry, render, spec, Recorder};
use super::*;
use farm_common::stats::RayStats;
use std::time::Instant;

/// Progress events count the workers holding the job's tiles again at
/// most every `PROGRESS_EVERY` (the count walks every tile out), and
/// exactly at the last tile.
#[test]
fn progress_counts_the_holders_at_most_every_interval() {
    let g = geometry();
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Recorder::default();
    let t0 = Instant::now();
    s.set_virtual_time(t0);
    for w in 1..=2 {
        s.worker_joined(WorkerId(w), format!("w{w}"), 1, 3, t0, &mut out);
    }
    let job = s.submit(spec(0), &mut out);
    let workers = |out: &Recorder| match out.updates.last() {
        Some((j, JobUpdate::Progress { workers, .. })) if *j == job => *workers,
        other => panic!("not a progress event: {other:?}"),
    };
    let done = |s: &mut Scheduler, out: &mut Recorder, w: u64| {
        let (_, a) = out.assigned.iter().find(|(h, _)| *h == WorkerId(w)).cloned().unwrap();
        out.assigned.retain(|(_, b)| b.key() != a.key());
        s.tile_done(WorkerId(w), a.key(), render(&g, a.tile), RayStats::default(), out);
    };
    done(&mut s, &mut out, 1);
    assert_eq!(workers(&out), 2, "both hold tiles");
    // Worker 2 leaves: within the interval, the last count stands.
    s.worker_left(WorkerId(2), &mut out);
    out.assigned.retain(|(w, _)| *w == WorkerId(1));
    done(&mut s, &mut out, 1);
    assert_eq!(workers(&out), 2, "counted again within the interval");
    s.set_virtual_time(t0 + jobs::PROGRESS_EVERY);
    done(&mut s, &mut out, 1);
    assert_eq!(workers(&out), 1, "counted again after it");
    // The rest, at the same time: the last tile's count is exact.
    while !out.assigned.is_empty() {
        done(&mut s, &mut out, 1);
    }
    let last = out.updates.iter().rev().find_map(|(j, u)| match u {
        JobUpdate::Progress { done, total, workers, .. } if *j == job => {
            Some((*done, *total, *workers))
        }
        _ => None,
    });
    assert_eq!(last, Some((g.tile_count(), g.tile_count(), 0)));
}

/// Within every pass, a progress event counts the worker that holds the
/// pass's tiles, even when the pass before ended (counting none out) a
/// moment earlier.
#[test]
fn each_pass_counts_its_holders_afresh() {
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Recorder::default();
    // One instant throughout: no recount is due to the clock.
    let t0 = Instant::now();
    s.set_virtual_time(t0);
    s.worker_joined(WorkerId(1), "a".into(), 2, 3, t0, &mut out);
    let job = s.submit(in_passes(&three(Some(0.0), None)), &mut out);
    run(&mut s, &mut out);
    let total = geometry().tile_count();
    let during: Vec<u32> = out
        .updates
        .iter()
        .filter_map(|(j, u)| match u {
            JobUpdate::Progress { done, workers, .. }
                if *j == job && *done > 0 && *done < total =>
            {
                Some(*workers)
            }
            _ => None,
        })
        .collect();
    assert_eq!(during.len(), 3 * (total as usize - 1), "every pass reports each tile");
    assert!(during.iter().all(|&w| w == 1), "{during:?}");
}
