//! Reading a user's input file (a job file, a uvspec input) as text, with
//! one set of errors: missing or unreadable (the operating system's
//! message), or not UTF-8 text (the line and byte where it stops being
//! text). All of them are user errors (exit code 2).

use std::path::Path;

use crate::error::{Error, Result};

/// The text of the file at `path`.
pub fn read_text(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let line = 1 + bytes[..at].iter().filter(|&&b| b == b'\n').count();
        let column = 1 + at - bytes[..at].iter().rposition(|&b| b == b'\n').map_or(0, |p| p + 1);
        Error::data(
            path.display().to_string(),
            format!(
                "not UTF-8 text: byte 0x{:02x} at line {line}, column {column} (byte offset {at}); \
                 save the file as UTF-8",
                bytes[at]
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_that_is_not_utf8_is_refused_with_its_position() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("job.toml");
        std::fs::write(&p, b"[sun]\nelevation_deg = 3\xe9\n").unwrap();
        let e = read_text(&p).unwrap_err();
        assert!(e.is_user_error());
        let msg = e.to_string();
        assert!(msg.contains("line 2, column 18") && msg.contains("0xe9"), "{msg}");
        std::fs::write(&p, "ok = \"é\"\n").unwrap();
        assert_eq!(read_text(&p).unwrap(), "ok = \"é\"\n");
    }

    #[test]
    fn a_missing_or_unreadable_file_is_a_user_error_named_once() {
        let dir = tempfile::tempdir().unwrap();
        for p in [dir.path().join("missing.toml"), dir.path().to_path_buf()] {
            let e = read_text(&p).unwrap_err();
            assert!(e.is_user_error(), "{e}");
            // The operating system's message appears once.
            let msg = e.to_string();
            let os = msg.rsplit(": ").next().unwrap();
            assert_eq!(msg.matches(os).count(), 1, "{msg}");
            assert!(std::error::Error::source(&e).is_none());
        }
    }
}
