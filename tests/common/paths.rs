//! Where the repository's files are, for tests run from any directory.

use std::path::Path;

/// The repository's root (the crate's manifest directory).
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A repository file's path as a command-line argument.
pub fn repo_file(path: &str) -> String {
    root()
        .join(path)
        .to_str()
        .expect("a UTF-8 path")
        .to_string()
}
