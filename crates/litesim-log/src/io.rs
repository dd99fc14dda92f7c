//! Writers and readers. Writes are atomic: a temporary file in the target's
//! folder, flushed, then renamed over the target.

use crate::log::SimulationLog;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Why a log could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    /// File-system trouble.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// Not a valid JSON log.
    #[error("{path}: line {line}, column {column}: {message}")]
    Json {
        /// The file.
        path: PathBuf,
        /// Line (1-based).
        line: usize,
        /// Column (1-based).
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// Not a log: not UTF-8 text, empty, or well-formed JSON that breaks
    /// the log's invariants.
    #[error("{path}: {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> LogError + '_ {
    move |source| LogError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// A file written beside its final name and put in place only when done: a
/// temporary file in the same folder (`.tmpXXXXXX`), synced to disk, made an
/// ordinary 0644 file and renamed over the name — a reader sees the old file
/// or the new one, never a part, and a crash leaves no named, empty file.
/// The one implementation of atomic writes: the log, the MCAP, the pictures
/// and a batch's files all go through it. Dropped without
/// [`AtomicFile::commit`], the temporary file is removed.
#[derive(Debug)]
pub struct AtomicFile {
    path: PathBuf,
    tmp: tempfile::NamedTempFile,
}

impl AtomicFile {
    /// Starts `path` (its folder made if missing).
    pub fn create(path: &Path) -> Result<Self, LogError> {
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&dir).map_err(io_err(path))?;
        let tmp = tempfile::NamedTempFile::new_in(&dir).map_err(io_err(path))?;
        Ok(Self {
            path: path.to_path_buf(),
            tmp,
        })
    }

    /// The final name.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The temporary file, to write into.
    pub fn file(&mut self) -> &mut std::fs::File {
        self.tmp.as_file_mut()
    }

    /// Syncs the file to disk and renames it over the final name.
    pub fn commit(self) -> Result<(), LogError> {
        let path = self.path;
        self.tmp.as_file().sync_all().map_err(io_err(&path))?;
        // Temporary files are created private (0600); a result is an
        // ordinary file.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let _ = self
                .tmp
                .as_file()
                .set_permissions(std::fs::Permissions::from_mode(0o644));
        }
        self.tmp
            .persist(&path)
            .map_err(|e| io_err(&path)(e.error))?;
        Ok(())
    }
}

/// Writes `fill`'s output to `path` atomically ([`AtomicFile`]).
pub fn write_atomic(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), LogError> {
    write_atomic_seekable(path, |w| fill(w))
}

/// [`write_atomic`] for formats that seek back while writing (a container
/// whose records point at each other, such as MCAP): the writer is the
/// temporary file itself behind a 64 KiB buffer, so nothing is built in
/// memory first.
pub fn write_atomic_seekable(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<&mut std::fs::File>) -> std::io::Result<()>,
) -> Result<(), LogError> {
    let mut out = AtomicFile::create(path)?;
    {
        let mut w = std::io::BufWriter::with_capacity(1 << 16, out.file());
        fill(&mut w).map_err(io_err(path))?;
        w.flush().map_err(io_err(path))?;
    }
    out.commit()
}

fn num(x: f64) -> String {
    if x.is_nan() {
        String::new()
    } else {
        format!("{x}")
    }
}

impl SimulationLog {
    /// Writes the JSON form atomically. NaN (no value) is written as `null`.
    pub fn write_json(&self, path: &Path) -> Result<(), LogError> {
        write_atomic(path, |w| {
            serde_json::to_writer(&mut *w, self).map_err(std::io::Error::other)?;
            writeln!(w)
        })
    }

    /// Writes the long CSV form atomically: one row per actor and tick.
    pub fn write_csv(&self, path: &Path) -> Result<(), LogError> {
        write_atomic(path, |w| {
            writeln!(
                w,
                "tick,time_s,actor_id,mode,x_m,y_m,z_m,yaw_rad,vx_mps,vy_mps,speed_mps,yaw_rate_radps,\
                 throttle,brake,steering,accel_cmd_mps2,steering_angle_rad,curvature_1pm,lat_acc_mps2,\
                 long_acc_mps2,slip_angle_rad,force_long_n,force_lat_n,friction_use"
            )?;
            let times: std::collections::BTreeMap<u64, f64> = self
                .tick
                .iter()
                .copied()
                .zip(self.time.iter().copied())
                .collect();
            for t in &self.tracks {
                for i in 0..t.len() {
                    let s = &t.state;
                    let c = &t.control;
                    let d = &t.derived;
                    let cols = [
                        s.x[i],
                        s.y[i],
                        s.z[i],
                        s.yaw[i],
                        s.vx[i],
                        s.vy[i],
                        s.speed[i],
                        s.yaw_rate[i],
                        c.throttle[i],
                        c.brake[i],
                        c.steering[i],
                        c.acceleration[i],
                        c.steering_angle[i],
                        d.curvature[i],
                        d.lateral_acceleration[i],
                        d.longitudinal_acceleration[i],
                        d.slip_angle[i],
                        d.force_longitudinal_n[i],
                        d.force_lateral_n[i],
                        d.friction_use[i],
                    ];
                    let time = times.get(&t.tick[i]).copied().unwrap_or(f64::NAN);
                    write!(
                        w,
                        "{},{},{},{}",
                        t.tick[i],
                        num(time),
                        csv_field(&t.id),
                        t.mode[i]
                    )?;
                    for v in cols {
                        write!(w, ",{}", num(v))?;
                    }
                    writeln!(w)?;
                }
            }
            Ok(())
        })
    }

    /// Reads and validates the JSON form.
    pub fn read_json(path: &Path) -> Result<Self, LogError> {
        use litesim_core::files::{MAX_INPUT_BYTES, ReadError, read_text};
        let text = read_text(path, MAX_INPUT_BYTES).map_err(|e| match e {
            ReadError::NotUtf8 { .. } => LogError::Invalid {
                path: path.to_path_buf(),
                message: "not UTF-8 text: not a litesim log (JSON)".into(),
            },
            ReadError::Io { source, .. } => io_err(path)(source),
            other => LogError::Invalid {
                path: path.to_path_buf(),
                message: other.reason(),
            },
        })?;
        Self::from_json_str(&text, path)
    }

    /// Parses and validates the JSON form (`path` is used in messages).
    pub fn from_json_str(text: &str, path: &Path) -> Result<Self, LogError> {
        let invalid = |message: String| LogError::Invalid {
            path: path.to_path_buf(),
            message,
        };
        if text.trim().is_empty() {
            return Err(invalid(
                "the file is empty (expected a litesim log: JSON)".into(),
            ));
        }
        let log: SimulationLog = serde_json::from_str(text).map_err(|e| {
            // serde_json's text ends with the place, which the error
            // gives on its own: say it once.
            let text = e.to_string();
            let place = format!(" at line {} column {}", e.line(), e.column());
            LogError::Json {
                path: path.to_path_buf(),
                line: e.line(),
                column: e.column(),
                message: text.strip_suffix(&place).unwrap_or(&text).to_string(),
            }
        })?;
        if log.format_version != 1 {
            return Err(invalid(format!(
                "format_version {} is not supported (expected 1)",
                log.format_version
            )));
        }
        if log.tick.len() != log.time.len() {
            return Err(invalid(format!(
                "{} ticks but {} times",
                log.tick.len(),
                log.time.len()
            )));
        }
        for t in &log.tracks {
            if let Some((name, len)) = t.bad_columns().first() {
                return Err(invalid(format!(
                    "track '{}': column {name} has {len} entries, expected {} (one per tick)",
                    t.id,
                    t.len()
                )));
            }
        }
        if let Some(t) = &log.tracking {
            let n = t.tick.len();
            let lens = [
                t.lateral_error.len(),
                t.heading_error.len(),
                t.progress.len(),
                t.cmd_acceleration.len(),
                t.cmd_steering.len(),
                t.predictions.len(),
            ];
            if lens.iter().any(|l| *l != n) {
                return Err(invalid(format!(
                    "tracking columns have lengths {lens:?}, expected {n} each"
                )));
            }
        }
        if let Some(p) = &log.plan {
            if p.grid.cells.len() != p.grid.width * p.grid.height {
                return Err(invalid(format!(
                    "plan grid has {} cells for {} × {}",
                    p.grid.cells.len(),
                    p.grid.width,
                    p.grid.height
                )));
            }
            if let Some(e) = p
                .edges
                .iter()
                .find(|e| e[0] >= p.samples.len() || e[1] >= p.samples.len())
            {
                return Err(invalid(format!(
                    "plan edge {e:?} refers to a sample that does not exist ({} samples)",
                    p.samples.len()
                )));
            }
        }
        Ok(log)
    }
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod atomic_tests {
    use super::AtomicFile;
    use std::io::Write;

    /// Nothing under the name until the commit, then all of it, as an
    /// ordinary file; a file dropped uncommitted leaves nothing behind.
    #[test]
    fn a_file_appears_whole_or_not_at_all() {
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("sub/out.txt");
        let mut f = AtomicFile::create(&path).unwrap();
        f.file().write_all(b"hello").unwrap();
        assert!(!path.exists());
        f.commit().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"hello");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&path).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o644);
        }
        let mut g = AtomicFile::create(&path).unwrap();
        g.file().write_all(b"half").unwrap();
        drop(g);
        assert_eq!(std::fs::read(&path).unwrap(), b"hello");
        let left: Vec<_> = std::fs::read_dir(path.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left.len(), 1, "{left:?}");
    }
}
