//! Jobs in passes through the scheduler: each pass hands out every tile
//! with its samples, the plan decides where to stop, and a journalled job
//! resumes in the pass it was in.

use super::tests::{geometry, spec, Durable, Recorder};
use super::*;
use farm_common::film::{FilmGeometry, FilmTile, PassPlan, PassStop, SampleRange};
use farm_common::ids::JobId;
use farm_common::ids::TileId;
use farm_common::image::RgbImage;
use farm_common::stats::RayStats;
use farm_common::Spectrum;
use std::time::Instant;

/// What any worker renders for a tile: two samples a pixel, one in each
/// half, so every pass has an estimate (the same whatever the pass asked).
pub(super) fn render(g: &FilmGeometry, tile: TileId) -> FilmTile {
    let mut t = FilmTile::new(g.tile_pixel_bounds(tile));
    for p in t.pixel_bounds.iter() {
        let v = ((p.x * 31 + p.y * 17 + tile.0 as i32 * 7) % 97) as f32 / 97.0 + 0.013;
        t.add(p, Spectrum::new(v, v * v, 1.0 / (1.0 + v)), 0.25 + v, false);
        t.add(p, Spectrum::new(v * 1.1, v, 0.5), 0.5, true);
    }
    t
}

/// Passes of 4, 8 and 16 samples.
pub(super) fn three(target_error: Option<f64>, time_limit: Option<f64>) -> PassPlan {
    PassPlan { totals: vec![4, 8, 16], ..PassPlan::new(16, target_error, time_limit) }
}

pub(super) fn in_passes(plan: &PassPlan) -> JobSpec {
    JobSpec { spp: *plan.totals.last().unwrap(), passes: Some(plan.clone()), ..spec(0) }
}

/// Renders every hand-out, the latest first, until none is left; returns
/// the samples each asked for, in the order they were handed out.
pub(super) fn run(s: &mut Scheduler, out: &mut Recorder) -> Vec<Option<SampleRange>> {
    let g = geometry();
    let mut asked = Vec::new();
    let mut queue = out.take();
    while let Some((w, a)) = queue.pop() {
        asked.push(a.samples);
        s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), out);
        queue.extend(out.take());
    }
    asked
}

pub(super) fn finished(out: &Recorder, job: JobId) -> std::sync::Arc<FinishedJob> {
    out.updates
        .iter()
        .find_map(|(j, u)| match u {
            JobUpdate::Finished(f) if *j == job => Some(f.clone()),
            _ => None,
        })
        .expect("the job finished")
}

pub(super) fn bits(i: &RgbImage) -> Vec<u32> {
    i.pixels.iter().flat_map(|p| p.map(f32::to_bits)).collect()
}

/// One worker (so no tile is speculated) renders the whole plan.
fn uninterrupted(plan: &PassPlan) -> (Vec<Option<SampleRange>>, std::sync::Arc<FinishedJob>) {
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Recorder::default();
    s.worker_joined(WorkerId(1), "a".into(), 2, 3, Instant::now(), &mut out);
    let job = s.submit(in_passes(plan), &mut out);
    let asked = run(&mut s, &mut out);
    assert_eq!(s.status().0[0].retries, 0, "a pass's hand-outs are not retries");
    (asked, finished(&out, job))
}

#[test]
fn every_pass_hands_out_every_tile_with_its_samples_up_to_the_cap() {
    // A target of 0 is not reached: every pass renders.
    let plan = three(Some(0.0), None);
    let (asked, f) = uninterrupted(&plan);
    let total = geometry().tile_count() as usize;
    assert_eq!(asked.len(), 3 * total, "passes of 4, 8 and 16 samples");
    for (k, pass) in asked.chunks(total).enumerate() {
        assert!(pass.iter().all(|r| *r == Some(plan.range(k))), "pass {k}: {pass:?}");
    }
    assert_eq!(f.spp, 16);
    assert_eq!(f.stopped, Some(PassStop::Cap));
    assert_eq!(f.passes.iter().map(|p| p.spp).collect::<Vec<_>>(), [4, 8, 16]);
    assert!(f.passes.iter().all(|p| p.estimate.is_some()), "{:?}", f.passes);
    assert_eq!(f.passes.last().unwrap().estimate, f.error.as_ref().map(|e| e.rel_mse));
}

#[test]
fn a_plan_stops_after_the_first_pass_that_meets_its_target_or_time() {
    let total = geometry().tile_count() as usize;
    for (plan, why) in [
        (three(Some(f64::MAX), None), PassStop::TargetReached),
        (three(None, Some(0.0)), PassStop::TimeLimit),
    ] {
        let (asked, f) = uninterrupted(&plan);
        assert_eq!(asked.len(), total, "one pass");
        assert_eq!((f.spp, f.stopped, f.passes.len()), (4, Some(why), 1));
    }
}

#[tokio::test]
async fn a_journalled_job_in_passes_resumes_in_its_pass_to_the_same_bits() {
    let plan = three(Some(0.0), None);
    let (_, reference) = uninterrupted(&plan);
    let dir = std::env::temp_dir().join(format!("farm-journal-passes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let db = dir.join("farm.db");
    let _ = std::fs::remove_file(&db);
    let g = geometry();
    let total = g.tile_count();
    // A coordinator gets through the first pass and a third of the second,
    // and dies.
    {
        let (journal, _) = crate::state::Journal::open(Some(&db)).unwrap();
        let mut s = Scheduler::new(SchedulerConfig::default());
        let mut out = Durable { rec: Recorder::default(), journal: journal.clone() };
        s.worker_joined(WorkerId(1), "a".into(), 1, 4, Instant::now(), &mut out);
        s.submit(in_passes(&plan), &mut out);
        let mut merged = 0;
        while merged < total + total / 3 {
            let mut batch = out.rec.take();
            let (w, a) = batch.remove(0);
            s.tile_done(w, a.key(), render(&g, a.tile), RayStats::default(), &mut out);
            out.rec.take().into_iter().for_each(|x| batch.push(x));
            for x in batch {
                out.rec.assign(x.0, x.1);
            }
            merged += 1;
        }
        journal.flush().await;
    }
    let (journal, restored) = crate::state::Journal::open(Some(&db)).unwrap();
    let saved = restored.jobs.into_iter().next().expect("the job was journalled");
    assert_eq!(saved.spec.passes.as_ref(), Some(&plan));
    assert_eq!(saved.tiles.len(), (total + total / 3) as usize);
    let mut s = Scheduler::new(SchedulerConfig::default());
    let mut out = Durable { rec: Recorder::default(), journal };
    s.restore(saved, &mut out);
    s.worker_joined(WorkerId(7), "b".into(), 1, 3, Instant::now(), &mut out.rec);
    let asked = run(&mut s, &mut out.rec);
    assert_eq!(asked.len() as u32, total - total / 3 + total, "the rest of pass 2, then pass 3");
    assert_eq!(asked[0], Some(plan.range(1)));
    assert_eq!(asked.last().unwrap(), &Some(plan.range(2)));
    let f = finished(&out.rec, JobId(1));
    assert_eq!(bits(&f.image), bits(&reference.image), "the same bits as without the restart");
    assert_eq!(f.error, reference.error);
    assert_eq!(f.passes.len(), 3);
    std::fs::remove_dir_all(dir).ok();
}
