//! `--link PATH`: a symbolic link to the pty's slave device.

use std::path::{Path, PathBuf};

use anyhow::{ensure, Context, Result};

/// A symbolic link to the slave device, removed when dropped.
pub(crate) struct Symlink {
    pub(crate) path: PathBuf,
    target: PathBuf,
}

impl Symlink {
    pub(crate) fn create(path: &Path, target: &Path) -> Result<Symlink> {
        if let Ok(meta) = std::fs::symlink_metadata(path) {
            ensure!(
                meta.file_type().is_symlink(),
                "--link {}: exists and is not a symbolic link",
                path.display()
            );
            std::fs::remove_file(path)
                .with_context(|| format!("cannot replace {}", path.display()))?;
        }
        std::os::unix::fs::symlink(target, path)
            .with_context(|| format!("cannot create the link {}", path.display()))?;
        Ok(Symlink {
            path: path.to_path_buf(),
            target: target.to_path_buf(),
        })
    }
}

impl Drop for Symlink {
    fn drop(&mut self) {
        // Only if it still points at our device.
        if std::fs::read_link(&self.path).is_ok_and(|t| t == self.target) {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}
