//! Background work. Long steps (chessboard detection, calibration, the HDR merge) run on a
//! thread so the window stays responsive; the tab polls its job every frame, shows the progress
//! and can cancel it. A panic on the thread becomes an error message, never a crash.

use anyhow::{Result, anyhow};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::thread::JoinHandle;

/// Progress shared between a job and the window.
#[derive(Debug, Default)]
pub struct Progress {
    done: AtomicUsize,
    total: AtomicUsize,
    cancel: AtomicBool,
}

impl Progress {
    /// Sets the number of steps done and the total (0 when unknown).
    pub fn set(&self, done: usize, total: usize) {
        self.done.store(done, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
    }

    /// `(done, total)`.
    pub fn get(&self) -> (usize, usize) {
        (self.done.load(Ordering::Relaxed), self.total.load(Ordering::Relaxed))
    }

    /// True once the user asked to stop; the job should return soon.
    pub fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
}

/// A step running on its own thread.
pub struct Job<T> {
    handle: Option<JoinHandle<Result<T>>>,
    progress: Arc<Progress>,
    /// What it does, for the window ("Detecting corners").
    pub what: String,
    cancellable: bool,
}

impl<T: Send + 'static> Job<T> {
    /// Starts `work` on a thread; `ctx` (when given) is asked to repaint when it ends.
    pub fn spawn(what: impl Into<String>, ctx: Option<egui::Context>, work: impl FnOnce(&Progress) -> Result<T> + Send + 'static) -> Self {
        let progress = Arc::new(Progress::default());
        let p = progress.clone();
        let handle = std::thread::spawn(move || {
            let r = work(&p);
            if let Some(ctx) = ctx {
                ctx.request_repaint();
            }
            r
        });
        Self { handle: Some(handle), progress, what: what.into(), cancellable: false }
    }

    /// Offers a Cancel button (for work that checks [`Progress::cancelled`]).
    pub fn cancellable(mut self) -> Self {
        self.cancellable = true;
        self
    }

    /// The result once the job has ended.
    pub fn poll(&mut self) -> Option<Result<T>> {
        if self.handle.as_ref().is_some_and(|h| h.is_finished()) { Some(self.join()) } else { None }
    }

    /// Waits for the job to end.
    #[cfg(test)]
    pub fn wait(mut self) -> Result<T> {
        self.join()
    }

    fn join(&mut self) -> Result<T> {
        let what = self.what.clone();
        match self.handle.take() {
            Some(h) => h.join().unwrap_or_else(|panic| {
                let msg = panic.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| panic.downcast_ref::<String>().cloned()).unwrap_or_default();
                Err(anyhow!("{what} stopped unexpectedly: {msg}"))
            }),
            None => Err(anyhow!("{what}: already finished")),
        }
    }

    /// Asks the job to stop.
    pub fn cancel(&self) {
        self.progress.cancel.store(true, Ordering::Relaxed);
    }

    /// Shows a progress bar (and a Cancel button when the work can stop); asks for a repaint so the job is polled.
    pub fn progress_ui(&self, ui: &mut egui::Ui) {
        let (done, total) = self.progress.get();
        ui.horizontal(|ui| {
            ui.spinner();
            let text = if total > 0 { format!("{} {done}/{total}", self.what) } else { format!("{}…", self.what) };
            let frac = if total > 0 { done as f32 / total as f32 } else { 0.0 };
            ui.add(egui::ProgressBar::new(frac).text(text).desired_width(220.0));
            if self.cancellable && ui.button("Cancel").clicked() {
                self.cancel();
            }
        });
        ui.ctx().request_repaint_after(std::time::Duration::from_millis(100));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_errors_and_panics_come_back() {
        assert_eq!(Job::spawn("adding", None, |_| Ok(2 + 2)).wait().unwrap(), 4);
        let e = Job::<()>::spawn("failing", None, |_| Err(anyhow!("bad input"))).wait().unwrap_err();
        assert_eq!(e.to_string(), "bad input");
        let e = Job::<()>::spawn("merging", None, |_| panic!("index out of bounds")).wait().unwrap_err();
        assert!(e.to_string().contains("merging stopped unexpectedly: index out of bounds"), "{e}");
    }
}
