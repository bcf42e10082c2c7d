//! Warnings on stderr, for every command alike.

use std::io::Write as _;

/// A warning on stderr; a closed stderr (a hung-up terminal) is ignored
/// rather than a panic.
pub fn warn(message: &str) {
    let _ = writeln!(std::io::stderr(), "host-bridge: warning: {message}");
}
