//! Real S3 API servers for the tests: `moto_server` (in memory, PyPI
//! `moto[server]`) and `s3s-fs` (file-backed, crates.io), started on a free
//! loopback port and killed on drop. A missing server is a test failure with
//! the command that installs it, never a skip.

use std::net::{SocketAddr, TcpListener, TcpStream};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use dmesh::store::ObjectViewStore;

/// Which S3 server.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `moto_server`: in memory.
    Moto,
    /// `s3s-fs`: objects as files under a directory, so it survives a restart.
    S3sFs,
}

/// A running S3 API server with one bucket.
pub struct S3Server {
    pub kind: Kind,
    pub addr: SocketAddr,
    pub bucket: String,
    child: Option<Child>,
    /// The directory `s3s-fs` serves (kept across restarts).
    root: Option<tempfile::TempDir>,
}

/// SIGKILLs `child`, if running, and reaps it.
pub fn kill(child: &mut Option<Child>) {
    if let Some(mut c) = child.take() {
        let _ = c.kill();
        let _ = c.wait();
    }
}

pub fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

fn spawn(kind: Kind, port: u16, root: Option<&std::path::Path>) -> Child {
    let (program, install) = match kind {
        Kind::Moto => ("moto_server", "pip install 'moto[server]'"),
        Kind::S3sFs => (
            "s3s-fs",
            "cargo install s3s-fs --version 0.14.1 --features binary --locked",
        ),
    };
    let mut cmd = Command::new(program);
    match kind {
        Kind::Moto => cmd.args(["-H", "127.0.0.1", "-p", &port.to_string()]),
        Kind::S3sFs => cmd
            .args(["--host", "127.0.0.1", "--port", &port.to_string()])
            .args(["--access-key", "test", "--secret-key", "test"])
            .arg(root.unwrap()),
    };
    cmd.stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {program} ({e}); install it: {install}"))
}

fn wait_listening(addr: SocketAddr, child: &mut Child) {
    let deadline = Instant::now() + Duration::from_secs(30);
    while TcpStream::connect_timeout(&addr, Duration::from_millis(200)).is_err() {
        if let Ok(Some(status)) = child.try_wait() {
            panic!("the S3 server on {addr} exited: {status}");
        }
        assert!(
            Instant::now() < deadline,
            "the S3 server on {addr} did not start in 30 s"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

impl S3Server {
    /// Starts a server with the bucket `dmesh`.
    pub fn start(kind: Kind) -> Self {
        let port = free_port();
        let root = (kind == Kind::S3sFs).then(|| tempfile::tempdir().unwrap());
        let bucket = "dmesh".to_string();
        if let Some(r) = &root {
            // s3s-fs serves each directory under its root as a bucket.
            std::fs::create_dir(r.path().join(&bucket)).unwrap();
        }
        let mut child = spawn(kind, port, root.as_ref().map(|r| r.path()));
        let addr = SocketAddr::from(([127, 0, 0, 1], port));
        wait_listening(addr, &mut child);
        let mut server = Self {
            kind,
            addr,
            bucket,
            child: Some(child),
            root,
        };
        if kind == Kind::Moto {
            server.create_moto_bucket();
        }
        server
    }

    /// moto checks no signature: an unsigned PUT creates the bucket. moto
    /// may listen before it answers (a test once read an empty reply under
    /// the whole workspace's load), so the PUT is tried again until it
    /// answers 200, for as long as the server may take to start.
    fn create_moto_bucket(&mut self) {
        use std::io::{Read, Write};
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            let reply = TcpStream::connect(self.addr).and_then(|mut s| {
                write!(
                    s,
                    "PUT /{} HTTP/1.1\r\nHost: {}\r\nContent-Length: 0\r\nConnection: close\r\n\r\n",
                    self.bucket, self.addr
                )?;
                let mut reply = String::new();
                s.read_to_string(&mut reply)?;
                Ok(reply)
            });
            if reply.as_ref().is_ok_and(|r| r.starts_with("HTTP/1.1 200")) {
                return;
            }
            if let Some(Ok(Some(status))) = self.child.as_mut().map(Child::try_wait) {
                panic!("the S3 server on {} exited: {status}", self.addr);
            }
            assert!(Instant::now() < deadline, "creating the bucket: {reply:?}");
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// The `AWS_*` settings that reach this server.
    pub fn vars(&self) -> Vec<(String, String)> {
        [
            ("AWS_ENDPOINT_URL", format!("http://{}", self.addr)),
            ("AWS_ALLOW_HTTP", "true".into()),
            ("AWS_REGION", "us-east-1".into()),
            ("AWS_ACCESS_KEY_ID", "test".into()),
            ("AWS_SECRET_ACCESS_KEY", "test".into()),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect()
    }

    /// `s3://BUCKET/PREFIX`.
    pub fn url(&self, prefix: &str) -> String {
        format!("s3://{}/{prefix}", self.bucket)
    }

    /// A view store over this server under `prefix`.
    pub fn store(&self, prefix: &str) -> ObjectViewStore {
        ObjectViewStore::open(&self.url(prefix), self.vars()).unwrap()
    }

    /// Kills the server (SIGKILL); what it held in memory is gone.
    pub fn kill(&mut self) {
        kill(&mut self.child);
    }

    /// Starts it again on the same port (and, for `s3s-fs`, the same files).
    pub fn restart(&mut self) {
        self.kill();
        let mut child = spawn(self.kind, self.addr.port(), self.root.as_ref().map(|r| r.path()));
        wait_listening(self.addr, &mut child);
        self.child = Some(child);
    }
}

impl Drop for S3Server {
    fn drop(&mut self) {
        self.kill();
    }
}
