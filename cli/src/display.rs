//! Streaming the image to a display server as it renders, as pbrt-v4's
//! `--display-server` does: tev's IPC protocol over TCP (tev listens on
//! port 14158). One `CreateImage` packet opens the image with channels R,
//! G and B; `UpdateImage` packets then send one channel of one rectangle
//! each, in pieces of at most 128×128 pixels, for the regions that changed.
//!
//! Every packet is a little-endian `u32` length (the whole packet's,
//! itself included), a type byte, then its fields: strings end in a NUL,
//! integers are `i32`, pixel values `f32`, row-major.
//!
//! A display server that is not there, or goes away, never fails the
//! render: sending stops with one message, and the image is still written.

use farm_common::geometry::{Bounds2i, Point2i};
use farm_common::image::RgbImage;
use std::io::Write;
use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

/// `CreateImage`.
pub const CREATE_IMAGE: u8 = 4;
/// `UpdateImage`.
pub const UPDATE_IMAGE: u8 = 3;
/// Largest rectangle one update carries (pbrt-v4's).
pub const PIECE: i32 = 128;
/// Least time between two updates of a live image (pbrt-v4's 250 ms).
pub const INTERVAL: Duration = Duration::from_millis(250);

/// One packet, with its length filled in.
fn packet(kind: u8, fill: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let mut b = vec![0u8; 4];
    b.push(kind);
    fill(&mut b);
    let len = b.len() as u32;
    b[..4].copy_from_slice(&len.to_le_bytes());
    b
}

fn string(b: &mut Vec<u8>, s: &str) {
    // A NUL ends the string on the wire; names with one are cut there.
    b.extend(s.bytes().take_while(|&c| c != 0));
    b.push(0);
}

/// The `CreateImage` packet for a `width`×`height` image with `channels`.
pub fn create_image(title: &str, width: i32, height: i32, channels: &[&str]) -> Vec<u8> {
    packet(CREATE_IMAGE, |b| {
        b.push(1); // grab focus
        string(b, title);
        for v in [width, height, channels.len() as i32] {
            b.extend(v.to_le_bytes());
        }
        for c in channels {
            string(b, c);
        }
    })
}

/// The `UpdateImage` packet for channel `channel` over `rect`; `values`
/// holds its pixels row-major.
pub fn update_image(title: &str, channel: &str, rect: Bounds2i, values: &[f32]) -> Vec<u8> {
    packet(UPDATE_IMAGE, |b| {
        b.push(0); // keep focus where it is
        string(b, title);
        string(b, channel);
        for v in [rect.min.x, rect.min.y, rect.width(), rect.height()] {
            b.extend(v.to_le_bytes());
        }
        for v in values {
            b.extend(v.to_le_bytes());
        }
    })
}

/// The 128×128 pieces of the image, numbered row by row, that meet `r`.
fn pieces(width: i32, height: i32, r: Bounds2i) -> impl Iterator<Item = Bounds2i> {
    let r = r.intersect(&Bounds2i::new(Point2i::new(0, 0), Point2i::new(width, height)));
    let (x0, y0) = (r.min.x / PIECE, r.min.y / PIECE);
    let (x1, y1) = if r.is_empty() {
        (x0, y0)
    } else {
        ((r.max.x + PIECE - 1) / PIECE, (r.max.y + PIECE - 1) / PIECE)
    };
    (y0..y1).flat_map(move |py| {
        (x0..x1).map(move |px| {
            let min = Point2i::new(px * PIECE, py * PIECE);
            let max = Point2i::new((min.x + PIECE).min(width), (min.y + PIECE).min(height));
            Bounds2i::new(min, max)
        })
    })
}

/// `r` moved by (dx, dy).
fn shift(r: Bounds2i, dx: i32, dy: i32) -> Bounds2i {
    Bounds2i::new(
        Point2i::new(r.min.x + dx, r.min.y + dy),
        Point2i::new(r.max.x + dx, r.max.y + dy),
    )
}

/// A connection to a display server, showing one image.
#[derive(Debug)]
pub struct Display {
    stream: Option<TcpStream>,
    address: String,
    title: String,
    width: i32,
    height: i32,
    /// The image's origin on the film (its crop window's corner).
    origin: Point2i,
    last: Option<Instant>,
    /// 128×128 pieces changed since the last send (by piece index).
    dirty: Vec<bool>,
}

impl Display {
    /// Connects to `address` (`HOST:PORT`) and opens an image of the film's
    /// cropped pixel bounds `film`. A server that cannot be reached is
    /// reported in the error; the caller renders on without it.
    pub fn connect(address: &str, title: &str, film: Bounds2i) -> Result<Display, String> {
        let addrs = address
            .to_socket_addrs()
            .map_err(|e| format!("display server {address}: {e} (expected HOST:PORT)"))?;
        let mut last = None;
        let stream = addrs
            .into_iter()
            .find_map(|a| match TcpStream::connect_timeout(&a, Duration::from_secs(3)) {
                Ok(s) => Some(s),
                Err(e) => {
                    last = Some(e);
                    None
                }
            })
            .ok_or_else(|| {
                format!(
                    "display server {address}: {}",
                    last.map_or("no address".into(), |e| e.to_string())
                )
            })?;
        stream.set_write_timeout(Some(Duration::from_secs(3))).ok();
        stream.set_nodelay(true).ok();
        let (width, height) = (film.width(), film.height());
        let n =
            pieces(width, height, Bounds2i::new(Point2i::new(0, 0), Point2i::new(width, height)))
                .count();
        let mut d = Display {
            stream: Some(stream),
            address: address.to_string(),
            title: format!("{title} ({})", std::process::id()),
            width,
            height,
            origin: film.min,
            last: None,
            dirty: vec![false; n],
        };
        d.send(&create_image(&d.title, width, height, &["R", "G", "B"]));
        Ok(d)
    }

    /// The image's name in the display server.
    pub fn title(&self) -> &str {
        &self.title
    }

    fn send(&mut self, bytes: &[u8]) {
        let Some(s) = self.stream.as_mut() else { return };
        if let Err(e) = s.write_all(bytes) {
            tracing::warn!(address = %self.address, error = %e, "display server stopped taking updates");
            self.stream = None;
        }
    }

    /// Notes that film region `r` (film pixel coordinates) has changed.
    pub fn changed(&mut self, r: Bounds2i) {
        let local = shift(r, -self.origin.x, -self.origin.y);
        let cols = (self.width + PIECE - 1) / PIECE;
        for p in pieces(self.width, self.height, local) {
            let i = (p.min.y / PIECE * cols + p.min.x / PIECE) as usize;
            self.dirty[i] = true;
        }
    }

    /// Whether an update is due: something changed and [`INTERVAL`] has
    /// passed since the last.
    pub fn due(&self) -> bool {
        self.stream.is_some()
            && self.dirty.iter().any(|&d| d)
            && self.last.is_none_or(|t| t.elapsed() >= INTERVAL)
    }

    /// Sends every changed piece; `pixels(film_region)` gives the film's
    /// values over a region of film coordinates.
    pub fn flush(&mut self, mut pixels: impl FnMut(Bounds2i) -> RgbImage) {
        self.last = Some(Instant::now());
        let full = Bounds2i::new(Point2i::new(0, 0), Point2i::new(self.width, self.height));
        let all: Vec<Bounds2i> = pieces(self.width, self.height, full).collect();
        for (i, p) in all.into_iter().enumerate() {
            if !std::mem::take(&mut self.dirty[i]) {
                continue;
            }
            let img = pixels(shift(p, self.origin.x, self.origin.y));
            if img.pixels.len() != p.area() {
                continue;
            }
            for (c, name) in ["R", "G", "B"].iter().enumerate() {
                let values: Vec<f32> = img.pixels.iter().map(|v| v[c]).collect();
                let bytes = update_image(&self.title, name, p, &values);
                self.send(&bytes);
            }
        }
    }

    /// Sends a whole image under its own name (a second image, such as the
    /// error map), with one channel per entry of `channels`.
    pub fn show(&mut self, title: &str, width: i32, height: i32, channels: &[(&str, Vec<f32>)]) {
        let title = format!("{title} ({})", std::process::id());
        let names: Vec<&str> = channels.iter().map(|(n, _)| *n).collect();
        self.send(&create_image(&title, width, height, &names));
        let full = Bounds2i::new(Point2i::new(0, 0), Point2i::new(width, height));
        for p in pieces(width, height, full) {
            for (name, data) in channels {
                let values: Vec<f32> = p
                    .iter()
                    .map(|q| data.get((q.y * width + q.x) as usize).copied().unwrap_or(0.0))
                    .collect();
                let bytes = update_image(&title, name, p, &values);
                self.send(&bytes);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packets_carry_their_length_and_fields() {
        let p = create_image("t", 3, 2, &["R", "G", "B"]);
        assert_eq!(u32::from_le_bytes(p[..4].try_into().unwrap()) as usize, p.len());
        assert_eq!(&p[4..8], &[CREATE_IMAGE, 1, b't', 0]);
        assert_eq!(i32::from_le_bytes(p[8..12].try_into().unwrap()), 3);
        assert_eq!(&p[20..], b"R\0G\0B\0");
        let r = Bounds2i::new(Point2i::new(1, 2), Point2i::new(3, 3));
        let u = update_image("t", "G", r, &[0.5, 2.0]);
        assert_eq!(u.len(), 4 + 1 + 1 + 2 + 2 + 16 + 8);
        assert_eq!(&u[4..10], &[UPDATE_IMAGE, 0, b't', 0, b'G', 0]);
        assert_eq!(f32::from_le_bytes(u[u.len() - 4..].try_into().unwrap()), 2.0);
    }

    #[test]
    fn pieces_cover_a_region_once() {
        let r = Bounds2i::new(Point2i::new(100, 0), Point2i::new(300, 10));
        let p: Vec<Bounds2i> = pieces(300, 200, r).collect();
        assert_eq!(p.len(), 3);
        assert_eq!(p[2], Bounds2i::new(Point2i::new(256, 0), Point2i::new(300, 128)));
        assert_eq!(
            pieces(300, 200, Bounds2i::new(Point2i::new(400, 0), Point2i::new(500, 5))).count(),
            0
        );
    }
}
