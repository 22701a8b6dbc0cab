//! What a user meets first, as one test binary: the exit statuses of every
//! binary, and an application outside the workspace built against the client.

#[path = "../common/mod.rs"]
mod common;

mod exit_status;
mod external_app;
