//! Where an output may go, and how it gets there (docs/decisions/output-files.md).
//!
//! An output goes to a new path in an existing folder or replaces a regular file the user may
//! write; never a device, FIFO, socket, directory or symbolic link, never a read-only file.
//! Every file is staged as a temporary sibling and renamed into place; an [`OutputSet`] checks
//! all the paths of a command before any work, stages each file, and renames them all at the
//! end, so a failure leaves none of them.

use crate::error::FomError;
use std::io::Write;
use std::path::{Path, PathBuf};

/// What a file that is not a regular one is, in words ("a FIFO (named pipe)", ...).
pub fn kind_name(t: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
    }
    if t.is_dir() {
        "a directory"
    } else if t.is_symlink() {
        "a symbolic link"
    } else {
        "not a regular file"
    }
}

/// Whether nobody may write the file (no write bit at all): checked on the mode bits, so it
/// holds for root too, who may write anything.
fn is_read_only(p: &std::fs::Permissions) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        p.mode() & 0o222 == 0
    }
    #[cfg(not(unix))]
    {
        p.readonly()
    }
}

fn refused(who: &str, path: &Path, kind: std::io::ErrorKind, why: String) -> FomError {
    FomError::Io {
        context: if who.is_empty() {
            format!("writing {}", path.display())
        } else {
            format!("{who} {}", path.display())
        },
        source: std::io::Error::new(kind, why),
    }
}

/// Checks that `path` may receive an output (`who` names it in messages, e.g. a flag): a new
/// name in an existing folder, or a regular file with a write bit. Returns the existing
/// file's permissions, which the new file keeps.
pub fn check_output_path(path: &Path, who: &str) -> Result<Option<std::fs::Permissions>, FomError> {
    use std::io::ErrorKind;
    if path.file_name().is_none() {
        return Err(refused(
            who,
            path,
            ErrorKind::InvalidInput,
            "not a file name".into(),
        ));
    }
    let dir = parent_dir(path);
    match std::fs::metadata(dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => {
            return Err(refused(
                who,
                path,
                ErrorKind::InvalidInput,
                format!("{} is not a directory", dir.display()),
            ))
        }
        Err(e) => {
            return Err(refused(
                who,
                path,
                e.kind(),
                format!("folder {}: {e}", dir.display()),
            ))
        }
    }
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(refused(who, path, e.kind(), e.to_string())),
    };
    let t = meta.file_type();
    if t.is_symlink() {
        return Err(refused(
            who,
            path,
            ErrorKind::InvalidInput,
            "is a symbolic link; outputs are not written through links (give the path of \
             the file itself)"
                .into(),
        ));
    }
    if !t.is_file() {
        return Err(refused(
            who,
            path,
            ErrorKind::InvalidInput,
            format!(
                "is {}; an output goes to a regular file or a new path",
                kind_name(&t)
            ),
        ));
    }
    let perms = meta.permissions();
    if is_read_only(&perms) {
        return Err(refused(
            who,
            path,
            ErrorKind::PermissionDenied,
            "is read-only; it is not replaced (make it writable or choose another path)".into(),
        ));
    }
    Ok(Some(perms))
}

/// The folder of `path` (`.` for a bare name).
fn parent_dir(path: &Path) -> &Path {
    path.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// `path` with its folder resolved, to tell two spellings of one output apart.
fn identity(path: &Path) -> PathBuf {
    let dir = parent_dir(path);
    let dir = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    dir.join(path.file_name().unwrap_or_default())
}

/// A fresh temporary sibling of `path`: `.NAME.PID-CALL-NANOS.tmp`, unique per process, call
/// and time, so writers on several nodes of a shared file system (training shards) never
/// share one (`crate::output::remove_stale_temporaries` knows the pattern).
fn temporary_for(path: &Path) -> PathBuf {
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    parent_dir(path).join(format!(
        ".{}.{}-{call}-{nanos}.tmp",
        path.file_name().unwrap_or_default().to_string_lossy(),
        std::process::id()
    ))
}

/// One output of a set: where it goes, who named it, and its staged file once written.
struct Planned {
    path: PathBuf,
    who: String,
    identity: PathBuf,
    staged: Option<PathBuf>,
}

/// The outputs of one command, written all together or not at all: [`OutputSet::add`] checks
/// each path before any work (and refuses one path named twice), [`OutputSet::write`] stages a
/// file as a temporary sibling, [`OutputSet::commit`] renames them all into place. Dropped
/// without a commit, it removes what it staged.
#[derive(Default)]
pub struct OutputSet {
    planned: Vec<Planned>,
}

impl OutputSet {
    pub fn new() -> Self {
        Self::default()
    }

    /// Plans an output at `path`, named `who` in messages (a flag such as `--out`).
    pub fn add(&mut self, path: &Path, who: &str) -> Result<(), FomError> {
        check_output_path(path, who)?;
        let identity = identity(path);
        if let Some(other) = self.planned.iter().find(|p| p.identity == identity) {
            return Err(refused(
                who,
                path,
                std::io::ErrorKind::InvalidInput,
                format!(
                    "is also the path of {}; each output needs its own file",
                    if other.who.is_empty() {
                        "another output"
                    } else {
                        &other.who
                    }
                ),
            ));
        }
        self.planned.push(Planned {
            path: path.to_path_buf(),
            who: who.to_string(),
            identity,
            staged: None,
        });
        Ok(())
    }

    fn slot(&mut self, path: &Path) -> &mut Planned {
        self.planned
            .iter_mut()
            .find(|p| p.path == path)
            .expect("an output is added before it is written")
    }

    /// Stages the planned output `path` through a file writer on its temporary file.
    pub fn write(
        &mut self,
        path: &Path,
        write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> Result<(), FomError> {
        let tmp = temporary_for(path);
        let result = (|| {
            let file = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&tmp)?;
            let mut w = std::io::BufWriter::new(file);
            write(&mut w)?;
            w.flush()?;
            w.get_ref().sync_all()
        })();
        if let Err(e) = result {
            let _ = std::fs::remove_file(&tmp);
            return Err(FomError::Io {
                context: format!("writing {}", path.display()),
                source: e,
            });
        }
        self.slot(path).staged = Some(tmp);
        Ok(())
    }

    /// Stages the planned output `path` through a writer that takes a path (one that writes
    /// its own file, such as a plot): it writes the temporary file instead.
    pub fn write_with<E: From<FomError>>(
        &mut self,
        path: &Path,
        write: impl FnOnce(&Path) -> Result<(), E>,
    ) -> Result<(), E> {
        let tmp = temporary_for(path);
        if let Err(e) = write(&tmp) {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
        self.slot(path).staged = Some(tmp);
        Ok(())
    }

    /// Renames every staged file into place, each target checked again first (it may have
    /// changed while the command worked) and an existing file's permissions kept. Planned
    /// outputs that were not written are left alone.
    pub fn commit(mut self) -> Result<(), FomError> {
        let mut modes = Vec::new();
        for p in self.planned.iter().filter(|p| p.staged.is_some()) {
            modes.push(check_output_path(&p.path, &p.who)?);
        }
        let staged = self.planned.iter_mut().filter(|p| p.staged.is_some());
        for (p, mode) in staged.zip(modes) {
            let tmp = p.staged.take().expect("filtered on staged");
            let result = mode
                .map_or(Ok(()), |m| std::fs::set_permissions(&tmp, m))
                .and_then(|()| std::fs::rename(&tmp, &p.path));
            if let Err(e) = result {
                let _ = std::fs::remove_file(&tmp);
                return Err(FomError::Io {
                    context: format!("writing {}", p.path.display()),
                    source: e,
                });
            }
        }
        Ok(())
    }
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        for tmp in self.planned.iter().filter_map(|p| p.staged.as_ref()) {
            let _ = std::fs::remove_file(tmp);
        }
    }
}

/// Writes `path` atomically through a one-file [`OutputSet`]: checked, staged, renamed.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), FomError> {
    let mut set = OutputSet::new();
    set.add(path, "")?;
    set.write(path, write)?;
    set.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_links_and_other_kinds_and_read_only_files() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("target.csv");
        std::fs::write(&target, "keep").unwrap();
        let link = dir.path().join("link.csv");
        #[cfg(unix)]
        std::os::unix::fs::symlink(&target, &link).unwrap();
        #[cfg(unix)]
        assert!(write_atomic(&link, |w| writeln!(w, "x")).is_err());
        assert!(write_atomic(dir.path(), |w| writeln!(w, "x")).is_err());
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o444)).unwrap();
            let e = write_atomic(&target, |w| writeln!(w, "x")).unwrap_err();
            assert!(e.to_string().contains("read-only"), "{e}");
            std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o600)).unwrap();
            write_atomic(&target, |w| writeln!(w, "new")).unwrap();
            let mode = std::fs::metadata(&target).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o600);
        }
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new\n");
    }

    #[test]
    fn a_set_refuses_one_path_twice_and_commits_all_or_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.csv");
        let b = dir.path().join("b.csv");
        let mut set = OutputSet::new();
        set.add(&a, "--out").unwrap();
        let e = set
            .add(&dir.path().join(".").join("a.csv"), "--plot")
            .unwrap_err();
        assert!(e.to_string().contains("--out"), "{e}");
        set.add(&b, "--plot").unwrap();
        set.write(&a, |w| writeln!(w, "a")).unwrap();
        assert!(set
            .write(&b, |_| Err(std::io::Error::other("boom")))
            .is_err());
        drop(set);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
