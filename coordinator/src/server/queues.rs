//! The event loop's two queues: requests from clients and pages go ahead
//! of the workers' messages.

use super::events::Event;
use tokio::sync::mpsc;

impl Event {
    /// Whether the event comes from the workers' side: their streams, the
    /// tick that judges them and the shutdown, which must come after the
    /// messages queued before them (a tick ahead of a worker's queued
    /// results could find it silent). The live previews' tick and the
    /// gauges' refresh are requests: they only read what is there.
    fn is_workers_side(&self) -> bool {
        matches!(
            self,
            Event::WorkerJoined { .. }
                | Event::FromWorker { .. }
                | Event::WorkerGone { .. }
                | Event::Tick
                | Event::Shutdown
        )
    }
}

/// Where events are sent: two queues, so that a request from a client or
/// a page (a status, a cancel, a watch, a dashboard look) does not wait
/// behind every worker message already queued. Under load the loop has
/// thousands of results waiting; each queue keeps its own order.
#[derive(Clone, Debug)]
pub struct EventTx {
    requests: mpsc::UnboundedSender<Event>,
    workers: mpsc::UnboundedSender<Event>,
}

impl EventTx {
    /// Queues `ev` on its side's queue.
    pub fn send(&self, ev: Event) -> Result<(), mpsc::error::SendError<Event>> {
        if ev.is_workers_side() {
            self.workers.send(ev)
        } else {
            self.requests.send(ev)
        }
    }
}

/// The loop's end of [`EventTx`].
#[derive(Debug)]
pub struct EventRx {
    requests: mpsc::UnboundedReceiver<Event>,
    workers: mpsc::UnboundedReceiver<Event>,
    /// Whether each queue still has senders.
    open: (bool, bool),
    /// Requests taken since the last worker message.
    in_a_row: u32,
}

/// At most this many requests are taken while a worker message waits, so
/// a flood of requests slows the farm's work but does not stop it.
const REQUESTS_IN_A_ROW: u32 = 32;

impl EventRx {
    /// The next event, a waiting request first (but a waiting worker
    /// message after [`REQUESTS_IN_A_ROW`] requests); `None` once every
    /// sender of both queues is gone. Cancel-safe, as each queue's `recv` is.
    pub async fn recv(&mut self) -> Option<Event> {
        if self.in_a_row >= REQUESTS_IN_A_ROW {
            if let Ok(ev) = self.workers.try_recv() {
                self.in_a_row = 0;
                return Some(ev);
            }
        }
        loop {
            tokio::select! {
                biased;
                ev = self.requests.recv(), if self.open.0 => match ev {
                    Some(ev) => {
                        self.in_a_row += 1;
                        return Some(ev);
                    }
                    None => self.open.0 = false,
                },
                ev = self.workers.recv(), if self.open.1 => match ev {
                    Some(ev) => {
                        self.in_a_row = 0;
                        return Some(ev);
                    }
                    None => self.open.1 = false,
                },
                else => return None,
            }
        }
    }
}

/// A new pair of event queues.
pub fn channel() -> (EventTx, EventRx) {
    let (requests, requests_rx) = mpsc::unbounded_channel();
    let (workers, workers_rx) = mpsc::unbounded_channel();
    let rx =
        EventRx { requests: requests_rx, workers: workers_rx, open: (true, true), in_a_row: 0 };
    (EventTx { requests, workers }, rx)
}

#[cfg(test)]
mod tests {
    use super::*;
    use farm_common::ids::{JobId, WorkerId};
    use tokio::sync::oneshot;

    fn cancel(job: u64) -> Event {
        Event::Cancel { job: JobId(job), reply: oneshot::channel().0 }
    }

    fn label(ev: &Event) -> String {
        match ev {
            Event::Cancel { job, .. } => format!("cancel {}", job.0),
            Event::WorkerGone { id } => format!("gone {}", id.0),
            Event::Tick => "tick".into(),
            _ => "other".into(),
        }
    }

    /// A waiting request is taken before any worker message, each queue
    /// in its own order (a tick stays behind the messages before it), and
    /// the queues end once every sender is gone.
    #[tokio::test]
    async fn requests_go_first_and_each_queue_keeps_its_order() {
        let (tx, mut rx) = channel();
        tx.send(Event::WorkerGone { id: WorkerId(1) }).unwrap();
        tx.send(Event::Tick).unwrap();
        tx.send(cancel(7)).unwrap();
        tx.send(Event::WorkerGone { id: WorkerId(2) }).unwrap();
        tx.send(cancel(8)).unwrap();
        let copy = tx.clone();
        drop(tx);
        copy.send(Event::WorkerGone { id: WorkerId(3) }).unwrap();
        drop(copy);
        let mut seen = Vec::new();
        while let Some(ev) = rx.recv().await {
            seen.push(label(&ev));
        }
        let want = ["cancel 7", "cancel 8", "gone 1", "tick", "gone 2", "gone 3"];
        assert_eq!(seen, want);
    }

    /// A flood of requests lets a waiting worker message through after
    /// at most `REQUESTS_IN_A_ROW` of them.
    #[tokio::test]
    async fn a_flood_of_requests_does_not_stop_the_workers_messages() {
        let (tx, mut rx) = channel();
        for job in 0..3 * REQUESTS_IN_A_ROW as u64 {
            tx.send(cancel(job)).unwrap();
        }
        tx.send(Event::WorkerGone { id: WorkerId(1) }).unwrap();
        let mut taken = 0;
        loop {
            let ev = rx.recv().await.unwrap();
            if matches!(ev, Event::WorkerGone { .. }) {
                break;
            }
            taken += 1;
        }
        assert_eq!(taken, REQUESTS_IN_A_ROW, "requests taken before the worker's message");
    }
}
