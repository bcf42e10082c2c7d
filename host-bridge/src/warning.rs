//! Warnings on stderr, for every command alike.

use std::io::Write as _;

/// A warning on stderr; a closed stderr (a hung-up terminal) is ignored
/// rather than a panic.
pub fn warn(message: &str) {
    let _ = writeln!(std::io::stderr(), "host-bridge: warning: {message}");
}

/// The warnings about one input: the first [`Limited::SHOWN`] printed,
/// the rest counted and summed up in one line ([`Limited::finish`]), so a
/// badly damaged file cannot flood the terminal.
#[derive(Clone, Debug, Default)]
pub struct Limited {
    shown: usize,
    hidden: usize,
}

impl Limited {
    /// Warnings printed before the rest are only counted.
    pub const SHOWN: usize = 10;

    /// Print `message` as a warning, or count it once [`Limited::SHOWN`]
    /// have been printed.
    pub fn warn(&mut self, message: &str) {
        if self.shown < Self::SHOWN {
            warn(message);
            self.shown += 1;
        } else {
            self.hidden += 1;
        }
    }

    /// Count `n` warnings that are not printed.
    pub fn hide(&mut self, n: usize) {
        self.hidden += n;
    }

    /// Warnings given so far, printed or not.
    pub fn count(&self) -> usize {
        self.shown + self.hidden
    }

    /// Say how many warnings were not printed (once), naming the input.
    pub fn finish(&mut self, input: &str) {
        if self.hidden > 0 {
            warn(&format!(
                "{input}: {} more warnings like these not shown",
                self.hidden
            ));
            self.shown += self.hidden;
            self.hidden = 0;
        }
    }
}
