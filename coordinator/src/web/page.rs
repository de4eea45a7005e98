//! The dashboard's pages, rendered here as HTML. Every value that comes
//! from a client (a job's name, a token's name, a failure message) is
//! escaped. The script refreshes the tables by fetching their fragments,
//! so there is one renderer of each table: this file.

use super::{may_touch, shutting_down, views, Caller, Web};
use crate::scheduler::{JobView, WorkerView};
use axum::extract::{Path, State};
use axum::http::{header, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use farm_common::ids::JobId;
use std::fmt::Write;

const SCRIPT: &str = include_str!("dashboard.js");
const STYLE: &str = include_str!("dashboard.css");

/// `s` with HTML's special characters escaped.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

fn shell(title: &str, body: &str) -> Html<String> {
    Html(format!(
        r#"<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title} · farm</title>
<link rel="stylesheet" href="/assets/dashboard.css">
<script src="/assets/dashboard.js" defer></script>
</head><body>
<header><a href="/" class="brand">farm</a>
<form method="post" action="/signout" class="signout"><button>Sign out</button></form></header>
<main>{body}</main>
</body></html>"#,
        title = escape(title)
    ))
}

/// A duration as "1 h 02 min", "3 min 05 s" or "12 s".
pub fn duration(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, s % 3600 / 60),
    }
}

fn job_actions(j: &JobView) -> String {
    if !matches!(j.state, "queued" | "running") {
        return String::new();
    }
    let id = j.id;
    format!(
        r#"<button data-action="/api/jobs/{id}/priority" data-body="priority={up}" title="Raise the priority">▲</button>
<button data-action="/api/jobs/{id}/priority" data-body="priority={down}" title="Lower the priority">▼</button>
<button class="cancel" id="cancel-{id}" data-action="/api/jobs/{id}/cancel">Cancel</button>"#,
        up = j.priority.saturating_add(1),
        down = j.priority.saturating_sub(1),
    )
}

fn job_row(out: &mut String, j: &JobView) {
    let pct =
        if j.tiles_total > 0 { 100.0 * j.tiles_done as f64 / j.tiles_total as f64 } else { 0.0 };
    let eta = j.eta_seconds.map(duration).unwrap_or_else(|| "–".into());
    let err = j.rel_mse.map(|e| format!("{e:.2e}")).unwrap_or_else(|| "–".into());
    let _ = write!(
        out,
        r#"<tr id="job-{id}" data-state="{state}"><td><a href="/jobs/{id}">{id}</a></td><td>{name}</td><td>{owner}</td>
<td class="state {state}" title="{msg}">{state}</td>
<td><progress max="{total}" value="{done}"></progress> {done}/{total} ({pct:.0}%)</td>
<td>{spp}</td><td>{eta}</td><td>{err}</td><td>{workers}</td><td>{prio}</td><td class="actions">{actions}</td></tr>
"#,
        id = j.id,
        name = escape(&j.name),
        owner = escape(&j.owner),
        state = j.state,
        msg = escape(j.message.as_deref().unwrap_or("")),
        total = j.tiles_total,
        done = j.tiles_done,
        spp = j.spp,
        workers = j.workers,
        prio = j.priority,
        actions = job_actions(j),
    );
}

fn jobs_table(jobs: &[JobView]) -> String {
    let mut out = String::from(
        "<table class=\"jobs\"><thead><tr><th>Job</th><th>Name</th><th>Owner</th><th>State</th><th>Tiles</th><th>spp</th><th>ETA</th><th>est. relMSE</th><th>Workers</th><th>Priority</th><th></th></tr></thead><tbody>\n",
    );
    for j in jobs.iter().rev() {
        job_row(&mut out, j);
    }
    if jobs.is_empty() {
        out.push_str("<tr><td colspan=\"11\" class=\"empty\">No jobs.</td></tr>");
    }
    out.push_str("</tbody></table>");
    out
}

fn workers_table(workers: &[WorkerView]) -> String {
    let mut out = String::from(
        "<table class=\"workers\"><thead><tr><th>Worker</th><th>Host</th><th>Threads</th><th>In flight</th><th>Tiles done</th><th>Tiles/s</th><th>Failures</th><th>Blocklisted on</th></tr></thead><tbody>\n",
    );
    for w in workers {
        let blocked: Vec<String> = w.blocklisted.iter().map(|j| format!("job {j}")).collect();
        let _ = writeln!(
            out,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.1}</td><td>{}</td><td>{}</td></tr>",
            w.id,
            escape(&w.name),
            w.threads,
            w.in_flight,
            w.tiles_done,
            w.tiles_per_second,
            w.failures,
            if blocked.is_empty() { "–".to_string() } else { blocked.join(", ") },
        );
    }
    if workers.is_empty() {
        out.push_str("<tr><td colspan=\"8\" class=\"empty\">No workers connected.</td></tr>");
    }
    out.push_str("</tbody></table>");
    out
}

pub(super) fn job_facts(j: &JobView) -> String {
    let mut out = String::new();
    let _ = write!(
        out,
        r#"<dl class="facts" data-state="{state}"><dt>State</dt><dd class="state {state}">{state}</dd>
<dt>Owner</dt><dd>{owner}</dd><dt>Image</dt><dd>{w}×{h}, {spp} spp</dd>
<dt>Tiles</dt><dd><progress max="{total}" value="{done}"></progress> {done}/{total}</dd>
<dt>Elapsed</dt><dd>{elapsed}</dd><dt>ETA</dt><dd>{eta}</dd>
<dt>est. relMSE</dt><dd>{err}</dd><dt>Workers</dt><dd>{workers}</dd>
<dt>Attempts</dt><dd>{attempts} ({retries} retries)</dd><dt>Priority</dt><dd>{prio}</dd></dl>
<div class="actions">{actions}</div>{msg}"#,
        state = j.state,
        owner = escape(&j.owner),
        w = j.width,
        h = j.height,
        spp = j.spp,
        total = j.tiles_total,
        done = j.tiles_done,
        elapsed = j.elapsed_seconds.map(duration).unwrap_or_else(|| "–".into()),
        eta = j.eta_seconds.map(duration).unwrap_or_else(|| "–".into()),
        err = j.rel_mse.map(|e| format!("{e:.3e}")).unwrap_or_else(|| "–".into()),
        workers = j.workers,
        attempts = j.attempts,
        retries = j.retries,
        prio = j.priority,
        actions = job_actions(j),
        msg = j
            .message
            .as_deref()
            .map(|m| format!("<p class=\"failure\">{}</p>", escape(m)))
            .unwrap_or_default(),
    );
    out
}

fn html(s: String) -> Response {
    ([(header::CACHE_CONTROL, "no-store")], Html(s)).into_response()
}

pub(super) async fn index(
    State(web): State<Web>,
    axum::Extension(caller): axum::Extension<Caller>,
) -> Response {
    let Some((jobs, workers)) = views(&web, &caller).await else { return shutting_down() };
    let body = format!(
        r#"<h1>Jobs</h1><section data-fragment="/fragments/jobs">{}</section>
<h1>Workers</h1><section data-fragment="/fragments/workers">{}</section>
<p class="foot">Signed in as {} ({}). <a href="/metrics">Metrics</a></p>"#,
        jobs_table(&jobs),
        workers_table(&workers),
        escape(&caller.who.name),
        caller.who.role,
    );
    shell("Jobs", &body).into_response()
}

pub(super) async fn jobs_fragment(
    State(web): State<Web>,
    axum::Extension(caller): axum::Extension<Caller>,
) -> Response {
    match views(&web, &caller).await {
        Some((jobs, _)) => html(jobs_table(&jobs)),
        None => shutting_down(),
    }
}

pub(super) async fn workers_fragment(
    State(web): State<Web>,
    axum::Extension(caller): axum::Extension<Caller>,
) -> Response {
    match views(&web, &caller).await {
        Some((_, workers)) => html(workers_table(&workers)),
        None => shutting_down(),
    }
}

async fn one_job(web: &Web, caller: &Caller, id: u64) -> Result<JobView, Response> {
    may_touch(web, caller, JobId(id)).await?;
    let Some((jobs, _)) = views(web, caller).await else { return Err(shutting_down()) };
    jobs.into_iter()
        .find(|j| j.id == id)
        .ok_or_else(|| (StatusCode::NOT_FOUND, "no such job of yours").into_response())
}

pub(super) async fn job(
    State(web): State<Web>,
    axum::Extension(caller): axum::Extension<Caller>,
    Path(id): Path<u64>,
) -> Response {
    let j = match one_job(&web, &caller, id).await {
        Ok(j) => j,
        Err(r) => return r,
    };
    let body = format!(
        r#"<h1>Job {id}: {name}</h1>
<section data-fragment="/fragments/job/{id}" data-every="5000">{facts}</section>
<div class="pictures" data-live="/api/jobs/{id}/live">
<figure><canvas id="image" width="{w}" height="{h}"></canvas><figcaption>Image</figcaption></figure>
<figure><canvas id="error" width="{w}" height="{h}"></canvas><figcaption>Estimated relMSE per pixel (log scale, 1e-5 black to 1 white)</figcaption></figure>
</div>"#,
        name = escape(&j.name),
        facts = job_facts(&j),
        w = j.width.max(1),
        h = j.height.max(1),
    );
    shell(&format!("Job {id}"), &body).into_response()
}

pub(super) async fn job_fragment(
    State(web): State<Web>,
    axum::Extension(caller): axum::Extension<Caller>,
    Path(id): Path<u64>,
) -> Response {
    match one_job(&web, &caller, id).await {
        Ok(j) => html(job_facts(&j)),
        Err(r) => r,
    }
}

/// The sign-in page, with a message after a refused token.
pub(super) fn signin_page(message: Option<&str>) -> Html<String> {
    let msg =
        message.map(|m| format!("<p class=\"failure\">{}</p>", escape(m))).unwrap_or_default();
    shell(
        "Sign in",
        &format!(
            r#"<h1>Sign in</h1>{msg}
<form method="post" action="/signin" class="signin">
<label>Token <input type="password" name="token" autocomplete="off" required></label>
<button>Sign in</button></form>
<p>An admin or client token: <code>farm token create --role client --name NAME</code>, or the
<code>client.token</code> the coordinator wrote in its state directory.</p>"#
        ),
    )
}

pub(super) async fn signin_form() -> Html<String> {
    signin_page(None)
}

pub(super) async fn script() -> Response {
    ([(header::CONTENT_TYPE, "text/javascript; charset=utf-8")], SCRIPT).into_response()
}

pub(super) async fn style() -> Response {
    ([(header::CONTENT_TYPE, "text/css; charset=utf-8")], STYLE).into_response()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn client_text_is_escaped_and_durations_read_well() {
        assert_eq!(
            escape(r#"<img src=x onerror="a&b">'"#),
            "&lt;img src=x onerror=&quot;a&amp;b&quot;&gt;&#39;"
        );
        assert_eq!(duration(5.4), "5 s");
        assert_eq!(duration(125.0), "2 min 05 s");
        assert_eq!(duration(3720.0), "1 h 02 min");
    }
}
