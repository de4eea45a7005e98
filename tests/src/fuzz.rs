//! The bodies of the fuzz targets in `fuzz/` (run by `cargo fuzz`), kept
//! here so `tests/tests/fuzz_corpus.rs` replays the committed corpus and a
//! burst of mutations of it in every `cargo test`. Each takes arbitrary
//! bytes and must return without panicking, aborting or hanging, whatever
//! they are.

use farm_common::ids::WorkerId;
use farm_coordinator::server::FromWorker;
use farm_proto::v1;
use prost::Message;
use std::path::Path;

/// The pbrt tokenizer, parser and scene builder, then the film layout with
/// its limits, on text that is UTF-8 (the parser reads UTF-8 files).
pub fn scene(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    // A folder that does not exist: Include and file parameters fail to read
    // instead of reaching the fuzzing host's files.
    let base = Path::new("/nonexistent-farm-fuzz");
    if let Ok((desc, _)) = farm_scene::parse_str(text, "fuzz.pbrt", base) {
        let _ = farm_common::film::checked_layout(&desc, None, &Default::default());
    }
}

/// The PLY reader.
pub fn ply(data: &[u8]) {
    let _ = farm_scene::ply::parse(data);
}

/// The image readers: the first byte picks EXR, PNG, TGA or PFM.
pub fn image(data: &[u8]) {
    let Some((&pick, bytes)) = data.split_first() else { return };
    let name = ["x.exr", "x.png", "x.tga", "x.pfm"][pick as usize % 4];
    let _ = farm_common::image::read_image(bytes, name);
}

/// Every message the coordinator receives, decoded as it decodes them,
/// and the job events a client receives: the first byte picks the message
/// type.
pub fn messages(data: &[u8]) {
    let Some((&pick, bytes)) = data.split_first() else { return };
    match pick % 8 {
        0 => {
            if let Ok(m) = v1::WorkerMessage::decode(bytes) {
                let _ = FromWorker::decode(WorkerId(1), m.kind);
            }
        }
        1 => drop(v1::RegisterWorkerRequest::decode(bytes)),
        2 => {
            if let Ok(c) = v1::BlobChunk::decode(bytes) {
                let _ = farm_proto::convert::BlobAssembler::new(1 << 20).push(&c);
            }
        }
        3 => drop(v1::SubmitJobRequest::decode(bytes)),
        4 => {
            drop(v1::FetchBlobRequest::decode(bytes));
            // What a client is sent while it watches: previews are checked
            // against the image they claim before anything is drawn.
            if let Ok(v1::JobEvent { kind: Some(v1::job_event::Kind::Preview(p)) }) =
                v1::JobEvent::decode(bytes)
            {
                let _ = farm_proto::convert::decode_preview(&p, p.width, p.height);
            }
        }
        5 => drop(v1::WatchJobRequest::decode(bytes).map(|_| v1::CancelJobRequest::decode(bytes))),
        6 => {
            // A scene manifest is a blob the coordinator decodes at SubmitJob.
            if let Ok((desc, _)) = farm_proto::convert::decode_manifest(bytes) {
                let _ = farm_common::film::checked_layout(&desc, None, &Default::default());
            }
        }
        _ => {
            if let Ok(t) = v1::FilmTile::decode(bytes) {
                let _ = farm_common::film::FilmTile::try_from(&t);
            }
        }
    }
}
