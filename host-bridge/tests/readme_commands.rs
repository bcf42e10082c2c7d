//! Every command the README and the user guide show is run, so that the
//! documentation cannot drift from the tool.
//!
//! The convention, for the lines of the ```sh blocks (also ```bash, ```shell,
//! ```console) of `README.md` and `docs/GUIDE.md` (a line ending in `\` is
//! joined with the next):
//!
//! * empty lines and comment lines are skipped;
//! * `cargo test --workspace` is CI's own test step (`.ci/run`) and skipped;
//! * a line ending in one of the [`MARKERS`] (`# needs a sensor`,
//!   `# needs a board`, `# needs QEMU`, `# needs ROS 2`, `# run by CI`) is not run here: it
//!   needs hardware, QEMU and the firmware, or a build that CI does;
//! * `mkdir -p DIR…` creates the folders;
//! * `cargo run --release -p host-bridge -- ARGS` and `host-bridge ARGS`
//!   run the built binary (`CARGO_BIN_EXE_host-bridge`, no nested cargo)
//!   with ARGS and must exit with status 0 within [`TIMEOUT`]; with a
//!   trailing ` &` the command runs in the background until the end of its
//!   block (later commands wait until its `--link PATH` exists), then gets
//!   SIGTERM, the last started first, and must exit with status 0;
//! * any other line fails the test: a new command is either run here or
//!   marked.
//!
//! A ```toml block whose first line is `# file: PATH` is written to PATH
//! before the commands after it run.
//!
//! The commands run in a scratch folder: `/tmp/lms` stands for a folder in
//! it, `../shared/` for the shared data beside the repository, and relative
//! paths (`target/plots`) land in the scratch folder, so nothing is written
//! into the repository.

use nix::sys::signal::{kill, Signal};
use nix::unistd::Pid;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::{files_under, workspace, BIN};

/// Trailing comments that mark a command this test does not run.
const MARKERS: [&str; 5] = [
    "# needs a sensor",
    "# needs a board",
    "# needs QEMU",
    "# needs ROS 2",
    "# run by CI",
];

/// The longest a foreground command may take.
const TIMEOUT: Duration = Duration::from_secs(60);

/// How one line of a ```sh block is handled.
#[derive(Debug, PartialEq)]
enum Step {
    /// Run by CI or marked as needing hardware: not run here.
    Skipped(String),
    /// `mkdir -p DIR…`.
    Mkdir(Vec<String>),
    /// `host-bridge ARGS`, in the background when `background`.
    Run { args: Vec<String>, background: bool },
    /// A ```toml block to write to a file.
    Write { path: String, text: String },
}

/// The steps of a Markdown document, in order, with the line each starts on;
/// an error names a line the convention does not cover.
fn steps(markdown: &str) -> Result<Vec<Vec<(usize, Step)>>, String> {
    let mut blocks = Vec::new();
    let mut lines = markdown.lines().enumerate();
    while let Some((_, line)) = lines.next() {
        let fence = line.trim_start();
        if matches!(fence, "```sh" | "```bash" | "```shell" | "```console") {
            let mut block = Vec::new();
            let mut pending: Option<(usize, String)> = None;
            for (n, line) in lines.by_ref() {
                if line.trim_start().starts_with("```") {
                    break;
                }
                let (start, mut joined) = pending.take().unwrap_or((n + 1, String::new()));
                joined.push_str(line.trim_end());
                if let Some(head) = joined.strip_suffix('\\') {
                    pending = Some((start, format!("{} ", head.trim_end())));
                    continue;
                }
                if let Some(step) = step(&joined).map_err(|e| format!("line {start}: {e}"))? {
                    block.push((start, step));
                }
            }
            blocks.push(block);
        } else if fence == "```toml" {
            let mut text = String::new();
            let mut first = None;
            for (n, line) in lines.by_ref() {
                if line.trim_start().starts_with("```") {
                    break;
                }
                first.get_or_insert((n + 1, line.to_owned()));
                text.push_str(line);
                text.push('\n');
            }
            if let Some((n, head)) = first {
                if let Some(path) = head.trim().strip_prefix("# file: ") {
                    let path = path.trim().to_owned();
                    blocks.push(vec![(n, Step::Write { path, text })]);
                }
            }
        }
    }
    Ok(blocks)
}

/// One (joined) line of a ```sh block.
fn step(line: &str) -> Result<Option<Step>, String> {
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') {
        return Ok(None);
    }
    if let Some(marker) = MARKERS.iter().find(|m| line.ends_with(*m)) {
        return Ok(Some(Step::Skipped((*marker).to_owned())));
    }
    if line == "cargo test --workspace" {
        return Ok(Some(Step::Skipped("CI's test step".to_owned())));
    }
    if line.contains(" #") {
        return Err(format!("unknown marker in `{line}` (known: {MARKERS:?})"));
    }
    if let Some(dirs) = line.strip_prefix("mkdir -p ") {
        return Ok(Some(Step::Mkdir(
            dirs.split_whitespace().map(str::to_owned).collect(),
        )));
    }
    let (command, background) = match line.strip_suffix('&') {
        Some(head) if !head.ends_with('&') => (head.trim_end(), true),
        _ => (line, false),
    };
    let args = command
        .strip_prefix("cargo run --release -p host-bridge -- ")
        .or_else(|| command.strip_prefix("host-bridge "))
        .ok_or_else(|| format!("`{line}` is neither run by this test nor marked {MARKERS:?}"))?;
    if let Some(c) = args.chars().find(|c| "|;<>'\"`$&".contains(*c)) {
        return Err(format!(
            "`{line}`: `{c}` needs a shell; write the command without it"
        ));
    }
    let args = args.split_whitespace().map(str::to_owned).collect();
    Ok(Some(Step::Run { args, background }))
}

/// Where the commands run and what their paths stand for.
struct Scratch {
    dir: PathBuf,
    tmp_lms: PathBuf,
    shared: PathBuf,
}

impl Scratch {
    fn new(name: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("host-bridge-readme-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared");
        let tmp_lms = dir.join("tmp-lms");
        Scratch {
            dir,
            tmp_lms,
            shared,
        }
    }

    /// A documented path or argument as it is run here.
    fn map(&self, arg: &str) -> String {
        arg.replace("/tmp/lms", &self.tmp_lms.to_string_lossy())
            .replace("../shared/", &format!("{}/", self.shared.display()))
    }

    fn path(&self, arg: &str) -> PathBuf {
        self.dir.join(self.map(arg))
    }
}

/// A background command, with the log files of its output.
struct Background {
    line: usize,
    child: Child,
    log: PathBuf,
}

fn spawn(scratch: &Scratch, args: &[String], log: &Path) -> Child {
    let out = std::fs::File::create(log).unwrap();
    Command::new(BIN)
        .args(args.iter().map(|a| scratch.map(a)))
        .current_dir(&scratch.dir)
        .stdin(Stdio::null())
        .stdout(out.try_clone().unwrap())
        .stderr(out)
        .spawn()
        .expect("cannot start host-bridge")
}

/// Wait for `child` for at most `limit`; kill it when it takes longer.
fn wait(child: &mut Child, limit: Duration) -> Option<ExitStatus> {
    let started = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return Some(status);
        }
        if started.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The path a background command makes with `--link PATH`, if any.
fn link_of(args: &[String]) -> Option<&str> {
    let at = args.iter().position(|a| a == "--link")?;
    args.get(at + 1).map(String::as_str)
}

/// Run one block; every failure is added to `failures`.
fn run_block(doc: &str, scratch: &Scratch, block: &[(usize, Step)], failures: &mut Vec<String>) {
    let mut background: Vec<Background> = Vec::new();
    for (line, step) in block {
        let started = Instant::now();
        match step {
            Step::Skipped(why) => println!("{doc}:{line}: skipped ({why})"),
            Step::Mkdir(dirs) => {
                for dir in dirs {
                    std::fs::create_dir_all(scratch.path(dir)).unwrap();
                }
            }
            Step::Write { path, text } => {
                std::fs::write(scratch.path(path), text).unwrap();
                println!("{doc}:{line}: wrote {path}");
            }
            Step::Run {
                args,
                background: true,
            } => {
                let log = scratch.dir.join(format!("background-{line}.log"));
                let child = spawn(scratch, args, &log);
                println!("{doc}:{line}: $ host-bridge {} &", args.join(" "));
                if let Some(link) = link_of(args) {
                    let link = scratch.path(link);
                    let ready = Instant::now();
                    while link.symlink_metadata().is_err()
                        && ready.elapsed() < Duration::from_secs(10)
                    {
                        std::thread::sleep(Duration::from_millis(20));
                    }
                }
                background.push(Background {
                    line: *line,
                    child,
                    log,
                });
            }
            Step::Run {
                args,
                background: false,
            } => {
                let log = scratch.dir.join(format!("command-{line}.log"));
                let mut child = spawn(scratch, args, &log);
                let status = wait(&mut child, TIMEOUT);
                let output = std::fs::read_to_string(&log).unwrap_or_default();
                println!(
                    "{doc}:{line}: $ host-bridge {} ({:.1} s, {status:?})\n{}",
                    args.join(" "),
                    started.elapsed().as_secs_f64(),
                    tail(&output)
                );
                match status {
                    Some(s) if s.success() => {}
                    Some(s) => failures.push(format!(
                        "{doc}:{line}: `{}` exited with {s}",
                        args.join(" ")
                    )),
                    None => failures.push(format!(
                        "{doc}:{line}: `{}` took over {TIMEOUT:?}",
                        args.join(" ")
                    )),
                }
            }
        }
    }
    // The last started first: a client before the server it talks to.
    for Background {
        line,
        mut child,
        log,
    } in background.into_iter().rev()
    {
        let early = child.try_wait().unwrap();
        let _ = kill(Pid::from_raw(child.id() as i32), Signal::SIGTERM);
        let status = early.or_else(|| wait(&mut child, Duration::from_secs(10)));
        let output = std::fs::read_to_string(&log).unwrap_or_default();
        println!(
            "{doc}:{line}: background command ended ({status:?})\n{}",
            tail(&output)
        );
        match (early, status) {
            (Some(s), _) if !s.success() => failures.push(format!(
                "{doc}:{line}: background command failed early with {s}"
            )),
            (_, Some(s)) if s.success() => {}
            (_, status) => failures.push(format!(
                "{doc}:{line}: background command did not exit cleanly on SIGTERM ({status:?})"
            )),
        }
    }
}

/// The last lines of a command's output.
fn tail(output: &str) -> String {
    let lines: Vec<&str> = output.lines().collect();
    lines[lines.len().saturating_sub(8)..].join("\n")
}

/// One document at a time: the commands stream scans on pseudo-terminals in
/// real time, and two documents at once load the machine twice.
static ONE_DOC_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Run every runnable command of `doc` (relative to the workspace root);
/// returns the number run.
fn run_doc(doc: &str) -> usize {
    let _one = ONE_DOC_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let path = workspace().join(doc);
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let blocks = steps(&text).unwrap_or_else(|e| panic!("{doc}: {e}"));
    let scratch = Scratch::new(&doc.replace('/', "-"));
    assert!(
        scratch.shared.join("data/carmen").is_dir(),
        "no shared data at {} (../shared must sit beside the repository)",
        scratch.shared.display()
    );
    let started = Instant::now();
    let mut failures = Vec::new();
    for block in &blocks {
        run_block(doc, &scratch, block, &mut failures);
    }
    println!(
        "{doc}: all commands in {:.1} s",
        started.elapsed().as_secs_f64()
    );
    assert!(failures.is_empty(), "{doc}:\n{}", failures.join("\n"));
    let _ = std::fs::remove_dir_all(&scratch.dir);
    blocks
        .iter()
        .flatten()
        .filter(|(_, s)| matches!(s, Step::Run { .. }))
        .count()
}

#[test]
fn every_readme_command_runs() {
    let text = workspace_file("README.md");
    let all: Vec<Step> = steps(&text)
        .unwrap()
        .into_iter()
        .flatten()
        .map(|(_, s)| s)
        .collect();
    // The two commands of the front page: the main job, run here, and the tests, run by CI.
    assert!(all.contains(&Step::Run {
        args: vec!["verify".into(), "--host".into()],
        background: false
    }));
    assert!(all.contains(&Step::Skipped("CI's test step".into())));
    let run = run_doc("README.md");
    assert!(run >= 5, "only {run} README commands found to run");
}

#[test]
fn every_guide_command_runs() {
    let run = run_doc("docs/GUIDE.md");
    assert!(run >= 5, "only {run} guide commands found to run");
}

#[test]
fn the_convention_is_enforced() {
    let doc = "```sh\ncargo build --release\n```\n";
    assert!(steps(doc).unwrap_err().contains("neither run"));
    let doc = "```sh\nhost-bridge extract > out.jsonl\n```\n";
    assert!(steps(doc).unwrap_err().contains("needs a shell"));
    let doc = "```sh\ncargo run --release -p host-bridge -- coprocessor --sensor /dev/ttyUSB0 \\\n    --link /tmp/lms/x   # needs a sensor\nhost-bridge simulate --link /tmp/lms/s &\n```\n";
    let blocks = steps(doc).unwrap();
    assert_eq!(blocks[0][0], (2, Step::Skipped("# needs a sensor".into())));
    assert_eq!(
        blocks[0][1].1,
        Step::Run {
            args: vec!["simulate".into(), "--link".into(), "/tmp/lms/s".into()],
            background: true
        }
    );
    let doc = "```sh\nhost-bridge verify   # needs a robot\n```\n";
    assert!(steps(doc).unwrap_err().contains("unknown marker"));
}

/// A file of the workspace as text.
fn workspace_file(path: &str) -> String {
    let full = workspace().join(path);
    std::fs::read_to_string(&full).unwrap_or_else(|e| panic!("cannot read {}: {e}", full.display()))
}

#[test]
fn the_readme_is_a_front_door() {
    let readme = workspace_file("README.md");
    let lines = readme.lines().count();
    assert!(
        lines <= 250,
        "README.md has {lines} lines (at most 250: the rest goes to docs/GUIDE.md)"
    );
    // The first screen: what it is, the picture, the two commands.
    let first_screen: String = readme.lines().take(40).collect::<Vec<_>>().join("\n");
    for needle in [
        "docs/images/",
        "verify --host",
        "cargo test --workspace",
        "docs/GUIDE.md",
    ] {
        assert!(
            first_screen.contains(needle),
            "README.md's first 40 lines lack `{needle}`"
        );
    }
}

/// Where the product speaks to its users: the documents, the sources of
/// every product crate and the bindings, and the lab (folders are read
/// whole, but for build output).
const USER_FACING: [&str; 21] = [
    "README.md",
    "CHANGELOG.md",
    "ARCHITECTURE.md",
    "docs",
    "host-bridge/README.md",
    "firmware/README.md",
    "fuzz/README.md",
    "lab/README.md",
    "python/README.md",
    "core/src",
    "host-bridge/src",
    "firmware/src",
    "scene/src",
    "lab/src",
    "lab/examples",
    "capi/src",
    "capi/include",
    "examples/c",
    "python/src",
    "python/pysrc",
    "python/tests",
];

/// Does `line` name a development milestone by number: `stop 21`,
/// `issues 14`, `STOP22`, `stop-23` (any case)?
fn names_a_milestone(line: &str) -> bool {
    let lower = line.to_lowercase();
    let digit_at = |t: &str| t.starts_with(|c: char| c.is_ascii_digit());
    let spaced = ["stop", "issue"].iter().any(|word| {
        lower.match_indices(word).any(|(i, _)| {
            let rest = &lower[i + word.len()..];
            let rest = rest.strip_prefix('s').unwrap_or(rest);
            rest.strip_prefix(' ').is_some_and(digit_at)
        })
    });
    let glued = lower
        .match_indices("stop")
        .any(|(i, _)| digit_at(&lower[i + 4..]));
    let words: Vec<&str> = lower.split(|c: char| !c.is_alphanumeric()).collect();
    let numbered = words
        .windows(2)
        .any(|w| matches!(w[0], "stop" | "stops" | "issue" | "issues") && digit_at(w[1]));
    spaced || glued || numbered
}

/// The product speaks to users in the present tense: no development
/// milestone by number in its documents, its sources or any subcommand's
/// `--help` (history lives in git and in CHANGELOG.md's versions).
#[test]
fn the_product_names_no_development_history() {
    let mut files = Vec::new();
    for place in USER_FACING {
        let path = workspace().join(place);
        assert!(path.exists(), "{place} is missing");
        for file in files_under(&path) {
            if let Ok(text) = std::fs::read_to_string(&file) {
                files.push((file, text));
            }
        }
    }
    for command in [
        "extract",
        "plot",
        "params",
        "scan",
        "simulate",
        "verify",
        "coprocessor",
    ] {
        let out = Command::new(BIN)
            .args([command, "--help"])
            .output()
            .unwrap();
        assert!(out.status.success(), "host-bridge {command} --help failed");
        let help = String::from_utf8_lossy(&out.stdout).into_owned();
        files.push((PathBuf::from(format!("host-bridge {command} --help")), help));
    }
    let mut found = Vec::new();
    for (path, text) in &files {
        for (n, line) in text.lines().enumerate() {
            if names_a_milestone(line) {
                found.push(format!("{}:{}: {line}", path.display(), n + 1));
            }
        }
    }
    assert!(files.len() > 200, "only {} files read", files.len());
    assert!(
        found.is_empty(),
        "development history in the product:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_history_check_finds_milestones() {
    for line in [
        "since stop 21",
        "Issues 14",
        "Params::STOP22",
        "stop-23's",
        "stops 3",
    ] {
        assert!(names_a_milestone(line), "{line}");
    }
    for line in [
        "a non-stop run",
        "issue a request",
        "stop bits 1",
        "stopwatch",
    ] {
        assert!(!names_a_milestone(line), "{line}");
    }
}

/// The version `host-bridge --version` prints is the newest in CHANGELOG.md,
/// and the firmware, fuzz and Python workspaces carry the same.
#[test]
fn the_version_is_the_changelogs_newest() {
    let version = env!("CARGO_PKG_VERSION");
    let changelog = workspace_file("CHANGELOG.md");
    let newest = changelog
        .lines()
        .find(|l| l.starts_with("## [") && !l.starts_with("## [Unreleased]"))
        .expect("CHANGELOG.md names no version");
    assert!(
        newest.starts_with(&format!("## [{version}] - ")),
        "CHANGELOG.md's newest version is `{newest}`, the workspace's {version}"
    );
    for manifest in [
        "firmware/Cargo.toml",
        "fuzz/Cargo.toml",
        "python/Cargo.toml",
    ] {
        let text = workspace_file(manifest);
        assert!(
            text.contains(&format!("\nversion = \"{version}\"\n")),
            "{manifest}: version is not {version}"
        );
    }
    let out = Command::new(BIN).arg("--version").output().unwrap();
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).trim(),
        format!("host-bridge {version}")
    );
}
