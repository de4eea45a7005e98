//! A dashboard page watching a render over `/api/jobs/ID/live`, as
//! `dashboard.js` does: it draws each answer's pieces (resolving the
//! film's sums itself) and passes back its cursor and merged-tile count.
//! While the job runs it must be sent each pixel at most once, already
//! final; once it is done, only what it lacks; and it must end up showing
//! the written image and error map, bit for bit.

use farm_cli::client::{self, RemoteOptions};
use farm_common::film::resolve;
use farm_tests::cluster::TestCluster;
use farm_tests::http;
use std::time::{Duration, Instant};

/// What the page has drawn.
struct Page {
    width: usize,
    image: Vec<Option<[f32; 3]>>,
    error: Vec<Option<f32>>,
    /// How often each pixel was drawn from a running job's sums.
    running_draws: Vec<u32>,
    cursor: u32,
    merged: u32,
    /// Answers with pieces while running, and the pixels sent once done.
    running_answers: usize,
    done_pixels: Option<usize>,
}

impl Page {
    fn new() -> Page {
        Page {
            width: 0,
            image: Vec::new(),
            error: Vec::new(),
            running_draws: Vec::new(),
            cursor: 0,
            merged: 0,
            running_answers: 0,
            done_pixels: None,
        }
    }

    /// Draws one answer; returns its state.
    fn draw(&mut self, body: &[u8]) -> u32 {
        let word = |i: usize| u32::from_le_bytes(body[4 * i..4 * i + 4].try_into().unwrap());
        let float = |i: usize| f32::from_bits(word(i));
        let (w, h, state, scale, n) = (word(0), word(1), word(4), float(5), word(6));
        if self.image.is_empty() && w > 0 {
            let count = (w * h) as usize;
            self.width = w as usize;
            self.image = vec![None; count];
            self.error = vec![None; count];
            self.running_draws = vec![0; count];
        }
        (self.cursor, self.merged) = (word(2), word(3));
        let (mut at, mut done_pixels) = (7, 0);
        for _ in 0..n {
            let (x, y, pw, ph, kind) =
                (word(at), word(at + 1), word(at + 2), word(at + 3), word(at + 4));
            at += 5;
            if kind != 2 {
                done_pixels += (pw * ph) as usize;
            }
            let index = |k: u32| ((y + k / pw) * w + x + k % pw) as usize;
            if kind != 2 {
                for k in 0..pw * ph {
                    let i = index(k);
                    self.image[i] = Some(if state == 1 {
                        [float(at), float(at + 1), float(at + 2)]
                    } else {
                        self.running_draws[i] += 1;
                        let c = [float(at), float(at + 1), float(at + 2)];
                        resolve(c, float(at + 3), scale)
                    });
                    at += if state == 1 { 3 } else { 4 };
                }
            }
            if kind != 0 {
                for k in 0..pw * ph {
                    self.error[index(k)] = Some(float(at));
                    at += 1;
                }
            }
        }
        assert_eq!(4 * at, body.len(), "the answer is exactly its pieces");
        match state {
            0 if n > 0 => self.running_answers += 1,
            1 => self.done_pixels = Some(done_pixels),
            _ => {}
        }
        state
    }
}

fn look(address: &str, job: u64, page: &mut Page) -> u32 {
    let path = format!("/api/jobs/{job}/live?from={}&merged={}", page.cursor, page.merged);
    let a = http::get(address, &path);
    assert_eq!(a.status, 200);
    page.draw(&a.body)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_page_watching_a_render_is_sent_each_pixel_once_and_ends_on_the_written_image() {
    let cluster = TestCluster::start(2, Duration::from_millis(500)).await;
    let remote = cluster.remote();
    let address = cluster.url.trim_start_matches("http://").to_string();
    let opts = RemoteOptions { spp: Some(32), ..Default::default() };
    let render = tokio::spawn(async move {
        client::submit(&remote, &farm_tests::example_scene(), &opts, |_, _| {}).await
    });
    let page = tokio::task::spawn_blocking(move || {
        let deadline = Instant::now() + Duration::from_secs(120);
        let job = loop {
            let status: serde_json::Value =
                serde_json::from_slice(&http::get(&address, "/api/status").body).unwrap();
            let jobs = status["jobs"].as_array().cloned().unwrap_or_default();
            if let Some(id) = jobs.iter().find_map(|j| j["id"].as_u64()) {
                break id;
            }
            assert!(Instant::now() < deadline, "no job appeared");
            std::thread::sleep(Duration::from_millis(20));
        };
        let mut page = Page::new();
        while look(&address, job, &mut page) == 0 {
            assert!(Instant::now() < deadline, "the job did not end");
            std::thread::sleep(Duration::from_millis(150));
        }
        page
    });
    let page = page.await.expect("the page");
    let summary = render.await.expect("join").expect("render");
    assert!(page.running_answers >= 2, "{} answers while running", page.running_answers);
    assert!(page.running_draws.iter().all(|&d| d <= 1), "a pixel was sent twice while running");
    let drawn: u32 = page.running_draws.iter().sum();
    assert!(drawn > 0, "nothing was drawn while running");
    // Done: the page was looking, so it is sent the tiles it had not seen
    // merged, not the whole image again.
    let sent = page.done_pixels.expect("a finished answer");
    assert!(sent < page.image.len(), "the whole image again, {sent} pixels");
    assert_eq!(page.width, summary.image.width);
    for (i, (shown, written)) in page.image.iter().zip(&summary.image.pixels).enumerate() {
        let shown = shown.unwrap_or_else(|| panic!("pixel {i} never drawn"));
        let bits = |p: [f32; 3]| p.map(f32::to_bits);
        assert_eq!(bits(shown), bits(*written), "pixel {i}");
    }
    let error = &summary.error.as_ref().expect("32 spp has an estimate").per_pixel;
    for (i, (shown, e)) in page.error.iter().zip(error).enumerate() {
        assert_eq!(shown.map(f32::to_bits), Some(e.to_bits()), "error at pixel {i}");
    }
    cluster.stop().await;
}
