//! Real processes: one `farm coordinator` (TLS and tokens, as it starts by
//! default), two `farm worker`s and a `farm submit --coordinator`; one
//! worker is killed with SIGKILL in the middle of the job, and the image
//! must equal the embedded render byte for byte. Then what the security
//! model refuses, as a user meets it on the command line.

mod common;

use common::{
    farm, free_port, memory, scene, spawn_worker, start_coordinator, start_coordinator_on,
    start_coordinator_with, status, token_file, Procs,
};
use std::process::Stdio;
use std::time::{Duration, Instant};

#[test]
fn sigkill_of_a_worker_process_changes_no_byte() {
    let tmp = tempfile::Builder::new().prefix("farm-procs-").tempdir().expect("temp dir");
    let dir = tmp.path();
    let state = dir.join("state");
    let mut procs = Procs(Vec::new());
    let url = start_coordinator(&mut procs, &state);
    let worker_token = token_file(&state, "worker");
    let client_token = token_file(&state, "client");

    for name in ["w1", "w2"] {
        procs.0.push(spawn_worker(&url, &worker_token, name));
    }

    let farm_out = dir.join("farm.pfm");
    let submit = farm()
        .args(["submit", "--quiet", "--spp", "4", "--coordinator", &url, "-o"])
        .arg(&farm_out)
        .arg("--token-file")
        .arg(&client_token)
        .arg(scene())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start submit");

    // Wait until the job is a fifth done, then SIGKILL the first worker.
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().expect("runtime");
    let text = std::fs::read_to_string(&client_token).expect("client token");
    let remote = farm_cli::client::Remote { url: url.clone(), token: Some(text.parse().unwrap()) };
    let deadline = Instant::now() + Duration::from_secs(120);
    let mut killed = false;
    while Instant::now() < deadline {
        if let Ok(s) = rt.block_on(farm_cli::client::status(&remote)) {
            if let Some(j) = s.jobs.first() {
                if j.tiles_total > 0 && j.tiles_done * 5 >= j.tiles_total && s.workers.len() == 2 {
                    procs.0[1].kill().expect("SIGKILL worker");
                    killed = true;
                    break;
                }
            }
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(killed, "the job never got a fifth done with two workers");
    let out = submit.wait_with_output().expect("submit finished");
    assert!(out.status.success(), "farm submit failed: {}", String::from_utf8_lossy(&out.stderr));

    let embedded_out = dir.join("embedded.pfm");
    let status = farm()
        .args(["submit", "--quiet", "--spp", "4", "-o"])
        .arg(&embedded_out)
        .arg(scene())
        .status()
        .expect("embedded render");
    assert!(status.success());
    let a = std::fs::read(&farm_out).expect("farm image");
    let b = std::fs::read(&embedded_out).expect("embedded image");
    assert!(a == b, "the farm's image differs from the embedded render");
}

#[test]
fn sigkill_of_the_coordinator_loses_only_the_tiles_in_flight() {
    let tmp = tempfile::Builder::new().prefix("farm-procs-restart-").tempdir().expect("temp dir");
    let dir = tmp.path();
    let state = dir.join("state");
    let listen = format!("127.0.0.1:{}", free_port());
    let mut procs = Procs(Vec::new());
    let url = start_coordinator_on(&mut procs, &state, &listen, "coordinator.log");
    let worker_token = token_file(&state, "worker");
    let client_token = token_file(&state, "client");
    for name in ["w1", "w2"] {
        procs.0.push(spawn_worker(&url, &worker_token, name));
    }
    let farm_out = dir.join("farm.pfm");
    let submit = farm()
        .args(["submit", "--quiet", "--spp", "8", "--coordinator", &url, "-o"])
        .arg(&farm_out)
        .arg("--token-file")
        .arg(&client_token)
        .arg(scene())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start submit");

    // SIGKILL the coordinator once a third of the job is in.
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().expect("runtime");
    let text = std::fs::read_to_string(&client_token).expect("client token");
    let remote = farm_cli::client::Remote { url: url.clone(), token: Some(text.parse().unwrap()) };
    let deadline = Instant::now() + Duration::from_secs(120);
    let mut done_at_kill = None;
    while Instant::now() < deadline && done_at_kill.is_none() {
        if let Some(s) = status(&rt, &remote) {
            if let Some(j) = s.jobs.first() {
                if j.tiles_total > 0 && j.tiles_done * 3 >= j.tiles_total {
                    procs.0[0].kill().expect("SIGKILL coordinator");
                    procs.0[0].wait().expect("reap coordinator");
                    done_at_kill = Some((j.tiles_done, j.tiles_total));
                }
            }
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let (done_at_kill, total) = done_at_kill.expect("the job never got a third done");

    // The same state directory, the same address: the job resumes, the
    // workers register again and the client reconnects to its job.
    start_coordinator_on(&mut procs, &state, &listen, "coordinator-2.log");
    let out = submit.wait_with_output().expect("submit finished");
    assert!(out.status.success(), "farm submit failed: {}", String::from_utf8_lossy(&out.stderr));
    let s = status(&rt, &remote).expect("status after the restart");
    let j = s.jobs.first().expect("the job survived the restart");
    assert_eq!((j.state.as_str(), j.tiles_done, j.tiles_total), ("done", total, total));
    // Rendered twice: the tiles in flight when the coordinator died (two
    // workers of one thread hold at most 6 each) and any whose result
    // arrived in the instant before its commit (the journal commits within
    // microseconds; allow a few under a loaded machine). Everything before
    // survived.
    let window = 2 * farm_proto::default_in_flight(1) + 4;
    eprintln!(
        "coordinator killed with {done_at_kill} of {total} tiles in; {} rendered again after the restart",
        j.retries
    );
    assert!(
        j.retries <= window,
        "{} tiles were rendered again after the restart, more than the {window} in flight ({done_at_kill} of {total} were done)",
        j.retries
    );
    assert!(done_at_kill > window, "the kill came too early to tell");
    assert_eq!(j.attempts, total + j.retries + j.speculated);

    let embedded_out = dir.join("embedded.pfm");
    let status = farm()
        .args(["submit", "--quiet", "--spp", "8", "-o"])
        .arg(&embedded_out)
        .arg(scene())
        .status()
        .expect("embedded render");
    assert!(status.success());
    let a = std::fs::read(&farm_out).expect("farm image");
    let b = std::fs::read(&embedded_out).expect("embedded image");
    assert!(a == b, "the image after a coordinator restart differs from the embedded render");

    // `farm watch` fetches the finished image from anywhere, again.
    let watch = |out: &std::path::Path| {
        let (code, _, err) = run(&[
            "watch",
            &j.job_id.to_string(),
            "--coordinator",
            &url,
            "--token-file",
            &client_token.to_string_lossy(),
            "-o",
            &out.to_string_lossy(),
        ]);
        assert_eq!(code, Some(0), "{err}");
    };
    let watched = dir.join("watched.pfm");
    watch(&watched);
    assert!(std::fs::read(&watched).expect("watched image") == a, "farm watch wrote another image");
    // An EXR written by `farm watch` carries the job's name, as one written
    // by `farm submit` carries the scene's.
    let watched = dir.join("watched.exr");
    watch(&watched);
    let meta = exr::meta::MetaData::read_from_file(&watched, false).expect("EXR header");
    let name =
        meta.headers[0].own_attributes.other.get(&exr::meta::attribute::Text::from("sceneName"));
    let want = exr::meta::attribute::Text::from_slice_unchecked(j.name.as_bytes());
    let want = exr::meta::attribute::AttributeValue::Text(want);
    assert!(!j.name.is_empty());
    assert_eq!(name, Some(&want), "the job is named {}", j.name);
    drop(procs);
}

const MIB: u64 = 1 << 20;

/// Chunk `i` of a made-up blob of `n` MiB.
fn made_up_chunk(hash: &[u8], n: u64, i: u64) -> farm_proto::v1::BlobChunk {
    farm_proto::v1::BlobChunk {
        hash: hash.to_vec(),
        total_size: n * MIB,
        offset: i * MIB,
        data: vec![(i * 31 % 251) as u8; MIB as usize],
    }
}

#[test]
fn upload_and_download_abuse_costs_the_coordinator_a_few_chunks() {
    use tonic::Code;
    let tmp = tempfile::Builder::new().prefix("farm-procs-abuse-").tempdir().expect("temp dir");
    let dir = tmp.path();
    let state = dir.join("state");
    let mut procs = Procs(Vec::new());
    let extra = ["--client-quota", "600M"];
    let url = start_coordinator_with(&mut procs, &state, "127.0.0.1:0", "coordinator.log", &extra);
    let pid = procs.0[0].id();
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build().expect("runtime");
    let token = |role| {
        let t = std::fs::read_to_string(token_file(&state, role)).expect("token");
        t.trim().parse::<farm_proto::auth::Token>().expect("token")
    };
    let (client_token, worker_token) = (token("client"), token("worker"));
    let connect = |t| rt.block_on(farm_proto::connect::connect(&url, Some(t))).expect("connect");
    let mut client = connect(&client_token);
    const N: u64 = 256;
    let (before, _) = memory(pid);

    // 256 MiB whose bytes do not match the hash they claim: refused at the
    // end, having cost a chunk or so, not the blob.
    let lie = [7u8; 32];
    let chunks = tokio_stream::iter((0..N).map(move |i| made_up_chunk(&lie, N, i)));
    let e = rt.block_on(client.upload_blob(chunks)).expect_err("a lying upload");
    assert_eq!(e.code(), Code::InvalidArgument, "{e}");
    assert!(e.message().contains("does not match its hash"), "{e}");
    let (after_lie, _) = memory(pid);

    // Over the client's quota: refused at the first chunk, saying which limit.
    let chunks = tokio_stream::iter((0..1024).map(move |i| made_up_chunk(&lie, 1024, i)));
    let e = rt.block_on(client.upload_blob(chunks)).expect_err("over quota");
    assert_eq!(e.code(), Code::ResourceExhausted, "{e}");
    assert!(e.message().contains("--client-quota"), "{e}");

    // A real 256 MiB blob, then ten readers that take one chunk and stall.
    let mut hasher = blake3::Hasher::new();
    for i in 0..N {
        hasher.update(&made_up_chunk(&[], N, i).data);
    }
    let hash = *hasher.finalize().as_bytes();
    let chunks = tokio_stream::iter((0..N).map(move |i| made_up_chunk(&hash, N, i)));
    let size = rt.block_on(client.upload_blob(chunks)).expect("a true upload").into_inner().size;
    assert_eq!(size, N * MIB);
    let (after_upload, _) = memory(pid);
    let mut readers = Vec::new();
    for _ in 0..10 {
        let mut w = connect(&worker_token);
        let request = farm_proto::v1::FetchBlobRequest { hash: hash.to_vec() };
        let mut stream = rt.block_on(w.fetch_blob(request)).expect("fetch").into_inner();
        let first = rt.block_on(stream.message()).expect("chunk").expect("a chunk");
        assert_eq!(first.offset, 0);
        readers.push((w, stream, first));
    }
    std::thread::sleep(Duration::from_secs(1));
    let (after_readers, _) = memory(pid);
    // One reader reads on to the end and gets the blob intact.
    let (_, mut stream, first) = readers.pop().expect("reader");
    let mut hasher = blake3::Hasher::new();
    hasher.update(&first.data);
    let mut got = first.data.len() as u64;
    while let Some(c) = rt.block_on(stream.message()).expect("chunk") {
        hasher.update(&c.data);
        got += c.data.len() as u64;
    }
    assert_eq!((got, *hasher.finalize().as_bytes()), (N * MIB, hash));
    let grown = |m: u64| m.saturating_sub(before) / MIB;
    eprintln!(
        "coordinator peak RSS {} MiB at start; +{} MiB after a 256 MiB lying upload, +{} MiB after a 256 MiB upload, +{} MiB with 10 stalled readers of it",
        before / MIB,
        grown(after_lie),
        grown(after_upload),
        grown(after_readers)
    );
    assert!(grown(after_lie) < 48, "a lying upload cost {} MiB", grown(after_lie));
    assert!(grown(after_upload) < 48, "an upload cost {} MiB", grown(after_upload));
    assert!(grown(after_readers) < 40, "ten stalled readers cost {} MiB", grown(after_readers));
    drop(readers);

    // A "scene" of 257 MiB: stored, but refused as a job before the
    // coordinator reads it to decode it.
    const BIG: u64 = 257;
    let mut hasher = blake3::Hasher::new();
    for i in 0..BIG {
        hasher.update(&made_up_chunk(&[], BIG, i).data);
    }
    let big = *hasher.finalize().as_bytes();
    let chunks = tokio_stream::iter((0..BIG).map(move |i| made_up_chunk(&big, BIG, i)));
    rt.block_on(client.upload_blob(chunks)).expect("a big upload");
    let (before_submit, _) = memory(pid);
    let request = farm_proto::v1::SubmitJobRequest {
        protocol_version: farm_proto::PROTOCOL_VERSION,
        scene_hash: big.to_vec(),
        ..Default::default()
    };
    let e = rt.block_on(client.submit_job(request)).expect_err("a huge manifest");
    assert_eq!(e.code(), Code::InvalidArgument, "{e}");
    assert!(e.message().contains("manifest") && e.message().contains("256.0 MiB"), "{e}");
    let (after_submit, _) = memory(pid);
    assert!(after_submit - before_submit < 16 * MIB, "the refusal read the manifest");
    drop(procs);
}

/// Runs `farm ARGS` to the end; its exit code and standard error.
fn run(args: &[&str]) -> (Option<i32>, String, String) {
    let out = farm().args(args).output().expect("run farm");
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (out.status.code(), text(&out.stdout), text(&out.stderr))
}

#[test]
fn the_command_line_refuses_what_the_security_model_refuses() {
    let tmp = tempfile::Builder::new().prefix("farm-procs-sec-").tempdir().expect("temp dir");
    let dir = tmp.path();
    let state = dir.join("state");
    let mut procs = Procs(Vec::new());
    let url = start_coordinator(&mut procs, &state);
    let file = |role: &str| token_file(&state, role).to_string_lossy().into_owned();
    // --insecure is for loopback only.
    let (code, _, err) = run(&["coordinator", "--insecure", "--listen", "0.0.0.0:0"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("only allowed on a loopback address"), "{err}");
    // No token: a clear error, not a hang or a panic.
    let (code, _, err) = run(&["status", "--coordinator", &url]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("give a token"), "{err}");
    // A worker token cannot list jobs; a client token can.
    let (code, _, err) = run(&["status", "--coordinator", &url, "--token-file", &file("worker")]);
    assert_eq!(code, Some(1));
    assert!(err.contains("only client and admin tokens"), "{err}");
    let (code, out, err) = run(&["status", "--coordinator", &url, "--token-file", &file("client")]);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("owner") && out.contains("retries"), "{out}");
    // A worker started with a client token stops at once, saying why.
    let (code, _, err) = run(&["worker", "--coordinator", &url, "--token-file", &file("client")]);
    assert_eq!(code, Some(1));
    assert!(err.contains("only worker and admin tokens"), "{err}");
    // Tokens are made, listed (without secrets) and revoked on the host.
    let state_arg = state.to_string_lossy().into_owned();
    let (code, token, err) =
        run(&["token", "create", "--role", "client", "--name", "carol", "--state-dir", &state_arg]);
    assert_eq!(code, Some(0), "{err}");
    let token = token.trim().to_string();
    let carol = dir.join("carol.token");
    std::fs::write(&carol, &token).expect("write token");
    let carol = carol.to_string_lossy().into_owned();
    let (code, _, _) = run(&["status", "--coordinator", &url, "--token-file", &carol]);
    assert_eq!(code, Some(0));
    let (_, list, _) = run(&["token", "list", "--state-dir", &state_arg]);
    let secret = token.rsplit('.').next().expect("secret");
    assert!(list.contains("carol") && !list.contains(secret), "{list}");
    let id = token.split(':').nth(2).and_then(|s| s.split('.').next()).expect("id");
    let (code, _, err) = run(&["token", "revoke", id, "--state-dir", &state_arg]);
    assert_eq!(code, Some(0), "{err}");
    let (code, _, err) = run(&["status", "--coordinator", &url, "--token-file", &carol]);
    assert_eq!(code, Some(1));
    assert!(err.contains("unknown or revoked"), "{err}");
    // The coordinator's log, at debug level, never shows a secret.
    drop(procs);
    let log = std::fs::read_to_string(dir.join("coordinator.log")).expect("log");
    assert!(log.contains("call refused"), "{log}");
    for role in ["admin", "worker", "client"] {
        let t = std::fs::read_to_string(file(role)).expect("token");
        assert!(!log.contains(t.trim().rsplit('.').next().unwrap()), "a {role} secret was logged");
    }
    assert!(!log.contains(secret), "a secret was logged");
}

#[test]
fn status_prints_json_for_scripts_and_redraws_in_place_with_watch() {
    let tmp = tempfile::Builder::new().prefix("farm-procs-status-").tempdir().expect("temp dir");
    let dir = tmp.path();
    let state = dir.join("state");
    let mut procs = Procs(Vec::new());
    let url = start_coordinator(&mut procs, &state);
    let client = token_file(&state, "client").to_string_lossy().into_owned();
    let (code, out, err) =
        run(&["status", "--json", "--coordinator", &url, "--token-file", &client]);
    assert_eq!(code, Some(0), "{err}");
    let v: serde_json::Value = serde_json::from_str(out.trim()).expect("one JSON object");
    assert!(v["jobs"].as_array().is_some() && v["workers"].as_array().is_some(), "{v}");
    // --watch redraws until interrupted; SIGINT ends it cleanly.
    let child = farm()
        .args(["status", "--watch", "0.2", "--coordinator", &url, "--token-file", &client])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("farm status --watch");
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let _ = std::process::Command::new("kill").args(["-INT", &child.id().to_string()]).status();
    let out = child.wait_with_output().expect("wait");
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    let redraws = text.matches("\x1b[H\x1b[2J").count();
    assert!(redraws >= 3, "{redraws} redraws in 1.5 s at 0.2 s: {text}");
    assert!(text.matches("tiles done").count() == redraws, "each redraw holds the tables");
    let (code, _, err) =
        run(&["status", "--watch", "0", "--coordinator", &url, "--token-file", &client]);
    assert_eq!(code, Some(2), "{err}");
    drop(procs);
}
