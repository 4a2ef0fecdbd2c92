//! CSV as RFC 4180 writes it, for the text files tandem writes and reads
//! back (trajectories, rollout tables): names from URDFs and problem files
//! are not restricted, so a joint or obstacle name may hold a comma, a quote
//! or a line break, and must come back as it was written.

use std::borrow::Cow;

/// `text` as one CSV field: quoted, with its quotes doubled, when it holds a
/// comma, a quote or a line break, or starts or ends with white space
/// (which a reader trims from unquoted fields); as it is otherwise.
pub fn field(text: &str) -> Cow<'_, str> {
    let edge_space = text.starts_with(char::is_whitespace) || text.ends_with(char::is_whitespace);
    if edge_space || text.contains([',', '"', '\n', '\r']) { Cow::Owned(quoted(text)) } else { Cow::Borrowed(text) }
}

/// `text` as one quoted CSV field, its quotes doubled, whatever it holds:
/// for a field a reader would otherwise take for something else.
pub fn quoted(text: &str) -> String {
    format!("\"{}\"", text.replace('"', "\"\""))
}

/// One record of a CSV text: the 1-based line it starts on and its fields.
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    /// The 1-based line of the record's first character.
    pub line: usize,
    /// The fields: unquoted ones trimmed of white space, quoted ones
    /// exactly as between their quotes (doubled quotes made single).
    pub fields: Vec<String>,
    /// Whether each field was quoted.
    pub quoted: Vec<bool>,
}

/// A CSV text that breaks RFC 4180's quoting, at its 1-based `line`.
#[derive(Debug, Clone, PartialEq)]
pub struct CsvSyntaxError {
    /// The 1-based line at fault.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

/// The records of `text`, in order; blank lines (outside quotes) are
/// skipped. A quoted field may span lines; CR LF ends a line as LF does.
///
/// # Errors
/// A quote left open at the end of the text (naming the line it opened on),
/// or text between a closing quote and the next comma or line end.
pub fn records(text: &str) -> Result<Vec<Record>, CsvSyntaxError> {
    let mut out = Vec::new();
    let mut chars = text.chars().peekable();
    let mut line = 1;
    while chars.peek().is_some() {
        let start = line;
        let mut fields = Vec::new();
        let mut quoted = Vec::new();
        loop {
            let (value, was_quoted, end) = next_field(&mut chars, &mut line)?;
            fields.push(value);
            quoted.push(was_quoted);
            if end != FieldEnd::Comma {
                break;
            }
        }
        let blank = fields.len() == 1 && !quoted[0] && fields[0].is_empty();
        if !blank {
            out.push(Record { line: start, fields, quoted });
        }
    }
    Ok(out)
}

#[derive(Debug, PartialEq)]
enum FieldEnd {
    /// Another field of the record follows.
    Comma,
    /// The record ends: a line break or the end of the text.
    Record,
}

/// The next field from `chars`, whether it was quoted, and what ended it;
/// `line` follows the line breaks read.
fn next_field(
    chars: &mut std::iter::Peekable<std::str::Chars<'_>>,
    line: &mut usize,
) -> Result<(String, bool, FieldEnd), CsvSyntaxError> {
    let mut value = String::new();
    // White space before an opening quote is not part of the field.
    while let Some(&c) = chars.peek() {
        if c == ' ' || c == '\t' {
            value.push(c);
            chars.next();
        } else {
            break;
        }
    }
    if chars.peek() == Some(&'"') {
        chars.next();
        let opened = *line;
        value.clear();
        loop {
            match chars.next() {
                None => {
                    let message = "a quoted field is not closed before the end of the file".to_string();
                    return Err(CsvSyntaxError { line: opened, message });
                }
                Some('"') if chars.peek() == Some(&'"') => {
                    chars.next();
                    value.push('"');
                }
                Some('"') => break,
                Some(c) => {
                    if c == '\n' {
                        *line += 1;
                    }
                    value.push(c);
                }
            }
        }
        loop {
            match chars.next() {
                None => return Ok((value, true, FieldEnd::Record)),
                Some(',') => return Ok((value, true, FieldEnd::Comma)),
                Some('\n') => {
                    *line += 1;
                    return Ok((value, true, FieldEnd::Record));
                }
                Some(c) if c.is_whitespace() => {}
                Some(c) => {
                    let message =
                        format!("'{c}' after a closing quote: a quoted field must end at a comma or line end");
                    return Err(CsvSyntaxError { line: *line, message });
                }
            }
        }
    }
    loop {
        match chars.next() {
            None => return Ok((value.trim().to_string(), false, FieldEnd::Record)),
            Some(',') => return Ok((value.trim().to_string(), false, FieldEnd::Comma)),
            Some('\n') => {
                *line += 1;
                return Ok((value.trim().to_string(), false, FieldEnd::Record));
            }
            Some(c) => value.push(c),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fields(text: &str) -> Vec<Vec<String>> {
        records(text).unwrap().into_iter().map(|r| r.fields).collect()
    }

    #[test]
    fn plain_fields_are_trimmed_and_blank_lines_skipped() {
        assert_eq!(fields("a, b ,c\r\n\n  \n1,2,3"), [vec!["a", "b", "c"], vec!["1", "2", "3"]]);
        assert_eq!(fields("a,,\n"), [vec!["a", "", ""]]);
        let r = records("x\n\n\"y\"\n").unwrap();
        assert_eq!((r[0].line, r[1].line), (1, 3));
        assert_eq!(r[1].quoted, [true]);
    }

    #[test]
    fn every_written_field_reads_back_as_it_was() {
        let names = ["plain", "a,b", "say \"hi\"", "two\nlines", "cr\r\nlf", " padded ", "", "\"", ",", "ü,ß"];
        let row: Vec<String> = names.iter().map(|n| field(n).into_owned()).collect();
        let text = format!("{}\n1,{}\n", row.join(","), vec!["2"; names.len() - 1].join(","));
        let r = records(&text).unwrap();
        assert_eq!(r.len(), 2);
        assert_eq!(r[0].fields, names);
        // The header spans three lines (two names hold line breaks).
        assert_eq!(r[1].line, 4, "{text:?}");
        assert_eq!(field("plain"), "plain");
        assert_eq!(field("a,b"), "\"a,b\"");
        assert_eq!(field("say \"hi\""), "\"say \"\"hi\"\"\"");
    }

    #[test]
    fn broken_quoting_names_the_line() {
        let e = records("a,b\n1,\"open\n2,3\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.message.contains("not closed"), "{}", e.message);
        let e = records("a,b\n\"x\"y,2\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.message.contains("'y' after a closing quote"), "{}", e.message);
    }
}
