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
use farm_common::image::{ImagePiece, RgbImage};
use farm_common::le::extend_f32s;
use farm_coordinator::live::{pieces, whole_pieces};
use std::io::Write;
use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

/// `CreateImage`.
pub const CREATE_IMAGE: u8 = 4;
/// `UpdateImage`.
pub const UPDATE_IMAGE: u8 = 3;
/// Least time between two updates of a live image (pbrt-v4's 250 ms).
pub const INTERVAL: Duration = Duration::from_millis(250);

/// Packets are written once this many bytes of them are ready (or all
/// are): few writes, each waking the display server once.
const SEND_AT: usize = 1 << 20;

/// One packet, with its length filled in.
fn packet(kind: u8, fill: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let mut b = Vec::new();
    packet_into(&mut b, kind, fill);
    b
}

/// One packet appended to `out`, with its length filled in.
fn packet_into(out: &mut Vec<u8>, kind: u8, fill: impl FnOnce(&mut Vec<u8>)) {
    let start = out.len();
    out.extend_from_slice(&[0; 4]);
    out.push(kind);
    fill(out);
    let len = (out.len() - start) as u32;
    out[start..start + 4].copy_from_slice(&len.to_le_bytes());
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
    let mut b = Vec::new();
    update_image_into(&mut b, title, channel, rect, values);
    b
}

/// [`update_image`], appended to `out`.
fn update_image_into(
    out: &mut Vec<u8>,
    title: &str,
    channel: &str,
    rect: Bounds2i,
    values: &[f32],
) {
    packet_into(out, UPDATE_IMAGE, |b| {
        b.push(0); // keep focus where it is
        string(b, title);
        string(b, channel);
        for v in [rect.min.x, rect.min.y, rect.width(), rect.height()] {
            b.extend(v.to_le_bytes());
        }
        extend_f32s(b, values);
    })
}

/// A connection to a display server, showing one image.
#[derive(Debug)]
pub struct Display {
    stream: Option<TcpStream>,
    address: String,
    title: String,
    width: i32,
    height: i32,
    last: Option<Instant>,
}

impl Display {
    /// Connects to `address` (`HOST:PORT`) and opens a `width`×`height`
    /// image. A server that cannot be reached is reported in the error; the
    /// caller renders on without it.
    pub fn connect(address: &str, title: &str, width: i32, height: i32) -> Result<Display, String> {
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
        let mut d = Display {
            stream: Some(stream),
            address: address.to_string(),
            title: format!("{title} ({})", std::process::id()),
            width,
            height,
            last: None,
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

    /// Whether an update is due: [`INTERVAL`] has passed since the last
    /// (and the server is still there).
    pub fn due(&self) -> bool {
        self.stream.is_some() && self.last.is_none_or(|t| t.elapsed() >= INTERVAL)
    }

    /// Sends pieces of the image (image coordinates), one packet per
    /// channel each, in writes of about [`SEND_AT`] bytes; pieces that do
    /// not fit the image are skipped.
    pub fn pieces(&mut self, pieces: &[ImagePiece]) {
        self.last = Some(Instant::now());
        let full = Bounds2i::new(Point2i::new(0, 0), Point2i::new(self.width, self.height));
        let mut bytes = Vec::new();
        let mut values = Vec::new();
        for p in pieces {
            if p.bounds.intersect(&full) != p.bounds || p.image.pixels.len() != p.bounds.area() {
                continue;
            }
            for (c, name) in ["R", "G", "B"].iter().enumerate() {
                values.clear();
                values.extend(p.image.pixels.iter().map(|v| v[c]));
                update_image_into(&mut bytes, &self.title, name, p.bounds, &values);
            }
            if bytes.len() >= SEND_AT {
                self.send(&bytes);
                bytes.clear();
            }
        }
        if !bytes.is_empty() {
            self.send(&bytes);
        }
    }

    /// Sends the finished image whole, so the display ends on the written
    /// bits, and the per-pixel error estimate as a second image.
    pub fn finish(&mut self, image: &RgbImage, error: Option<&[f32]>) {
        let (w, h) = (image.width as i32, image.height as i32);
        self.pieces(&whole_pieces(image, None));
        if let Some(e) = error {
            let title = self.title.rsplit_once(" (").map_or(self.title.clone(), |t| t.0.into());
            self.show(&format!("{title} relMSE"), w, h, &[("relMSE", e.to_vec())]);
        }
    }

    /// Sends a whole image under its own name (a second image, such as the
    /// error map), with one channel per entry of `channels`.
    pub fn show(&mut self, title: &str, width: i32, height: i32, channels: &[(&str, Vec<f32>)]) {
        let title = format!("{title} ({})", std::process::id());
        let names: Vec<&str> = channels.iter().map(|(n, _)| *n).collect();
        self.send(&create_image(&title, width, height, &names));
        let full = Bounds2i::new(Point2i::new(0, 0), Point2i::new(width, height));
        for (_, p) in pieces(width, height, full) {
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

/// A display fed from a coordinator's previews (`farm submit
/// --coordinator`, `farm watch`): it connects when the first preview says
/// how large the image is, and never fails the render.
#[derive(Debug)]
pub struct LiveDisplay {
    address: String,
    title: String,
    display: Option<Display>,
    /// Set once connecting failed (reported once; nothing more is tried).
    gave_up: bool,
    /// Whether to print why the display is not shown.
    quiet: bool,
}

impl LiveDisplay {
    /// A display server at `address` for an image named `title`.
    pub fn new(address: &str, title: &str, quiet: bool) -> Self {
        LiveDisplay {
            address: address.into(),
            title: title.into(),
            display: None,
            gave_up: false,
            quiet,
        }
    }

    fn open(&mut self, width: i32, height: i32) -> Option<&mut Display> {
        if self.display.is_none() && !self.gave_up {
            match Display::connect(&self.address, &self.title, width, height) {
                Ok(d) => self.display = Some(d),
                Err(e) => {
                    self.gave_up = true;
                    if !self.quiet {
                        eprintln!("warning: {e}; not streaming the image");
                    }
                }
            }
        }
        self.display.as_mut().filter(|d| d.width == width && d.height == height)
    }

    /// Pieces of a `width`×`height` image as it renders.
    pub fn pieces(&mut self, width: u32, height: u32, pieces: &[ImagePiece]) {
        if let Some(d) = self.open(width as i32, height as i32) {
            d.pieces(pieces);
        }
    }

    /// The finished image and its error map.
    pub fn finish(&mut self, image: &RgbImage, error: Option<&[f32]>) {
        if let Some(d) = self.open(image.width as i32, image.height as i32) {
            d.finish(image, error);
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
}
