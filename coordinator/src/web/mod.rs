//! The coordinator's web side, on the gRPC port (axum beside tonic): the
//! dashboard, its small JSON and binary API, and Prometheus `/metrics`.
//!
//! ```text
//! GET  /                        jobs and workers (server-rendered; the script refreshes fragments)
//! GET  /jobs/ID                 one job: its image and error map as they render
//! GET  /signin, POST /signin    a token in a form, kept in an HttpOnly cookie
//! POST /signout
//! GET  /fragments/jobs, /fragments/workers, /fragments/job/ID   the tables, as HTML
//! GET  /api/status              jobs and workers as JSON
//! GET  /api/jobs/ID/live?from=N&merged=M the pixels completed since cursor N, the error map of tiles M.. (binary, see `live.rs`)
//! POST /api/jobs/ID/cancel, /api/jobs/ID/priority (priority=P)
//! GET  /metrics                 Prometheus text format
//! GET  /assets/…                the script and style sheet (served by the binary: no CDN)
//! ```
//!
//! Every request but the sign-in page and the assets carries a token: an
//! `Authorization: Bearer` header or the sign-in cookie. An insecure
//! coordinator (loopback only) asks for none. Worker tokens may read
//! `/metrics` only; a client token sees and acts on its own jobs, an admin
//! token on every job. Requests that act (POST) made with the cookie must
//! also carry the `x-farm-csrf` header the script sends, which no other
//! site's form can.

pub(crate) mod live;
mod page;

use crate::metrics::Metrics;
use crate::security::{Principal, Security};
use crate::server::events::Event;
use crate::state::Journal;
use axum::body::Body;
use axum::extract::{DefaultBodyLimit, Path, Request, State};
use axum::http::{header, HeaderMap, HeaderValue, Method, StatusCode};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Redirect, Response};
use axum::routing::{get, post};
use axum::{Form, Json, Router};
use farm_common::ids::JobId;
use farm_proto::auth::{Role, Token};
use std::sync::Arc;
use tokio::sync::oneshot;

/// The cookie the sign-in form sets.
pub const COOKIE: &str = "farm_token";
/// The header a cookie-authenticated POST must carry.
pub const CSRF_HEADER: &str = "x-farm-csrf";

/// What the handlers share.
#[derive(Clone)]
pub struct Web {
    /// The event loop.
    pub events: crate::server::events::EventTx,
    /// How callers are checked.
    pub security: Security,
    /// The metrics.
    pub metrics: Arc<Metrics>,
    /// The journal, where finished images are kept with a state directory.
    pub journal: Option<Journal>,
}

/// The routes, with the token check in front of them.
pub fn router(web: Web) -> Router {
    let checked = Router::new()
        .route("/", get(page::index))
        .route("/jobs/{id}", get(page::job))
        .route("/fragments/jobs", get(page::jobs_fragment))
        .route("/fragments/workers", get(page::workers_fragment))
        .route("/fragments/job/{id}", get(page::job_fragment))
        .route("/api/status", get(status))
        .route("/api/jobs/{id}/live", get(live::live))
        .route("/api/jobs/{id}/cancel", post(cancel))
        .route("/api/jobs/{id}/priority", post(priority))
        .route("/metrics", get(metrics))
        .route_layer(middleware::from_fn_with_state(web.clone(), authenticate));
    Router::new()
        .route("/signin", get(page::signin_form).post(signin))
        // Signing out only clears the cookie: it needs no token, and a
        // plain form (which sends no CSRF header) may do it.
        .route("/signout", post(signout))
        .route("/assets/dashboard.js", get(page::script))
        .route("/assets/dashboard.css", get(page::style))
        .merge(checked)
        .layer(DefaultBodyLimit::max(4096))
        .with_state(web)
}

/// How a request proved who it is.
#[derive(Clone, Debug)]
pub(crate) struct Caller {
    pub(crate) who: Principal,
    /// By the sign-in cookie (so an action needs the CSRF header too).
    pub(crate) by_cookie: bool,
}

fn cookie_token(headers: &HeaderMap) -> Option<String> {
    headers
        .get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .filter_map(|kv| kv.trim().split_once('='))
        .find(|(k, _)| *k == COOKIE)
        .map(|(_, v)| v.to_string())
}

/// Who presents `headers`, if anyone the coordinator knows.
fn identify(security: &Security, headers: &HeaderMap) -> Option<Caller> {
    match security {
        Security::Insecure => Some(Caller { who: Principal::local(), by_cookie: false }),
        Security::Tls { tokens, .. } => {
            let bearer = headers
                .get(header::AUTHORIZATION)
                .and_then(|v| v.to_str().ok())
                .and_then(|v| v.strip_prefix("Bearer "))
                .map(str::to_string);
            let (text, by_cookie) = match bearer {
                Some(t) => (t, false),
                None => (cookie_token(headers)?, true),
            };
            let token: Token = text.trim().parse().ok()?;
            let who = tokens.verify(&token)?;
            Some(Caller { who, by_cookie })
        }
    }
}

async fn authenticate(State(web): State<Web>, mut req: Request, next: Next) -> Response {
    let path = req.uri().path().to_string();
    let api = path.starts_with("/api/") || path == "/metrics" || path.starts_with("/fragments/");
    let Some(caller) = identify(&web.security, req.headers()) else {
        tracing::warn!(%path, "dashboard request refused: no valid token");
        return if api {
            (StatusCode::UNAUTHORIZED, "a valid token is required (Authorization: Bearer …)")
                .into_response()
        } else {
            Redirect::to("/signin").into_response()
        };
    };
    // Workers render; they have no business with the jobs.
    if caller.who.role == Role::Worker && path != "/metrics" {
        return (StatusCode::FORBIDDEN, "worker tokens may read /metrics only").into_response();
    }
    if req.method() == Method::POST && caller.by_cookie && !req.headers().contains_key(CSRF_HEADER)
    {
        return (StatusCode::FORBIDDEN, "missing the x-farm-csrf header").into_response();
    }
    req.extensions_mut().insert(caller);
    next.run(req).await
}

#[derive(serde::Deserialize)]
struct SignIn {
    token: String,
}

async fn signin(State(web): State<Web>, Form(f): Form<SignIn>) -> Response {
    let tls = matches!(web.security, Security::Tls { .. });
    let caller = f.token.trim().parse::<Token>().ok().and_then(|t| match &web.security {
        Security::Tls { tokens, .. } => tokens.verify(&t).map(|p| (p, t)),
        Security::Insecure => None,
    });
    match caller {
        Some((p, t)) if p.role != Role::Worker => {
            let cookie = format!(
                "{COOKIE}={}; HttpOnly; SameSite=Strict; Path=/{}",
                t.expose(),
                if tls { "; Secure" } else { "" }
            );
            let mut r = Redirect::to("/").into_response();
            if let Ok(v) = HeaderValue::from_str(&cookie) {
                r.headers_mut().insert(header::SET_COOKIE, v);
            }
            r
        }
        _ if !tls => Redirect::to("/").into_response(),
        _ => {
            tracing::warn!("dashboard sign-in refused");
            page::signin_page(Some("That token is unknown, revoked, or a worker's."))
                .into_response()
        }
    }
}

async fn signout() -> Response {
    let mut r = Redirect::to("/signin").into_response();
    let clear = format!("{COOKIE}=; HttpOnly; SameSite=Strict; Path=/; Max-Age=0");
    if let Ok(v) = HeaderValue::from_str(&clear) {
        r.headers_mut().insert(header::SET_COOKIE, v);
    }
    r
}

/// Asks the event loop; `None` when it has stopped.
async fn ask<T>(web: &Web, make: impl FnOnce(oneshot::Sender<T>) -> Event) -> Option<T> {
    let (tx, rx) = oneshot::channel();
    web.events.send(make(tx)).ok()?;
    rx.await.ok()
}

fn shutting_down() -> Response {
    (StatusCode::SERVICE_UNAVAILABLE, "the coordinator is shutting down").into_response()
}

/// Jobs (the caller's own, or all for an admin) and workers.
pub(crate) async fn views(
    web: &Web,
    caller: &Caller,
) -> Option<(Vec<crate::scheduler::JobView>, Vec<crate::scheduler::WorkerView>)> {
    let (mut jobs, workers) = ask(web, |reply| Event::Views { reply }).await?;
    if caller.who.role != Role::Admin {
        jobs.retain(|j| j.owner_id == caller.who.id);
    }
    Some((jobs, workers))
}

/// Whether `caller` may see and act on `job` (an admin any, a client its
/// own): the refusal to answer with otherwise. Another client's job is
/// "not found", as a job that does not exist is.
pub(crate) async fn may_touch(web: &Web, caller: &Caller, job: JobId) -> Result<(), Response> {
    if caller.who.role == Role::Admin {
        return Ok(());
    }
    match ask(web, |reply| Event::Owner { job, reply }).await {
        None => Err(shutting_down()),
        Some(Some(o)) if o.id == caller.who.id => Ok(()),
        Some(_) => Err((StatusCode::NOT_FOUND, "no such job of yours").into_response()),
    }
}

/// The answer to an action the loop says was done (`Some(true)`), came
/// too late (`Some(false)`), or could not be asked.
fn acted(done: Option<bool>, what: &'static str) -> Response {
    match done {
        Some(true) => (StatusCode::OK, what).into_response(),
        Some(false) => (StatusCode::CONFLICT, "the job has already ended").into_response(),
        None => shutting_down(),
    }
}

async fn status(
    State(web): State<Web>,
    axum::Extension(caller): axum::Extension<Caller>,
) -> Response {
    match views(&web, &caller).await {
        Some((jobs, workers)) => {
            Json(serde_json::json!({ "jobs": jobs, "workers": workers })).into_response()
        }
        None => shutting_down(),
    }
}

async fn cancel(
    State(web): State<Web>,
    axum::Extension(caller): axum::Extension<Caller>,
    Path(id): Path<u64>,
) -> Response {
    let job = JobId(id);
    if let Err(refused) = may_touch(&web, &caller, job).await {
        return refused;
    }
    let done = ask(&web, |reply| Event::Cancel { job, reply }).await;
    if done == Some(true) {
        tracing::info!(job = id, by = %caller.who.name, "job cancelled from the dashboard");
    }
    acted(done, "cancelled")
}

#[derive(serde::Deserialize)]
struct PriorityForm {
    priority: i32,
}

async fn priority(
    State(web): State<Web>,
    axum::Extension(caller): axum::Extension<Caller>,
    Path(id): Path<u64>,
    Form(f): Form<PriorityForm>,
) -> Response {
    let job = JobId(id);
    if let Err(refused) = may_touch(&web, &caller, job).await {
        return refused;
    }
    let priority = f.priority;
    acted(ask(&web, |reply| Event::Priority { job, priority, reply }).await, "priority changed")
}

async fn metrics(State(web): State<Web>) -> Response {
    if ask(&web, |reply| Event::Gauges { reply }).await.is_none() {
        return shutting_down();
    }
    let mut r = Response::new(Body::from(web.metrics.encode()));
    r.headers_mut().insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("application/openmetrics-text; version=1.0.0; charset=utf-8"),
    );
    r
}

#[cfg(test)]
mod tests;
