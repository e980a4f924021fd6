//! Files that appear complete or not at all: written under a temporary name in the same
//! directory and renamed onto their final name once everything is written and flushed
//! ([`AtomicFile`]). A run that is killed, or that fills the disk, never leaves a truncated
//! file under the final name (at most a `.NAME.tmp-PID` beside it, removed on error).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// A buffered file written under a temporary name (`.NAME.tmp-PID` in the same directory,
/// hence on the same file system, so that the final rename is atomic) and renamed onto its
/// final path by [`AtomicFile::commit`]. Dropped without `commit` (an error, a panic), it
/// removes its temporary file.
#[derive(Debug)]
pub struct AtomicFile {
    /// The final path.
    path: PathBuf,
    /// The temporary path the bytes go to until `commit`.
    temp: PathBuf,
    /// The writer; `None` once committed.
    writer: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Creates the temporary file for `path` (creating `path`'s directory if needed).
    pub fn create(path: &Path) -> std::io::Result<AtomicFile> {
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
        if let Some(dir) = dir {
            std::fs::create_dir_all(dir)?;
        }
        let name = path.file_name().ok_or_else(|| {
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("{} does not name a file", path.display()),
            )
        })?;
        let mut temp_name = std::ffi::OsString::from(".");
        temp_name.push(name);
        temp_name.push(format!(".tmp-{}", std::process::id()));
        let temp = match dir {
            Some(dir) => dir.join(temp_name),
            None => PathBuf::from(temp_name),
        };
        let file = File::create(&temp)?;
        Ok(AtomicFile {
            path: path.to_path_buf(),
            temp,
            writer: Some(BufWriter::new(file)),
        })
    }

    /// The final path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Flushes, syncs the data to the disk and renames the file onto its final path. On error
    /// the temporary file is removed and nothing is left under the final name.
    pub fn commit(mut self) -> std::io::Result<()> {
        let writer = self
            .writer
            .take()
            .expect("an uncommitted file has a writer");
        let result = (|| {
            let file = writer.into_inner().map_err(|e| e.into_error())?;
            file.sync_data()?;
            drop(file);
            std::fs::rename(&self.temp, &self.path)
        })();
        if result.is_err() {
            let _ = std::fs::remove_file(&self.temp);
        }
        result
    }

    /// Writes `bytes` to `path` through a temporary file (see [`AtomicFile`]).
    pub fn write(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
        let mut file = AtomicFile::create(path)?;
        file.write_all(bytes)?;
        file.commit()
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.writer
            .as_mut()
            .expect("an uncommitted file has a writer")
            .write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.writer
            .as_mut()
            .expect("an uncommitted file has a writer")
            .flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if let Some(writer) = self.writer.take() {
            // Not committed: the bytes never reach the final name.
            drop(writer.into_parts());
            let _ = std::fs::remove_file(&self.temp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("articula-atomic-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// Until `commit` the final name does not exist; after it, it holds every byte and the
    /// temporary file is gone.
    #[test]
    fn the_final_name_appears_only_complete() {
        let dir = scratch("commit");
        let path = dir.join("out.csv");
        let mut f = AtomicFile::create(&path).unwrap();
        f.write_all(b"a,b\n1,2\n").unwrap();
        f.flush().unwrap();
        assert!(!path.exists());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "a,b\n1,2\n");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    }

    /// A file dropped without `commit` (an error on the way) leaves nothing behind, and an
    /// earlier complete file under the final name is kept.
    #[test]
    fn an_uncommitted_file_leaves_nothing() {
        let dir = scratch("drop");
        let path = dir.join("frame.png");
        std::fs::write(&path, b"old").unwrap();
        let mut f = AtomicFile::create(&path).unwrap();
        f.write_all(&[7; 100_000]).unwrap();
        drop(f);
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    }
}
