//! A stand-in for tev: accepts one connection, decodes its IPC packets
//! (`CreateImage`, `UpdateImage`) and keeps the images they build, so a
//! test can compare what a display server would show with the image
//! written.

use std::collections::BTreeMap;
use std::io::Read;
use std::net::TcpListener;
use std::sync::{Arc, Mutex};

/// One image as tev would hold it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TevImage {
    /// Width and height.
    pub size: (usize, usize),
    /// Channel name → values, row-major.
    pub channels: BTreeMap<String, Vec<f32>>,
    /// Update packets received for it.
    pub updates: usize,
}

/// What the fake server has seen.
#[derive(Debug, Default)]
pub struct Seen {
    /// Images by title.
    pub images: BTreeMap<String, TevImage>,
    /// Packets it could not decode (a test wants none).
    pub errors: Vec<String>,
}

/// A fake tev on a free loopback port.
pub struct FakeTev {
    /// `HOST:PORT` to pass as `--display-server`.
    pub address: String,
    /// What it received, filled in as packets arrive.
    pub seen: Arc<Mutex<Seen>>,
    thread: std::thread::JoinHandle<()>,
}

impl FakeTev {
    /// Listens and serves one connection on a thread.
    pub fn start() -> FakeTev {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
        let address = listener.local_addr().unwrap().to_string();
        let seen = Arc::new(Mutex::new(Seen::default()));
        let s = seen.clone();
        let thread = std::thread::spawn(move || {
            let Ok((mut c, _)) = listener.accept() else { return };
            let mut bytes = Vec::new();
            c.read_to_end(&mut bytes).ok();
            decode(&bytes, &mut s.lock().unwrap());
        });
        FakeTev { address, seen, thread }
    }

    /// Waits for the connection to close and returns what was seen.
    pub fn finish(self) -> Seen {
        self.thread.join().expect("fake tev thread");
        Arc::try_unwrap(self.seen).expect("one owner").into_inner().unwrap()
    }
}

struct Cursor<'a>(&'a [u8]);

impl Cursor<'_> {
    fn take(&mut self, n: usize) -> Option<&[u8]> {
        (self.0.len() >= n).then(|| {
            let (a, b) = self.0.split_at(n);
            self.0 = b;
            a
        })
    }
    fn i32(&mut self) -> Option<i32> {
        Some(i32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn f32(&mut self) -> Option<f32> {
        Some(f32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn string(&mut self) -> Option<String> {
        let end = self.0.iter().position(|&c| c == 0)?;
        let s = String::from_utf8_lossy(&self.0[..end]).into_owned();
        self.0 = &self.0[end + 1..];
        Some(s)
    }
}

fn decode(mut bytes: &[u8], seen: &mut Seen) {
    while bytes.len() >= 4 {
        let len = u32::from_le_bytes(bytes[..4].try_into().unwrap()) as usize;
        if len < 5 || len > bytes.len() {
            seen.errors.push(format!("bad packet length {len} with {} bytes left", bytes.len()));
            return;
        }
        let mut c = Cursor(&bytes[4..len]);
        if packet(&mut c, seen).is_none() || !c.0.is_empty() {
            seen.errors.push(format!("malformed packet of type {}", bytes[4]));
        }
        bytes = &bytes[len..];
    }
    if !bytes.is_empty() {
        seen.errors.push(format!("{} trailing bytes", bytes.len()));
    }
}

fn packet(c: &mut Cursor, seen: &mut Seen) -> Option<()> {
    let kind = c.take(1)?[0];
    let _grab_focus = c.take(1)?;
    let title = c.string()?;
    match kind {
        4 => {
            let (w, h, n) = (c.i32()? as usize, c.i32()? as usize, c.i32()?);
            let mut img = TevImage { size: (w, h), ..Default::default() };
            for _ in 0..n {
                img.channels.insert(c.string()?, vec![0.0; w * h]);
            }
            seen.images.insert(title, img);
        }
        3 => {
            let channel = c.string()?;
            let (x, y, w, h) =
                (c.i32()? as usize, c.i32()? as usize, c.i32()? as usize, c.i32()? as usize);
            let img = seen.images.get_mut(&title)?;
            let width = img.size.0;
            if x + w > width || y + h > img.size.1 {
                return None;
            }
            let data = img.channels.get_mut(&channel)?;
            for j in 0..h {
                for i in 0..w {
                    data[(y + j) * width + x + i] = c.f32()?;
                }
            }
            img.updates += 1;
        }
        _ => return None,
    }
    Some(())
}
