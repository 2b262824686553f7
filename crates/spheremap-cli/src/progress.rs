//! Waiting for long work: a progress bar on stderr (after a moment), and Ctrl-C turned into
//! the core's cancel flag so the work stops cleanly and nothing is written.

use spheremap::resample::Progress;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Set by the binary's Ctrl-C handler (or the Python console script on KeyboardInterrupt).
pub static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Installs the Ctrl-C handler of the `spheremap` binary: the first Ctrl-C cancels the work in
/// progress (the command then reports it and exits 2 without writing); a second one exits.
pub fn install_ctrlc() {
    let _ = ctrlc::set_handler(|| {
        if INTERRUPTED.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
    });
}

/// Runs `work` on a thread of its own with a fresh [`Progress`] and waits for it as [`watch`]
/// does; a panic in the work is resumed here (the binary reports it in one line).
pub fn run<T: Send>(show: bool, what: &str, work: impl FnOnce(&Progress) -> T + Send) -> T {
    let p = Progress::default();
    std::thread::scope(|s| {
        let handle = s.spawn(|| work(&p));
        watch(&p, &handle, show, what);
        handle
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    })
}

/// Waits for `work`, forwarding Ctrl-C to `p.cancel`; shows a bar when `show` and the work
/// takes more than 0.4 s.
pub fn watch<T>(p: &Progress, work: &std::thread::ScopedJoinHandle<'_, T>, show: bool, what: &str) {
    use indicatif::{ProgressBar, ProgressStyle};
    let start = Instant::now();
    let mut bar: Option<ProgressBar> = None;
    while !work.is_finished() {
        std::thread::sleep(Duration::from_millis(20));
        if INTERRUPTED.load(Ordering::Relaxed) {
            p.cancel.store(true, Ordering::Relaxed);
        }
        if !show {
            continue;
        }
        if bar.is_none() && start.elapsed().as_millis() > 400 {
            let b = ProgressBar::new(p.total.load(Ordering::Relaxed).max(1) as u64);
            let template =
                format!("{{spinner}} {what} [{{bar:40}}] {{pos}}/{{len}} rows, {{eta}} left");
            b.set_style(
                ProgressStyle::with_template(&template)
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar = Some(b);
        }
        if let Some(b) = &bar {
            b.set_length(p.total.load(Ordering::Relaxed).max(1) as u64);
            b.set_position(p.done.load(Ordering::Relaxed) as u64);
        }
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
}
