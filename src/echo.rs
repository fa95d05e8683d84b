//! Quoting user input in messages: never more than a few hundred characters of it.
//!
//! An error names what was wrong with an input and shows the input, but a hostile or
//! accidental input can be megabytes on one line (a CSV line, a TOML value, a command-line
//! argument); echoing it whole floods the terminal and hides the message.

/// Characters of input shown at most.
pub const MAX_ECHO_CHARS: usize = 200;

/// At most `max_chars` characters of `s`, with `…` if cut.
pub fn clip_to(s: &str, max_chars: usize) -> String {
    match s.char_indices().nth(max_chars) {
        Some((end, _)) => format!("{}…", &s[..end]),
        None => s.to_string(),
    }
}

/// `text` quoted (Rust debug syntax), cut after [`MAX_ECHO_CHARS`] characters with `…` and the
/// total length.
pub fn echo(text: &str) -> String {
    match text.char_indices().nth(MAX_ECHO_CHARS) {
        Some((cut, _)) => format!(
            "{:?}… ({} characters in all)",
            &text[..cut],
            text.chars().count()
        ),
        None => format!("{text:?}"),
    }
}

/// A path for a message: whole up to [`MAX_ECHO_CHARS`] characters, else its start and its
/// end (where the file name is) around `…`, with the total length.
pub fn path(p: &std::path::Path) -> String {
    let text = p.display().to_string();
    let n = text.chars().count();
    if n <= MAX_ECHO_CHARS {
        return text;
    }
    let head: String = text.chars().take(60).collect();
    let tail: String = text.chars().skip(n - 120).collect();
    format!("{head}…{tail} ({n} characters in all)")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_input_is_cut() {
        assert_eq!(echo("1,2"), "\"1,2\"");
        let long = "é".repeat(10_000);
        let e = echo(&long);
        assert!(e.chars().count() < MAX_ECHO_CHARS + 40, "{e}");
        assert!(e.ends_with("(10000 characters in all)"), "{e}");
    }
}
