//! What a `SubmitJob` brings, checked before anything is allocated for it:
//! the manifest within the size a coordinator decodes, every asset it
//! names uploaded, the shapes' parameters sent apart within the same
//! bound, the film within the limits, and the frame's place in a shot.

use crate::error::Error;
use crate::scheduler::{JobSpec, Owner, ShotFrame};
use crate::state::BlobStore;
use farm_common::film::{Limits, PassPlan};
use farm_common::ids::JobId;
use farm_proto::convert::{decode_manifest, is_shape_key, Hash};
use farm_proto::v1;
use tonic::Status;
use tracing::warn;

/// The largest scene manifest (the scene file and its includes, without
/// assets) a coordinator decodes; also the most that the shapes'
/// parameters sent apart may add up to, since every worker decodes them.
pub const MAX_MANIFEST: u64 = 256 << 20;

/// The most frames a shot may declare.
pub const MAX_FRAMES: u32 = 1_000_000;

/// Refuses `what` of `size` bytes over [`MAX_MANIFEST`].
fn within_bound(what: &str, size: u64) -> Result<(), Status> {
    if size <= MAX_MANIFEST {
        return Ok(());
    }
    let (size, bound) = (crate::state::bytes(size), crate::state::bytes(MAX_MANIFEST));
    Err(Error::BadManifest(format!("{what} {size}, over the {bound} a coordinator decodes")).into())
}

/// The job `r` asks for, submitted by `owner`, once checked.
pub(super) async fn job_spec(
    blobs: &BlobStore,
    limits: &Limits,
    r: v1::SubmitJobRequest,
    owner: Owner,
) -> Result<JobSpec, Status> {
    let manifest_hash: Hash = r.scene_hash.as_slice().try_into().map_err(|_| Error::NoManifest)?;
    // The coordinator decodes the manifest, so its size is bounded before
    // it is read (assets are only hashed, never decoded here).
    within_bound("the scene manifest is", blobs.size(&manifest_hash).ok_or(Error::NoManifest)?)?;
    let manifest = blobs.read(&manifest_hash).await.ok_or(Error::NoManifest)?;
    let (desc, assets) =
        decode_manifest(&manifest).map_err(|e| Error::BadManifest(e.to_string()))?;
    drop(manifest);
    // Shapes' parameters sent apart are decoded by every worker, once per
    // shape that names them: bounded in all as the manifest is.
    let mut shape_bytes = 0u64;
    for (key, hash) in &assets {
        let Some(size) = blobs.size(hash) else {
            return Err(Error::MissingAsset(key.trim_start_matches('\0').to_string()).into());
        };
        if is_shape_key(key) {
            shape_bytes = shape_bytes.saturating_add(size);
        }
    }
    within_bound("the scene's shapes with their parameters sent apart take", shape_bytes)?;
    let mut needed: Vec<Hash> = assets.iter().map(|(_, h)| *h).collect();
    needed.push(manifest_hash);
    needed.sort_unstable();
    needed.dedup();
    let spp_override = (r.spp > 0).then_some(r.spp);
    // Refused before anything is allocated for it.
    let (layout, _) = farm_common::film::checked_layout(&desc, spp_override, limits)
        .inspect_err(|e| warn!(error = %e, "job refused"))
        .map_err(Error::from)?;
    let spp = layout.spp();
    let geometry = layout.geometry;
    if geometry.cropped_pixel_bounds.is_empty() {
        return Err(Error::EmptyFilm.into());
    }
    let passes = PassPlan::for_job(layout.sampler, spp, r.target_error, r.time_limit);
    if let Some(p) = &passes {
        p.check().map_err(Error::BadPasses)?;
        // The journal keys a tile of a job in passes by pass × tiles + tile.
        let keys = p.totals.len() as u64 * u64::from(geometry.tile_count());
        if keys > u64::from(u32::MAX) {
            let why = format!(
                "{} passes of {} tiles are too many",
                p.totals.len(),
                geometry.tile_count()
            );
            return Err(Error::BadPasses(why).into());
        }
    }
    Ok(JobSpec {
        name: if r.name.is_empty() { desc.name.clone() } else { r.name },
        priority: r.priority,
        scene_hash: r.scene_hash,
        spp_override: r.spp,
        spp,
        geometry,
        owner,
        detach: r.detach,
        blobs: needed,
        shot: shot_frame(r.shot.as_ref())?,
        passes,
        parallel_tiles: layout.sampler.continues_sequence(),
    })
}

/// A submitted job's place in a shot, checked for sense (whether the shot
/// is the client's is the event loop's to check).
fn shot_frame(s: Option<&v1::ShotFrame>) -> Result<Option<ShotFrame>, Status> {
    let Some(s) = s else { return Ok(None) };
    if s.frames == 0 || s.frames > MAX_FRAMES {
        let why = format!("a shot has 1 to {MAX_FRAMES} frames, not {}", s.frames);
        return Err(Error::BadShot(why).into());
    }
    Ok(Some(ShotFrame { shot: JobId(s.shot), frame: s.frame, frames: s.frames }))
}
