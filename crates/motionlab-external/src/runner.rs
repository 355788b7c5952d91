//! Running the program: consent, exchange folder, process, timeout, bounded output, and
//! errors that name the plugin and the command.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

use serde_json::{Map, Value};

use motionlab_core::{Error, ErrorKind, Motion, Result, programs};

use crate::protocol::{self, Meta, ReplyError};

/// How many trailing lines of stderr an exit-status error quotes.
const STDERR_LINES: usize = 5;
/// How often the wait for the program checks the clock.
const POLL: Duration = Duration::from_millis(5);
/// How much of the end of stderr is kept for messages (the rest is read and dropped, so a
/// program that writes without end to stderr neither blocks nor fills memory).
const STDERR_KEPT_BYTES: usize = 64 << 10;
/// A signal's number when the program wrote a file beyond its RLIMIT_FSIZE (the platform's
/// own: 25 on x86 and ARM, 31 on MIPS).
#[cfg(unix)]
const SIGXFSZ: i32 = rustix::process::Signal::XFSZ.as_raw();

/// A checked external command: what the `external*` plugins run for each motion.
#[derive(Clone, Debug)]
pub struct Invocation {
    /// The registered plugin name, for messages and `meta.json`.
    pub plugin: &'static str,
    pub command: Vec<String>,
    pub timeout: Duration,
    /// The most bytes the program may print on stdout, and the largest file it may write.
    pub max_output_bytes: u64,
    pub params: Map<String, Value>,
}

impl Invocation {
    /// Validates the parameters shared by the external plugins (errors name the field).
    pub fn check(
        plugin: &'static str,
        command: Vec<String>,
        timeout_s: f64,
        max_output_mb: u64,
        params: Map<String, Value>,
    ) -> Result<Self> {
        let Some(program) = command.first().filter(|p| !p.is_empty()) else {
            return Err(Error::new(
                ErrorKind::MissingKey,
                "command must name a program: command = [\"python3\", \"my_segmenter.py\"]",
            )
            .with_field("command"));
        };
        if find_program(program).is_none() {
            let cwd = std::env::current_dir()
                .map(|d| d.display().to_string())
                .unwrap_or_else(|_| "?".into());
            let where_ = if program.contains('/') {
                format!("relative to the current directory {cwd}")
            } else {
                "on PATH".to_string()
            };
            return Err(Error::new(
                ErrorKind::Io,
                format!("program {program:?} not found {where_}"),
            )
            .with_field("command"));
        }
        // One day at most: longer is surely a unit mistake (ms for s), and `Duration` must hold it.
        let timeout = Duration::try_from_secs_f64(timeout_s)
            .ok()
            .filter(|t| !t.is_zero() && t.as_secs() <= 86_400)
            .ok_or_else(|| {
                Error::new(
                    ErrorKind::OutOfRange,
                    format!("must be a number of seconds in (0, 86400], found {timeout_s}"),
                )
                .with_field("timeout_s")
            })?;
        let max_output_bytes =
            max_output_mb.checked_mul(1 << 20).filter(|&b| b > 0).ok_or_else(|| {
                Error::new(
                    ErrorKind::OutOfRange,
                    format!("must be a whole number of MiB from 1, found {max_output_mb}"),
                )
                .with_field("max_output_mb")
            })?;
        Ok(Invocation { plugin, command, timeout, max_output_bytes, params })
    }

    /// The command as a user would read it, control characters escaped.
    pub fn command_line(&self) -> String {
        programs::command_line(&self.command)
    }

    /// One error naming the plugin and the command.
    pub fn error(&self, kind: ErrorKind, message: impl std::fmt::Display) -> Error {
        Error::new(kind, format!("{} `{}`: {message}", self.plugin, self.command_line()))
    }

    /// Converts a protocol check's error.
    fn reply_error(&self, (kind, message): ReplyError) -> Error {
        self.error(kind, message)
    }

    /// One call of the protocol: runs the program on `motion`, parses its stdout as `R` and
    /// checks and converts it with `convert` (given the motion's frame count).
    pub fn call<R: serde::de::DeserializeOwned, T>(
        &self,
        motion: &Motion,
        expects: &str,
        convert: fn(R, usize) -> Result<T, ReplyError>,
    ) -> Result<T> {
        let stdout = self.exchange(motion, expects)?;
        let reply: R = protocol::parse_reply(&stdout).map_err(|e| self.reply_error(e))?;
        convert(reply, motion.n_frames()).map_err(|e| self.reply_error(e))
    }

    /// Writes the motion to a fresh folder, runs the program on it and returns its stdout.
    fn exchange(&self, motion: &Motion, expects: &str) -> Result<Vec<u8>> {
        let dir =
            tempfile::Builder::new().prefix("motionlab-external-").tempdir().map_err(|e| {
                self.error(ErrorKind::Io, format!("cannot create the exchange folder: {e}"))
            })?;
        let meta = Meta::new(self.plugin, expects, &self.command, &self.params, motion);
        protocol::write_exchange(dir.path(), &meta, motion).map_err(|e| {
            self.error(
                ErrorKind::Io,
                format!("cannot write the motion to {}: {e}", dir.path().display()),
            )
        })?;
        self.run(dir.path())
    }

    /// Runs the command with `dir` as last argument; kills it (and its process group) after the timeout.
    fn run(&self, dir: &Path) -> Result<Vec<u8>> {
        // The engine allows a run's command lines once the user consented; anything else is
        // refused here, before a process exists.
        if !programs::is_allowed(&self.command) {
            return Err(self.error(
                ErrorKind::NotAllowed,
                "not started: motionlab starts a program named by an experiment only when allowed (--allow-external, or `motionlab trust EXPERIMENT`)",
            ));
        }
        let mut cmd = Command::new(&self.command[0]);
        cmd.args(&self.command[1..])
            .arg(dir)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        #[cfg(unix)]
        {
            // Its own process group, so a timeout also kills what a wrapper script started.
            use std::os::unix::process::CommandExt;
            cmd.process_group(0);
            let max_file = self.max_output_bytes;
            // SAFETY: runs in the child between fork and exec, where only async-signal-safe
            // work is allowed: two raw system calls (getrlimit, setrlimit), no allocation, no
            // lock. RLIMIT_FSIZE makes the kernel stop the program (SIGXFSZ) when it writes a
            // file beyond max_output_mb — in the exchange folder or anywhere else.
            unsafe {
                cmd.pre_exec(move || {
                    use rustix::process::{Resource, Rlimit, getrlimit, setrlimit};
                    let hard =
                        getrlimit(Resource::Fsize).maximum.map_or(max_file, |h| h.min(max_file));
                    setrlimit(Resource::Fsize, Rlimit { current: Some(hard), maximum: Some(hard) })
                        .map_err(std::io::Error::from)
                });
            }
        }
        let mut child = cmd.spawn().map_err(|e| {
            let why = match e.kind() {
                std::io::ErrorKind::NotFound => {
                    "not found (on PATH, or relative to the current directory)".to_string()
                }
                std::io::ErrorKind::PermissionDenied => {
                    "not executable (permission denied)".to_string()
                }
                _ => e.to_string(),
            };
            self.error(ErrorKind::Io, format!("cannot start the program: {why}"))
        })?;
        let started = Instant::now();
        let overflow = Arc::new(AtomicBool::new(false));
        let stdout = read_in_background(
            child.stdout.take(),
            Keep::AtMost(self.max_output_bytes, Arc::clone(&overflow)),
        );
        let stderr = read_in_background(child.stderr.take(), Keep::Last(STDERR_KEPT_BYTES));
        let deadline = started + self.timeout;
        let too_much = || {
            self.error(
                ErrorKind::TooLarge,
                format!(
                    "printed more than {} on stdout (max_output_mb) and was killed",
                    motionlab_core::limits::describe_limit(self.max_output_bytes)
                ),
            )
        };
        let status = match wait_until(&mut child, deadline, &overflow) {
            Ok(Some(status)) => status,
            Ok(None) if overflow.load(Ordering::SeqCst) => {
                kill(&mut child);
                return Err(too_much());
            }
            Ok(None) => {
                kill(&mut child);
                return Err(self.error(
                    ErrorKind::Io,
                    format!(
                        "timed out after {} s (timeout_s) and was killed",
                        self.timeout.as_secs_f64()
                    ),
                ));
            }
            Err(e) => {
                kill(&mut child);
                return Err(self.error(ErrorKind::Io, format!("cannot wait for the program: {e}")));
            }
        };
        // A process the program left behind may still hold the pipes: wait no longer than the timeout.
        let remaining = deadline.saturating_duration_since(Instant::now());
        let (Ok(out), Ok(err)) = (
            stdout.recv_timeout(remaining),
            stderr.recv_timeout(POLL.max(deadline.saturating_duration_since(Instant::now()))),
        ) else {
            kill(&mut child);
            return Err(self.error(ErrorKind::Io, "exited, but a process it started still held its output open at the timeout (killed)"));
        };
        // The program may have exited (or died of the closed pipe) just as stdout overflowed.
        if overflow.load(Ordering::SeqCst) {
            kill(&mut child);
            return Err(too_much());
        }
        if !status.success() {
            let mut why = describe_status(status);
            #[cfg(unix)]
            if std::os::unix::process::ExitStatusExt::signal(&status) == Some(SIGXFSZ) {
                why += &format!(
                    " (SIGXFSZ: it wrote a file larger than {}, max_output_mb)",
                    motionlab_core::limits::describe_limit(self.max_output_bytes)
                );
            }
            return Err(self.error(ErrorKind::Io, format!("{why}; {}", stderr_tail(&err))));
        }
        Ok(out)
    }
}

/// What a pipe's reader keeps.
enum Keep {
    /// Everything up to this many bytes; beyond it the flag is raised and reading stops (the
    /// program then dies of the closed pipe, or is killed).
    AtMost(u64, Arc<AtomicBool>),
    /// The last this many bytes; everything is read.
    Last(usize),
}

/// Reads a pipe on a thread; the channel delivers the bytes kept.
fn read_in_background(
    pipe: Option<impl Read + Send + 'static>,
    keep: Keep,
) -> mpsc::Receiver<Vec<u8>> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut bytes = Vec::new();
        if let Some(p) = pipe {
            // A read error ends the output early; the exit status or JSON check reports it.
            match keep {
                Keep::AtMost(limit, overflow) => {
                    let _ = p.take(limit.saturating_add(1)).read_to_end(&mut bytes);
                    if bytes.len() as u64 > limit {
                        overflow.store(true, Ordering::SeqCst);
                        bytes.clear();
                    }
                }
                Keep::Last(n) => {
                    let mut p = p;
                    let mut buf = vec![0u8; 16 << 10];
                    loop {
                        match p.read(&mut buf) {
                            Ok(0) => break,
                            Ok(k) => {
                                bytes.extend_from_slice(&buf[..k]);
                                if bytes.len() > 2 * n {
                                    bytes.drain(..bytes.len() - n);
                                }
                            }
                            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                            Err(_) => break,
                        }
                    }
                    if bytes.len() > n {
                        bytes.drain(..bytes.len() - n);
                    }
                }
            }
        }
        let _ = tx.send(bytes);
    });
    rx
}

/// The exit status once the child exits, or `None` at the deadline or as soon as `stop` is raised.
fn wait_until(
    child: &mut Child,
    deadline: Instant,
    stop: &AtomicBool,
) -> std::io::Result<Option<ExitStatus>> {
    loop {
        if let Some(status) = child.try_wait()? {
            return Ok(Some(status));
        }
        let now = Instant::now();
        if now >= deadline || stop.load(Ordering::SeqCst) {
            return Ok(None);
        }
        std::thread::sleep(POLL.min(deadline - now));
    }
}

/// Kills the child's process group (Unix) or the child, and reaps it.
fn kill(child: &mut Child) {
    #[cfg(unix)]
    if let Ok(pid) = i32::try_from(child.id())
        && let Some(pid) = rustix::process::Pid::from_raw(pid)
    {
        // The group exists while any member lives; an error means all are gone already.
        let _ = rustix::process::kill_process_group(pid, rustix::process::Signal::KILL);
    }
    let _ = child.kill();
    let _ = child.wait();
}

fn describe_status(status: ExitStatus) -> String {
    if let Some(code) = status.code() {
        return format!("exited with status {code}");
    }
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if let Some(signal) = status.signal() {
            return format!("was killed by signal {signal}");
        }
    }
    format!("failed ({status})")
}

/// The last lines of stderr on one line (` | ` between lines).
fn stderr_tail(stderr: &[u8]) -> String {
    let text = String::from_utf8_lossy(stderr);
    let lines: Vec<&str> = text.lines().map(str::trim).filter(|l| !l.is_empty()).collect();
    if lines.is_empty() {
        return "stderr was empty".into();
    }
    let tail = &lines[lines.len().saturating_sub(STDERR_LINES)..];
    let clipped: Vec<String> = tail
        .iter()
        .map(|l| {
            if l.chars().count() > 200 {
                format!("{}…", l.chars().take(200).collect::<String>())
            } else {
                l.to_string()
            }
        })
        .collect();
    format!("last lines of stderr: {}", clipped.join(" | "))
}

/// Where `program` would be found: a path (when it contains `/`) or the first `PATH` entry
/// holding a file of that name.
fn find_program(program: &str) -> Option<PathBuf> {
    if program.contains('/') {
        let p = PathBuf::from(program);
        return p.is_file().then_some(p);
    }
    std::env::split_paths(&std::env::var_os("PATH")?).map(|d| d.join(program)).find(|p| p.is_file())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stderr_tail_keeps_the_last_lines_on_one_line() {
        let err = b"a\nb\n\nc\nd\ne\nf\n";
        assert_eq!(stderr_tail(err), "last lines of stderr: b | c | d | e | f");
        assert_eq!(stderr_tail(b"\n"), "stderr was empty");
    }

    #[test]
    fn command_line_quotes_what_needs_it() {
        let inv = Invocation::check(
            "external",
            vec!["sh".into(), "-c".into(), "exit 1".into()],
            1.0,
            1,
            Map::new(),
        )
        .unwrap();
        assert_eq!(inv.command_line(), "sh -c \"exit 1\"");
        let e = Invocation::check("external", vec!["sh".into()], 0.0, 1, Map::new()).unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("timeout_s"));
        let e = Invocation::check("external", vec![], 1.0, 1, Map::new()).unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("command"));
        let e = Invocation::check("external", vec!["sh".into()], 1.0, 0, Map::new()).unwrap_err();
        assert_eq!(e.location().field.as_deref(), Some("max_output_mb"));
    }
}
