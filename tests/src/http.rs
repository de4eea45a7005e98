//! A plain HTTP/1.1 client for the tests of the coordinator's web side and
//! the metrics endpoints (no TLS: the tests that use it run insecure
//! coordinators on loopback).

use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::Duration;

/// An answer: status, headers (lower-case names) and body.
#[derive(Debug)]
pub struct Answer {
    /// The status code.
    pub status: u16,
    /// Headers, names lower-case.
    pub headers: BTreeMap<String, String>,
    /// The body, de-chunked.
    pub body: Vec<u8>,
}

/// Sends `method path` to `address` (`HOST:PORT`) with `headers` and `body`.
pub fn request(
    address: &str,
    method: &str,
    path: &str,
    headers: &[(&str, &str)],
    body: &[u8],
) -> std::io::Result<Answer> {
    let mut s = TcpStream::connect(address)?;
    s.set_read_timeout(Some(Duration::from_secs(30)))?;
    let mut req = format!(
        "{method} {path} HTTP/1.1\r\nHost: {address}\r\nConnection: close\r\nContent-Length: {}\r\n",
        body.len()
    );
    for (k, v) in headers {
        req.push_str(&format!("{k}: {v}\r\n"));
    }
    req.push_str("\r\n");
    s.write_all(req.as_bytes())?;
    s.write_all(body)?;
    let mut raw = Vec::new();
    s.read_to_end(&mut raw)?;
    let bad = |m: &str| std::io::Error::new(std::io::ErrorKind::InvalidData, m.to_string());
    let end = raw.windows(4).position(|w| w == b"\r\n\r\n").ok_or_else(|| bad("no header end"))?;
    let head = String::from_utf8_lossy(&raw[..end]).into_owned();
    let mut lines = head.split("\r\n");
    let status = lines
        .next()
        .and_then(|l| l.split(' ').nth(1))
        .and_then(|c| c.parse().ok())
        .ok_or_else(|| bad("no status"))?;
    let headers: BTreeMap<String, String> = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(k, v)| (k.trim().to_ascii_lowercase(), v.trim().to_string()))
        .collect();
    let mut rest = &raw[end + 4..];
    let body = if headers.get("transfer-encoding").is_some_and(|t| t.contains("chunked")) {
        let mut out = Vec::new();
        loop {
            let nl = rest.windows(2).position(|w| w == b"\r\n").ok_or_else(|| bad("chunk"))?;
            let size = usize::from_str_radix(String::from_utf8_lossy(&rest[..nl]).trim(), 16)
                .map_err(|_| bad("chunk size"))?;
            rest = &rest[nl + 2..];
            if size == 0 {
                break;
            }
            out.extend_from_slice(rest.get(..size).ok_or_else(|| bad("short chunk"))?);
            rest = &rest[(size + 2).min(rest.len())..];
        }
        out
    } else {
        rest.to_vec()
    };
    Ok(Answer { status, headers, body })
}

/// `GET path` with no headers; panics on a transport error.
pub fn get(address: &str, path: &str) -> Answer {
    request(address, "GET", path, &[], b"").expect("HTTP request")
}

/// The samples `GET /metrics` at `address` answers (blocking), and the
/// text they were parsed from.
pub fn scrape(address: &str) -> Result<(Vec<Sample>, String), String> {
    let answer = request(address, "GET", "/metrics", &[], b"").map_err(|e| e.to_string())?;
    if answer.status != 200 {
        return Err(format!("GET /metrics: HTTP {}", answer.status));
    }
    let text = String::from_utf8(answer.body).map_err(|e| e.to_string())?;
    let samples = parse_prometheus(&text).map_err(|e| format!("{e}\n{text}"))?;
    Ok((samples, text))
}

/// One sample of the Prometheus text format.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// The metric's name.
    pub name: String,
    /// Its labels.
    pub labels: BTreeMap<String, String>,
    /// Its value.
    pub value: f64,
}

/// Parses the Prometheus text exposition format strictly: every sample's
/// family must have a `# TYPE` and a `# HELP` line before it, every line
/// must parse, and names follow Prometheus' rules.
pub fn parse_prometheus(text: &str) -> Result<Vec<Sample>, String> {
    let mut typed = BTreeMap::new();
    let mut helped = std::collections::BTreeSet::new();
    let mut out = Vec::new();
    let valid = |n: &str| {
        !n.is_empty()
            && n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == ':')
            && !n.starts_with(|c: char| c.is_ascii_digit())
    };
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        if let Some(rest) = line.strip_prefix("# TYPE ") {
            let (name, kind) = rest.split_once(' ').ok_or(format!("bad TYPE line: {line}"))?;
            typed.insert(name.to_string(), kind.to_string());
            continue;
        }
        if let Some(rest) = line.strip_prefix("# HELP ") {
            helped.insert(rest.split(' ').next().unwrap_or("").to_string());
            continue;
        }
        if line.starts_with('#') {
            continue;
        }
        let (series, value) = line.rsplit_once(' ').ok_or(format!("no value: {line}"))?;
        let value: f64 = value.parse().map_err(|_| format!("bad value: {line}"))?;
        let (name, labels) = match series.split_once('{') {
            Some((n, l)) => {
                let l = l.strip_suffix('}').ok_or(format!("unclosed labels: {line}"))?;
                let mut m = BTreeMap::new();
                for kv in l.split(',').filter(|s| !s.is_empty()) {
                    let (k, v) = kv.split_once('=').ok_or(format!("bad label: {line}"))?;
                    let v = v.strip_prefix('"').and_then(|v| v.strip_suffix('"'));
                    m.insert(
                        k.to_string(),
                        v.ok_or(format!("unquoted label: {line}"))?.to_string(),
                    );
                }
                (n.to_string(), m)
            }
            None => (series.to_string(), BTreeMap::new()),
        };
        if !valid(&name) {
            return Err(format!("bad metric name: {name}"));
        }
        let family = ["_total", "_bucket", "_count", "_sum", "_created"]
            .iter()
            .find_map(|s| name.strip_suffix(s).filter(|f| typed.contains_key(*f)))
            .unwrap_or(&name)
            .to_string();
        if !typed.contains_key(&family) || !helped.contains(&family) {
            return Err(format!("{name} has no # TYPE and # HELP for {family}"));
        }
        out.push(Sample { name, labels, value });
    }
    Ok(out)
}

/// The value of the sample `name` with exactly `labels`, if present.
pub fn value(samples: &[Sample], name: &str, labels: &[(&str, &str)]) -> Option<f64> {
    samples
        .iter()
        .find(|s| {
            s.name == name
                && s.labels.len() == labels.len()
                && labels.iter().all(|(k, v)| s.labels.get(*k).map(String::as_str) == Some(*v))
        })
        .map(|s| s.value)
}
