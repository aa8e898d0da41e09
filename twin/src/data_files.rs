//! Opening a data set's files (docs/reliability.md, "Inputs"): regular files only, checked
//! before they are opened (a FIFO would block the reader forever, a device never end), and,
//! for the files a manifest names, only inside the data set's folder once every symbolic link
//! is resolved. A refused file is never read, so no message can show its content.

use std::fs::File;
use std::io::Read;
use std::path::Path;

/// Why a data file was not opened.
#[derive(Debug)]
pub enum OpenError {
    /// Nothing at the path.
    Missing,
    /// Refused or unreadable, and why.
    Refused(String),
}

impl OpenError {
    /// The message, with `missing` for a missing file.
    pub fn message(&self, missing: &str) -> String {
        match self {
            OpenError::Missing => missing.to_string(),
            OpenError::Refused(why) => why.clone(),
        }
    }
}

fn io(e: std::io::Error) -> OpenError {
    if e.kind() == std::io::ErrorKind::NotFound {
        OpenError::Missing
    } else {
        OpenError::Refused(format!("cannot read: {e}"))
    }
}

fn not_regular(t: &std::fs::FileType) -> OpenError {
    OpenError::Refused(format!(
        "is {}; a data file must be a regular file",
        fom::output_files::kind_name(t)
    ))
}

/// Opens `path` (links followed) when it is a regular file; the opened file is checked
/// again, so a file swapped between the check and the open is refused too.
pub fn open_regular(path: &Path) -> Result<File, OpenError> {
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(not_regular(&meta.file_type()));
    }
    let file = File::open(path).map_err(io)?;
    let meta = file.metadata().map_err(io)?;
    if !meta.is_file() {
        return Err(not_regular(&meta.file_type()));
    }
    Ok(file)
}

/// Opens `relative` in the data set's folder `dir`: refused when, its links resolved, it lies
/// outside the folder (itself resolved), or is not a regular file.
pub fn read_inside(dir: &Path, relative: &Path) -> Result<File, OpenError> {
    let root = std::fs::canonicalize(dir).map_err(io)?;
    let path = dir.join(relative);
    std::fs::symlink_metadata(&path).map_err(io)?;
    let real = std::fs::canonicalize(&path).map_err(|e| match io(e) {
        OpenError::Missing => {
            OpenError::Refused("is a symbolic link to nothing (a dangling link)".into())
        }
        other => other,
    })?;
    if !real.starts_with(&root) {
        return Err(OpenError::Refused(
            "leads outside the data set's folder (through a symbolic link); a data set's \
             files lie inside its folder"
                .into(),
        ));
    }
    open_regular(&real)
}

/// The text of `file`, refused beyond `max_bytes` or when it is not UTF-8 (never shown).
pub fn read_text(file: File, max_bytes: u64) -> Result<String, OpenError> {
    let mut bytes = Vec::new();
    file.take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| OpenError::Refused(format!("cannot read: {e}")))?;
    if bytes.len() as u64 > max_bytes {
        return Err(OpenError::Refused(format!(
            "larger than {max_bytes} bytes; not a data set's file"
        )));
    }
    String::from_utf8(bytes)
        .map_err(|_| OpenError::Refused("is not UTF-8 text; not a data set's file".into()))
}
