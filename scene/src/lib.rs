//! Synthetic scenes (in progress).
