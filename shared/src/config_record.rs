//! The configuration fusiond runs with, as it publishes it on `<ns>/config`
//! (history 1, once at start): the text of its configuration file, its version
//! and the wire version of its snapshots. `fusionctl record` keeps it with a run
//! (the MCAP metadata `fusion.config`), and `fusiond replay` replays the run with
//! it unless given another.

use iceoryx2::prelude::ZeroCopySend;

use crate::StateSnapshot;

/// Longest configuration text fusiond publishes, bytes (a longer one is not
/// published, and fusiond says so at start).
pub const MAX_CONFIG_TEXT: usize = 32 * 1024;
/// Longest version text.
pub const MAX_VERSION: usize = 64;

/// The name of the MCAP metadata record that holds the configuration of a run.
pub const METADATA_NAME: &str = "fusion.config";
/// Its keys: the TOML text, fusiond's version, the snapshot wire type name.
pub const METADATA_TOML: &str = "toml";
/// See [`METADATA_TOML`].
pub const METADATA_VERSION: &str = "fusiond_version";
/// See [`METADATA_TOML`].
pub const METADATA_WIRE: &str = "snapshot_wire";

/// The snapshot wire type name of this build (`fusion.StateSnapshot.vN`).
pub fn snapshot_wire() -> &'static str {
    // SAFETY: `type_name` only reads the name set by `#[type_name]`.
    unsafe { <StateSnapshot as ZeroCopySend>::type_name() }
}

/// fusiond's configuration text and version (see the module docs).
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("fusion.ConfigRecord.v1")]
#[repr(C)]
pub struct ConfigRecord {
    /// Bytes of `text` in use.
    pub text_len: u32,
    /// Bytes of `version` in use.
    pub version_len: u32,
    /// fusiond's version (UTF-8).
    pub version: [u8; MAX_VERSION],
    /// The configuration file's text (UTF-8 TOML).
    pub text: [u8; MAX_CONFIG_TEXT],
}

impl ConfigRecord {
    /// A record of `text` and `version`; `None` when either is too long.
    pub fn new(text: &str, version: &str) -> Option<Self> {
        if text.len() > MAX_CONFIG_TEXT || version.len() > MAX_VERSION {
            return None;
        }
        let mut r = Self {
            text_len: text.len() as u32,
            version_len: version.len() as u32,
            version: [0; MAX_VERSION],
            text: [0; MAX_CONFIG_TEXT],
        };
        r.text[..text.len()].copy_from_slice(text.as_bytes());
        r.version[..version.len()].copy_from_slice(version.as_bytes());
        Some(r)
    }

    /// The configuration text, if it is valid UTF-8 of a valid length.
    pub fn text(&self) -> Option<&str> {
        std::str::from_utf8(self.text.get(..self.text_len as usize)?).ok()
    }

    /// fusiond's version, if valid.
    pub fn version(&self) -> Option<&str> {
        std::str::from_utf8(self.version.get(..self.version_len as usize)?).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_gives_back_its_text_and_refuses_what_does_not_fit() {
        let r = ConfigRecord::new("[model]\nkind = \"ins\"\n", "0.1.0").unwrap();
        assert_eq!((r.text(), r.version()), (Some("[model]\nkind = \"ins\"\n"), Some("0.1.0")));
        assert!(ConfigRecord::new(&"x".repeat(MAX_CONFIG_TEXT + 1), "0.1.0").is_none());
        let garbled = ConfigRecord { text_len: u32::MAX, ..r };
        assert_eq!(garbled.text(), None);
        assert!(snapshot_wire().starts_with("fusion.StateSnapshot.v"));
    }
}
