//! Which external programs this process may start.
//!
//! An experiment file can name a program to run (the `external` segmenter's `command`), and
//! experiment files are shared: a paper's TOML, a colleague's sweep. A program is therefore
//! started only when the user has allowed its exact command line. The engine asks for that
//! consent before a run (`--allow-external`, or a trust record written by `motionlab trust`)
//! and then [`allow`]s the run's command lines here; a plugin that starts a program asks
//! [`is_allowed`] first (and refuses with its own located error), so a command line nobody allowed is refused even if it reached a plugin by
//! a path the engine did not list. Nothing is allowed until someone allows it.
//!
//! A plugin that runs a program says so in its params schema with the [`RUNS_PROGRAM_KEY`]
//! extension naming the key that holds the command line,
//! `#[schemars(extend("x-runs-program" = "command"))]`, which is how the engine finds every
//! command line of an experiment before anything runs.

use std::collections::BTreeSet;
use std::sync::RwLock;

/// The schema key (on a params struct) naming the parameter that holds the program and its
/// arguments, as an array of strings (`"command"`).
pub const RUNS_PROGRAM_KEY: &str = "x-runs-program";

/// The parameter holding the command line, when the plugin's params schema declares one.
pub fn program_key(schema: &schemars::Schema) -> Option<String> {
    schema.as_value().get(RUNS_PROGRAM_KEY).and_then(|v| v.as_str()).map(str::to_string)
}

struct Policy {
    any: bool,
    allowed: BTreeSet<Vec<String>>,
}

static POLICY: RwLock<Policy> = RwLock::new(Policy { any: false, allowed: BTreeSet::new() });

/// Allows this process to start exactly these command lines (programs and arguments, as the
/// experiment gives them); others stay refused.
pub fn allow<'a>(commands: impl IntoIterator<Item = &'a [String]>) {
    let mut p = POLICY.write().unwrap_or_else(|e| e.into_inner());
    p.allowed.extend(commands.into_iter().map(<[String]>::to_vec));
}

/// Allows every command line: for code that builds external stages itself and so has decided
/// already (a test of the plugin, a program embedding motionlab's stages).
pub fn allow_any() {
    POLICY.write().unwrap_or_else(|e| e.into_inner()).any = true;
}

/// Whether `command` may be started.
pub fn is_allowed(command: &[String]) -> bool {
    let p = POLICY.read().unwrap_or_else(|e| e.into_inner());
    p.any || p.allowed.contains(command)
}

/// A command line as a user would read it, and safe to print: an argument is quoted when it
/// is empty or holds white space, quotes, backslashes or any character a terminal would not
/// show as itself (control characters, escape sequences, bidirectional overrides), which are
/// written as Rust escapes (`\u{1b}`), so a command cannot disguise itself on the screen.
pub fn command_line(command: &[String]) -> String {
    let quote = |a: &String| {
        let plain =
            !a.is_empty() && a.chars().all(|c| !c.is_whitespace() && c.escape_debug().len() == 1);
        if plain { a.clone() } else { format!("{a:?}") }
    };
    command.iter().map(quote).collect::<Vec<_>>().join(" ")
}

/// `s` as one POSIX shell word, for a command the user can copy (or a job script): unchanged
/// when it holds only characters no shell treats specially, else single-quoted.
pub fn shell_word(s: &str) -> String {
    if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c)) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(args: &[&str]) -> Vec<String> {
        args.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn only_allowed_command_lines_pass() {
        let cmd = v(&["programs-test-only", "x"]);
        assert!(!is_allowed(&cmd));
        allow([cmd.as_slice()]);
        assert!(is_allowed(&cmd));
        // One more argument is another command line.
        assert!(!is_allowed(&v(&["programs-test-only", "x", "y"])));
    }

    #[test]
    fn command_lines_print_escaped() {
        assert_eq!(command_line(&v(&["sh", "-c", "exit 1"])), "sh -c \"exit 1\"");
        assert_eq!(command_line(&v(&["python3", "my_seg.py"])), "python3 my_seg.py");
        assert_eq!(
            command_line(&v(&["a\u{1b}[2Jb", "", "r\u{202e}l", "日本"])),
            "\"a\\u{1b}[2Jb\" \"\" \"r\\u{202e}l\" 日本"
        );
        assert_eq!(shell_word("/x/exp.toml"), "/x/exp.toml");
        assert_eq!(shell_word("it's here"), "'it'\\''s here'");
    }
}
