//! PLY (Stanford polygon files): the header's elements and properties,
//! then the `vertex` element's `x`, `y`, `z`; other elements (faces) are
//! read past, lists included.

use super::{PointCloudError, PointSink, Scalar, header_lines};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Ascii,
    Binary { little: bool },
}

/// A property: a scalar, or a list (its count's type and its items').
#[derive(Debug, Clone)]
struct Property {
    name: String,
    scalar: Scalar,
    list_count: Option<Scalar>,
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
    line: usize,
}

fn scalar(name: &str) -> Option<Scalar> {
    Some(match name {
        "char" | "int8" => Scalar::I8,
        "uchar" | "uint8" => Scalar::U8,
        "short" | "int16" => Scalar::I16,
        "ushort" | "uint16" => Scalar::U16,
        "int" | "int32" => Scalar::I32,
        "uint" | "uint32" => Scalar::U32,
        "float" | "float32" => Scalar::F32,
        "double" | "float64" => Scalar::F64,
        _ => return None,
    })
}

pub(super) fn parse(bytes: &[u8], file: &str, cloud: &mut impl PointSink) -> Result<(), PointCloudError> {
    let err = |line: Option<usize>, m: String| PointCloudError::new(file, line, m);
    let (lines, body) = header_lines(bytes, file, |l| l == "end_header")?;
    if lines.first().map(|(_, l)| l.trim()) != Some("ply") {
        return Err(err(Some(1), "a PLY file starts with the line `ply`".into()));
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for &(n, text) in &lines[1..lines.len() - 1] {
        let words: Vec<&str> = text.split_whitespace().collect();
        match words.as_slice() {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", kind, version] => {
                if *version != "1.0" {
                    return Err(err(Some(n), format!("PLY version {version}: only 1.0 is known")));
                }
                format = Some(match *kind {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Binary { little: true },
                    "binary_big_endian" => Format::Binary { little: false },
                    other => return Err(err(Some(n), format!("unknown PLY format '{other}'"))),
                });
            }
            ["element", name, count] => {
                let count = count.parse().map_err(|_| err(Some(n), format!("element {name}: count '{count}'")))?;
                elements.push(Element { name: name.to_string(), count, properties: Vec::new(), line: n });
            }
            ["property", "list", count, item, name] => {
                let (Some(c), Some(i)) = (scalar(count), scalar(item)) else {
                    return Err(err(Some(n), format!("property list {count} {item}: unknown type")));
                };
                let element =
                    elements.last_mut().ok_or_else(|| err(Some(n), "a property before any element".into()))?;
                element.properties.push(Property { name: name.to_string(), scalar: i, list_count: Some(c) });
            }
            ["property", kind, name] => {
                let s = scalar(kind).ok_or_else(|| err(Some(n), format!("property {name}: unknown type '{kind}'")))?;
                let element =
                    elements.last_mut().ok_or_else(|| err(Some(n), "a property before any element".into()))?;
                element.properties.push(Property { name: name.to_string(), scalar: s, list_count: None });
            }
            _ => return Err(err(Some(n), format!("not a PLY header line: '{text}'"))),
        }
    }
    let format = format.ok_or_else(|| err(None, "the header has no `format` line".into()))?;
    let Some(vertex) = elements.iter().position(|e| e.name == "vertex") else {
        return Err(err(None, "no `vertex` element".into()));
    };
    let v = &elements[vertex];
    let axis = |name: &str| -> Result<usize, PointCloudError> {
        match v.properties.iter().position(|p| p.name == name) {
            Some(k) if v.properties[k].list_count.is_none() => Ok(k),
            Some(_) => Err(err(Some(v.line), format!("vertex property {name} is a list"))),
            None => Err(err(Some(v.line), format!("the vertex element has no property {name}"))),
        }
    };
    let xyz = [axis("x")?, axis("y")?, axis("z")?];
    cloud.reserve(v.count);
    let mut values = vec![0.0; v.properties.len()];
    match format {
        Format::Ascii => {
            let text =
                std::str::from_utf8(&bytes[body..]).map_err(|_| err(None, "the ASCII body is not text".into()))?;
            let mut rows = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
            for (e, element) in elements.iter().enumerate().take(vertex + 1) {
                for k in 0..element.count {
                    let Some((row, line)) = rows.next() else {
                        return Err(err(None, format!("element {} ends after {k} of {}", element.name, element.count)));
                    };
                    let n = lines.len() + row + 1;
                    let mut tokens = line.split_whitespace();
                    let mut next = || -> Result<f64, PointCloudError> {
                        let t = tokens.next().ok_or_else(|| err(Some(n), "too few values".into()))?;
                        t.parse::<f64>().map_err(|_| err(Some(n), format!("'{t}' is not a number")))
                    };
                    for (i, p) in element.properties.iter().enumerate() {
                        if p.list_count.is_some() {
                            let len = next()?;
                            for _ in 0..list_len(len, file, Some(n))? {
                                next()?;
                            }
                        } else {
                            let x = next()?;
                            if e == vertex {
                                values[i] = x;
                            }
                        }
                    }
                    if e == vertex {
                        cloud.push(xyz.map(|i| values[i]));
                    }
                }
            }
        }
        Format::Binary { little } => {
            let mut at = body;
            for (e, element) in elements.iter().enumerate().take(vertex + 1) {
                for k in 0..element.count {
                    for (i, p) in element.properties.iter().enumerate() {
                        let short = || {
                            err(None, format!("element {} ends in its record {k} of {}", element.name, element.count))
                        };
                        if let Some(c) = p.list_count {
                            let raw = bytes.get(at..at + c.size()).ok_or_else(short)?;
                            let len = list_len(c.read(raw, little), file, None)?;
                            at += c.size() + len * p.scalar.size();
                            if at > bytes.len() {
                                return Err(short());
                            }
                        } else {
                            let raw = bytes.get(at..at + p.scalar.size()).ok_or_else(short)?;
                            if e == vertex {
                                values[i] = p.scalar.read(raw, little);
                            }
                            at += p.scalar.size();
                        }
                    }
                    if e == vertex {
                        cloud.push(xyz.map(|i| values[i]));
                    }
                }
            }
        }
    }
    Ok(())
}

/// A list's length from its count field: a whole number, not negative.
fn list_len(count: f64, file: &str, line: Option<usize>) -> Result<usize, PointCloudError> {
    if count >= 0.0 && count.fract() == 0.0 && count < 1e9 {
        Ok(count as usize)
    } else {
        Err(PointCloudError::new(file, line, format!("a list of {count} items")))
    }
}
