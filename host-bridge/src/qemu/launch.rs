//! `--qemu`: the firmware under `qemu-system-arm -M netduinoplus2`, its
//! three UARTs on TCP sockets on 127.0.0.1 ([`TcpLink`]).

use std::io::{self, BufRead, BufReader, Read, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpListener, TcpStream};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context, Result};
use lms_core::telegram::Baud;

use super::DEFAULT_ELF;
use crate::serial::{is_quiet, CoLines, Link, WRITE_TIMEOUT};

/// A TCP connection to one of QEMU's serial ports.
pub(crate) struct TcpLink {
    stream: TcpStream,
    name: String,
    /// When the connection was made (the origin of [`Link::now`]).
    origin: Instant,
    /// The socket is in non-blocking mode.
    nonblocking: bool,
}

impl TcpLink {
    /// Connect to `addr`, retrying until `deadline` while `alive` says the
    /// server may still come up.
    fn connect(
        addr: SocketAddr,
        name: String,
        deadline: Instant,
        mut alive: impl FnMut() -> Result<()>,
    ) -> Result<Self> {
        loop {
            match TcpStream::connect_timeout(&addr, Duration::from_millis(200)) {
                Ok(stream) => {
                    stream.set_nodelay(true)?;
                    stream.set_write_timeout(Some(WRITE_TIMEOUT))?;
                    return Ok(TcpLink {
                        stream,
                        name,
                        origin: Instant::now(),
                        nonblocking: false,
                    });
                }
                Err(e) if Instant::now() >= deadline => {
                    bail!("cannot connect to {name} ({addr}): {e}")
                }
                Err(_) => {
                    alive()?;
                    std::thread::sleep(Duration::from_millis(20));
                }
            }
        }
    }

    fn set_nonblocking(&mut self, on: bool) -> io::Result<()> {
        if self.nonblocking != on {
            self.stream.set_nonblocking(on)?;
            self.nonblocking = on;
        }
        Ok(())
    }
}

impl Link for TcpLink {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.set_nonblocking(false)?;
        self.stream.write_all(bytes)
    }

    fn receive(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        if timeout.is_zero() {
            self.set_nonblocking(true)?;
        } else {
            self.set_nonblocking(false)?;
            self.stream.set_read_timeout(Some(timeout))?;
        }
        match self.stream.read(buf) {
            Ok(0) => Err(io::Error::new(
                io::ErrorKind::ConnectionAborted,
                "QEMU closed the connection",
            )),
            Ok(n) => Ok(n),
            Err(e) if is_quiet(&e) => Ok(0),
            Err(e) => Err(e),
        }
    }

    fn set_baud(&mut self, _baud: Baud) -> io::Result<()> {
        Ok(()) // QEMU ignores line rates.
    }

    fn discard_input(&mut self) -> io::Result<()> {
        let mut buf = [0u8; 4096];
        while self.receive(&mut buf, Duration::ZERO)? > 0 {}
        Ok(())
    }

    fn now(&self) -> Duration {
        self.origin.elapsed()
    }

    fn name(&self) -> String {
        self.name.clone()
    }
}

/// QEMU running the firmware; killed (its whole process group) when dropped.
pub(crate) struct Qemu {
    pub(crate) child: Child,
    elf: PathBuf,
    /// Holds the raw defmt log, QEMU's stderr and its QMP socket.
    dir: PathBuf,
    /// Keep `dir` when dropped (the run failed).
    pub(crate) keep: bool,
    /// The QEMU Machine Protocol connection, made on first use.
    qmp: Option<Qmp>,
}

/// The sensor line's USART (USART2) baud-rate register.
const USART2_BRR: u32 = 0x4000_4408;

/// The bus clock the firmware assumes for USART2 under QEMU (APB1,
/// `firmware/src/rcc.rs`: `Clocks::QEMU` keeps the nominal 42 MHz, so that
/// its `BRR` values are the silicon ones).
const QEMU_PCLK1_HZ: u32 = 42_000_000;

/// A QEMU Machine Protocol (QMP) connection on a Unix socket: JSON
/// commands, one reply line each (event lines in between are skipped).
struct Qmp {
    writer: UnixStream,
    reader: BufReader<UnixStream>,
}

impl Qmp {
    /// Connect to `path` (QEMU creates it at start), read the greeting and
    /// leave negotiation mode.
    fn connect(path: &Path, deadline: Instant) -> Result<Qmp> {
        let stream = loop {
            match UnixStream::connect(path) {
                Ok(s) => break s,
                Err(e) if Instant::now() >= deadline => {
                    bail!(
                        "cannot connect to QEMU's QMP socket {}: {e}",
                        path.display()
                    )
                }
                Err(_) => std::thread::sleep(Duration::from_millis(20)),
            }
        };
        stream.set_read_timeout(Some(Duration::from_secs(5)))?;
        let reader = BufReader::new(stream.try_clone()?);
        let mut qmp = Qmp {
            writer: stream,
            reader,
        };
        qmp.line().context("QMP greeting")?;
        qmp.execute(serde_json::json!({ "execute": "qmp_capabilities" }))?;
        Ok(qmp)
    }

    fn line(&mut self) -> Result<serde_json::Value> {
        let mut text = String::new();
        let n = self.reader.read_line(&mut text)?;
        ensure!(n > 0, "QEMU closed its QMP socket");
        serde_json::from_str(&text).with_context(|| format!("QMP sent {text:?}"))
    }

    /// Run one command; its `return` value.
    fn execute(&mut self, command: serde_json::Value) -> Result<serde_json::Value> {
        let mut text = command.to_string();
        text.push('\n');
        self.writer.write_all(text.as_bytes())?;
        loop {
            let mut reply = self.line()?;
            if let Some(r) = reply.get_mut("return") {
                return Ok(r.take());
            }
            if let Some(e) = reply.get("error") {
                bail!("QMP {command}: {e}");
            }
        }
    }

    /// A human-monitor command (e.g. `xp`); its text output.
    fn monitor(&mut self, line: &str) -> Result<String> {
        let r = self.execute(serde_json::json!({
            "execute": "human-monitor-command",
            "arguments": { "command-line": line }
        }))?;
        Ok(r.as_str().unwrap_or_default().to_string())
    }
}

/// `name` as an executable found on `PATH`.
fn on_path(name: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join(name))
            .find(|p| p.is_file())
    })
}

/// The firmware ELF: the one given, or the default relative to the working
/// directory, then to this source tree.
fn firmware_elf(given: Option<&Path>) -> Result<PathBuf> {
    if let Some(p) = given {
        ensure!(p.is_file(), "no firmware ELF at {}", p.display());
        return Ok(p.to_path_buf());
    }
    let here = PathBuf::from(DEFAULT_ELF);
    if here.is_file() {
        return Ok(here);
    }
    let tree = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(DEFAULT_ELF);
    ensure!(
        tree.is_file(),
        "no firmware ELF at {DEFAULT_ELF} (build it: cd firmware && cargo build --release)"
    );
    Ok(tree)
}

/// Three free TCP ports on the loopback interface.
fn free_ports() -> io::Result<[u16; 3]> {
    let listeners = [
        TcpListener::bind((Ipv4Addr::LOCALHOST, 0))?,
        TcpListener::bind((Ipv4Addr::LOCALHOST, 0))?,
        TcpListener::bind((Ipv4Addr::LOCALHOST, 0))?,
    ];
    let mut ports = [0u16; 3];
    for (p, l) in ports.iter_mut().zip(&listeners) {
        *p = l.local_addr()?.port();
    }
    Ok(ports)
}

impl Qemu {
    /// Start `qemu-system-arm -M netduinoplus2` with the firmware and its
    /// serial ports on TCP `ports` (host, sensor, console), bounded by
    /// `bound` (with `timeout`, if installed).
    pub(crate) fn start(elf: &Path, ports: [u16; 3], bound: Duration) -> Result<Qemu> {
        let qemu = on_path("qemu-system-arm")
            .context("qemu-system-arm not found on PATH (apt-get install qemu-system-arm)")?;
        let dir = std::env::temp_dir().join(format!("host-bridge-verify-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir)
            .with_context(|| format!("cannot create {}", dir.display()))?;
        let mut cmd = match on_path("timeout") {
            Some(timeout) => {
                let mut c = Command::new(timeout);
                c.arg("--kill-after=5")
                    .arg(format!("{}", bound.as_secs().max(1)))
                    .arg(&qemu);
                c
            }
            None => Command::new(&qemu),
        };
        let serial = |p: u16| format!("tcp:127.0.0.1:{p},server=on,wait=off,nodelay=on");
        cmd.args([
            "-M",
            "netduinoplus2",
            "-display",
            "none",
            "-monitor",
            "none",
        ])
        .arg("-qmp")
        .arg(format!(
            "unix:{},server=on,wait=off",
            dir.join("qmp.sock").display()
        ))
        .args(["-semihosting-config", "enable=on,target=native"])
        .args(["-serial", &serial(ports[0])])
        .args(["-serial", &serial(ports[1])])
        .args(["-serial", &serial(ports[2])])
        // Extra QEMU arguments, as firmware/run-qemu.sh takes them (e.g. the
        // instruction-counting plugin of tools/qemu-icount).
        .args(
            std::env::var("QEMU_EXTRA")
                .unwrap_or_default()
                .split_whitespace(),
        )
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(dir.join("defmt.raw"))?)
        .stderr(std::fs::File::create(dir.join("qemu.stderr"))?);
        // Its own process group, so that the guard can kill QEMU together
        // with the `timeout` around it.
        std::os::unix::process::CommandExt::process_group(&mut cmd, 0);
        let child = cmd
            .spawn()
            .with_context(|| format!("cannot start {}", qemu.display()))?;
        Ok(Qemu {
            child,
            elf: elf.to_path_buf(),
            dir,
            keep: false,
            qmp: None,
        })
    }

    fn qmp(&mut self) -> Result<&mut Qmp> {
        if self.qmp.is_none() {
            let path = self.dir.join("qmp.sock");
            self.qmp = Some(Qmp::connect(
                &path,
                Instant::now() + Duration::from_secs(5),
            )?);
        }
        Ok(self.qmp.as_mut().expect("connected above"))
    }

    /// Reset the MCU (QMP `system_reset`: the core restarts from its reset
    /// vector; the UARTs' TCP connections stay up, as wires would).
    pub(crate) fn reset(&mut self) -> Result<()> {
        self.qmp()?
            .execute(serde_json::json!({ "execute": "system_reset" }))
            .context("QMP system_reset")?;
        Ok(())
    }

    /// The sensor line's rate as the firmware has programmed it (from
    /// USART2's `BRR`, read through the monitor), `None` while unset.
    /// QEMU itself ignores the register; verify models the line with it.
    pub(crate) fn sensor_baud(&mut self) -> Result<Option<u32>> {
        let text = self.qmp()?.monitor(&format!("xp /1wx {USART2_BRR:#x}"))?;
        let brr = text
            .rsplit(':')
            .next()
            .and_then(|v| u32::from_str_radix(v.trim().trim_start_matches("0x"), 16).ok())
            .with_context(|| format!("unexpected xp output {text:?}"))?;
        Ok((brr != 0).then(|| QEMU_PCLK1_HZ / brr))
    }

    /// An error if QEMU has exited (with the first lines of what it said;
    /// all of it stays in the temporary directory).
    pub(crate) fn check(&mut self) -> Result<()> {
        if let Some(status) = self.child.try_wait()? {
            self.keep = true;
            let path = self.dir.join("qemu.stderr");
            let stderr = std::fs::read_to_string(&path).unwrap_or_default();
            let said: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
            let said = match said.len() {
                0 => String::new(),
                1..=2 => format!("; QEMU said: {}", said.join(" / ")),
                n => format!(
                    "; QEMU said: {} / {} (+{} lines in {})",
                    said[0],
                    said[1],
                    n - 2,
                    path.display()
                ),
            };
            bail!(
                "QEMU exited during the run ({status}; firmware exit codes: 1 panic, 2 hard \
                 fault, 3 unexpected interrupt, 124 time-out){said}"
            );
        }
        Ok(())
    }

    /// Wait up to `limit` for QEMU to exit; its status if it did.
    pub(crate) fn wait_exit(&mut self, limit: Duration) -> Option<std::process::ExitStatus> {
        let until = Instant::now() + limit;
        loop {
            if let Ok(Some(s)) = self.child.try_wait() {
                return Some(s);
            }
            if Instant::now() >= until {
                return None;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// The end of the firmware's log, decoded with `defmt-print` if it is
    /// installed.
    pub(crate) fn log_tail(&self) -> String {
        let raw = self.dir.join("defmt.raw");
        let decoded = on_path("defmt-print").and_then(|tool| {
            let input = std::fs::File::open(&raw).ok()?;
            let out = Command::new(tool)
                .arg("-e")
                .arg(&self.elf)
                .stdin(input)
                .stderr(Stdio::null())
                .output()
                .ok()?;
            Some(String::from_utf8_lossy(&out.stdout).into_owned())
        });
        match decoded {
            Some(text) if text.trim().is_empty() => {
                format!("the firmware logged nothing ({})", self.dir.display())
            }
            Some(text) => {
                let lines: Vec<&str> = text.lines().collect();
                let tail = &lines[lines.len().saturating_sub(15)..];
                format!("firmware log (last lines):\n  {}", tail.join("\n  "))
            }
            None => format!(
                "raw defmt log in {} (decode: defmt-print -e {} < it)",
                raw.display(),
                self.elf.display()
            ),
        }
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            if let Ok(pid) = i32::try_from(self.child.id()) {
                use nix::sys::signal::{killpg, Signal};
                let _ = killpg(nix::unistd::Pid::from_raw(pid), Signal::SIGKILL);
            }
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
        if !self.keep {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

/// The firmware under QEMU and our ends of its three UARTs as
/// [`Link`]s (for `verify --qemu` and `coprocessor --qemu`); QEMU is
/// stopped when this is dropped, after its lines.
pub(crate) type Connected = CoLines<Qemu>;

/// Start QEMU (bounded by `timeout` + 30 s) and connect to its three
/// UARTs: USART1 = host line, USART2 = sensor line, USART3 = console.
pub(crate) fn connect(
    elf: Option<&Path>,
    timeout: Duration,
    stop: &Arc<AtomicBool>,
) -> Result<Connected> {
    let elf = firmware_elf(elf)?;
    let ports = free_ports().context("no free TCP ports")?;
    let mut qemu = Qemu::start(&elf, ports, timeout + Duration::from_secs(30))?;
    let addr = |p: u16| SocketAddr::from((Ipv4Addr::LOCALHOST, p));
    let connect_by = Instant::now() + Duration::from_secs(10);
    let mut lines = Vec::new();
    for (p, name) in ports
        .iter()
        .zip(["host (USART1)", "sensor (USART2)", "console (USART3)"])
    {
        let line = TcpLink::connect(addr(*p), name.to_string(), connect_by, || {
            ensure!(!stop.load(Ordering::Relaxed), "interrupted");
            qemu.check()
        })?;
        lines.push(line);
    }
    let console = lines.pop().map(|l| Box::new(l) as Box<dyn Link>);
    let sensor = lines.pop().context("sensor line")?;
    let host = lines.pop().context("host line")?;
    let how = format!(
        "firmware {} under QEMU netduinoplus2 (pid {}), host line tcp:{}, sensor line tcp:{}, console tcp:{}",
        elf.display(),
        qemu.child.id(),
        ports[0],
        ports[1],
        ports[2]
    );
    Ok(Connected {
        sensor: Box::new(sensor),
        host: Box::new(host),
        console,
        runner: qemu,
        how,
    })
}
