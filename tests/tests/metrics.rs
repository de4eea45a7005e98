//! Prometheus `/metrics` on the coordinator (its own port) and on a worker
//! (`--metrics-listen`), scraped over HTTP after a real render and parsed
//! strictly: the counts must be the render's.

use farm_cli::client::{self, RemoteOptions};
use farm_tests::cluster::TestCluster;
use farm_tests::http::{self, parse_prometheus, value};
use std::collections::BTreeSet;
use std::time::Duration;

fn free_port() -> std::net::SocketAddr {
    std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn coordinator_and_worker_metrics_count_the_render() {
    let mut cluster = TestCluster::start(0, Duration::from_millis(500)).await;
    let worker_addr = free_port();
    cluster.add_worker_with(|c| c.metrics_listen = Some(worker_addr));
    cluster.add_worker();
    let opts = RemoteOptions { spp: Some(2), ..Default::default() };
    let summary = client::submit(&cluster.remote(), &farm_tests::example_scene(), &opts, |_, _| {})
        .await
        .expect("farm render");
    let status = client::status(&cluster.remote()).await.expect("status");
    let tiles = f64::from(status.jobs[0].tiles_total);
    let address = cluster.url.trim_start_matches("http://").to_string();

    let scrape = |addr: String, path: &'static str| async move {
        tokio::task::spawn_blocking(move || http::get(&addr, path)).await.unwrap()
    };
    let answer = scrape(address.clone(), "/metrics").await;
    assert_eq!(answer.status, 200);
    assert!(answer.headers["content-type"].starts_with("application/openmetrics-text"));
    let text = String::from_utf8(answer.body).unwrap();
    let m = parse_prometheus(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    let v = |name: &str, labels: &[(&str, &str)]| {
        value(&m, name, labels).unwrap_or_else(|| panic!("no {name} {labels:?} in\n{text}"))
    };
    assert_eq!(v("farm_tiles_merged_total", &[]), tiles);
    // No retries in a healthy render; the tiles still out at the end may
    // be handed out a second time to idle workers (speculation).
    let speculated = f64::from(status.jobs[0].speculated);
    assert_eq!(v("farm_tiles_dispatched_total", &[]), tiles + speculated);
    assert_eq!(v("farm_tiles_speculated_total", &[]), speculated);
    assert_eq!(v("farm_tiles_retried_total", &[]), 0.0);
    assert_eq!(v("farm_tiles_failed_total", &[]), 0.0);
    assert_eq!(v("farm_tile_latency_seconds_count", &[]), tiles);
    assert!(v("farm_tile_latency_seconds_sum", &[]) > 0.0);
    assert_eq!(v("farm_jobs", &[("state", "done")]), 1.0);
    assert_eq!(v("farm_jobs", &[("state", "running")]), 0.0);
    assert_eq!(v("farm_queue_depth", &[]), 0.0);
    assert_eq!(v("farm_workers_connected", &[]), 2.0);
    assert_eq!(v("farm_rays_total", &[("kind", "camera")]), summary.stats.camera_rays as f64);
    assert_eq!(v("farm_rays_total", &[("kind", "shadow")]), summary.stats.shadow_rays as f64);
    assert!(v("farm_blob_store_bytes", &[]) > 0.0, "the scene's blobs are stored");
    // The loop handled the job's events; idle, it waits and counts next
    // to nothing (a tick or two, and the scrapes).
    let busy = v("farm_event_loop_busy_seconds_total", &[]);
    assert!(busy > 0.0, "the job's events were counted");
    tokio::time::sleep(Duration::from_millis(600)).await;
    let addr = address.clone();
    let (again, _) =
        tokio::task::spawn_blocking(move || http::scrape(&addr)).await.unwrap().unwrap();
    let idle = value(&again, "farm_event_loop_busy_seconds_total", &[]).unwrap() - busy;
    assert!((0.0..0.1).contains(&idle), "{idle} s busy in 0.6 s idle");
    // Labels are bounded: only these keys, never a job, tile or worker.
    let keys: BTreeSet<&str> = m.iter().flat_map(|s| s.labels.keys().map(String::as_str)).collect();
    assert_eq!(keys, BTreeSet::from(["kind", "le", "state"]));
    assert!(!text.contains("example"), "no job names in metrics");

    let answer = scrape(worker_addr.to_string(), "/metrics").await;
    assert_eq!(answer.status, 200);
    let text = String::from_utf8(answer.body).unwrap();
    let w = parse_prometheus(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    let wv = |name: &str, labels: &[(&str, &str)]| {
        value(&w, name, labels).unwrap_or_else(|| panic!("no {name} in\n{text}"))
    };
    let rendered = wv("farm_worker_tiles_rendered_total", &[]);
    assert!(rendered > 0.0 && rendered < tiles, "one of two workers: {rendered} of {tiles}");
    assert_eq!(wv("farm_worker_tile_duration_seconds_count", &[]), rendered);
    assert_eq!(wv("farm_worker_threads", &[]), 1.0);
    assert_eq!(wv("farm_worker_connected", &[]), 1.0);
    assert!(wv("farm_worker_rays_total", &[("kind", "camera")]) > 0.0);
    assert_eq!(scrape(worker_addr.to_string(), "/").await.status, 404);
    cluster.stop().await;
}
