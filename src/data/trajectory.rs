//! Single trajectories as files: CSV for people and spreadsheets, Parquet
//! for learning stacks (what `tandem solve --out` writes).

use arrow_array::{ArrayRef, Float64Array, RecordBatch, UInt32Array};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::ArrowWriter;
use parquet::basic::Compression;
use parquet::file::properties::WriterProperties;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use thiserror::Error;

/// Errors writing trajectory files.
#[derive(Debug, Error)]
pub enum DataError {
    #[error("cannot write {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot write {path}: {message}")]
    Format { path: PathBuf, message: String },
    /// Configurations whose length differs from the joint count.
    #[error("configuration {index} has {got} values for {expected} joints")]
    Shape { index: usize, expected: usize, got: usize },
}

/// A joint trajectory sampled every `time_step` seconds: row `t` is the
/// configuration at time `(t + 1) · time_step` (slices 1 … T; slice 0,
/// the start, is not stored).
#[derive(Debug, Clone, PartialEq)]
pub struct TrajectoryTable {
    /// Active joint names, one column each.
    pub joints: Vec<String>,
    /// Seconds between rows.
    pub time_step: f64,
    /// Joint values (rad or m), one row per slice.
    pub configurations: Vec<Vec<f64>>,
}

impl TrajectoryTable {
    fn check(&self) -> Result<(), DataError> {
        let expected = self.joints.len();
        match self.configurations.iter().position(|q| q.len() != expected) {
            Some(index) => Err(DataError::Shape { index, expected, got: self.configurations[index].len() }),
            None => Ok(()),
        }
    }
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> DataError + '_ {
    move |source| DataError::Io { path: path.into(), source }
}

/// Writes `slice,time,<joint>…` with one row per configuration.
///
/// # Errors
/// I/O errors, or configurations of the wrong length.
pub fn write_csv(table: &TrajectoryTable, path: &Path) -> Result<(), DataError> {
    table.check()?;
    let mut out = String::from("slice,time");
    for name in &table.joints {
        out.push(',');
        out.push_str(name);
    }
    out.push('\n');
    for (t, q) in table.configurations.iter().enumerate() {
        out.push_str(&format!("{},{}", t + 1, (t + 1) as f64 * table.time_step));
        for v in q {
            out.push_str(&format!(",{v}"));
        }
        out.push('\n');
    }
    let mut file = std::fs::File::create(path).map_err(io(path))?;
    file.write_all(out.as_bytes()).map_err(io(path))
}

/// Writes a Parquet file with columns `slice` (u32), `time` (s) and one
/// f64 column per joint, Snappy-compressed.
///
/// # Errors
/// I/O or encoding errors, or configurations of the wrong length.
pub fn write_parquet(table: &TrajectoryTable, path: &Path) -> Result<(), DataError> {
    table.check()?;
    let format = |e: &dyn std::fmt::Display| DataError::Format { path: path.into(), message: e.to_string() };
    let rows = table.configurations.len();
    let mut fields = vec![Field::new("slice", DataType::UInt32, false), Field::new("time", DataType::Float64, false)];
    fields.extend(table.joints.iter().map(|j| Field::new(j, DataType::Float64, false)));
    let schema = Arc::new(Schema::new(fields));
    let mut columns: Vec<ArrayRef> = vec![
        Arc::new(UInt32Array::from_iter_values((1..=rows).map(|t| t as u32))),
        Arc::new(Float64Array::from_iter_values((1..=rows).map(|t| t as f64 * table.time_step))),
    ];
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
