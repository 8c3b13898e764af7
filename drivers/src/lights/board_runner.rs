//! Runs a simulated [`Board`] on a [`Port`] in a thread, as a real board
//! runs its firmware on the other end of the cable.
//!
//! Boundaries: moves bytes and time; the behaviour is `super::board`'s. The
//! board is shared behind a mutex so tests and the simulated rig can read
//! what the lights really emit.

use super::board::Board;
use super::port::Port;
use super::wire::LineBuffer;
use std::io::ErrorKind;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// A board running in its own thread; stops when dropped or when the host
/// end of the port closes.
pub struct RunningBoard {
    board: Arc<Mutex<Board>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl RunningBoard {
    /// Powers `board` on (it prints READY) and serves `port`.
    pub fn spawn(mut port: Box<dyn Port>, board: Board) -> RunningBoard {
        let board = Arc::new(Mutex::new(board));
        let stop = Arc::new(AtomicBool::new(false));
        let (b, s) = (board.clone(), stop.clone());
        let thread = std::thread::spawn(move || serve(port.as_mut(), &b, &s));
        RunningBoard {
            board,
            stop,
            thread: Some(thread),
        }
    }

    /// The board's state now.
    pub fn board(&self) -> MutexGuard<'_, Board> {
        // A panic in the serving thread leaves a consistent board (every
        // mutation is a plain assignment), so a poisoned lock is still
        // readable.
        self.board.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// A handle to the shared board, for readers outliving this borrow.
    pub fn shared(&self) -> Arc<Mutex<Board>> {
        self.board.clone()
    }
}

impl Drop for RunningBoard {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn serve(port: &mut dyn Port, board: &Mutex<Board>, stop: &AtomicBool) {
    let lock = || board.lock().unwrap_or_else(|p| p.into_inner());
    let banner = lock().boot();
    if port.write_all(banner.as_bytes()).is_err() {
        return;
    }
    if port.set_read_timeout(Duration::from_millis(5)).is_err() {
        return;
    }
    let mut lines = LineBuffer::default();
    let mut buf = [0u8; 256];
    while !stop.load(Ordering::Relaxed) {
        match port.read(&mut buf) {
            Ok(0) => return,
            Ok(n) => lines.push(&buf[..n]),
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
                ) => {}
            Err(_) => return,
        }
        while let Some(line) = lines.pop() {
            let replies = lock().on_line(&line, Instant::now());
            for r in replies {
                if port.write_all(r.as_bytes()).is_err() {
                    return;
                }
            }
        }
        lock().tick(Instant::now());
    }
}
