//! LMS 2xx telegrams (PROTOCOL.md). Work in progress.
