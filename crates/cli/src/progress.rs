use indicatif::{ProgressBar, ProgressStyle};

/// A bar on stderr that follows a job's named steps (hidden when stderr is not a terminal).
pub fn bar(len: u64) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:30} {percent:>3}% {msg}")
            .expect("template is valid"),
    );
    bar
}
