//! The trajectory files: CSV and (with the `data` feature) Parquet; see
//! the [module](super) for the formats.

use super::{JointTrajectory, TrajectoryError};
use crate::files::FileError;
use crate::files::csv::{Record, field, quoted, records};
use std::io::Write;
use std::path::Path;

/// Relative tolerance on the spacing of the `time` column.
const TIME_TOLERANCE: f64 = 1e-6;

impl JointTrajectory {
    /// The CSV text of the trajectory (format: [module](super)).
    pub fn to_csv(&self) -> String {
        let mut out = String::from("time");
        for name in self.joints() {
            out.push(',');
            // A name that reads as a number is quoted too: unquoted, the
            // reader takes it for a data row without a header.
            if name.trim().parse::<f64>().is_ok() {
                out.push_str(&quoted(name));
            } else {
                out.push_str(&field(name));
            }
        }
        out.push('\n');
        for (k, q) in self.positions().enumerate() {
            out.push_str(&format!("{}", k as f64 * self.dt()));
            for v in q {
                out.push_str(&format!(",{v}"));
            }
            out.push('\n');
        }
        out
    }

    /// Writes the trajectory as CSV (format: [module](super)).
    ///
    /// # Errors
    /// I/O errors.
    pub fn write_csv(&self, path: &Path) -> Result<(), FileError> {
        let mut file = std::fs::File::create(path).map_err(FileError::io(path))?;
        file.write_all(self.to_csv().as_bytes()).map_err(FileError::io(path))
    }

    /// Reads a trajectory CSV file; the time step is the spacing of its
    /// `time` column.
    ///
    /// # Errors
    /// An unreadable file, or any error of [`from_csv_str`](Self::from_csv_str).
    pub fn read_csv(path: &Path) -> Result<JointTrajectory, TrajectoryError> {
        let text = std::fs::read_to_string(path).map_err(FileError::io(path))?;
        Self::from_csv_str(&text, &path.display().to_string())
    }

    /// Parses trajectory CSV text read from `origin` (a path, for errors).
    /// Fields may be quoted as RFC 4180 says, so a joint name may hold a
    /// comma, a quote or a line break.
    ///
    /// # Errors
    /// [`TrajectoryError::Csv`] naming the line: a quote left open or
    /// followed by text, a missing or malformed
    /// header (first column not `time`, a joint name that is empty, a
    /// number, or given twice), fewer than two rows, a row of another
    /// length, a value that is not a finite number, times that do not
    /// start at 0 or are not evenly spaced; then any error of
    /// [`new`](Self::new) (values so far apart that a velocity overflows).
    pub fn from_csv_str(text: &str, origin: &str) -> Result<JointTrajectory, TrajectoryError> {
        let bad = |line: usize, message: String| TrajectoryError::Csv { origin: origin.to_string(), line, message };
        // A byte-order mark (spreadsheets write one) is not part of `time`.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut rows = records(text).map_err(|e| bad(e.line, e.message))?.into_iter();
        let header = rows.next().ok_or_else(|| bad(1, "the file is empty".into()))?;
        let header_line = header.line;
        let joints = parse_header(header).map_err(|m| bad(header_line, m))?;
        let mut times = Vec::new();
        let mut configurations = Vec::new();
        for Record { line, fields, .. } in rows {
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
        JointTrajectory::new(joints, time_step, &configurations)
    }

    /// Writes a Parquet file with columns `time` (s) and one f64 column per
    /// joint, one row per configuration (the start first), Snappy-compressed.
    ///
    /// # Errors
    /// I/O or encoding errors.
    #[cfg(feature = "data")]
    pub fn write_parquet(&self, path: &Path) -> Result<(), FileError> {
        use arrow_array::{ArrayRef, Float64Array, RecordBatch};
        use arrow_schema::{DataType, Field, Schema};
        use parquet::arrow::ArrowWriter;
        use parquet::basic::Compression;
        use parquet::file::properties::WriterProperties;
        use std::sync::Arc;

        let format = |e: &dyn std::fmt::Display| FileError::format(path, e);
        let rows = self.len();
        let mut fields = vec![Field::new("time", DataType::Float64, false)];
        fields.extend(self.joints().iter().map(|j| Field::new(j, DataType::Float64, false)));
        let schema = Arc::new(Schema::new(fields));
        let mut columns: Vec<ArrayRef> =
            vec![Arc::new(Float64Array::from_iter_values((0..rows).map(|k| k as f64 * self.dt())))];
        for k in 0..self.dof() {
            columns.push(Arc::new(Float64Array::from_iter_values(self.positions().map(|q| q[k]))));
        }
        let batch = RecordBatch::try_new(schema.clone(), columns).map_err(|e| format(&e))?;
        let file = std::fs::File::create(path).map_err(FileError::io(path))?;
        let props = WriterProperties::builder().set_compression(Compression::SNAPPY).build();
        let mut writer = ArrowWriter::try_new(file, schema, Some(props)).map_err(|e| format(&e))?;
        writer.write(&batch).map_err(|e| format(&e))?;
        writer.close().map_err(|e| format(&e))?;
        Ok(())
    }
}

/// The joint names of a header `time,<joint>,…`.
fn parse_header(header: Record) -> Result<Vec<String>, String> {
    let Record { fields, quoted, .. } = header;
    if fields[0] != "time" {
        let hint = if fields[0].parse::<f64>().is_ok() { " (a number: is the header missing?)" } else { "" };
        return Err(format!(
            "the header must be `time` followed by the joint names; its first column is '{}'{hint}",
            fields[0]
        ));
    }
    let joints = &fields[1..];
    if joints.is_empty() {
        return Err("the header names no joint after `time`".into());
    }
    for (k, name) in joints.iter().enumerate() {
        if name.is_empty() {
            return Err(format!("column {} has an empty joint name", k + 2));
        }
        if name.parse::<f64>().is_ok() && !quoted[k + 1] {
            return Err(format!("column {} is named '{name}', a number: is the header missing?", k + 2));
        }
        if let Some(first) = joints[..k].iter().position(|n| n == name) {
            return Err(format!("joint '{name}' is named twice (columns {} and {})", first + 2, k + 2));
        }
    }
    Ok(joints.to_vec())
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

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<JointTrajectory, String> {
        JointTrajectory::from_csv_str(text, "t.csv").map_err(|e| e.to_string())
    }

    #[test]
    fn written_trajectories_read_back_exactly() {
        let waypoints: Vec<Vec<f64>> =
            (0..51).map(|k| vec![k as f64 * 0.013, -1.0 / (k + 1) as f64, 1e-17 * k as f64]).collect();
        let written = JointTrajectory::new(vec!["a".into(), "b".into(), "c".into()], 0.08, &waypoints).unwrap();
        let back = parse(&written.to_csv()).unwrap();
        assert_eq!(back.joints(), written.joints());
        assert!(back.positions().eq(written.positions()));
        assert!((back.dt() - 0.08).abs() < 1e-15, "{}", back.dt());
    }

    /// URDF names are any XML attribute text: a joint named with a comma
    /// shifted every column after it, and one named like a number was
    /// refused as a missing header.
    #[test]
    fn joint_names_with_commas_quotes_breaks_or_digits_read_back() {
        let names = ["arm,joint 1", "the \"wrist\"", "two\nlines", " padded", "2", "1e-3", "plain"];
        let waypoints: Vec<Vec<f64>> = (0..3).map(|k| vec![k as f64; names.len()]).collect();
        let written = JointTrajectory::new(names.iter().map(|n| n.to_string()).collect(), 0.1, &waypoints).unwrap();
        let text = written.to_csv();
        assert!(text.starts_with(
            "time,\"arm,joint 1\",\"the \"\"wrist\"\"\",\"two\nlines\",\" padded\",\"2\",\"1e-3\",plain\n"
        ));
        let back = parse(&text).unwrap();
        assert_eq!(back.joints(), names);
        assert!(back.positions().eq(written.positions()));
        // A quote left open or followed by text names its line.
        let e = parse("time,\"j1\n0,0\n0.1,0\n").unwrap_err();
        assert!(e.contains("t.csv:1: a quoted field is not closed"), "{e}");
        let e = parse("time,j1\n0,0\n0.1,\"0\"x\n").unwrap_err();
        assert!(e.contains("t.csv:3: 'x' after a closing quote"), "{e}");
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

    /// Spreadsheets save CSV with a UTF-8 byte-order mark; it was refused
    /// as a first column named "\u{feff}time", invisible in the message.
    #[test]
    fn a_byte_order_mark_is_skipped() {
        let t = parse("\u{feff}time,j1\n0,0.5\n0.1,0.6\n").unwrap();
        assert_eq!(t.joints(), ["j1"]);
        let e = parse("\u{feff}\u{feff}time,j1\n0,0.5\n0.1,0.6\n").unwrap_err().to_string();
        assert!(e.contains("t.csv:1"), "{e}");
    }

    #[test]
    fn values_whose_velocity_overflows_name_the_waypoint() {
        // ±1e308 are finite numbers, but the velocity between them is not.
        let e = parse("time,j1\n0,1e308\n0.1,-1e308\n").unwrap_err();
        assert!(e.contains("waypoint 1: joint 'j1' moves from"), "{e}");
        let t = parse("time,j1\n0,1e300\n0.1,1e300\n").unwrap();
        assert_eq!(t.position(1), [1e300]);
    }
}
