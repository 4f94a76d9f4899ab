//! Work the editor runs on a thread of its own (exports, reference runs):
//! progress while it runs, a result or a reason at the end, and cancel.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, channel};
use std::time::Instant;

/// News from a job.
enum News<T> {
    Progress(usize),
    Finished(Result<T, String>),
}

/// A job on its own thread producing a `T`.
pub struct Job<T> {
    news: Receiver<News<T>>,
    cancel: Arc<AtomicBool>,
    /// Units of work done so far (frames).
    pub done: usize,
    /// Units of work in all.
    pub total: usize,
    /// When it started.
    started: Instant,
}

impl<T: Send + 'static> Job<T> {
    /// Starts `work` on a thread: it gets the cancel flag to watch and a
    /// callback to report the units done, and returns its result or why it
    /// stopped.
    pub fn start(
        total: usize,
        work: impl FnOnce(&AtomicBool, &dyn Fn(usize)) -> Result<T, String> + Send + 'static,
    ) -> Job<T> {
        let (sender, news) = channel();
        let cancel = Arc::new(AtomicBool::new(false));
        let stop = cancel.clone();
        std::thread::spawn(move || {
            let progress = |done| {
                let _ = sender.send(News::Progress(done));
            };
            let result = work(&stop, &progress);
            let result = match result {
                Ok(_) if stop.load(Ordering::Relaxed) => Err("cancelled".to_owned()),
                other => other,
            };
            let _ = sender.send(News::Finished(result));
        });
        Job { news, cancel, done: 0, total, started: Instant::now() }
    }

    /// Asks the job to stop after the unit in progress.
    pub fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }

    /// Whether the user asked the job to stop.
    pub fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    /// Seconds left at the pace so far, once a unit is done.
    pub fn time_left_s(&self) -> Option<f64> {
        let done = self.done.min(self.total);
        (done > 0).then(|| self.started.elapsed().as_secs_f64() / done as f64 * (self.total - done) as f64)
    }

    /// Takes in the news: the result once the job has finished.
    pub fn poll(&mut self) -> Option<Result<T, String>> {
        for news in self.news.try_iter() {
            match news {
                News::Progress(done) => self.done = done,
                News::Finished(result) => return Some(result),
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Polls `job` until it has finished.
    fn finished<T: Send + 'static>(job: &mut Job<T>) -> Result<T, String> {
        loop {
            if let Some(result) = job.poll() {
                return result;
            }
            std::thread::yield_now();
        }
    }

    #[test]
    fn a_job_reports_progress_then_its_result_and_stops_when_cancelled() {
        let mut job = Job::start(3, |_, progress| {
            (1..=3).for_each(progress);
            Ok(42)
        });
        let result = finished(&mut job);
        assert_eq!((result, job.done), (Ok(42), 3));
        let (gate, wait) = channel::<()>();
        let mut job = Job::start(1, move |stop, _| {
            let _ = wait.recv();
            Ok(stop.load(Ordering::Relaxed))
        });
        job.cancel();
        drop(gate);
        assert_eq!(finished(&mut job), Err("cancelled".to_owned()), "a cancelled job never reports success");
    }
}
