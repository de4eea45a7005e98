//! The web side's checks, driven through the router without a socket: who
//! may see what, the CSRF header, and the sign-in cookie.

use super::*;
use crate::scheduler::{JobView, Owner};
use crate::security::bootstrap;
use axum::http::Request;
use tower::ServiceExt;

fn view(id: u64, owner_id: &str, name: &str) -> JobView {
    JobView {
        id,
        name: name.into(),
        owner: owner_id.into(),
        owner_id: owner_id.into(),
        state: "running",
        message: None,
        tiles_done: 1,
        tiles_total: 4,
        spp: 8,
        priority: 0,
        width: 32,
        height: 32,
        elapsed_seconds: Some(1.0),
        eta_seconds: Some(3.0),
        rel_mse: Some(0.01),
        workers: 1,
        attempts: 2,
        retries: 0,
        speculated: 0,
    }
}

/// A router over a stand-in event loop holding job 1 of `mine` and job 2
/// of somebody else; returns it and the admin, client and worker tokens.
fn setup(tag: &str) -> (Router, [String; 3], std::path::PathBuf) {
    let dir = std::env::temp_dir().join(format!("farm-web-{tag}-{}", std::process::id()));
    let security = bootstrap(&dir, &["localhost".into()], None).expect("security");
    let token = |r: &str| std::fs::read_to_string(dir.join(format!("{r}.token"))).unwrap();
    let tokens = [token("admin"), token("client"), token("worker")].map(|t| t.trim().to_string());
    let client_id = tokens[1].parse::<Token>().unwrap().id;
    let (events, mut rx) = crate::server::events::channel();
    tokio::spawn(async move {
        while let Some(ev) = rx.recv().await {
            match ev {
                Event::Views { reply } => {
                    let jobs = vec![view(1, &client_id, "mine"), view(2, "other", "<b>theirs</b>")];
                    let _ = reply.send((jobs, Vec::new()));
                }
                Event::Owner { job, reply } => {
                    let id = if job.0 == 1 { client_id.clone() } else { "other".into() };
                    let _ = reply.send(Some(Owner { id, name: String::new() }));
                }
                Event::Cancel { reply, .. } => {
                    let _ = reply.send(true);
                }
                Event::Gauges { reply } => {
                    let _ = reply.send(());
                }
                Event::Live { job, facts, reply, .. } => {
                    let row = facts.then(|| view(job.0, &client_id, "mine"));
                    let _ = reply.send((crate::server::events::LiveAnswer::Ended, row));
                }
                _ => {}
            }
        }
    });
    let web = Web { events, security, metrics: Arc::default(), journal: None };
    (router(web), tokens, dir)
}

async fn call(app: &Router, method: &str, path: &str, headers: &[(&str, &str)]) -> (u16, String) {
    let (status, bytes) = call_bytes(app, method, path, headers).await;
    (status, String::from_utf8_lossy(&bytes).into_owned())
}

async fn call_bytes(
    app: &Router,
    method: &str,
    path: &str,
    headers: &[(&str, &str)],
) -> (u16, Vec<u8>) {
    let mut req = Request::builder().method(method).uri(path);
    for (k, v) in headers {
        req = req.header(*k, *v);
    }
    let body = if method == "POST" { Body::from("priority=3") } else { Body::empty() };
    let mut req = req.body(body).unwrap();
    if method == "POST" {
        req.headers_mut().insert(
            header::CONTENT_TYPE,
            HeaderValue::from_static("application/x-www-form-urlencoded"),
        );
    }
    let r = app.clone().oneshot(req).await.unwrap();
    let status = r.status().as_u16();
    let bytes = axum::body::to_bytes(r.into_body(), 1 << 20).await.unwrap();
    (status, bytes.to_vec())
}

#[tokio::test]
async fn every_page_wants_a_token_and_each_role_sees_its_share() {
    let (app, [admin, client, worker], dir) = setup("roles");
    let bearer = |t: &str| format!("Bearer {t}");
    // No token: pages send to the sign-in form, the API and metrics refuse.
    let (s, _) = call(&app, "GET", "/", &[]).await;
    assert_eq!(s, 303, "redirect to /signin");
    assert_eq!(call(&app, "GET", "/api/status", &[]).await.0, 401);
    assert_eq!(call(&app, "GET", "/metrics", &[]).await.0, 401);
    let forged = format!("Bearer {}x", &admin[..admin.len() - 1]);
    assert_eq!(call(&app, "GET", "/api/status", &[("authorization", &forged)]).await.0, 401);
    // The sign-in page and the assets are public.
    assert_eq!(call(&app, "GET", "/signin", &[]).await.0, 200);
    assert_eq!(call(&app, "GET", "/assets/dashboard.js", &[]).await.0, 200);
    // An admin sees every job, escaped.
    let (s, body) = call(&app, "GET", "/", &[("authorization", &bearer(&admin))]).await;
    assert_eq!(s, 200);
    assert!(body.contains("job-1") && body.contains("job-2"));
    assert!(body.contains("&lt;b&gt;theirs") && !body.contains("<b>theirs"), "escaped");
    // A client sees and acts on its own jobs only.
    let (s, body) = call(&app, "GET", "/api/status", &[("authorization", &bearer(&client))]).await;
    assert_eq!(s, 200);
    let v: serde_json::Value = serde_json::from_str(&body).unwrap();
    let ids: Vec<u64> =
        v["jobs"].as_array().unwrap().iter().map(|j| j["id"].as_u64().unwrap()).collect();
    assert_eq!(ids, [1]);
    let auth = [("authorization", bearer(&client))];
    let h: Vec<(&str, &str)> = auth.iter().map(|(k, v)| (*k, v.as_str())).collect();
    assert_eq!(call(&app, "POST", "/api/jobs/2/cancel", &h).await.0, 404);
    assert_eq!(call(&app, "GET", "/jobs/2", &h).await.0, 404);
    assert_eq!(call(&app, "GET", "/api/jobs/2/live", &h).await.0, 404);
    assert_eq!(call(&app, "POST", "/api/jobs/1/cancel", &h).await.0, 200);
    // A worker token reads the metrics and nothing else.
    let w = bearer(&worker);
    assert_eq!(call(&app, "GET", "/", &[("authorization", &w)]).await.0, 403);
    let (s, text) = call(&app, "GET", "/metrics", &[("authorization", &w)]).await;
    assert_eq!(s, 200);
    assert!(text.contains("farm_tiles_dispatched_total"), "{text}");
    std::fs::remove_dir_all(dir).ok();
}

#[tokio::test]
async fn the_sign_in_cookie_works_and_its_actions_need_the_csrf_header() {
    let (app, [_, client, worker], dir) = setup("cookie");
    // A worker's token or a wrong one sets no cookie.
    let form = |t: &str| format!("token={}", t.replace(':', "%3A"));
    let signin = |body: String| {
        Request::builder()
            .method("POST")
            .uri("/signin")
            .header(header::CONTENT_TYPE, "application/x-www-form-urlencoded")
            .body(Body::from(body))
            .unwrap()
    };
    for bad in [worker.clone(), "farm1:00:nope.nope".into()] {
        let r = app.clone().oneshot(signin(form(&bad))).await.unwrap();
        assert!(r.headers().get(header::SET_COOKIE).is_none());
    }
    let r = app.clone().oneshot(signin(form(&client))).await.unwrap();
    let cookie = r.headers()[header::SET_COOKIE].to_str().unwrap().to_string();
    assert!(cookie.contains("HttpOnly") && cookie.contains("SameSite=Strict"), "{cookie}");
    assert!(cookie.contains("Secure"), "TLS cookies are Secure: {cookie}");
    let pair = cookie.split(';').next().unwrap().to_string();
    assert_eq!(call(&app, "GET", "/", &[("cookie", &pair)]).await.0, 200);
    // A form from another site could send the cookie, but not the header.
    assert_eq!(call(&app, "POST", "/api/jobs/1/cancel", &[("cookie", &pair)]).await.0, 403);
    let with = [("cookie", pair.as_str()), (CSRF_HEADER, "1")];
    assert_eq!(call(&app, "POST", "/api/jobs/1/cancel", &with).await.0, 200);
    // The sign-out form clears the cookie.
    let out = Request::builder().method("POST").uri("/signout").header("cookie", &pair);
    let r = app.clone().oneshot(out.body(Body::empty()).unwrap()).await.unwrap();
    assert_eq!(r.status(), StatusCode::SEE_OTHER);
    let cleared = r.headers()[header::SET_COOKIE].to_str().unwrap();
    assert!(cleared.starts_with(&format!("{COOKIE}=;")) && cleared.contains("Max-Age=0"));
    std::fs::remove_dir_all(dir).ok();
}

#[tokio::test]
async fn a_look_brings_the_jobs_facts_when_asked() {
    let (app, [_, client, _], dir) = setup("facts");
    let auth = format!("Bearer {client}");
    let h = [("authorization", auth.as_str())];
    // Without facts=1: the image's answer only (here its 28-byte header).
    let (s, plain) = call_bytes(&app, "GET", "/api/jobs/1/live?from=0&merged=0", &h).await;
    assert_eq!((s, plain.len()), (200, 28));
    // With: then the facts fragment's HTML, after its length.
    let (s, with) = call_bytes(&app, "GET", "/api/jobs/1/live?from=0&merged=0&facts=1", &h).await;
    assert_eq!(s, 200);
    assert_eq!(with[..28], plain[..]);
    let n = u32::from_le_bytes(with[28..32].try_into().unwrap()) as usize;
    assert_eq!(with.len(), 32 + n);
    let html = std::str::from_utf8(&with[32..]).unwrap();
    let (_, fragment) = call(&app, "GET", "/fragments/job/1", &h).await;
    assert_eq!(html, fragment, "the same facts the fragment shows");
    assert!(html.contains("1/4"), "{html}");
    // Still only one's own job.
    assert_eq!(call(&app, "GET", "/api/jobs/2/live?facts=1", &h).await.0, 404);
    std::fs::remove_dir_all(dir).ok();
}
