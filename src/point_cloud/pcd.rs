//! PCD (the Point Cloud Library's format, version 0.7): the header's
//! fields, then `x`, `y`, `z` from an `ascii`, `binary` (records of the
//! fields, little-endian) or `binary_compressed` body (LZF-compressed, one
//! field's values after another).

use super::{PointCloudError, PointSink, Scalar, header_lines};

/// One field: its name, scalar type and count (values per point).
#[derive(Debug, Clone)]
struct Field {
    name: String,
    scalar: Scalar,
    count: usize,
}

pub(super) fn parse(bytes: &[u8], file: &str, cloud: &mut impl PointSink) -> Result<(), PointCloudError> {
    let err = |line: Option<usize>, m: String| PointCloudError::new(file, line, m);
    let (lines, body) = header_lines(bytes, file, |l| l.starts_with("DATA"))?;
    let mut names: Vec<String> = Vec::new();
    let (mut sizes, mut types, mut counts): (Vec<usize>, Vec<char>, Vec<usize>) = (vec![], vec![], vec![]);
    let (mut width, mut height, mut points) = (None, 1usize, None);
    let mut data = "";
    let mut data_line = 0;
    for &(n, text) in &lines {
        let mut words = text.split_whitespace();
        let Some(key) = words.next() else { continue };
        let rest: Vec<&str> = words.collect();
        let whole = |w: &str| w.parse::<usize>().map_err(|_| err(Some(n), format!("{key}: '{w}' is not a count")));
        match key {
            k if k.starts_with('#') => {}
            "VERSION" => {}
            "FIELDS" => names = rest.iter().map(|s| s.to_string()).collect(),
            "SIZE" => sizes = rest.iter().map(|w| whole(w)).collect::<Result<_, _>>()?,
            "TYPE" => {
                types = rest
                    .iter()
                    .map(|w| match *w {
                        "F" | "I" | "U" => Ok(w.chars().next().unwrap_or('F')),
                        _ => Err(err(Some(n), format!("TYPE '{w}' is not F, I or U"))),
                    })
                    .collect::<Result<_, _>>()?;
            }
            "COUNT" => counts = rest.iter().map(|w| whole(w)).collect::<Result<_, _>>()?,
            "WIDTH" => width = Some(whole(rest.first().copied().unwrap_or(""))?),
            "HEIGHT" => height = whole(rest.first().copied().unwrap_or(""))?,
            "VIEWPOINT" => {}
            "POINTS" => points = Some(whole(rest.first().copied().unwrap_or(""))?),
            "DATA" => {
                data = rest.first().copied().unwrap_or("");
                data_line = n;
            }
            other => return Err(err(Some(n), format!("not a PCD header key: '{other}'"))),
        }
    }
    if counts.is_empty() {
        counts = vec![1; names.len()];
    }
    if sizes.len() != names.len() || types.len() != names.len() || counts.len() != names.len() {
        return Err(err(
            None,
            format!(
                "FIELDS has {} names, SIZE {}, TYPE {}, COUNT {}: they must agree",
                names.len(),
                sizes.len(),
                types.len(),
                counts.len()
            ),
        ));
    }
    let mut fields = Vec::with_capacity(names.len());
    for (((name, &size), &kind), &count) in names.iter().zip(&sizes).zip(&types).zip(&counts) {
        let scalar = match (kind, size) {
            ('F', 4) => Scalar::F32,
            ('F', 8) => Scalar::F64,
            ('I', 1) => Scalar::I8,
            ('I', 2) => Scalar::I16,
            ('I', 4) => Scalar::I32,
            ('I', 8) => Scalar::I64,
            ('U', 1) => Scalar::U8,
            ('U', 2) => Scalar::U16,
            ('U', 4) => Scalar::U32,
            ('U', 8) => Scalar::U64,
            _ => return Err(err(None, format!("field {name}: TYPE {kind} with SIZE {size}"))),
        };
        fields.push(Field { name: name.clone(), scalar, count });
    }
    let axis = |axis: &str| -> Result<usize, PointCloudError> {
        match fields.iter().position(|f| f.name == axis) {
            Some(k) if fields[k].scalar == Scalar::F32 || fields[k].scalar == Scalar::F64 => Ok(k),
            Some(_) => Err(err(None, format!("field {axis} is not a float (F 4 or F 8)"))),
            None => Err(err(None, format!("no field {axis} (FIELDS {})", names.join(" ")))),
        }
    };
    let xyz = [axis("x")?, axis("y")?, axis("z")?];
    let count = match (points, width) {
        (Some(p), Some(w)) if p != w * height => {
            return Err(err(None, format!("POINTS {p} is not WIDTH {w} × HEIGHT {height}")));
        }
        (Some(p), _) => p,
        (None, Some(w)) => w * height,
        (None, None) => return Err(err(None, "neither POINTS nor WIDTH".into())),
    };
    // Byte offset of each field in a binary record, and the record's size.
    let mut offsets = Vec::with_capacity(fields.len());
    let mut record = 0;
    for f in &fields {
        offsets.push(record);
        record += f.scalar.size() * f.count;
    }
    cloud.reserve(count);
    match data {
        "ascii" => {
            let text =
                std::str::from_utf8(&bytes[body..]).map_err(|_| err(None, "the ASCII body is not text".into()))?;
            let mut rows = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
            // Token index of each field's first value.
            let mut starts = Vec::with_capacity(fields.len());
            let mut width = 0;
            for f in &fields {
                starts.push(width);
                width += f.count;
            }
            for k in 0..count {
                let Some((row, line)) = rows.next() else {
                    return Err(err(None, format!("the body ends after {k} of {count} points")));
                };
                let n = data_line + row + 1;
                let tokens: Vec<&str> = line.split_whitespace().collect();
                if tokens.len() != width {
                    return Err(err(Some(n), format!("{} values, the fields have {width}", tokens.len())));
                }
                let value = |i: usize| -> Result<f64, PointCloudError> {
                    let t = tokens[starts[i]];
                    // PCL writes missing points as "nan".
                    t.parse::<f64>().map_err(|_| err(Some(n), format!("'{t}' is not a number")))
                };
                cloud.push([value(xyz[0])?, value(xyz[1])?, value(xyz[2])?]);
            }
        }
        "binary" => {
            let need = count * record;
            let raw = bytes.get(body..body + need).ok_or_else(|| {
                err(
                    None,
                    format!("the binary body has {} bytes, {count} points of {record} need {need}", bytes.len() - body),
                )
            })?;
            for p in raw.chunks_exact(record.max(1)) {
                cloud.push(xyz.map(|i| fields[i].scalar.read(&p[offsets[i]..], true)));
            }
        }
        "binary_compressed" => {
            let head = bytes.get(body..body + 8).ok_or_else(|| err(None, "binary_compressed: no sizes".into()))?;
            let compressed = u32::from_le_bytes(head[..4].try_into().expect("4 bytes")) as usize;
            let size = u32::from_le_bytes(head[4..].try_into().expect("4 bytes")) as usize;
            if size != count * record {
                return Err(err(
                    None,
                    format!("binary_compressed: {size} bytes, {count} points of {record} need {}", count * record),
                ));
            }
            let input = bytes.get(body + 8..body + 8 + compressed).ok_or_else(|| {
                err(None, format!("binary_compressed: {compressed} compressed bytes announced, fewer there"))
            })?;
            let raw = lzf_decompress(input, size).map_err(|m| err(None, format!("binary_compressed: {m}")))?;
            // One field's values for every point, then the next field's.
            let mut start = Vec::with_capacity(fields.len());
            let mut at = 0;
            for f in &fields {
                start.push(at);
                at += count * f.scalar.size() * f.count;
            }
            for k in 0..count {
                cloud.push(xyz.map(|i| {
                    let f = &fields[i];
                    fields[i].scalar.read(&raw[start[i] + k * f.scalar.size() * f.count..], true)
                }));
            }
        }
        other => return Err(err(Some(data_line), format!("DATA '{other}' is not ascii, binary or binary_compressed"))),
    }
    Ok(())
}

/// LZF decompression (liblzf's format, as PCL writes it) of `input` into
/// exactly `size` bytes.
fn lzf_decompress(input: &[u8], size: usize) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(size);
    let mut ip = 0;
    while ip < input.len() {
        let ctrl = usize::from(input[ip]);
        ip += 1;
        if ctrl < 32 {
            // A literal run of ctrl + 1 bytes.
            let run = input.get(ip..ip + ctrl + 1).ok_or("a literal run past the end of the input")?;
            out.extend_from_slice(run);
            ip += ctrl + 1;
        } else {
            // A back reference: length (ctrl >> 5) + 2, extended by a byte
            // when the 3 bits are all set; distance from the 13 bits.
            let mut len = ctrl >> 5;
            if len == 7 {
                len += usize::from(*input.get(ip).ok_or("a back reference past the end of the input")?);
                ip += 1;
            }
            let low = usize::from(*input.get(ip).ok_or("a back reference past the end of the input")?);
            ip += 1;
            let distance = ((ctrl & 0x1f) << 8) + low + 1;
            let from = out.len().checked_sub(distance).ok_or("a back reference before the start of the output")?;
            for k in 0..len + 2 {
                let b = out[from + k];
                out.push(b);
            }
        }
        if out.len() > size {
            return Err(format!("decompresses to more than the announced {size} bytes"));
        }
    }
    if out.len() != size {
        return Err(format!("decompresses to {} bytes, {size} announced", out.len()));
    }
    Ok(out)
}

#[cfg(test)]
pub(super) fn lzf_for_tests(input: &[u8], size: usize) -> Result<Vec<u8>, String> {
    lzf_decompress(input, size)
}
