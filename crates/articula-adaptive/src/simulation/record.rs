//! What a run leaves behind: the [`Recorder`] hook every exporter implements, and the CSV
//! trajectory ([`CsvRecorder`], `docs/state-format.md#trajectory-csv`).

use super::{Simulation, Stop};
use articula_dca::State;
use articula_model::{AtomicFile, Model};
use std::io::Write;
use std::path::{Path, PathBuf};

/// A hook called by [`Simulation::run`]: once at the start (the state at the run's first time),
/// after every step done (the state passed the checks), and once at the end with the reason
/// the run stopped. An error stops the run ([`StopReason::RecorderFailed`](super::StopReason)).
pub trait Recorder {
    /// The state before the first step of the run.
    fn begin(&mut self, sim: &Simulation) -> std::io::Result<()> {
        self.record(sim)
    }

    /// The state after a step done (`sim.steps_done()`, `sim.time()`, `sim.state()`).
    fn record(&mut self, sim: &Simulation) -> std::io::Result<()>;

    /// The run ended (every step done, or stopped); flush and close here.
    fn finish(&mut self, sim: &Simulation, stop: &Stop) -> std::io::Result<()> {
        let _ = (sim, stop);
        Ok(())
    }
}

/// Writes the trajectory as CSV: a header, then one row `t, q…, qd…` at the start and after
/// every step done. The file is written under a temporary name and renamed onto `path` when
/// the run ends, so that a killed run or a full disk never leaves a cut file under `path`;
/// rows are complete up to the last step done, also when the run was stopped.
#[derive(Debug)]
pub struct CsvRecorder {
    /// The file, until the run ends.
    file: Option<AtomicFile>,
    /// Its final path.
    path: PathBuf,
    /// Whether a write failed (the file is then dropped, not renamed).
    failed: bool,
}

impl CsvRecorder {
    /// Creates the temporary file for `path` (and its directory if needed) and writes the
    /// header of `model`'s columns.
    pub fn create(path: &Path, model: &Model) -> std::io::Result<CsvRecorder> {
        let mut file = AtomicFile::create(path)?;
        writeln!(file, "{}", csv_header(model))?;
        Ok(CsvRecorder {
            file: Some(file),
            path: path.to_path_buf(),
            failed: false,
        })
    }

    /// The final path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Recorder for CsvRecorder {
    fn record(&mut self, sim: &Simulation) -> std::io::Result<()> {
        let Some(file) = &mut self.file else {
            return Ok(());
        };
        let result = write_row(file, sim.time(), sim.state());
        self.failed |= result.is_err();
        result.map_err(|e| self.error(e))
    }

    fn finish(&mut self, _: &Simulation, _: &Stop) -> std::io::Result<()> {
        match self.file.take() {
            Some(file) if !self.failed => file.commit().map_err(|e| self.error(e)),
            _ => Ok(()),
        }
    }
}

impl CsvRecorder {
    /// `e` with the file named: `cannot write PATH: e`.
    fn error(&self, e: std::io::Error) -> std::io::Error {
        std::io::Error::new(
            e.kind(),
            format!("cannot write {}: {e}", self.path.display()),
        )
    }
}

/// The CSV header: `t`, then one column per position coordinate (`joint`, or `joint[i]` for a
/// joint with several), then the same for velocities prefixed `qd:`.
pub fn csv_header(model: &Model) -> String {
    let mut cols = vec!["t".to_string()];
    for p in model.coordinate_parts() {
        push_columns(&mut cols, "", &p.name, p.nq());
    }
    for p in model.coordinate_parts() {
        push_columns(&mut cols, "qd:", &p.name, p.nv());
    }
    cols.iter()
        .map(|c| csv_field(c))
        .collect::<Vec<_>>()
        .join(",")
}

fn push_columns(cols: &mut Vec<String>, prefix: &str, name: &str, n: usize) {
    if n == 1 {
        cols.push(format!("{prefix}{name}"));
    } else {
        cols.extend((0..n).map(|i| format!("{prefix}{name}[{i}]")));
    }
}

/// Quotes a CSV field when it holds a comma, a quote or a line break (RFC 4180).
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// One row: `t`, then `q` and `qd`, each number in its shortest round-trip form.
fn write_row(w: &mut impl Write, t: f64, state: &State) -> std::io::Result<()> {
    let mut row = format!("{t:?}");
    for x in state.q.iter().chain(&state.qd) {
        use std::fmt::Write as _;
        let _ = write!(row, ",{x:?}");
    }
    row.push('\n');
    w.write_all(row.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_fields_are_quoted_when_needed() {
        assert_eq!(csv_field("joint1"), "joint1");
        assert_eq!(csv_field("a,b"), "\"a,b\"");
        assert_eq!(csv_field("a\"b"), "\"a\"\"b\"");
    }
}
