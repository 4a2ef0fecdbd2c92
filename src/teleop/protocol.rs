//! The page's messages to the server, parsed strictly: anything else is a
//! typed error the page is told about, never a panic or a dropped session.

use serde::Deserialize;

/// The longest message a session accepts (bytes); a longer one closes the
/// connection with code 1009 ("message too big").
pub const MAX_MESSAGE_BYTES: usize = 4096;

/// The longest frame the WebSocket layer reads in full (bytes). Messages
/// between [`MAX_MESSAGE_BYTES`] and this are read and then refused with a
/// clean closing handshake; a longer one is cut off mid-frame, and the
/// page may see an abnormal close (1006) when the kernel resets a socket
/// that still holds unread bytes.
pub const MAX_FRAME_BYTES: usize = 1 << 20;

/// One message from the page.
#[derive(Debug, Clone, PartialEq)]
pub enum ClientMessage {
    /// The operator's gripper velocity (m/s, world axes); NaN where the
    /// page sent `null` (JavaScript's `JSON.stringify(NaN)`).
    Command {
        /// Linear velocity of the gripper.
        linear: [f64; 3],
    },
    /// Switch the arbitration mode (a name `tandem arbitrate --mode` takes).
    Mode {
        /// The mode's name.
        mode: String,
    },
    /// End the episode and start a new one, on `task` (default: the same)
    /// with `seed` (default: the next).
    Reset {
        /// `reach-grasp` or `planar`.
        task: Option<String>,
        /// The task's seed (planar object placement).
        seed: Option<u64>,
    },
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum Wire {
    Command { linear: [Option<f64>; 3] },
    Mode { mode: String },
    Reset { task: Option<String>, seed: Option<u64> },
}

/// Parses one text frame.
///
/// # Errors
/// A message that is not JSON, has an unknown `type` or fields, or values
/// of the wrong kind, with serde's description of where.
pub fn parse_client_message(text: &str) -> Result<ClientMessage, String> {
    let wire: Wire = serde_json::from_str(text).map_err(|e| format!("malformed message: {e}"))?;
    Ok(match wire {
        Wire::Command { linear } => ClientMessage::Command { linear: linear.map(|v| v.unwrap_or(f64::NAN)) },
        Wire::Mode { mode } => ClientMessage::Mode { mode },
        Wire::Reset { task, seed } => ClientMessage::Reset { task, seed },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_modes_and_resets_parse() {
        let m = parse_client_message(r#"{"type":"command","linear":[0.1,-0.2,0]}"#).unwrap();
        assert_eq!(m, ClientMessage::Command { linear: [0.1, -0.2, 0.0] });
        let m = parse_client_message(r#"{"type":"mode","mode":"sos"}"#).unwrap();
        assert_eq!(m, ClientMessage::Mode { mode: "sos".into() });
        let m = parse_client_message(r#"{"type":"reset","task":"planar"}"#).unwrap();
        assert_eq!(m, ClientMessage::Reset { task: Some("planar".into()), seed: None });
    }

    #[test]
    fn null_is_nan_and_garbage_is_an_error() {
        match parse_client_message(r#"{"type":"command","linear":[null,0,0]}"#).unwrap() {
            ClientMessage::Command { linear } => assert!(linear[0].is_nan() && linear[1] == 0.0),
            other => panic!("{other:?}"),
        }
        for bad in [
            "",
            "{",
            "[]",
            r#"{"type":"fly"}"#,
            r#"{"type":"command","linear":[1,2]}"#,
            r#"{"type":"command","linear":["a",0,0]}"#,
            r#"{"type":"command","linear":[0,0,0],"extra":1}"#,
            r#"{"type":"reset","seed":-1}"#,
        ] {
            let e = parse_client_message(bad).unwrap_err();
            assert!(e.starts_with("malformed message"), "{bad}: {e}");
        }
    }
}
