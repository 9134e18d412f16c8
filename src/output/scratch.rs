//! What the writers' tests share: a fresh folder with a file's path in it, and a link
//! planted at that path to a file outside, which a write must replace, not follow.

use std::fs;
use std::path::PathBuf;
use tempfile::TempDir;

/// A fresh folder (removed when the guard drops) and the path of `name` in it.
pub fn scratch(name: &str) -> (TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    (dir, path)
}

/// A link at `path` in a fresh folder to `target`, a file outside holding "keep".
#[cfg(unix)]
pub struct Planted {
    _outside: TempDir,
    pub dir: TempDir,
    pub target: PathBuf,
    pub path: PathBuf,
}

#[cfg(unix)]
impl Planted {
    pub fn new(name: &str) -> Self {
        let (outside, target) = scratch("precious");
        fs::write(&target, "keep").unwrap();
        let (dir, path) = scratch(name);
        std::os::unix::fs::symlink(&target, &path).unwrap();
        Self {
            _outside: outside,
            dir,
            target,
            path,
        }
    }

    /// The write replaced the link with a file and left its target as it was.
    pub fn assert_replaced(&self) {
        assert_eq!(fs::read_to_string(&self.target).unwrap(), "keep");
        assert!(!fs::symlink_metadata(&self.path).unwrap().is_symlink());
    }
}
