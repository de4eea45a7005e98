//! The watchers: a job page's requests over a kept-alive HTTP/1.1
//! connection, and a display server standing in for tev.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A browser's connection: HTTP/1.1 kept alive between requests.
struct Browser {
    addr: String,
    conn: Option<BufReader<TcpStream>>,
}

impl Browser {
    /// `GET path`, the body (empty on any failure; the next call reconnects).
    fn get(&mut self, path: &str) -> Vec<u8> {
        let body = self.try_get(path);
        if body.is_none() {
            self.conn = None;
        }
        body.unwrap_or_default()
    }

    fn try_get(&mut self, path: &str) -> Option<Vec<u8>> {
        if self.conn.is_none() {
            self.conn = Some(BufReader::new(TcpStream::connect(&self.addr).ok()?));
        }
        let c = self.conn.as_mut()?;
        let req = format!("GET {path} HTTP/1.1\r\nHost: {}\r\n\r\n", self.addr);
        c.get_mut().write_all(req.as_bytes()).ok()?;
        let mut len = 0usize;
        loop {
            let mut line = String::new();
            if c.read_line(&mut line).ok()? == 0 {
                return None;
            }
            let line = line.trim_end();
            if line.is_empty() {
                break;
            }
            if let Some((k, v)) = line.split_once(':') {
                if k.eq_ignore_ascii_case("content-length") {
                    len = v.trim().parse().ok()?;
                }
            }
        }
        let mut body = vec![0u8; len];
        c.read_exact(&mut body).ok()?;
        Some(body)
    }
}

/// A job page open on the running job until `stop`: returns the requests made.
pub fn dashboard(addr: String, stop: Arc<AtomicBool>) -> std::thread::JoinHandle<u64> {
    std::thread::spawn(move || {
        let mut browser = Browser { addr, conn: None };
        let mut requests = 0u64;
        let job = loop {
            if stop.load(Ordering::Relaxed) {
                return requests;
            }
            requests += 1;
            let status: serde_json::Value =
                serde_json::from_slice(&browser.get("/api/status")).unwrap_or_default();
            let running = status["jobs"].as_array().and_then(|jobs| {
                jobs.iter().find(|j| j["state"] == "running").and_then(|j| j["id"].as_u64())
            });
            match running {
                Some(id) => break id,
                None => std::thread::sleep(Duration::from_millis(50)),
            }
        };
        browser.get(&format!("/jobs/{job}"));
        let (mut cursor, mut merged, mut last_facts) = (0u32, 0u32, Instant::now());
        let (mut last_look, mut merged_at_look, mut more) = (Instant::now(), 0u32, false);
        loop {
            // Once the render has ended, one more look fetches the
            // finished image, as the page does.
            let last = stop.load(Ordering::Relaxed);
            // The job's facts come with a look every five seconds.
            let facts = last_facts.elapsed() >= Duration::from_secs(5);
            if facts {
                last_facts = Instant::now();
            }
            let f = if facts { "&facts=1" } else { "" };
            let body =
                browser.get(&format!("/api/jobs/{job}/live?from={cursor}&merged={merged}{f}"));
            requests += 1;
            if body.len() >= 28 {
                let word =
                    |i: usize| u32::from_le_bytes([body[i], body[i + 1], body[i + 2], body[i + 3]]);
                (cursor, merged) = (word(8), word(12));
                more = word(16) == 3;
                if word(16) != 0 && !more {
                    // Done (or ended): the page stops looking, as the script does.
                    break;
                }
            }
            if last {
                break;
            }
            if more {
                continue;
            }
            // The script's pace (`nextLook`): a look per 64 tiles merged,
            // between two and five seconds apart.
            let rate = f64::from(merged.saturating_sub(merged_at_look))
                / last_look.elapsed().as_secs_f64().max(1e-3);
            (last_look, merged_at_look) = (Instant::now(), merged);
            let wait = if rate > 0.0 { (64.0 / rate).clamp(2.0, 5.0) } else { 5.0 };
            let t = Instant::now();
            while t.elapsed().as_secs_f64() < wait && !stop.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        requests
    })
}

/// A display server that takes everything and counts the bytes.
pub fn tev_sink() -> (String, Arc<AtomicU64>) {
    let l = TcpListener::bind("127.0.0.1:0").expect("bind");
    let addr = l.local_addr().expect("addr").to_string();
    let bytes = Arc::new(AtomicU64::new(0));
    let count = bytes.clone();
    std::thread::spawn(move || {
        for s in l.incoming().flatten() {
            let count = count.clone();
            std::thread::spawn(move || {
                let mut s = s;
                let mut buf = vec![0u8; 1 << 16];
                while let Ok(n) = s.read(&mut buf) {
                    if n == 0 {
                        break;
                    }
                    count.fetch_add(n as u64, Ordering::Relaxed);
                }
            });
        }
    });
    (addr, bytes)
}
