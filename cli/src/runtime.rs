//! The async runtime the network commands run on, and the signals that
//! stop them.

use std::process::ExitCode;

/// Runs `f` on a multi-threaded runtime.
pub fn block_on(f: impl std::future::Future<Output = ExitCode>) -> ExitCode {
    block_on_with(tokio::runtime::Builder::new_multi_thread(), f)
}

/// Runs `f` on a single-threaded runtime.
pub fn block_on_one_thread(f: impl std::future::Future<Output = ExitCode>) -> ExitCode {
    block_on_with(tokio::runtime::Builder::new_current_thread(), f)
}

fn block_on_with(
    mut runtime: tokio::runtime::Builder,
    f: impl std::future::Future<Output = ExitCode>,
) -> ExitCode {
    match runtime.enable_all().build() {
        Ok(rt) => rt.block_on(f),
        Err(e) => {
            eprintln!("error: cannot start the async runtime: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Completes on SIGINT or SIGTERM.
pub async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {}
        _ = term => {}
    }
}
