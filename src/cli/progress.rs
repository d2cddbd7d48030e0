//! The terminal's [`Observer`]: an indicatif progress bar on stderr when it is a terminal;
//! otherwise nothing, or with [`Bar::heartbeat`] a line every ten steps of each kind, so a long
//! run in a log (CI) shows it is alive.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::Instant;
use tactus::work::Observer;

/// A progress bar drawn with `template` (indicatif's) when stderr is a terminal.
pub struct Bar {
    bar: ProgressBar,
    heartbeat: Option<(Mutex<BTreeMap<String, u64>>, Instant)>,
}

impl Bar {
    /// A bar with `template`, hidden unless stderr is a terminal.
    pub fn new(template: &str) -> Self {
        let bar = ProgressBar::new(0);
        if std::io::stderr().is_terminal() {
            bar.set_style(ProgressStyle::with_template(template).expect("valid template"));
        } else {
            bar.set_draw_target(ProgressDrawTarget::hidden());
        }
        Self { bar, heartbeat: None }
    }

    /// Whether the bar is drawn (stderr is a terminal).
    pub fn visible(&self) -> bool {
        !self.bar.is_hidden()
    }

    /// Without a terminal, prints "  WHAT: N done (S s)" every ten steps of each kind.
    pub fn heartbeat(mut self) -> Self {
        if !self.visible() {
            self.heartbeat = Some((Mutex::new(BTreeMap::new()), Instant::now()));
        }
        self
    }

    /// Removes the bar from the terminal.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

impl Observer for Bar {
    fn started(&self, total: u64) {
        self.bar.set_length(total);
    }

    fn advanced(&self, what: &str, steps: u64) {
        self.bar.set_message(what.to_owned());
        self.bar.inc(steps);
        if let Some((counts, started)) = &self.heartbeat {
            let mut c = counts.lock().unwrap_or_else(|e| e.into_inner());
            let n = c.entry(what.to_owned()).or_insert(0);
            *n += steps;
            if n.is_multiple_of(10) {
                eprintln!("  {what}: {n} done ({:.0} s)", started.elapsed().as_secs_f64());
            }
        }
    }

    fn stage(&self, what: &str) {
        if self.bar.is_hidden() {
            eprintln!("{what}");
        } else {
            self.bar.println(what);
        }
    }
}
