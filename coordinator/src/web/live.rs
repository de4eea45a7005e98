//! `/api/jobs/ID/live?from=N`: what a job page draws. The page keeps a
//! cursor into the film's changes (see [`crate::live`]) and is sent the
//! pieces changed since it as the film's sums, unresolved, with the error
//! map's pieces beside them: the coordinator only copies, and the page
//! divides, tone-maps and colours (`dashboard.js`). All numbers
//! little-endian, every field 4 bytes:
//!
//! ```text
//! u32 width, u32 height, u32 next cursor, u32 state (0 running, 1 done, 2 ended without an image),
//! f32 scale, u32 piece count, then per piece:
//!   u32 x0, u32 y0, u32 w, u32 h, u32 has error map (0 or 1),
//!   running: w·h × (f32 Σw·r, Σw·g, Σw·b, Σw); done: w·h × (f32 r, g, b),
//!   then w·h × f32 relMSE if it has an error map
//! ```
//!
//! While running, a pixel shows max(Σw·c / Σw, 0) · scale (Σw·c · scale
//! where Σw is 0). A finished image is one piece of the written pixel
//! values, copied as the journal holds them.

use super::{may_touch, Caller, Web};
use crate::live::{shift, LiveCursor};
use crate::merge::Film;
use crate::server::events::{Event, LiveAnswer};
use crate::state::Command;
use axum::body::Body;
use axum::extract::{Path, Query, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use farm_common::geometry::{Bounds2i, Point2i};
use farm_common::ids::JobId;
use farm_common::image::RgbImage;
use farm_proto::v1;
use prost::Message;

#[derive(serde::Deserialize)]
pub(super) struct Since {
    #[serde(default)]
    from: usize,
}

/// The answer's state field.
const RUNNING: u32 = 0;
const DONE: u32 = 1;
const ENDED: u32 = 2;

fn put(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn header(width: u32, height: u32, next: usize, state: u32, scale: f32, pieces: usize) -> Vec<u8> {
    let mut out = Vec::new();
    for v in [width, height, next as u32, state, scale.to_bits(), pieces as u32] {
        put(&mut out, v);
    }
    out
}

/// Appends a piece's header; returns where its error-map flag is.
fn piece_header(out: &mut Vec<u8>, b: Bounds2i, has_error: bool) -> usize {
    for v in [b.min.x, b.min.y, b.width(), b.height()] {
        put(out, v as u32);
    }
    put(out, u32::from(has_error));
    out.len() - 4
}

/// A running job's answer: the pieces changed since cursor `from`, as
/// they stand, with the running estimate's error map (as last brought up
/// to date).
pub fn running(film: &Film, from: usize) -> Vec<u8> {
    let g = film.geometry();
    let b = g.cropped_pixel_bounds;
    let mut cursor = LiveCursor::at(from);
    let regions = cursor.take(film, usize::MAX);
    let (w, h) = (b.width() as u32, b.height() as u32);
    let mut out = header(w, h, cursor.position(), RUNNING, g.scale, regions.len());
    out.reserve(regions.iter().map(|r| 20 + r.area() * 20).sum());
    for r in regions {
        let flag = piece_header(&mut out, r, false);
        out.extend_from_slice(&film.region_sums(shift(r, b.min.x, b.min.y)));
        if film.write_error_map(r, &mut out) {
            out[flag] = 1;
        }
    }
    out
}

/// A finished image's answer: one piece of the whole image.
pub fn finished(image: &RgbImage, error: Option<&[f32]>) -> Vec<u8> {
    let (w, h) = (image.width as u32, image.height as u32);
    let mut out = header(w, h, 0, DONE, 1.0, 1);
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(w as i32, h as i32));
    let error = error.filter(|e| e.len() == image.pixels.len());
    piece_header(&mut out, b, error.is_some());
    let mut body: Vec<[u8; 4]> = Vec::with_capacity(image.pixels.len() * 4);
    body.extend(image.pixels.iter().flatten().map(|v| v.to_le_bytes()));
    body.extend(error.into_iter().flatten().map(|v| v.to_le_bytes()));
    out.extend_from_slice(body.as_flattened());
    out
}

/// A finished image's answer from the image events the journal stores,
/// their bytes copied as they are: the rows must follow on from each
/// other and fill the image, with an error map for all of them or none.
pub fn finished_from_events(events: &[Vec<u8>]) -> Option<Vec<u8>> {
    let chunks: Vec<v1::JobImage> = events
        .iter()
        .filter_map(|bytes| match v1::JobEvent::decode(bytes.as_slice()).ok()?.kind {
            Some(v1::job_event::Kind::Image(img)) => Some(img),
            _ => None,
        })
        .collect();
    let first = chunks.first()?;
    let (w, h) = (first.width as usize, first.height as usize);
    let with_error = !first.error_map.is_empty();
    let mut row = 0usize;
    for c in &chunks {
        let rows = c.rgb.len().checked_div(w * 12)?;
        let fits = (c.width as usize, c.height as usize) == (w, h)
            && c.first_row as usize == row
            && c.rgb.len() == rows * w * 12
            && c.error_map.len() == if with_error { rows * w * 4 } else { 0 };
        if !fits {
            return None;
        }
        row += rows;
    }
    if row != h {
        return None;
    }
    let mut out = header(w as u32, h as u32, 0, DONE, 1.0, 1);
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(w as i32, h as i32));
    piece_header(&mut out, b, with_error);
    out.reserve(w * h * if with_error { 16 } else { 12 });
    for c in &chunks {
        out.extend_from_slice(&c.rgb);
    }
    for c in &chunks {
        out.extend_from_slice(&c.error_map);
    }
    Some(out)
}

fn binary(bytes: Vec<u8>) -> Response {
    let mut r = Response::new(Body::from(bytes));
    r.headers_mut()
        .insert(header::CONTENT_TYPE, HeaderValue::from_static("application/octet-stream"));
    r.headers_mut().insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    r
}

/// A finished job's answer from the image the journal stores.
async fn stored(web: &Web, job: JobId) -> Option<Vec<u8>> {
    let journal = web.journal.as_ref()?;
    let (reply, rx) = tokio::sync::oneshot::channel();
    journal.send(Command::ReadImage { job: job.0, reply });
    finished_from_events(&rx.await.ok()?)
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
    let ended = || binary(header(0, 0, 0, ENDED, 1.0, 0));
    match answer {
        LiveAnswer::Running(bytes) => binary(bytes),
        LiveAnswer::Done(f) => {
            binary(finished(&f.image, f.error.as_ref().map(|e| e.per_pixel.as_slice())))
        }
        LiveAnswer::Stored => match stored(&web, job).await {
            Some(bytes) => binary(bytes),
            None => ended(),
        },
        LiveAnswer::Ended => ended(),
        LiveAnswer::NoJob => (StatusCode::NOT_FOUND, "no such job of yours").into_response(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::film::{FilmGeometry, FilmTile};
    use farm_common::geometry::Vec2;
    use farm_common::ids::TileId;

    fn words(bytes: &[u8]) -> Vec<u32> {
        bytes.chunks_exact(4).map(|c| u32::from_le_bytes(c.try_into().unwrap())).collect()
    }

    #[test]
    fn a_running_answer_has_the_documented_layout() {
        let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(40, 20));
        let g = FilmGeometry::new(b.max, b, Vec2::splat(0.5), 2.0, f32::INFINITY, "x".into(), 35.0);
        let mut film = Film::new(g.clone());
        let tb = g.tile_pixel_bounds(TileId(0));
        let mut t = FilmTile::new(tb);
        for p in t.pixel_bounds.iter() {
            t.add(p, farm_common::Spectrum::new(3.0, 0.0, 1.0), 0.5, false);
            t.add(p, farm_common::Spectrum::new(1.0, 0.0, 1.0), 0.5, true);
        }
        film.accept(TileId(0), t).unwrap();
        film.running_estimate();
        let u = words(&running(&film, 0));
        assert_eq!(&u[..6], &[40, 20, 1, RUNNING, 2.0f32.to_bits(), 1]);
        let (w, h) = (tb.width() as u32, tb.height() as u32);
        assert_eq!(&u[6..11], &[0, 0, w, h, 1], "tile 0's pixels, with an error map");
        let f = |i: usize| f32::from_bits(u[i]);
        assert_eq!([f(11), f(12), f(13), f(14)], [2.0, 0.0, 1.0, 1.0], "the first pixel's sums");
        assert_eq!(u.len(), 11 + tb.area() * 5);
        assert!(f(11 + tb.area() * 4) > 0.0, "an error estimate follows the sums");
        let again = words(&running(&film, 1));
        assert_eq!(&again[..6], &[40, 20, 1, RUNNING, 2.0f32.to_bits(), 0], "nothing new");
    }

    #[test]
    fn a_finished_answer_is_one_piece_of_pixel_values() {
        let image = RgbImage { width: 2, height: 1, pixels: vec![[1.0, 0.0, 0.5], [0.0; 3]] };
        let u = words(&finished(&image, Some(&[0.25, 0.0])));
        assert_eq!(&u[..11], &[2, 1, 0, DONE, 1f32.to_bits(), 1, 0, 0, 2, 1, 1]);
        let f: Vec<f32> = u[11..].iter().map(|&v| f32::from_bits(v)).collect();
        assert_eq!(f, [1.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.25, 0.0]);
    }

    #[test]
    fn a_stored_image_is_sent_as_the_journal_holds_it_if_it_fits() {
        let image = RgbImage {
            width: 3,
            height: 4,
            pixels: (0..12).map(|i| [i as f32, 0.5, 2.0]).collect(),
        };
        let error: Vec<f32> = (0..12).map(|i| i as f32 * 0.01).collect();
        let direct = finished(&image, Some(&error));
        // Two chunks of rows, as the journal stores them.
        let chunk = |rows: std::ops::Range<usize>, with_error: bool| {
            let px = &image.pixels[rows.start * 3..rows.end * 3];
            let e = &error[rows.start * 3..rows.end * 3];
            let img = v1::JobImage {
                width: 3,
                height: 4,
                first_row: rows.start as u32,
                rgb: px.iter().flatten().flat_map(|v| v.to_le_bytes()).collect(),
                error_map: if with_error {
                    e.iter().flat_map(|v| v.to_le_bytes()).collect()
                } else {
                    Vec::new()
                },
                ..Default::default()
            };
            v1::JobEvent { kind: Some(v1::job_event::Kind::Image(img)) }.encode_to_vec()
        };
        let events = [chunk(0..1, true), chunk(1..4, true)];
        assert_eq!(finished_from_events(&events).as_deref(), Some(direct.as_slice()));
        // Rows missing, out of order, or an error map for some rows only.
        assert!(finished_from_events(&events[..1]).is_none());
        assert!(finished_from_events(&[chunk(1..4, true), chunk(0..1, true)]).is_none());
        assert!(finished_from_events(&[chunk(0..1, true), chunk(1..4, false)]).is_none());
        assert!(finished_from_events(&[]).is_none());
    }
}
