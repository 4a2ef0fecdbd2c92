//! Part files: one Parquet file per id chunk, written to a temporary name
//! and renamed into place, so a part either exists whole or not at all.

use super::sample::{Rejection, SampleOutcome, TrajectoryRecord};
use super::schema::{SCHEMA_VERSION, record_batch};
use crate::files::FileError;
use parquet::arrow::ArrowWriter;
use parquet::basic::Compression;
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::file::reader::{FileReader, SerializedFileReader};
use sha2::{Digest, Sha256};
use std::io::Write;
use std::path::{Path, PathBuf};

/// What a part file holds besides its rows.
#[derive(Debug, Clone)]
pub struct PartMeta<'a> {
    /// Active joint names, in column order.
    pub joints: &'a [String],
    /// Gripper frame of `ee_pose` (empty when none).
    pub ee_frame: &'a str,
    pub horizon: usize,
    /// Ids `first .. end` this part covers.
    pub ids: [u64; 2],
}

/// A written (or found) part file.
#[derive(Debug, Clone, PartialEq)]
pub struct PartSummary {
    /// Ids `[first, end)` the part covers.
    pub ids: [u64; 2],
    /// Accepted trajectories (rows).
    pub rows: u64,
    /// The rejected ids of the range, with their reasons.
    pub rejected: Vec<Rejection>,
    /// SHA-256 of the file, lower-case hex.
    pub sha256: String,
    /// Size of the file (bytes).
    pub bytes: u64,
}

/// The temporary name a file is written under before the rename: hidden
/// (a leading dot), so dataset readers such as pyarrow skip it.
pub fn temporary_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp"))
}

/// Writes `outcomes` (ids `meta.ids`, in order) as the part file `path`:
/// accepted ones as rows, rejected ones in the metadata. Atomic: written to
/// a hidden temporary name (`temporary_path`), flushed to disk, then renamed.
///
/// # Errors
/// I/O or encoding errors, or outcomes that do not cover `meta.ids` in order.
pub fn write_part(path: &Path, meta: &PartMeta<'_>, outcomes: &[SampleOutcome]) -> Result<PartSummary, FileError> {
    if !outcomes.iter().map(SampleOutcome::id).eq(meta.ids[0]..meta.ids[1]) {
        return Err(FileError::format(
            path,
            format!("outcomes do not cover ids {}..{} in order", meta.ids[0], meta.ids[1]),
        ));
    }
    let records: Vec<&TrajectoryRecord> = outcomes
        .iter()
        .filter_map(|o| match o {
            SampleOutcome::Accepted(r) => Some(r.as_ref()),
            SampleOutcome::Rejected(_) => None,
        })
        .collect();
    let rejected: Vec<Rejection> = outcomes
        .iter()
        .filter_map(|o| match o {
            SampleOutcome::Rejected(r) => Some(r.clone()),
            SampleOutcome::Accepted(_) => None,
        })
        .collect();
    let batch = record_batch(&records, meta.joints.len(), meta.horizon).map_err(|e| FileError::format(path, e))?;
    let props = WriterProperties::builder()
        .set_compression(Compression::SNAPPY)
        .set_key_value_metadata(Some(key_values(meta, &rejected)))
        .build();
    let mut buffer = Vec::new();
    let mut writer =
        ArrowWriter::try_new(&mut buffer, batch.schema(), Some(props)).map_err(|e| FileError::format(path, e))?;
    writer.write(&batch).map_err(|e| FileError::format(path, e))?;
    writer.close().map_err(|e| FileError::format(path, e))?;
    write_atomically(path, &buffer)?;
    Ok(PartSummary {
        ids: meta.ids,
        rows: records.len() as u64,
        rejected,
        sha256: sha256_hex(&buffer),
        bytes: buffer.len() as u64,
    })
}

fn key_values(meta: &PartMeta<'_>, rejected: &[Rejection]) -> Vec<KeyValue> {
    let json = |v: serde_json::Value| v.to_string();
    vec![
        KeyValue::new("tandem.schema_version".into(), SCHEMA_VERSION.to_string()),
        KeyValue::new("tandem.joints".into(), json(serde_json::json!(meta.joints))),
        KeyValue::new("tandem.ee_frame".into(), meta.ee_frame.to_string()),
        KeyValue::new("tandem.horizon".into(), meta.horizon.to_string()),
        KeyValue::new("tandem.ids".into(), json(serde_json::json!(meta.ids))),
        KeyValue::new("tandem.rejected".into(), json(serde_json::json!(rejected))),
    ]
}

/// Writes `bytes` to `path` through a temporary file, synced before the
/// rename (and the folder after it), so a killed process leaves either the
/// old state or the whole file.
///
/// # Errors
/// I/O errors, naming the file.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    let temporary = temporary_path(path);
    let mut file = std::fs::File::create(&temporary).map_err(FileError::io(&temporary))?;
    file.write_all(bytes).map_err(FileError::io(&temporary))?;
    file.sync_all().map_err(FileError::io(&temporary))?;
    drop(file);
    std::fs::rename(&temporary, path).map_err(FileError::io(path))?;
    if let Some(folder) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        // Directory fsync makes the rename durable; not all platforms allow it.
        let _ = std::fs::File::open(folder).and_then(|d| d.sync_all());
    }
    Ok(())
}

/// SHA-256 of `bytes` as lower-case hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

/// Reads a part file's metadata: ids, rows, rejections and hash.
///
/// # Errors
/// An unreadable file, not Parquet, another schema version, or metadata
/// that does not account for every id of its range.
pub fn read_part_summary(path: &Path) -> Result<PartSummary, FileError> {
    let bytes = std::fs::read(path).map_err(FileError::io(path))?;
    let handle = std::fs::File::open(path).map_err(FileError::io(path))?;
    let reader = SerializedFileReader::new(handle).map_err(|e| FileError::format(path, e))?;
    let file = reader.metadata().file_metadata();
    let value = |key: &str| -> Result<String, FileError> {
        file.key_value_metadata()
            .and_then(|kv| kv.iter().find(|e| e.key == key))
            .and_then(|e| e.value.clone())
            .ok_or_else(|| FileError::format(path, format!("no {key} in the file metadata")))
    };
    let version = value("tandem.schema_version")?;
    if version != SCHEMA_VERSION.to_string() {
        return Err(FileError::format(path, format!("schema version {version}, this tandem writes {SCHEMA_VERSION}")));
    }
    let parse = |key: &str| -> Result<serde_json::Value, FileError> {
        serde_json::from_str(&value(key)?).map_err(|e| FileError::format(path, format!("{key}: {e}")))
    };
    let ids: [u64; 2] = serde_json::from_value(parse("tandem.ids")?).map_err(|e| FileError::format(path, e))?;
    let rejected: Vec<Rejection> =
        serde_json::from_value(parse("tandem.rejected")?).map_err(|e| FileError::format(path, e))?;
    let rows = u64::try_from(file.num_rows()).unwrap_or(0);
    if rows + rejected.len() as u64 != ids[1].saturating_sub(ids[0]) {
        return Err(FileError::format(
            path,
            format!("{rows} rows + {} rejections ≠ ids {}..{}", rejected.len(), ids[0], ids[1]),
        ));
    }
    Ok(PartSummary { ids, rows, rejected, sha256: sha256_hex(&bytes), bytes: bytes.len() as u64 })
}
