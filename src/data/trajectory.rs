//! Single trajectories as files, in one format that every command writing
//! one (`tandem solve --out`, `tandem demo`) produces and every command
//! taking one (`tandem policy --reference`) reads back.
//!
//! A trajectory is `q_0 … q_T` sampled every `time_step` seconds, `q_0`
//! the start configuration at time 0 (as MoveIt trajectories begin at the
//! start state), `q_1 … q_T` the optimized ones.
//!
//! - **CSV**: a header `time,<joint>,…` (the active joint names, the order
//!   of every row), then one row per configuration: its time `k ·
//!   time_step` (s) and the joint values (rad or m). Times start at 0 and
//!   are evenly spaced. No header, duplicate joint names, rows of another
//!   length, non-numbers and non-finite values are errors naming the file,
//!   line and column.
//! - **Parquet** (with the `data` feature): columns `time` (f64) and one
//!   f64 column per joint, the same rows, Snappy-compressed.
//!
//! ```
//! use tandem::data::TrajectoryTable;
//! let table = TrajectoryTable {
//!     joints: vec!["j1".into(), "j2".into()],
//!     time_step: 0.1,
//!     configurations: vec![vec![0.0, 0.0], vec![0.1, -0.2], vec![0.2, -0.3]],
//! };
//! let text = table.to_csv();
//! assert!(text.starts_with("time,j1,j2\n0,0,0\n"));
//! assert_eq!(TrajectoryTable::from_csv_str(&text, "<example>").unwrap(), table);
//! ```

use std::io::Write;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Errors reading or writing trajectory files.
#[derive(Debug, Error)]
pub enum DataError {
    /// A file that could not be read or written.
    #[error("cannot access {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        #[source]
        /// The underlying error.
        source: std::io::Error,
    },
    /// An encoding error writing a file.
    #[error("cannot write {path}: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Configurations whose length differs from the joint count.
    #[error("configuration {index} has {got} values for {expected} joints")]
    Shape {
        /// Index of the configuration.
        index: usize,
        /// The joint count.
        expected: usize,
        /// Its length.
        got: usize,
    },
    /// A malformed trajectory CSV: the file (or `<string>`), its 1-based
    /// line, and what is wrong there.
    #[error("{origin}:{line}: {message}")]
    Csv {
        /// The file, or `<string>`.
        origin: String,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// A joint trajectory sampled every `time_step` seconds: row `k` is the
/// configuration at time `k · time_step`, row 0 the start.
///
/// Its files: CSV with a header `time,<joint>,…` and one row per
/// configuration (its time, then the joint values; times start at 0 and
/// are evenly spaced), and Parquet with columns `time` and one per joint
/// (see [`write_csv`], `write_parquet`, [`read_csv`](Self::read_csv)).
#[derive(Debug, Clone, PartialEq)]
pub struct TrajectoryTable {
    /// Active joint names, one column each.
    pub joints: Vec<String>,
    /// Seconds between rows.
    pub time_step: f64,
    /// Joint values (rad or m), one row per slice, the start first.
    pub configurations: Vec<Vec<f64>>,
}

/// Relative tolerance on the spacing of the `time` column.
const TIME_TOLERANCE: f64 = 1e-6;

impl TrajectoryTable {
    pub(crate) fn check(&self) -> Result<(), DataError> {
        let expected = self.joints.len();
        match self.configurations.iter().position(|q| q.len() != expected) {
            Some(index) => Err(DataError::Shape { index, expected, got: self.configurations[index].len() }),
            None => Ok(()),
        }
    }

    /// The CSV text of the table (format: [`TrajectoryTable`]).
    pub fn to_csv(&self) -> String {
        let mut out = String::from("time");
        for name in &self.joints {
            out.push(',');
            out.push_str(name);
        }
        out.push('\n');
        for (k, q) in self.configurations.iter().enumerate() {
            out.push_str(&format!("{}", k as f64 * self.time_step));
            for v in q {
                out.push_str(&format!(",{v}"));
            }
            out.push('\n');
        }
        out
    }

    /// Reads a trajectory CSV file.
    ///
    /// # Errors
    /// An unreadable file, or any error of [`from_csv_str`](Self::from_csv_str).
    pub fn read_csv(path: &Path) -> Result<TrajectoryTable, DataError> {
        let text = std::fs::read_to_string(path).map_err(io(path))?;
        Self::from_csv_str(&text, &path.display().to_string())
    }

    /// Parses trajectory CSV text read from `origin` (a path, for errors).
    ///
    /// # Errors
    /// [`DataError::Csv`] naming the line: a missing or malformed header
    /// (first column not `time`, a joint name that is empty, a number, or
    /// given twice), fewer than two rows, a row of another length, a value
    /// that is not a finite number, times that do not start at 0 or are
    /// not evenly spaced.
    pub fn from_csv_str(text: &str, origin: &str) -> Result<TrajectoryTable, DataError> {
        let bad = |line: usize, message: String| DataError::Csv { origin: origin.to_string(), line, message };
        let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())).filter(|(_, l)| !l.is_empty());
        let (header_line, header) = lines.next().ok_or_else(|| bad(1, "the file is empty".into()))?;
        let joints = parse_header(header).map_err(|m| bad(header_line, m))?;
        let mut times = Vec::new();
        let mut configurations = Vec::new();
        for (line, text) in lines {
            let fields: Vec<&str> = text.split(',').map(str::trim).collect();
            if fields.len() != joints.len() + 1 {
                let msg = format!(
                    "{} values, the header has {} columns (time and {} joints)",
                    fields.len(),
                    joints.len() + 1,
                    joints.len()
                );
                return Err(bad(line, msg));
            }
            let mut row = Vec::with_capacity(fields.len());
            for (column, field) in fields.iter().enumerate() {
                let name = if column == 0 { "time" } else { joints[column - 1].as_str() };
                let value = field
                    .parse::<f64>()
                    .map_err(|_| bad(line, format!("column {} ({name}): '{field}' is not a number", column + 1)))?;
                if !value.is_finite() {
                    return Err(bad(line, format!("column {} ({name}): {field} is not finite", column + 1)));
                }
                row.push(value);
            }
            times.push((line, row[0]));
            row.remove(0);
            configurations.push(row);
        }
        let time_step = time_step(&times).map_err(|(line, m)| bad(line.unwrap_or(header_line), m))?;
        Ok(TrajectoryTable { joints, time_step, configurations })
    }
}

/// The joint names of a header `time,<joint>,…`.
fn parse_header(header: &str) -> Result<Vec<String>, String> {
    let fields: Vec<&str> = header.split(',').map(str::trim).collect();
    if fields[0] != "time" {
        let hint = if fields[0].parse::<f64>().is_ok() { " (a number: is the header missing?)" } else { "" };
        return Err(format!(
            "the header must be `time` followed by the joint names; its first column is '{}'{hint}",
            fields[0]
        ));
    }
    let joints: Vec<String> = fields[1..].iter().map(|s| s.to_string()).collect();
    if joints.is_empty() {
        return Err("the header names no joint after `time`".into());
    }
    for (k, name) in joints.iter().enumerate() {
        if name.is_empty() {
            return Err(format!("column {} has an empty joint name", k + 2));
        }
        if name.parse::<f64>().is_ok() {
            return Err(format!("column {} is named '{name}', a number: is the header missing?", k + 2));
        }
        if let Some(first) = joints[..k].iter().position(|n| n == name) {
            return Err(format!("joint '{name}' is named twice (columns {} and {})", first + 2, k + 2));
        }
    }
    Ok(joints)
}

/// The spacing of the `time` column `(line, t)`: starting at 0, evenly
/// spaced within [`TIME_TOLERANCE`]; errors with the line at fault.
fn time_step(times: &[(usize, f64)]) -> Result<f64, (Option<usize>, String)> {
    let (Some(&(first_line, first)), Some(&(_, last))) = (times.first(), times.last()) else {
        return Err((None, "the trajectory has no rows".into()));
    };
    if times.len() < 2 {
        return Err((Some(first_line), "one row only: the time step needs at least two".into()));
    }
    if first != 0.0 {
        return Err((Some(first_line), format!("the first time must be 0 (the start configuration), got {first}")));
    }
    let dt = last / (times.len() - 1) as f64;
    if !(dt > 0.0 && dt.is_finite()) {
        return Err((Some(times[1].0), format!("times must increase, got {} after 0", times[1].1)));
    }
    for (k, &(line, t)) in times.iter().enumerate() {
        let expected = k as f64 * dt;
        if (t - expected).abs() > TIME_TOLERANCE * dt {
            let msg = format!("time {t} s breaks the even spacing of {dt} s (row {k} should be at {expected} s)");
            return Err((Some(line), msg));
        }
    }
    Ok(dt)
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> DataError + '_ {
    move |source| DataError::Io { path: path.into(), source }
}

/// Writes the table as CSV (format: [`TrajectoryTable`]).
///
/// # Errors
/// I/O errors, or configurations of the wrong length.
pub fn write_csv(table: &TrajectoryTable, path: &Path) -> Result<(), DataError> {
    table.check()?;
    let mut file = std::fs::File::create(path).map_err(io(path))?;
    file.write_all(table.to_csv().as_bytes()).map_err(io(path))
}

/// Writes a Parquet file with columns `time` (s) and one f64 column per
/// joint, one row per configuration (the start first), Snappy-compressed.
///
/// # Errors
/// I/O or encoding errors, or configurations of the wrong length.
#[cfg(feature = "data")]
pub fn write_parquet(table: &TrajectoryTable, path: &Path) -> Result<(), DataError> {
    use arrow_array::{ArrayRef, Float64Array, RecordBatch};
    use arrow_schema::{DataType, Field, Schema};
    use parquet::arrow::ArrowWriter;
    use parquet::basic::Compression;
    use parquet::file::properties::WriterProperties;
    use std::sync::Arc;

    table.check()?;
    let format = |e: &dyn std::fmt::Display| DataError::Format { path: path.into(), message: e.to_string() };
    let rows = table.configurations.len();
    let mut fields = vec![Field::new("time", DataType::Float64, false)];
    fields.extend(table.joints.iter().map(|j| Field::new(j, DataType::Float64, false)));
    let schema = Arc::new(Schema::new(fields));
    let mut columns: Vec<ArrayRef> =
        vec![Arc::new(Float64Array::from_iter_values((0..rows).map(|k| k as f64 * table.time_step)))];
    for k in 0..table.joints.len() {
        columns.push(Arc::new(Float64Array::from_iter_values(table.configurations.iter().map(|q| q[k]))));
    }
    let batch = RecordBatch::try_new(schema.clone(), columns).map_err(|e| format(&e))?;
    let file = std::fs::File::create(path).map_err(io(path))?;
    let props = WriterProperties::builder().set_compression(Compression::SNAPPY).build();
    let mut writer = ArrowWriter::try_new(file, schema, Some(props)).map_err(|e| format(&e))?;
    writer.write(&batch).map_err(|e| format(&e))?;
    writer.close().map_err(|e| format(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<TrajectoryTable, String> {
        TrajectoryTable::from_csv_str(text, "t.csv").map_err(|e| e.to_string())
    }

    #[test]
    fn written_tables_read_back_exactly() {
        let table = TrajectoryTable {
            joints: vec!["a".into(), "b".into(), "c".into()],
            time_step: 0.08,
            configurations: (0..51).map(|k| vec![k as f64 * 0.013, -1.0 / (k + 1) as f64, 1e-17 * k as f64]).collect(),
        };
        let back = parse(&table.to_csv()).unwrap();
        assert_eq!(back.joints, table.joints);
        assert_eq!(back.configurations, table.configurations);
        assert!((back.time_step - 0.08).abs() < 1e-15, "{}", back.time_step);
    }

    #[test]
    fn malformed_files_name_line_and_column() {
        let cases = [
            ("", "t.csv:1: the file is empty"),
            ("0,0.1\n0.1,0.2\n", "t.csv:1: the header must be `time`"),
            ("0,0.1\n", "is the header missing?"),
            ("slice,time,j1\n1,0.1,0\n", "its first column is 'slice'"),
            ("time\n0\n0.1\n", "names no joint"),
            ("time,j1,j1\n0,0,0\n", "joint 'j1' is named twice (columns 2 and 3)"),
            ("time,j1,\n0,0,0\n", "column 3 has an empty joint name"),
            ("time,j1\n0,0\n0.1\n", "t.csv:3: 1 values, the header has 2 columns"),
            ("time,j1\n0,0\n0.1,x\n", "t.csv:3: column 2 (j1): 'x' is not a number"),
            ("time,j1\n0,0\n0.1,inf\n", "column 2 (j1): inf is not finite"),
            ("time,j1\n0,0\n", "one row only"),
            ("time,j1\n0.5,0\n1,0\n", "the first time must be 0"),
            ("time,j1\n0,0\n0.1,0\n0.3,0\n", "t.csv:3: time 0.1 s breaks the even spacing"),
            ("time,j1\n0,0\n0,1\n", "times must increase"),
        ];
        for (text, expected) in cases {
            let e = parse(text).unwrap_err();
            assert!(e.contains(expected), "{text:?}: {e}");
        }
    }

    #[test]
    fn large_values_are_values_not_errors_here() {
        // ±1e308 are finite numbers: the reader keeps them, the users of a
        // trajectory judge them (limits, velocities).
        let t = parse("time,j1\n0,1e308\n0.1,-1e308\n").unwrap();
        assert_eq!(t.configurations, vec![vec![1e308], vec![-1e308]]);
    }
}
