//! Reading the journal back at start-up: the jobs with their states,
//! shots and passes, the tiles merged so far, and the stored blobs.

use super::tiles::TileLogs;
use super::{Ending, Restored, SavedBlob, SavedJob};
use crate::scheduler::{JobSpec, ShotFrame};
use farm_common::film::{FilmTile, PassPlan};
use farm_common::ids::JobId;
use farm_common::stats::RayStats;
use rusqlite::{params, Connection, OptionalExtension};
use std::collections::BTreeMap;
use tracing::error;
pub(super) fn restore(conn: &Connection, logs: &TileLogs) -> rusqlite::Result<Restored> {
    let next_job: i64 = conn
        .query_row("SELECT value FROM meta WHERE key = 'next_job'", [], |r| r.get(0))
        .optional()?
        .unwrap_or(1);
    let mut jobs = Vec::new();
    let mut st =
        conn.prepare("SELECT id, spec, state, reason, detach, ended_at FROM jobs ORDER BY id")?;
    let rows = st.query_map([], |r| {
        Ok((
            r.get::<_, i64>(0)?,
            r.get::<_, Vec<u8>>(1)?,
            r.get::<_, String>(2)?,
            r.get::<_, Option<String>>(3)?,
            r.get::<_, bool>(4)?,
            r.get::<_, Option<i64>>(5)?,
        ))
    })?;
    for row in rows {
        let (id, spec, state, reason, detach, ended_at) = row?;
        let Ok(mut spec) = postcard::from_bytes::<JobSpec>(&spec) else {
            error!(job = id, "a job in the journal does not decode: skipped");
            continue;
        };
        let mut f = conn.prepare_cached("SELECT shot, frame, frames FROM frames WHERE job = ?1")?;
        spec.shot = f
            .query_row(params![id], |r| {
                Ok(ShotFrame {
                    shot: JobId(r.get::<_, i64>(0)? as u64),
                    frame: r.get(1)?,
                    frames: r.get(2)?,
                })
            })
            .optional()?;
        let mut p = conn.prepare_cached("SELECT plan FROM passes WHERE job = ?1")?;
        let plan = p.query_row(params![id], |r| r.get::<_, Vec<u8>>(0)).optional()?;
        if let Some(bytes) = plan {
            let Ok(plan) = postcard::from_bytes::<PassPlan>(&bytes) else {
                error!(job = id, "a job's passes in the journal do not decode: skipped");
                continue;
            };
            spec.passes = Some(plan);
        }
        let mut q = conn.prepare_cached("SELECT 1 FROM parallel_tiles WHERE job = ?1")?;
        spec.parallel_tiles = q.exists(params![id])?;
        let ending = match state.as_str() {
            "done" => Some(Ending::Done),
            "failed" => Some(Ending::Failed(reason.unwrap_or_default())),
            "cancelled" => Some(Ending::Cancelled),
            _ => None,
        };
        let mut tiles = Vec::new();
        if ending.is_none() {
            // Rows from before the tile logs, then the job's log.
            let mut t = conn.prepare_cached("SELECT tile, data FROM tiles WHERE job = ?1")?;
            let mut saved = t
                .query_map(params![id], |r| Ok((r.get::<_, u32>(0)?, r.get::<_, Vec<u8>>(1)?)))?
                .collect::<rusqlite::Result<BTreeMap<_, _>>>()?;
            saved.extend(logs.read(id as u64));
            for (tile, data) in saved {
                match postcard::from_bytes::<(FilmTile, RayStats)>(&data) {
                    Ok((ft, stats)) => tiles.push((tile, ft, stats)),
                    Err(_) => error!(
                        job = id,
                        tile, "a tile in the journal does not decode: it renders again"
                    ),
                }
            }
        }
        let mut a = conn.prepare_cached("SELECT tile, n FROM attempts WHERE job = ?1")?;
        let attempts = a
            .query_map(params![id], |r| Ok((r.get::<_, u32>(0)?, r.get::<_, u32>(1)?)))?
            .collect::<rusqlite::Result<Vec<_>>>()?;
        jobs.push(SavedJob { id: id as u64, spec, ending, ended_at, detach, tiles, attempts });
    }
    let mut b = conn.prepare("SELECT hash, size, owner FROM blobs")?;
    let blobs = b
        .query_map([], |r| {
            Ok((r.get::<_, Vec<u8>>(0)?, r.get::<_, i64>(1)?, r.get::<_, String>(2)?))
        })?
        .filter_map(Result::ok)
        .filter_map(|(h, size, owner)| {
            Some(SavedBlob { hash: h.try_into().ok()?, size: size as u64, owner })
        })
        .collect();
    let next_job = jobs.iter().map(|j| j.id + 1).max().unwrap_or(1).max(next_job as u64);
    Ok(Restored { next_job, jobs, blobs })
}
