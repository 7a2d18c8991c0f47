//! Where ferrobot keeps what it computes once and reuses between runs
//! (sphere models, generated object meshes): the one folder rule.
//!
//! The root is `$FERROBOT_CACHE_DIR`, else `$XDG_CACHE_HOME/ferrobot`, else
//! `$HOME/.cache/ferrobot`; each kind of entry has its own subfolder
//! (`spheres`, `objects`). `FERROBOT_CACHE_DIR=off` (or no home) means no
//! disk cache: callers keep what they need in memory or in a temporary
//! folder of their own.

use std::path::PathBuf;

/// The cache's root folder, or `None` when the disk cache is off
/// (`FERROBOT_CACHE_DIR=off`) or no folder can be named (no `HOME`).
/// Empty variables count as unset. The folder is not created here.
pub fn cache_root() -> Option<PathBuf> {
    match std::env::var_os("FERROBOT_CACHE_DIR") {
        Some(d) if d == "off" => None,
        Some(d) if !d.is_empty() => Some(PathBuf::from(d)),
        _ => match std::env::var_os("XDG_CACHE_HOME") {
            Some(d) if !d.is_empty() => Some(PathBuf::from(d).join("ferrobot")),
            _ => match std::env::var_os("HOME") {
                Some(h) if !h.is_empty() => Some(PathBuf::from(h).join(".cache").join("ferrobot")),
                _ => None,
            },
        },
    }
}

/// The subfolder `kind` (e.g. `"spheres"`, `"objects"`) of [`cache_root`],
/// or `None` when the disk cache is off.
pub fn cache_dir(kind: &str) -> Option<PathBuf> {
    cache_root().map(|r| r.join(kind))
}
