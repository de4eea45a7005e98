//! `/api/jobs/ID/live?from=N&merged=M`: what a job page draws. The page
//! keeps a cursor into the film's changes (see [`crate::live`]) and the
//! count of tiles merged when it last looked, and is sent what is new
//! since: the pixels whose sums became complete, as the film's sums,
//! unresolved, and the error map over the pixels of the tiles merged since
//! (the running estimate's, [`FilmGeometry::tile_final_pixels`]). Each
//! pixel and its error are sent once while the job runs (the finished
//! error map once more at its end). The coordinator only copies; the
//! page divides, tone-maps and colours (`dashboard.js`). All numbers
//! little-endian, every field 4 bytes:
//!
//! ```text
//! u32 width, u32 height, u32 next cursor, u32 tiles merged, u32 state (0 running,
//! 1 done, 2 ended without an image, 3 running with more ready: look again now), f32 scale, u32 piece count, then per piece:
//!   u32 x0, u32 y0, u32 w, u32 h, u32 kind (0 pixels, 1 pixels and error map, 2 error map),
//!   pixels: running: w·h × (f32 Σw·r, Σw·g, Σw·b, Σw); done: w·h × (f32 r, g, b),
//!   then error map: w·h × f32 relMSE
//! then, if asked for with `facts=1`: u32 n, n bytes of the job's facts
//!   as HTML (the `/fragments/job/ID` fragment; none if the job has gone)
//! ```
//!
//! While running, a pixel shows max(Σw·c / Σw, 0) · scale (Σw·c · scale
//! where Σw is 0). Once the job is done, a page that was looking as it
//! ended is sent the written pixel values of the tiles it had not seen
//! merged, and the whole finished error map (which differs from the
//! running one); any other page, the whole image as one piece, copied as
//! the journal holds it.

use super::{may_touch, Caller, Web};
use crate::live::{shift, strips};
use crate::merge::Film;
use crate::server::events::{Event, LiveAnswer};
use crate::state::Command;
use axum::body::Body;
use axum::extract::{Path, Query, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use farm_common::film::FilmGeometry;
use farm_common::geometry::{Bounds2i, Point2i};
use farm_common::ids::{JobId, TileId};
use farm_common::image::RgbImage;
use farm_common::le::extend_f32s;
use farm_proto::v1;
use prost::Message;

#[derive(serde::Deserialize)]
pub(super) struct Since {
    #[serde(default)]
    from: usize,
    #[serde(default)]
    merged: u32,
    /// `facts=1`: the job's facts too.
    #[serde(default)]
    facts: u8,
}

/// The answer's state field.
const RUNNING: u32 = 0;
const DONE: u32 = 1;
const ENDED: u32 = 2;
/// Running, and this answer is a part: more is ready now.
const MORE: u32 = 3;

/// How many of `sizes`, in order, fit in `max` (at least one, if any).
fn upto(sizes: impl Iterator<Item = usize>, max: usize) -> usize {
    let mut total = 0usize;
    let mut n = 0;
    for s in sizes {
        total = total.saturating_add(s);
        if n > 0 && total > max {
            break;
        }
        n += 1;
    }
    n
}

/// A piece's kind: what follows its header.
const PIXELS: u32 = 0;
const PIXELS_AND_ERROR: u32 = 1;
const ERROR: u32 = 2;

fn put(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

/// The answer's header.
struct Header {
    width: u32,
    height: u32,
    next: usize,
    merged: u32,
    state: u32,
    scale: f32,
    pieces: usize,
}

impl Header {
    fn done(width: u32, height: u32, merged: u32, pieces: usize) -> Header {
        Header { width, height, next: 0, merged, state: DONE, scale: 1.0, pieces }
    }

    fn bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        let Header { width, height, next, merged, state, scale, pieces } = *self;
        for v in [width, height, next as u32, merged, state, scale.to_bits(), pieces as u32] {
            put(&mut out, v);
        }
        out
    }
}

fn piece_header(out: &mut Vec<u8>, b: Bounds2i, kind: u32) {
    for v in [b.min.x, b.min.y, b.width(), b.height()] {
        put(out, v as u32);
    }
    put(out, kind);
}

/// Tiles' final pixels (film coordinates, within the crop `b`) in image
/// coordinates, as strips.
fn final_pixels(b: Bounds2i, fin: impl Iterator<Item = Bounds2i>) -> Vec<Bounds2i> {
    strips(fin.map(|r| shift(r, -b.min.x, -b.min.y)))
}

/// Pixels in one running answer, at most (16 bytes each: 4 MiB): a page
/// that looks first at a large film's end, or a client that asks again
/// and again from the start, is sent the film in parts of this size
/// (state [`MORE`]), never a whole 4K film's sums in one go.
pub const ANSWER_PIXELS: usize = 1 << 18;

/// The answer for a running job with nothing new since the page's cursor
/// (`from`, `merged`): its film is lent out a moment (a pass's estimate,
/// the job's end).
pub fn unchanged(g: &FilmGeometry, from: usize, merged: u32) -> Vec<u8> {
    let b = g.cropped_pixel_bounds;
    let (width, height) = (b.width() as u32, b.height() as u32);
    let state = RUNNING;
    Header { width, height, next: from, merged, state, scale: g.scale, pieces: 0 }.bytes()
}

/// A running job's answer: the pixels completed since cursor `from`, and
/// the running estimate's error map (as last brought up to date) over the
/// tiles merged since the page saw `merged`; each up to `max_pixels`, the
/// rest left for the next look (state [`MORE`]).
pub fn running(film: &Film, from: usize, merged: u32, max_pixels: usize) -> Vec<u8> {
    let g = film.geometry();
    let b = g.cropped_pixel_bounds;
    // The oldest changes first, as many as fit (at least one).
    let (changes, end) = film.changes_since(from);
    let taken = upto(changes.iter().map(|r| r.area()), max_pixels);
    let regions = strips(changes[..taken].iter().map(|r| shift(*r, -b.min.x, -b.min.y)));
    let now = film.merged();
    let merged = merged.min(now);
    let (errors, now) = if film.has_running_estimate() {
        let tiles = merged..now;
        let n = upto(tiles.clone().map(|t| film.final_pixels(TileId(t)).area()), max_pixels);
        let last = merged + n as u32;
        (final_pixels(b, (merged..last).map(|t| film.final_pixels(TileId(t)))), last)
    } else {
        (Vec::new(), now)
    };
    let more = taken < changes.len() || now < film.merged();
    let next = end - changes.len() + taken;
    let state = if more { MORE } else { RUNNING };
    let (width, height) = (b.width() as u32, b.height() as u32);
    let pieces = regions.len() + errors.len();
    let scale = g.scale;
    let mut out = Header { width, height, next, merged: now, state, scale, pieces }.bytes();
    let area = |v: &[Bounds2i]| v.iter().map(|r| 20 + r.area()).sum::<usize>();
    out.reserve(area(&regions) * 16 + area(&errors) * 4);
    for r in regions {
        piece_header(&mut out, r, PIXELS);
        film.write_region_sums(shift(r, b.min.x, b.min.y), &mut out);
    }
    for r in errors {
        piece_header(&mut out, r, ERROR);
        film.write_error_map(r, &mut out);
    }
    out
}

/// A finished image's answer for a page that had seen `merged` tiles of
/// the film laid out as `g` merged: the written values of the tiles'
/// final pixels it had not, then the whole error map as one piece (the
/// finished estimate counts each pixel against its neighbourhood's level,
/// so it differs from the running one the page was sent).
pub fn finished_since(
    image: &RgbImage,
    error: Option<&[f32]>,
    g: &FilmGeometry,
    merged: u32,
) -> Vec<u8> {
    let (w, h) = (image.width, image.height);
    let error = error.filter(|e| e.len() == image.pixels.len());
    let b = g.cropped_pixel_bounds;
    let fin = (merged..g.tile_count()).map(|t| g.tile_final_pixels(TileId(t)).intersect(&b));
    let regions = final_pixels(b, fin);
    let cropped = g.cropped_pixel_bounds;
    if merged == 0 || (cropped.width() as usize, cropped.height() as usize) != (w, h) {
        return finished(image, error);
    }
    let pieces = regions.len() + usize::from(error.is_some());
    let mut out = Header::done(w as u32, h as u32, g.tile_count(), pieces).bytes();
    for r in regions {
        piece_header(&mut out, r, PIXELS);
        let cols = r.min.x as usize..r.max.x as usize;
        for y in r.min.y as usize..r.max.y as usize {
            extend_f32s(&mut out, image.pixels[y * w..][cols.clone()].as_flattened());
        }
    }
    if let Some(e) = error {
        let all = Bounds2i::new(Point2i::new(0, 0), Point2i::new(w as i32, h as i32));
        piece_header(&mut out, all, ERROR);
        extend_f32s(&mut out, e);
    }
    out
}

/// A finished image's answer: one piece of the whole image.
pub fn finished(image: &RgbImage, error: Option<&[f32]>) -> Vec<u8> {
    let (w, h) = (image.width as u32, image.height as u32);
    let mut out = Header::done(w, h, 0, 1).bytes();
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(w as i32, h as i32));
    let error = error.filter(|e| e.len() == image.pixels.len());
    piece_header(&mut out, b, if error.is_some() { PIXELS_AND_ERROR } else { PIXELS });
    out.reserve(image.pixels.len() * 16);
    extend_f32s(&mut out, image.pixels.as_flattened());
    extend_f32s(&mut out, error.unwrap_or_default());
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
    let mut out = Header::done(w as u32, h as u32, 0, 1).bytes();
    let b = Bounds2i::new(Point2i::new(0, 0), Point2i::new(w as i32, h as i32));
    piece_header(&mut out, b, if with_error { PIXELS_AND_ERROR } else { PIXELS });
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
    let (from, merged, facts) = (q.from, q.merged, q.facts == 1);
    let Some((answer, view)) =
        super::ask(&web, |reply| Event::Live { job, from, merged, facts, reply }).await
    else {
        return super::shutting_down();
    };
    let ended = || {
        Header { width: 0, height: 0, next: 0, merged: 0, state: ENDED, scale: 1.0, pieces: 0 }
            .bytes()
    };
    let mut bytes = match answer {
        LiveAnswer::Running(bytes) => bytes,
        LiveAnswer::Done(f, geometry) => {
            let error = f.error.as_ref().map(|e| e.per_pixel.as_slice());
            match geometry {
                Some(g) => finished_since(&f.image, error, &g, merged),
                None => finished(&f.image, error),
            }
        }
        LiveAnswer::Stored => stored(&web, job).await.unwrap_or_else(ended),
        LiveAnswer::Ended => ended(),
        LiveAnswer::NoJob => {
            return (StatusCode::NOT_FOUND, "no such job of yours").into_response()
        }
    };
    if facts {
        append_facts(&mut bytes, view.map(|v| super::page::job_facts(&v)).as_deref());
    }
    binary(bytes)
}

/// The facts' trailer: their HTML's length in bytes, then the HTML (an
/// empty trailer if the job has gone).
fn append_facts(out: &mut Vec<u8>, html: Option<&str>) {
    let html = html.unwrap_or_default();
    put(out, html.len() as u32);
    out.extend_from_slice(html.as_bytes());
}

#[cfg(test)]
#[path = "live_tests.rs"]
mod tests;
