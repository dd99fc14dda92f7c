//! Reading input files, in one guarded place: every file litesim reads (a
//! scenario, a map, a config, a log, a certificate) comes through
//! [`read_bytes`] or [`read_text`]. Only a regular file is opened (a FIFO
//! would wait for a writer, `/dev/zero` never ends, a directory is a
//! mistake), and at most a caller-given number of bytes is read, so that a
//! wrong path fails at once with a clear error instead of hanging or
//! filling memory.

use std::io::Read;
use std::path::{Path, PathBuf};

/// The default most bytes of an input file: larger than any scenario, map
/// or log litesim writes (a 100,000-run batch's results are ~60 MB).
pub const MAX_INPUT_BYTES: u64 = 256 * 1024 * 1024;

/// Why a file could not be read. Displayed as `path: reason`.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The operating system refused (missing, no permission, …).
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// Not a regular file.
    #[error("{}: {}", path.display(), self.reason())]
    NotAFile {
        /// The path.
        path: PathBuf,
        /// `directory`, or `FIFO, socket or device`.
        kind: &'static str,
    },
    /// Larger than the caller reads.
    #[error("{}: {}", path.display(), self.reason())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size (or at least this many bytes).
        len: u64,
        /// The limit.
        max: u64,
    },
    /// Not UTF-8 text.
    #[error("{}: {}", path.display(), self.reason())]
    NotUtf8 {
        /// The file.
        path: PathBuf,
        /// Line of the first invalid byte (1-based).
        line: usize,
        /// Column, in characters (1-based).
        column: usize,
        /// The byte.
        byte: u8,
    },
}

impl ReadError {
    /// What went wrong, without the path: for messages that name the file
    /// their own way.
    pub fn reason(&self) -> String {
        match self {
            ReadError::Io { source, .. } => source.to_string(),
            ReadError::NotAFile { kind, .. } => format!("not a regular file (a {kind})"),
            ReadError::TooLarge { len, max, .. } => {
                format!("{len} bytes; at most {max} bytes are read")
            }
            ReadError::NotUtf8 {
                line, column, byte, ..
            } => format!("not UTF-8 text (byte 0x{byte:02X} at {line}:{column})"),
        }
    }

    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            ReadError::Io { path, .. }
            | ReadError::NotAFile { path, .. }
            | ReadError::TooLarge { path, .. }
            | ReadError::NotUtf8 { path, .. } => path,
        }
    }
}

/// The file's metadata when it is a regular file.
fn regular(path: &Path) -> Result<std::fs::Metadata, ReadError> {
    let meta = std::fs::metadata(path).map_err(|source| ReadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    if !meta.is_file() {
        return Err(ReadError::NotAFile {
            path: path.to_path_buf(),
            kind: if meta.is_dir() {
                "directory"
            } else {
                "FIFO, socket or device"
            },
        });
    }
    Ok(meta)
}

/// Opens a regular file to read it as a stream (a results file of a large
/// batch, read line by line): the same refusal of what is not a regular
/// file as [`read_bytes`], no size limit (the reader holds one line).
pub fn open_regular(path: &Path) -> Result<std::fs::File, ReadError> {
    regular(path)?;
    std::fs::File::open(path).map_err(|source| ReadError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads a regular file of at most `max` bytes.
pub fn read_bytes(path: &Path, max: u64) -> Result<Vec<u8>, ReadError> {
    let io = |source| ReadError::Io {
        path: path.to_path_buf(),
        source,
    };
    let meta = regular(path)?;
    let too_large = |len| ReadError::TooLarge {
        path: path.to_path_buf(),
        len,
        max,
    };
    if meta.len() > max {
        return Err(too_large(meta.len()));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    // The file may grow between the look and the read: read one byte more
    // than allowed to see it.
    std::fs::File::open(path)
        .and_then(|f| f.take(max + 1).read_to_end(&mut bytes))
        .map_err(io)?;
    if bytes.len() as u64 > max {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

/// Reads a regular UTF-8 text file of at most `max` bytes.
pub fn read_text(path: &Path, max: u64) -> Result<String, ReadError> {
    String::from_utf8(read_bytes(path, max)?).map_err(|e| {
        let (line, column, byte) = first_invalid(&e);
        ReadError::NotUtf8 {
            path: path.to_path_buf(),
            line,
            column,
            byte,
        }
    })
}

/// Where the first invalid byte of a failed UTF-8 decoding is: line and
/// column (1-based, columns in characters) and the byte.
pub fn first_invalid(e: &std::string::FromUtf8Error) -> (usize, usize, u8) {
    let bytes = e.as_bytes();
    let at = e.utf8_error().valid_up_to();
    // The prefix is valid UTF-8 by definition.
    let before = std::str::from_utf8(&bytes[..at]).unwrap_or_default();
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column, bytes.get(at).copied().unwrap_or(0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regular_files_within_the_limit_are_read_and_others_refused() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("a.txt");
        std::fs::write(&p, "héllo\nwörld").unwrap();
        assert_eq!(read_text(&p, 100).unwrap(), "héllo\nwörld");
        assert!(matches!(
            read_text(&p, 4),
            Err(ReadError::TooLarge {
                len: 13,
                max: 4,
                ..
            })
        ));
        assert!(matches!(
            read_bytes(d.path(), 100),
            Err(ReadError::NotAFile {
                kind: "directory",
                ..
            })
        ));
        let e = read_bytes(&d.path().join("missing"), 100).unwrap_err();
        assert!(matches!(e, ReadError::Io { .. }));
        assert!(e.to_string().contains("missing"), "{e}");
        std::fs::write(&p, b"ok\nab\xFFc").unwrap();
        let e = read_text(&p, 100).unwrap_err();
        assert!(
            matches!(
                e,
                ReadError::NotUtf8 {
                    line: 2,
                    column: 3,
                    byte: 0xFF,
                    ..
                }
            ),
            "{e:?}"
        );
        #[cfg(unix)]
        {
            let e = read_bytes(Path::new("/dev/zero"), 100).unwrap_err();
            assert!(matches!(e, ReadError::NotAFile { .. }), "{e:?}");
        }
    }
}
