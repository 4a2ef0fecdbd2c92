//! Shared-control episodes as Parquet: one row per control tick, so a
//! person's driven runs and the simulated operators' can be read and
//! compared with the same code.
//!
//! Columns: `episode` (a label, e.g. `right/approach/sos/3`), `step` (u32),
//! `time` (s), `q` and `qdot` (fixed-size lists of the joint values, rad or
//! m, and the executed joint velocity), `human` and `executed` (the
//! operator's gripper velocity command and the executed gripper velocity,
//! m/s, world axes), `robot` (the most likely goal's robot action), `beliefs`
//! (one per goal), `status` (the tick's status), `outcome` and `reason` (the
//! episode's, on every row); from a physics simulator also `object` (the
//! grasped object's pose before the tick: x, y, z in m, then the unit
//! quaternion w, x, y, z; world frame).
//!
//! ```python
//! import pyarrow.parquet as pq
//! t = pq.read_table("episodes.parquet").to_pandas()
//! t.groupby("episode").outcome.first().value_counts()
//! ```

use super::EpisodeRecord;
use crate::files::FileError;
use arrow_array::builder::{FixedSizeListBuilder, Float64Builder, ListBuilder, StringBuilder};
use arrow_array::{ArrayRef, Float64Array, RecordBatch, UInt32Array};
use arrow_schema::{Field, Schema};
use parquet::arrow::ArrowWriter;
use parquet::basic::Compression;
use parquet::file::properties::WriterProperties;
use std::path::Path;
use std::sync::Arc;

/// Writes `episodes` (label, record, control period in s) to `path`. The
/// records must have been recorded (`EpisodeSettings::record`).
///
/// # Errors
/// I/O or encoding errors; records of different joint counts.
pub fn write_episodes(path: &Path, episodes: &[(String, &EpisodeRecord, f64)]) -> Result<(), FileError> {
    let format = |e: &dyn std::fmt::Display| FileError::Format { path: path.into(), message: e.to_string() };
    let n = episodes.iter().find_map(|(_, r, _)| r.q.first().map(Vec::len)).unwrap_or(0);
    if let Some((label, _, _)) = episodes.iter().find(|(_, r, _)| r.q.iter().any(|q| q.len() != n)) {
        return Err(format(&format!("episode {label} has another joint count than {n}")));
    }
    let width = i32::try_from(n).map_err(|e| format(&e))?;
    let mut label = StringBuilder::new();
    let (mut step, mut time) = (vec![], vec![]);
    let mut q = FixedSizeListBuilder::new(Float64Builder::new(), width);
    let mut qdot = FixedSizeListBuilder::new(Float64Builder::new(), width);
    let mut human = FixedSizeListBuilder::new(Float64Builder::new(), 3);
    let mut executed = FixedSizeListBuilder::new(Float64Builder::new(), 3);
    let mut robot = ListBuilder::new(Float64Builder::new());
    let mut beliefs = ListBuilder::new(Float64Builder::new());
    let (mut status, mut outcome, mut reason) = (StringBuilder::new(), StringBuilder::new(), StringBuilder::new());
    // Physics records carry the object's pose at every configuration.
    let with_object = !episodes.is_empty() && episodes.iter().all(|(_, r, _)| r.object.len() >= r.statuses.len());
    let mut object = FixedSizeListBuilder::new(Float64Builder::new(), 7);
    for (name, record, period) in episodes {
        for t in 0..record.statuses.len() {
            label.append_value(name);
            step.push(t as u32);
            time.push(t as f64 * period);
            q.values().append_slice(&record.q[t]);
            q.append(true);
            qdot.values().append_slice(&record.qdot[t]);
            qdot.append(true);
            human.values().append_slice(&record.human[t]);
            human.append(true);
            executed.values().append_slice(&record.executed[t]);
            executed.append(true);
            robot.values().append_slice(&record.robot[t]);
            robot.append(true);
            beliefs.values().append_slice(&record.beliefs[t]);
            beliefs.append(true);
            if with_object {
                object.values().append_slice(&record.object[t]);
                object.append(true);
            }
            status.append_value(record.statuses[t].as_str());
            outcome.append_value(record.outcome.as_str());
            reason.append_value(record.reason.to_string());
        }
    }
    let mut columns: Vec<(&str, ArrayRef)> = vec![
        ("episode", Arc::new(label.finish())),
        ("step", Arc::new(UInt32Array::from(step))),
        ("time", Arc::new(Float64Array::from(time))),
        ("q", Arc::new(q.finish())),
        ("qdot", Arc::new(qdot.finish())),
        ("human", Arc::new(human.finish())),
        ("executed", Arc::new(executed.finish())),
        ("robot", Arc::new(robot.finish())),
        ("beliefs", Arc::new(beliefs.finish())),
        ("status", Arc::new(status.finish())),
        ("outcome", Arc::new(outcome.finish())),
        ("reason", Arc::new(reason.finish())),
    ];
    if with_object {
        columns.push(("object", Arc::new(object.finish())));
    }
    let fields: Vec<Field> = columns.iter().map(|(name, a)| Field::new(*name, a.data_type().clone(), false)).collect();
    let schema = Arc::new(Schema::new(fields));
    let batch =
        RecordBatch::try_new(schema.clone(), columns.into_iter().map(|(_, a)| a).collect()).map_err(|e| format(&e))?;
    let file = std::fs::File::create(path).map_err(|source| FileError::Io { path: path.into(), source })?;
    let props = WriterProperties::builder().set_compression(Compression::SNAPPY).build();
    let mut writer = ArrowWriter::try_new(file, schema, Some(props)).map_err(|e| format(&e))?;
    writer.write(&batch).map_err(|e| format(&e))?;
    writer.close().map_err(|e| format(&e))?;
    Ok(())
}
