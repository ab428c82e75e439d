//! A cluster on loopback, as `docker/compose.yaml` runs it: a real S3 API
//! server (`moto_server`), `dmesh serve --store` replicas as processes, and
//! HAProxy with `docker/haproxy.cfg` in front, the replicas' addresses and
//! the listening port replaced. A missing program is a failure that names what
//! installs it, never a skip.
#![allow(dead_code)]

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

#[path = "../../../tests/server_support/s3.rs"]
pub mod s3;

pub use s3::free_port;

/// The `dmesh` server binary: `DMESH_BIN` (a directory, as the node tests
/// take it) or the one `cargo test --workspace` built beside this test.
pub fn dmesh_bin() -> PathBuf {
    let path = match std::env::var_os("DMESH_BIN") {
        Some(dir) => PathBuf::from(dir).join("dmesh"),
        // target/debug/deps/cluster-HASH -> target/debug/dmesh
        None => std::env::current_exe()
            .unwrap()
            .parent()
            .unwrap()
            .parent()
            .unwrap()
            .join("dmesh"),
    };
    assert!(
        path.exists(),
        "{} is missing: build it with `cargo build --bin dmesh` (or run `cargo test --workspace`)",
        path.display()
    );
    path
}

/// Waits until `addr` answers `GET /healthz` with 200, or `child` exits.
fn wait_healthy(addr: SocketAddr, child: &mut Child, what: &str) {
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        if let Ok(r) = get(addr, "/healthz") {
            if r.status == 200 {
                return;
            }
        }
        if let Ok(Some(status)) = child.try_wait() {
            panic!("{what} on {addr} exited: {status}");
        }
        assert!(Instant::now() < deadline, "{what} on {addr} not healthy in 60 s");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// One HTTP/1.1 answer.
pub struct Answer {
    pub status: u16,
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Answer {
    pub fn header(&self, name: &str) -> Option<&str> {
        (self.headers.iter())
            .find(|(k, _)| k.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }
}

/// `GET path` on a fresh connection (the headers matter here, so no client
/// library's pooling or redirects in between).
pub fn get(addr: SocketAddr, path: &str) -> std::io::Result<Answer> {
    let mut s = TcpStream::connect_timeout(&addr, Duration::from_secs(2))?;
    s.set_read_timeout(Some(Duration::from_secs(30)))?;
    write!(s, "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n")?;
    let mut raw = Vec::new();
    s.read_to_end(&mut raw)?;
    let split =
        (raw.windows(4).position(|w| w == b"\r\n\r\n")).ok_or_else(|| std::io::Error::other("no end of headers"))?;
    let head = String::from_utf8_lossy(&raw[..split]).into_owned();
    let mut lines = head.split("\r\n");
    let status = (lines
        .next()
        .and_then(|l| l.split(' ').nth(1))
        .and_then(|c| c.parse().ok()))
    .ok_or_else(|| std::io::Error::other("no status"))?;
    let headers: Vec<(String, String)> = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
        .collect();
    let mut body = raw[split + 4..].to_vec();
    let chunked = headers
        .iter()
        .any(|(k, v)| k.eq_ignore_ascii_case("transfer-encoding") && v.contains("chunked"));
    if chunked {
        body = dechunk(&body);
    }
    Ok(Answer { status, headers, body })
}

fn dechunk(mut b: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    while let Some(eol) = b.windows(2).position(|w| w == b"\r\n") {
        let size = usize::from_str_radix(String::from_utf8_lossy(&b[..eol]).trim(), 16).unwrap_or(0);
        if size == 0 {
            break;
        }
        out.extend_from_slice(&b[eol + 2..eol + 2 + size]);
        b = &b[eol + 4 + size..];
    }
    out
}

/// A `dmesh serve --store` process.
pub struct Replica {
    pub addr: SocketAddr,
    args: Vec<String>,
    vars: Vec<(String, String)>,
    log: PathBuf,
    child: Option<Child>,
}

impl Replica {
    fn start(addr: SocketAddr, args: Vec<String>, vars: Vec<(String, String)>, log: PathBuf) -> Self {
        let mut r = Self {
            addr,
            args,
            vars,
            log,
            child: None,
        };
        r.restart();
        r
    }

    /// The number a `/metrics` gauge shows.
    pub fn gauge(&self, name: &str) -> f64 {
        let a = get(self.addr, "/metrics").unwrap();
        let text = String::from_utf8_lossy(&a.body).into_owned();
        (text.lines())
            .find_map(|l| l.strip_prefix(name)?.strip_prefix(' ')?.trim().parse().ok())
            .unwrap_or_else(|| panic!("/metrics has no {name}"))
    }

    /// SIGKILL: no shutdown, requests in flight are cut.
    pub fn kill(&mut self) {
        s3::kill(&mut self.child);
    }

    /// Starts it (again) on the same port, and waits until it is healthy.
    pub fn restart(&mut self) {
        self.kill();
        let log = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&self.log)
            .unwrap();
        let mut child = Command::new(dmesh_bin())
            .arg("serve")
            .args(["--listen", &self.addr.to_string()])
            .args(&self.args)
            .envs(self.vars.iter().map(|(k, v)| (k, v)))
            .stdout(log.try_clone().unwrap())
            .stderr(log)
            .spawn()
            .unwrap();
        wait_healthy(self.addr, &mut child, "dmesh serve");
        self.child = Some(child);
    }
}

impl Drop for Replica {
    fn drop(&mut self) {
        self.kill();
    }
}

/// HAProxy with the repository's config.
pub struct Balancer {
    pub addr: SocketAddr,
    child: Child,
}

impl Balancer {
    /// HAProxy in front of `upstreams` (in place of `dmesh-1:8080`, ...),
    /// waiting until it reaches the first (its health checks mark every
    /// replica up after two passes).
    pub fn start(dir: &Path, upstreams: &[SocketAddr]) -> Self {
        let template = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docker/haproxy.cfg")).unwrap();
        let addr = SocketAddr::from(([127, 0, 0, 1], free_port()));
        assert!(template.contains("bind :8080\n"), "docker/haproxy.cfg binds no :8080");
        let mut conf = template.replace("bind :8080\n", &format!("bind {addr}\n"));
        for (k, u) in upstreams.iter().enumerate() {
            let name = format!("dmesh-{}:8080", k + 1);
            assert!(conf.contains(&name), "docker/haproxy.cfg names no {name}");
            conf = conf.replace(&name, &u.to_string());
        }
        let path = dir.join("haproxy.cfg");
        std::fs::write(&path, conf).unwrap();
        let mut child = Command::new("haproxy")
            .arg("-db")
            .arg("-f")
            .arg(&path)
            .stdout(Stdio::null())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start haproxy ({e}); install it: apt-get install -y haproxy"));
        wait_healthy(addr, &mut child, "haproxy");
        // Every replica up in the balancer's eyes (two checks, 250 ms apart).
        std::thread::sleep(Duration::from_millis(700));
        Self { addr, child }
    }
}

impl Drop for Balancer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// moto, `n` replicas over one prefix of its bucket, and (optionally) the
/// balancer.
pub struct Cluster {
    pub replicas: Vec<Replica>,
    pub balancer: Option<Balancer>,
    pub s3: s3::S3Server,
    pub dir: tempfile::TempDir,
}

impl Cluster {
    /// `revalidate_ms`: `None` for the default.
    pub fn start(n: usize, revalidate_ms: Option<u64>, balancer: bool) -> Self {
        let s3 = s3::S3Server::start(s3::Kind::Moto);
        let dir = tempfile::tempdir().unwrap();
        let replicas: Vec<Replica> = (0..n)
            .map(|k| {
                let addr = SocketAddr::from(([127, 0, 0, 1], free_port()));
                let mut args = vec![
                    "--store".to_string(),
                    s3.url("cluster"),
                    // Slots for every client of these tests: a failure here
                    // is one the kill caused, not load shedding.
                    "--max-concurrency".to_string(),
                    "4".to_string(),
                    "--queue-wait-ms".to_string(),
                    "2000".to_string(),
                ];
                if let Some(ms) = revalidate_ms {
                    args.extend(["--revalidate-ms".to_string(), ms.to_string()]);
                }
                Replica::start(addr, args, s3.vars(), dir.path().join(format!("replica-{}.log", k + 1)))
            })
            .collect();
        let balancer =
            balancer.then(|| Balancer::start(dir.path(), &replicas.iter().map(|r| r.addr).collect::<Vec<_>>()));
        Self {
            replicas,
            balancer,
            s3,
            dir,
        }
    }

    /// The balancer's address.
    pub fn front(&self) -> SocketAddr {
        self.balancer.as_ref().expect("a cluster with a balancer").addr
    }

    /// The replica the balancer sends `scene` to (its `X-Upstream`).
    pub fn owner(&self, scene: &str) -> usize {
        let a = get(self.front(), &format!("/v1/scenes/{scene}/views")).unwrap();
        let upstream = a
            .header("x-upstream")
            .expect("the balancer sets X-Upstream")
            .to_string();
        (self.replicas.iter())
            .position(|r| r.addr.to_string() == upstream)
            .unwrap_or_else(|| panic!("X-Upstream {upstream} is no replica"))
    }

    /// What the replicas logged (for a failing assertion's message).
    pub fn logs(&self) -> String {
        (1..=self.replicas.len())
            .map(|k| {
                let log = std::fs::read_to_string(self.dir.path().join(format!("replica-{k}.log"))).unwrap_or_default();
                let tail: Vec<&str> = log.lines().rev().take(20).collect();
                format!(
                    "--- replica {k}\n{}",
                    tail.into_iter().rev().collect::<Vec<_>>().join("\n")
                )
            })
            .collect::<Vec<_>>()
            .join("\n")
    }
}
