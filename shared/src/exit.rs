//! How every fusion binary ends (`fusiond`, `fusion-bridge`, `fusion-sim`,
//! `fusionctl`, `fusion-demo`): one exit-status policy and one error line.
//!
//! | status | meaning |
//! |---|---|
//! | [`SUCCESS`] (0) | the job was done |
//! | [`FAILURE`] (1) | it was not: the one line on stderr says why |
//! | [`USAGE`] (2) | invalid arguments, refused before anything started |
//! | [`NO_STATE_YET`] (3) | `fusionctl state`: fusiond runs but has published no snapshot yet |
//! | [`DAMAGED`] (4) | the input (a bag, a recording) is damaged: what could be read was processed and its output written; stderr names the damage and what was lost |
//! | [`INTERRUPTED`] (130) | stopped by SIGINT or SIGTERM before the job was done (the shells' status for Ctrl-C); stderr says how far it got |

/// The job was done.
pub const SUCCESS: u8 = 0;
/// The job failed; the error line says why.
pub const FAILURE: u8 = 1;
/// Invalid arguments (an unknown option, a bad value, a path-like namespace),
/// refused before anything started: clap's status for a usage error.
pub const USAGE: u8 = 2;
/// `fusionctl state`: fusiond runs in the namespace but has published no
/// snapshot yet (it has had no input); try again, or give `--wait`.
pub const NO_STATE_YET: u8 = 3;

/// The input (a bag, a recording) is damaged: the readable part was read and
/// its output written; the error line names the damage and what was lost.
pub const DAMAGED: u8 = 4;

/// Stopped by SIGINT or SIGTERM before the job was done, as shells report a
/// command ended by Ctrl-C (128 + 2).
pub const INTERRUPTED: u8 = 130;

/// The error a tool ends with when a signal stopped it before its job was
/// done ([`INTERRUPTED`]): what it did up to there.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct Interrupted(pub String);

/// The error a tool ends with when its input was damaged ([`DAMAGED`]): it
/// did its job on the readable part, and says what was lost.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct InputDamaged(pub String);

/// The exit status of a run that ended with `error`: [`DAMAGED`] when an
/// [`InputDamaged`] is among its causes, [`INTERRUPTED`] for an
/// [`Interrupted`], else [`FAILURE`].
pub fn status_of(error: &(dyn std::error::Error + 'static)) -> u8 {
    let mut next = Some(error);
    while let Some(e) = next {
        if e.is::<InputDamaged>() {
            return DAMAGED;
        }
        if e.is::<Interrupted>() {
            return INTERRUPTED;
        }
        next = e.source();
    }
    FAILURE
}

/// `error` and its causes on one line, `what: why: deeper cause`, each text
/// once: a cause whose text the line already holds (an error that prints its
/// source in its own message, as many do) is not repeated, and line breaks
/// inside a message become spaces.
pub fn error_line(error: &(dyn std::error::Error + 'static)) -> String {
    let mut line = String::new();
    let mut next = Some(error);
    while let Some(e) = next {
        let text = e.to_string().split_whitespace().collect::<Vec<_>>().join(" ");
        if !text.is_empty() && !line.contains(&text) {
            if !line.is_empty() {
                line.push_str(": ");
            }
            line.push_str(&text);
        }
        next = e.source();
    }
    line
}

#[cfg(test)]
mod tests {
    use super::error_line;

    #[derive(Debug)]
    struct Wrap(&'static str, Option<Box<dyn std::error::Error + 'static>>);
    impl std::fmt::Display for Wrap {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str(self.0)
        }
    }
    impl std::error::Error for Wrap {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            self.1.as_deref()
        }
    }

    #[test]
    fn each_cause_once_on_one_line() {
        let io = || std::io::Error::from(std::io::ErrorKind::NotFound);
        let io_text = io().to_string();
        // A message that already holds its source's text (thiserror's "{0}" with #[from]).
        let doubled = Wrap("cannot read config /x: entity not found", Some(Box::new(io())));
        assert_eq!(error_line(&doubled), format!("cannot read config /x: {io_text}"));
        let chained = Wrap("outer", Some(Box::new(Wrap("middle\n  wrapped", Some(Box::new(io()))))));
        assert_eq!(error_line(&chained), format!("outer: middle wrapped: {io_text}"));
    }
}
