//! The dashboard in a real browser: Debian's Chromium, driven over
//! WebDriver (chromedriver), against a coordinator and a worker in this
//! process. The job page must show the image changing while the job
//! renders, and a job cancelled from the page must end cancelled.
//!
//! Needs `chromium` and `chromium-driver` (`.ci/run` installs them). Where
//! they are missing the test says so and passes, except under CI, where it
//! fails.

use fantoccini::{Client, ClientBuilder, Locator};
use farm_cli::client::{self, RemoteOptions};
use farm_tests::cluster::TestCluster;
use serde_json::json;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// chromedriver, killed when dropped, and Chromium's profile folder,
/// removed after that (Chromium itself is closed by the test's session;
/// a test that panics first may leave it writing there briefly).
struct Driver(Child, tempfile::TempDir);

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn find(names: &[&str]) -> Option<String> {
    names.iter().map(|n| n.to_string()).find(|p| std::path::Path::new(p).is_file())
}

async fn browser() -> Option<(Driver, Client)> {
    let driver = find(&["/usr/bin/chromedriver", "/usr/lib/chromium/chromedriver"]);
    let chromium = find(&["/usr/bin/chromium", "/usr/lib/chromium/chromium"]);
    let (Some(driver), Some(chromium)) = (driver, chromium) else {
        let msg = "chromium and chromium-driver are not installed (apt-get install chromium chromium-driver)";
        assert!(std::env::var_os("CI").is_none(), "{msg}: CI must run the browser test");
        eprintln!("skipping the browser test: {msg}");
        return None;
    };
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let dir = tempfile::Builder::new().prefix("farm-chromium-").tempdir().expect("temp dir");
    // Chromium's own scratch folders go in here too, and go with it.
    let tmp = dir.path().join("tmp");
    std::fs::create_dir(&tmp).expect("temp dir");
    let child = Command::new(driver)
        .arg(format!("--port={port}"))
        .env("TMPDIR", &tmp)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start chromedriver");
    let driver = Driver(child, dir);
    let profile = driver.1.path().join("profile");
    let mut caps = serde_json::Map::new();
    caps.insert(
        "goog:chromeOptions".into(),
        json!({
            "binary": chromium,
            "args": [
                "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--disable-quic", "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--window-size=1400,1000",
                format!("--user-data-dir={}", profile.display()),
            ]
        }),
    );
    let url = format!("http://127.0.0.1:{port}");
    let started = Instant::now();
    loop {
        let connector = hyper_util::client::legacy::connect::HttpConnector::new();
        match ClientBuilder::new(connector).capabilities(caps.clone()).connect(&url).await {
            Ok(c) => return Some((driver, c)),
            Err(e) if started.elapsed() < Duration::from_secs(30) => {
                let _ = e;
                tokio::time::sleep(Duration::from_millis(200)).await;
            }
            Err(e) => panic!("cannot start a Chromium session: {e}"),
        }
    }
}

/// A checksum of the job page's image canvas and the job's state there.
async fn look(c: &Client) -> (String, String) {
    let v = c
        .execute(
            r#"const cv = document.getElementById("image");
               const d = cv.getContext("2d").getImageData(0, 0, cv.width, cv.height).data;
               let h = 0;
               for (let i = 0; i < d.length; i += 7) h = (h * 31 + d[i]) >>> 0;
               const f = document.querySelector(".facts");
               return [String(h), f ? f.dataset.state : ""];"#,
            vec![],
        )
        .await
        .expect("script");
    let a = v.as_array().expect("array");
    (a[0].as_str().unwrap_or("").into(), a[1].as_str().unwrap_or("").into())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn the_job_page_shows_the_image_changing_and_cancels_a_job() {
    let Some((_driver, c)) = browser().await else { return };
    let cluster = TestCluster::start(1, Duration::from_millis(500)).await;
    let remote = cluster.remote();
    let scene = farm_tests::example_scene();
    // A job long enough to watch (one worker of one thread), and one
    // queued behind it at a lower priority, to cancel.
    let opts = RemoteOptions { spp: Some(256), detach: true, ..Default::default() };
    let long = client::start(&remote, &scene, &opts).await.expect("submit").job;
    let queued_opts = RemoteOptions { priority: -1, ..opts.clone() };
    let queued = client::start(&remote, &scene, &queued_opts).await.expect("submit").job;
    let base = cluster.url.clone();

    c.goto(&format!("{base}/jobs/{long}")).await.expect("open the job page");
    let mut seen: Vec<String> = Vec::new();
    let mut changes_while_running = 0;
    let mut shot = 0;
    let deadline = Instant::now() + Duration::from_secs(240);
    loop {
        let (sum, state) = look(&c).await;
        if seen.last() != Some(&sum) {
            if !seen.is_empty() && state == "running" {
                changes_while_running += 1;
            }
            seen.push(sum);
        }
        // The last one taken while it runs stays: the page furthest along.
        if changes_while_running >= 2 && shot < changes_while_running && state == "running" {
            shot = changes_while_running;
            let png = c.screenshot().await.expect("screenshot");
            let path = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("dashboard-job.png");
            std::fs::write(&path, png).expect("write the screenshot");
            eprintln!("screenshot of the job page mid-render: {}", path.display());
        }
        if state == "done" || changes_while_running >= 4 || Instant::now() > deadline {
            break;
        }
        tokio::time::sleep(Duration::from_millis(250)).await;
    }
    assert!(
        changes_while_running >= 2,
        "the image changed {changes_while_running} times while the job ran"
    );
    let status = client::status(&remote).await.expect("status");
    let state = |id: u64| status.jobs.iter().find(|j| j.job_id == id).unwrap().state.clone();
    assert_eq!(state(long), "running", "still rendering when the changes were seen");

    // Cancel the queued job from the dashboard's list.
    c.goto(&format!("{base}/")).await.expect("open the dashboard");
    c.find(Locator::Id(&format!("cancel-{queued}")))
        .await
        .expect("the queued job's cancel button")
        .click()
        .await
        .expect("click");
    let until = Instant::now() + Duration::from_secs(20);
    loop {
        let status = client::status(&remote).await.expect("status");
        let s = status.jobs.iter().find(|j| j.job_id == queued).unwrap().state.clone();
        if s == "cancelled" {
            break;
        }
        assert!(Instant::now() < until, "job {queued} is {s}, not cancelled");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    // The page shows it too, once its table refreshes.
    let row = format!("tr#job-{queued}[data-state=cancelled]");
    let until = Instant::now() + Duration::from_secs(10);
    while c.find(Locator::Css(&row)).await.is_err() {
        assert!(Instant::now() < until, "the dashboard does not show job {queued} cancelled");
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    let _ = client::cancel(&remote, long).await;
    c.close().await.expect("close the browser");
    cluster.stop().await;
}
