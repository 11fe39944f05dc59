//! A throwaway PostgreSQL cluster for a test: `initdb` into a temporary folder, the server on
//! a loopback port (trust authentication, fsync off), stopped (immediately) when dropped.
//! Needs Debian's `postgresql` package (`.ci/run` installs it); as root, the server runs as
//! the `postgres` user the package creates.

use std::path::PathBuf;
use std::process::Command;

pub struct PgCluster {
    dir: PathBuf,
    bin: PathBuf,
    pub port: u16,
    as_postgres: bool,
}

/// The folder with `initdb` and `pg_ctl` (the newest installed major version).
fn bin_dir() -> PathBuf {
    let mut found: Vec<PathBuf> = std::fs::read_dir("/usr/lib/postgresql")
        .expect("PostgreSQL is not installed: apt-get install postgresql (see .ci/run)")
        .filter_map(|e| e.ok().map(|e| e.path().join("bin")))
        .filter(|p| p.join("initdb").exists())
        .collect();
    found.sort_by_key(|p| {
        p.parent()
            .and_then(|v| v.file_name())
            .and_then(|v| v.to_str())
            .and_then(|v| v.parse::<u32>().ok())
            .unwrap_or(0)
    });
    found
        .pop()
        .expect("no initdb under /usr/lib/postgresql/*/bin: apt-get install postgresql")
}

impl PgCluster {
    /// Makes and starts a cluster with one superuser, `caustica`.
    pub fn start(name: &str) -> PgCluster {
        let dir = std::env::temp_dir().join(format!("caustica-pg-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        // SAFETY: geteuid has no preconditions.
        let as_postgres = unsafe { libc::geteuid() } == 0;
        if as_postgres {
            let st = Command::new("chown")
                .args(["-R", "postgres:postgres"])
                .arg(&dir)
                .status()
                .unwrap();
            assert!(st.success(), "chown of {}", dir.display());
        }
        let port = {
            let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
            l.local_addr().unwrap().port()
        };
        let c = PgCluster {
            dir,
            bin: bin_dir(),
            port,
            as_postgres,
        };
        let data = c.dir.join("data");
        c.run(
            "initdb",
            &[
                "-D",
                data.to_str().unwrap(),
                "-U",
                "caustica",
                "--auth=trust",
                "--no-sync",
                "-E",
                "UTF8",
            ],
        );
        c.pg_ctl_start();
        c
    }

    /// `postgres://` URL of database `db` (created first unless it is `postgres`).
    pub fn url(&self, db: &str) -> String {
        let url = format!("postgres://caustica@127.0.0.1:{}/{db}", self.port);
        if db != "postgres" {
            let admin = self.url("postgres");
            let create = format!("CREATE DATABASE {db}");
            sync(move || {
                let mut c = postgres::Client::connect(&admin, postgres::NoTls)
                    .expect("connect to the test cluster");
                c.batch_execute(&create).unwrap();
            });
        }
        url
    }

    /// Stops the server (fast: connections are closed) and starts it again on the same port.
    pub fn restart(&self) {
        self.pg_ctl(&["stop", "-m", "fast", "-w"]);
        self.pg_ctl_start();
    }

    /// Stops the server (fast) until [`PgCluster::start_again`]: an outage.
    pub fn stop(&self) {
        self.pg_ctl(&["stop", "-m", "fast", "-w"]);
    }

    /// Starts a stopped server again on the same port.
    pub fn start_again(&self) {
        self.pg_ctl_start();
    }

    fn pg_ctl_start(&self) {
        let opts = format!(
            "-p {} -c listen_addresses=127.0.0.1 -k {} -c fsync=off -c max_connections=200",
            self.port,
            self.dir.display()
        );
        let log = self.dir.join("server.log");
        self.pg_ctl(&[
            "start",
            "-w",
            "-t",
            "60",
            "-l",
            log.to_str().unwrap(),
            "-o",
            &opts,
        ]);
    }

    fn pg_ctl(&self, args: &[&str]) {
        let data = self.dir.join("data");
        let mut a = vec!["-D", data.to_str().unwrap()];
        a.extend_from_slice(args);
        self.run("pg_ctl", &a);
    }

    fn run(&self, tool: &str, args: &[&str]) {
        let exe = self.bin.join(tool);
        let out = if self.as_postgres {
            Command::new("runuser")
                .args(["-u", "postgres", "--"])
                .arg(&exe)
                .args(args)
                .current_dir(&self.dir)
                .output()
        } else {
            Command::new(&exe)
                .args(args)
                .current_dir(&self.dir)
                .output()
        }
        .unwrap_or_else(|e| panic!("running {}: {e}", exe.display()));
        assert!(
            out.status.success(),
            "{tool} {args:?} failed: {}\n{}\n{}",
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
    }
}

/// Runs `f` (a synchronous PostgreSQL client's work) on a thread of its own: that client must
/// not run on a thread that drives async tasks, as a `#[tokio::test]`'s does.
pub fn sync<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    std::thread::scope(|s| s.spawn(f).join().unwrap())
}

impl Drop for PgCluster {
    fn drop(&mut self) {
        let data = self.dir.join("data");
        let exe = self.bin.join("pg_ctl");
        let args = [
            "-D",
            data.to_str().unwrap_or(""),
            "stop",
            "-m",
            "immediate",
            "-w",
        ];
        let _ = if self.as_postgres {
            Command::new("runuser")
                .args(["-u", "postgres", "--"])
                .arg(&exe)
                .args(args)
                .output()
        } else {
            Command::new(&exe).args(args).output()
        };
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}
