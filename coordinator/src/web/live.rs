//! `/api/jobs/ID/live?from=N`: what a job page draws. The page keeps a
//! cursor into the film's changes (see [`crate::live`]) and is sent, as
//! 8-bit RGBA ready for a canvas, the pieces changed since it, and the
//! error map's pieces beside them. All numbers little-endian:
//!
//! ```text
//! u32 width, u32 height, u32 next cursor, u32 state (0 running, 1 done, 2 ended without an image),
//! u32 piece count, then per piece:
//!   u32 x0, u32 y0, u32 w, u32 h, u32 has error map (0 or 1),
//!   w·h·4 bytes of image, then w·h·4 bytes of error map if it has one
//! ```

use super::{may_touch, Caller, Web};
use crate::server::events::{Event, LiveAnswer};
use crate::state::Command;
use axum::body::Body;
use axum::extract::{Path, Query, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use farm_common::ids::JobId;
use farm_common::image::{ImagePiece, RgbImage};
use farm_proto::convert::ImageAssembler;
use prost::Message;

#[derive(serde::Deserialize)]
pub(super) struct Since {
    #[serde(default)]
    from: usize,
}

/// Entries of the sRGB table: linear [0, 1] in steps of 1/4096.
const SRGB_STEPS: usize = 4096;

/// Linear to an 8-bit sRGB code value (clamped to [0, 1]), by table: the
/// pages draw every pixel that changes, and `powf` per channel was most of
/// what drawing cost.
pub fn srgb8(v: f32) -> u8 {
    static TABLE: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    let t = TABLE.get_or_init(|| {
        (0..=SRGB_STEPS)
            .map(|i| {
                let v = i as f32 / SRGB_STEPS as f32;
                let s =
                    if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
                (s * 255.0 + 0.5) as u8
            })
            .collect()
    });
    let v = if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 };
    t[(v * SRGB_STEPS as f32 + 0.5) as usize]
}

/// Colours of the heat map, from t = 0 to 1.
const HEAT_STEPS: usize = 256;

/// A relMSE estimate as a colour: log scale from 1e-5 (black) through
/// purple, orange and yellow to 1 and above (white). The logarithm is
/// read off the float's exponent and mantissa (within 0.03 of a decade,
/// invisible in a colour map) and the colour off a table.
pub fn heat(e: f32) -> [u8; 3] {
    static TABLE: std::sync::OnceLock<Vec<[u8; 3]>> = std::sync::OnceLock::new();
    let t = TABLE.get_or_init(|| {
        const STOPS: [[f32; 3]; 5] =
            [[0.0, 0.0, 0.0], [0.34, 0.06, 0.43], [0.87, 0.32, 0.23], [0.99, 0.8, 0.15], [1.0; 3]];
        (0..=HEAT_STEPS)
            .map(|k| {
                let x = k as f32 / HEAT_STEPS as f32 * (STOPS.len() - 1) as f32;
                let i = (x as usize).min(STOPS.len() - 2);
                let f = x - i as f32;
                let c = |j: usize| {
                    ((STOPS[i][j] * (1.0 - f) + STOPS[i + 1][j] * f) * 255.0 + 0.5) as u8
                };
                [c(0), c(1), c(2)]
            })
            .collect()
    });
    if !(e > 0.0 && e.is_finite()) {
        return t[0];
    }
    let bits = e.to_bits();
    let log2 = ((bits >> 23) as f32 - 127.0) + (bits & 0x7f_ffff) as f32 / (1 << 23) as f32;
    let x = ((log2 * std::f32::consts::LOG10_2 + 5.0) / 5.0).clamp(0.0, 1.0);
    t[(x * HEAT_STEPS as f32 + 0.5) as usize]
}

fn put(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

/// The binary answer (see the module documentation).
pub fn encode(width: u32, height: u32, next: usize, state: u32, pieces: &[ImagePiece]) -> Vec<u8> {
    let mut out = Vec::new();
    for v in [width, height, next as u32, state, pieces.len() as u32] {
        put(&mut out, v);
    }
    for p in pieces {
        let b = p.bounds;
        for v in [b.min.x, b.min.y, b.width(), b.height()] {
            put(&mut out, v as u32);
        }
        put(&mut out, u32::from(p.error.is_some()));
        for px in &p.image.pixels {
            out.extend_from_slice(&[srgb8(px[0]), srgb8(px[1]), srgb8(px[2]), 255]);
        }
        if let Some(e) = &p.error {
            for v in e {
                let [r, g, b] = heat(*v);
                out.extend_from_slice(&[r, g, b, 255]);
            }
        }
    }
    out
}

fn binary(bytes: Vec<u8>) -> Response {
    let mut r = Response::new(Body::from(bytes));
    r.headers_mut()
        .insert(header::CONTENT_TYPE, HeaderValue::from_static("application/octet-stream"));
    r.headers_mut().insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    r
}

/// A finished image read back from the journal.
async fn stored(web: &Web, job: JobId) -> Option<(RgbImage, Option<Vec<f32>>)> {
    let journal = web.journal.as_ref()?;
    let (reply, rx) = tokio::sync::oneshot::channel();
    journal.send(Command::ReadImage { job: job.0, reply });
    let mut asm = ImageAssembler::default();
    for bytes in rx.await.ok()? {
        let ev = farm_proto::v1::JobEvent::decode(bytes.as_slice()).ok()?;
        if let Some(farm_proto::v1::job_event::Kind::Image(img)) = ev.kind {
            if let Some(done) = asm.add(&img).ok()? {
                return Some((done.image, done.error.map(|e| e.0)));
            }
        }
    }
    None
}

pub(super) async fn live(
    State(web): State<Web>,
    axum::Extension(caller): axum::Extension<Caller>,
    Path(id): Path<u64>,
    Query(q): Query<Since>,
) -> Response {
    let job = JobId(id);
    if let Err(refused) = may_touch(&web, &caller, job).await {
        return refused;
    }
    let Some(answer) = super::ask(&web, |reply| Event::Live { job, from: q.from, reply }).await
    else {
        return super::shutting_down();
    };
    let done = |image: &RgbImage, error: Option<&[f32]>| {
        let (w, h) = (image.width as u32, image.height as u32);
        binary(encode(w, h, 0, 1, &crate::live::whole_pieces(image, error)))
    };
    match answer {
        LiveAnswer::Running { width, height, next, pieces } => {
            binary(encode(width, height, next, 0, &pieces))
        }
        LiveAnswer::Done(f) => done(&f.image, f.error.as_ref().map(|e| e.per_pixel.as_slice())),
        LiveAnswer::Stored => match stored(&web, job).await {
            Some((image, error)) => done(&image, error.as_deref()),
            None => binary(encode(0, 0, 0, 2, &[])),
        },
        LiveAnswer::Ended => binary(encode(0, 0, 0, 2, &[])),
        LiveAnswer::NoJob => (StatusCode::NOT_FOUND, "no such job of yours").into_response(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::geometry::{Bounds2i, Point2i};

    #[test]
    fn tone_and_heat_maps_are_monotone_and_bounded() {
        assert_eq!(srgb8(0.0), 0);
        assert_eq!(srgb8(1.0), 255);
        assert_eq!(srgb8(7.0), 255);
        assert_eq!(srgb8(f32::NAN), 0);
        assert_eq!(srgb8(0.5), 188, "sRGB's curve");
        let lum = |c: [u8; 3]| c.iter().map(|&v| u32::from(v)).sum::<u32>();
        let mut last = 0;
        for k in -6..=1 {
            let l = lum(heat(10f32.powi(k)));
            assert!(l >= last, "heat not monotone at 1e{k}");
            last = l;
        }
        assert_eq!(heat(0.0), [0, 0, 0]);
        assert_eq!(heat(10.0), [255, 255, 255]);
    }

    #[test]
    fn the_binary_answer_has_the_documented_layout() {
        let b = Bounds2i::new(Point2i::new(2, 3), Point2i::new(4, 4));
        let image = RgbImage { width: 2, height: 1, pixels: vec![[1.0, 0.0, 0.0], [0.0; 3]] };
        let p = ImagePiece { bounds: b, image, error: Some(vec![1.0, 0.0]) };
        let bytes = encode(10, 5, 7, 0, &[p]);
        let u = |i: usize| u32::from_le_bytes(bytes[i * 4..i * 4 + 4].try_into().unwrap());
        assert_eq!([u(0), u(1), u(2), u(3), u(4)], [10, 5, 7, 0, 1]);
        assert_eq!([u(5), u(6), u(7), u(8), u(9)], [2, 3, 2, 1, 1]);
        assert_eq!(&bytes[40..48], &[255, 0, 0, 255, 0, 0, 0, 255]);
        assert_eq!(&bytes[48..52], &[255, 255, 255, 255]);
        assert_eq!(bytes.len(), 40 + 8 + 8);
    }
}
