//! deploy/ on two and on three hosts: network namespaces joined by a bridge
//! (addresses only inside them), each service started from its systemd
//! unit's ExecStart with deploy/cluster.env and the Zenoh configs of
//! deploy/zenoh, the router found by name as on real hosts; on three, then
//! one host's link cut and its lights frozen. Needs root and iproute2: a
//! notice and a skip without them, unless TRAFFICMESH_REQUIRE_NETNS=1 (CI).

mod container;
mod secure;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

fn repo() -> PathBuf {
    trafficmesh_testkit::repo_root()
}

fn deploy() -> PathBuf {
    repo().join("deploy")
}

/// Runs `ip` with `args`; panics with its error output on failure.
fn ip(args: &[&str]) {
    let out = Command::new("ip").args(args).output().expect("ip runs");
    assert!(
        out.status.success(),
        "ip {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Can this process make network namespaces?
fn netns_available() -> bool {
    let root = unsafe { libc::geteuid() } == 0;
    let ip = Command::new("ip")
        .args(["netns", "list"])
        .output()
        .is_ok_and(|o| o.status.success());
    if root && ip {
        return true;
    }
    if std::env::var("TRAFFICMESH_REQUIRE_NETNS").is_ok_and(|v| v == "1") {
        panic!("TRAFFICMESH_REQUIRE_NETNS=1 but this is not root with iproute2");
    }
    eprintln!("NOTICE: skipped: network namespaces need root and iproute2");
    false
}

/// Hosts as network namespaces on one bridge (itself in a namespace of its
/// own), 10.77.0.<n>/24; each host resolves `trafficmesh-router` to the
/// first. Removed, with their processes, on drop.
struct Hosts {
    prefix: String,
    count: usize,
    children: Vec<(String, Child)>,
}

impl Hosts {
    fn new(count: usize) -> Hosts {
        let prefix = format!("tm{}", std::process::id() % 100_000);
        let hosts = Hosts {
            prefix,
            count,
            children: Vec::new(),
        };
        let sw = hosts.switch();
        ip(&["netns", "add", &sw]);
        ip(&["-n", &sw, "link", "add", "br0", "type", "bridge"]);
        ip(&["-n", &sw, "link", "set", "br0", "up"]);
        for n in 1..=count {
            let host = hosts.name(n);
            ip(&["netns", "add", &host]);
            let (outside, inside) = (format!("s{n}"), format!("{}e{n}", hosts.prefix));
            ip(&[
                "-n", &sw, "link", "add", &outside, "type", "veth", "peer", "name", &inside,
                "netns", &host,
            ]);
            ip(&["-n", &sw, "link", "set", &outside, "master", "br0", "up"]);
            ip(&[
                "-n",
                &host,
                "addr",
                "add",
                &format!("10.77.0.{n}/24"),
                "dev",
                &inside,
            ]);
            ip(&["-n", &host, "link", "set", &inside, "up"]);
            ip(&["-n", &host, "link", "set", "lo", "up"]);
            // `ip netns exec` puts /etc/netns/<name>/hosts over /etc/hosts.
            let etc = PathBuf::from("/etc/netns").join(&host);
            std::fs::create_dir_all(&etc).unwrap();
            std::fs::write(
                etc.join("hosts"),
                "127.0.0.1 localhost\n10.77.0.1 trafficmesh-router\n",
            )
            .unwrap();
        }
        hosts
    }

    fn switch(&self) -> String {
        format!("{}sw", self.prefix)
    }

    fn name(&self, n: usize) -> String {
        format!("{}h{n}", self.prefix)
    }

    /// `command` on host `n` with `env`, its output in `log`.
    fn spawn(&mut self, n: usize, what: &str, command: &[String], env: &Env, log: &Path) {
        let file = std::fs::File::create(log).unwrap();
        let child = Command::new("ip")
            .args(["netns", "exec", &self.name(n)])
            .args(command)
            .env_clear()
            .envs(env)
            .env("RUST_LOG", "info,zenoh=warn")
            .stdout(file.try_clone().unwrap())
            .stderr(file)
            .spawn()
            .unwrap();
        self.children.push((what.to_string(), child));
    }
}

impl Drop for Hosts {
    fn drop(&mut self) {
        for (_, child) in &mut self.children {
            unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
        }
        let deadline = Instant::now() + Duration::from_secs(10);
        for (_, child) in &mut self.children {
            while child.try_wait().ok().flatten().is_none() && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = child.kill();
            let _ = child.wait();
        }
        for n in 1..=self.count {
            let _ = Command::new("ip")
                .args(["netns", "del", &self.name(n)])
                .status();
            let _ = std::fs::remove_dir_all(PathBuf::from("/etc/netns").join(self.name(n)));
        }
        let _ = Command::new("ip")
            .args(["netns", "del", &self.switch()])
            .status();
    }
}

type Env = BTreeMap<String, String>;

/// deploy/cluster.env as `KEY=value` lines.
fn cluster_env() -> Env {
    std::fs::read_to_string(deploy().join("cluster.env"))
        .unwrap()
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| {
            let (k, v) = l.split_once('=').expect("KEY=value");
            (k.to_string(), v.to_string())
        })
        .collect()
}

/// A unit's ExecStart, split into words, its `${VAR}`s from `env`, the
/// installed paths (/usr/local/bin, /etc/trafficmesh/zenoh) mapped to this
/// build and this checkout.
fn exec_start(service: &str, env: &Env, bin: &Path) -> Vec<String> {
    let unit =
        std::fs::read_to_string(deploy().join(format!("systemd/trafficmesh-{service}.service")))
            .unwrap();
    assert!(
        unit.contains("EnvironmentFile=/etc/trafficmesh/cluster.env"),
        "{service}: the unit does not read cluster.env"
    );
    let line = unit
        .lines()
        .find_map(|l| l.strip_prefix("ExecStart="))
        .unwrap_or_else(|| panic!("{service}: no ExecStart"));
    line.split_whitespace()
        .map(|word| {
            let mut word = word
                .replace("/usr/local/bin", &bin.display().to_string())
                .replace(
                    "/etc/trafficmesh/zenoh",
                    &deploy().join("zenoh").display().to_string(),
                );
            for (k, v) in env {
                word = word.replace(&format!("${{{k}}}"), v);
            }
            assert!(
                !word.contains("${"),
                "{service}: {word} names no cluster.env entry"
            );
            word
        })
        .collect()
}

/// Which services run on which host.
type Placement<'a> = &'a [(usize, &'a [&'a str])];

/// Three hosts. Host 1: the router and the stepper; host 2: every other
/// service; host 3 has a user's `trafficmesh watch` and `trafficmesh status`.
const THREE_HOSTS: Placement = &[
    (1, &["router", "stepper"]),
    (
        2,
        &[
            "spawner",
            "lights",
            "crosswalks",
            "pedestrians",
            "intersection",
            "admin",
        ],
    ),
];

/// Two hosts. Host 1: the router, the stepper, the crosswalks and the
/// walkers; host 2: the spawner, the lights, the intersection manager and
/// the admin, with the user's `watch` and `status`.
const TWO_HOSTS: Placement = &[
    (1, &["router", "stepper", "crosswalks", "pedestrians"]),
    (2, &["spawner", "lights", "intersection", "admin"]),
];

/// Waits for `child` to exit by itself.
fn wait_exit(child: &mut Child, timeout: Duration, what: &str, logs: &dyn Fn() -> String) {
    let deadline = Instant::now() + timeout;
    while child.try_wait().unwrap().is_none() {
        assert!(Instant::now() < deadline, "{what} never ended:\n{}", logs());
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn a_cluster_over_three_hosts_from_the_deploy_files_delivers_telemetry_to_a_third() {
    deploy_over(
        3,
        THREE_HOSTS,
        &[("link cut", 3), ("link cut", 15), ("lights frozen", 5)],
    );
}

#[test]
fn a_cluster_over_two_hosts_from_the_deploy_files_runs_and_reports_healthy() {
    deploy_over(2, TWO_HOSTS, &[]);
}

/// The cluster over `count` hosts as `placement` puts it, a user's `watch`
/// and `status` on the last host; then each of `faults` on host 2 (its
/// link cut, its lights frozen), for so many seconds.
fn deploy_over(count: usize, placement: Placement, faults: &[(&str, u64)]) {
    if !netns_available() {
        return;
    }
    let observer = count;
    let bin = PathBuf::from(env!("CARGO_BIN_EXE_trafficmesh"))
        .parent()
        .unwrap()
        .to_path_buf();
    let dir = tempfile::tempdir().unwrap();
    let mut env = cluster_env();
    for key in [
        "TRAFFICMESH_CLUSTER",
        "TRAFFICMESH_ZENOH_CONFIG",
        "TRAFFICMESH_ROUTER_CONFIG",
        "TRAFFICMESH_MAP",
        "TRAFFICMESH_SEED",
        "TRAFFICMESH_STATE",
        "TRAFFICMESH_ADMIN_BIND",
    ] {
        assert!(env.contains_key(key), "cluster.env has no {key}");
    }
    // This checkout's files in place of the installed ones.
    let state = dir.path().join("state");
    std::fs::create_dir_all(&state).unwrap();
    env.insert(
        "TRAFFICMESH_CLUSTER".into(),
        format!("deploy{}", std::process::id()),
    );
    env.insert(
        "TRAFFICMESH_ZENOH_CONFIG".into(),
        deploy().join("zenoh/service.json5").display().to_string(),
    );
    env.insert(
        "TRAFFICMESH_ROUTER_CONFIG".into(),
        deploy().join("zenoh/router.json5").display().to_string(),
    );
    env.insert(
        "TRAFFICMESH_MAP".into(),
        repo()
            .join("configs/maps/four_way.map.json")
            .display()
            .to_string(),
    );
    env.insert("TRAFFICMESH_STATE".into(), state.display().to_string());
    env.insert("PATH".into(), std::env::var("PATH").unwrap_or_default());

    let mut hosts = Hosts::new(count);
    for &(host, services) in placement {
        for service in services {
            let command = exec_start(service, &env, &bin);
            let log = dir.path().join(format!("{service}.log"));
            hosts.spawn(host, service, &command, &env, &log);
        }
    }
    let watch_log = dir.path().join("watch.log");
    let mut watch = vec![bin.join("trafficmesh").display().to_string()];
    watch.extend(["watch".into(), "--count".into(), "12".into()]);
    hosts.spawn(observer, "watch", &watch, &env, &watch_log);
    let logs = || {
        std::fs::read_dir(dir.path())
            .unwrap()
            .filter_map(|e| {
                let p = e.ok()?.path();
                (p.extension()? == "log").then(|| {
                    format!(
                        "---- {}\n{}",
                        p.display(),
                        std::fs::read_to_string(&p).unwrap_or_default()
                    )
                })
            })
            .collect::<Vec<_>>()
            .join("\n")
    };
    // The watcher's lines, until it has printed its twelve.
    let watcher = &mut hosts.children.last_mut().unwrap().1;
    wait_exit(watcher, Duration::from_secs(60), "watch", &logs);
    let text = std::fs::read_to_string(&watch_log).unwrap();
    let lines: Vec<&str> = text.lines().filter(|l| l.starts_with("t=")).collect();
    assert!(
        lines.len() >= 3,
        "no clock reached host {observer}:\n{}",
        logs()
    );
    let figure = |line: &str, key: &str| -> f64 {
        line.split_whitespace()
            .find_map(|w| w.strip_prefix(key))
            .map(|v| v.trim_end_matches('s').parse().unwrap())
            .unwrap_or_else(|| panic!("no {key} in {line}"))
    };
    let last = lines[lines.len() - 1];
    assert!(
        figure(last, "t=") > figure(lines[0], "t=") + 1.0,
        "the clock did not advance:\n{text}"
    );
    assert!(
        figure(last, "vehicles=") > 0.0,
        "no vehicles spawned across hosts:\n{}",
        logs()
    );
    // `trafficmesh status` from the observer: healthy, every service on its host.
    let status = |hosts: &mut Hosts, timeout: &str| {
        let log = dir.path().join("status.json");
        let mut command = vec![bin.join("trafficmesh").display().to_string()];
        command.extend(["status".into(), "--json".into(), "--timeout".into()]);
        command.push(timeout.into());
        hosts.spawn(observer, "status", &command, &env, &log);
        let child = &mut hosts.children.last_mut().unwrap().1;
        wait_exit(child, Duration::from_secs(20), "status", &|| String::new());
        let text = std::fs::read_to_string(&log).unwrap();
        let json = text
            .lines()
            .find(|l| l.starts_with('{'))
            .unwrap_or_else(|| panic!("no JSON from trafficmesh status:\n{text}"));
        serde_json::from_str::<serde_json::Value>(json).unwrap()
    };
    // Until every service has answered from its host (the services come
    // up one by one), as a user would ask again.
    let on_their_hosts = |h: &serde_json::Value| {
        h["degraded"] == false
            && ["stepper", "spawner", "lights", "crosswalks", "admin"]
                .iter()
                .all(|s| {
                    let s = &h["services"][s];
                    s["alive"] == true
                        && s["pid"].as_u64().is_some()
                        && !s["host"].as_str().unwrap_or("").is_empty()
                        // Each a client of the one router.
                        && s["peers"].as_array().is_some_and(|p| {
                            p.len() == 1 && p[0].as_str().unwrap_or("").starts_with("router ")
                        })
                })
    };
    let asked = Instant::now();
    let health = loop {
        let health = status(&mut hosts, "1");
        if on_their_hosts(&health) {
            break health;
        }
        assert!(
            asked.elapsed() < Duration::from_secs(20),
            "the cluster never looked healthy from host {observer}: {health}\n{}",
            logs()
        );
    };
    let lag = health["services"]["lights"]["lag_s"].as_f64().unwrap();
    assert!(lag.abs() < 5.0, "the lights lag {lag} s behind the stepper");

    // Faults on host 2: its link cut for 3 s and for 15 s (past the 3 s
    // lease: its sessions are torn down and dialled again), its lights
    // service frozen (SIGSTOP) for 5 s. During each, the observer keeps seeing the
    // stepper with its fail-safe in force (lights no longer vouched for
    // count as red, crosswalks as blocked); within 5 s of the fault's end
    // the cluster is healthy again, and the branch statistics saved on host
    // 2 have lost nothing.
    let link = format!("{}e2", hosts.prefix);
    let host2 = hosts.name(2);
    let answered = |h: &serde_json::Value| h["services"]["stepper"]["pid"].is_u64();
    let lights_pid = health["services"]["lights"]["pid"].as_u64().unwrap() as i32;
    let csv = state.join("traffic_branch_decisions.csv");
    let decisions = || {
        std::fs::read_to_string(&csv).map_or(0, |t| {
            t.lines()
                .skip(1)
                .filter_map(|l| l.split(',').nth(3)?.parse::<u64>().ok())
                .sum::<u64>()
        })
    };
    for &(fault, seconds) in faults {
        let saved = decisions();
        let start = |on: bool| match (fault, on) {
            ("link cut", true) => ip(&["-n", &host2, "link", "set", &link, "down"]),
            ("link cut", false) => ip(&["-n", &host2, "link", "set", &link, "up"]),
            (_, true) => unsafe {
                libc::kill(lights_pid, libc::SIGSTOP);
            },
            (_, false) => unsafe {
                libc::kill(lights_pid, libc::SIGCONT);
            },
        };
        start(true);
        let began = Instant::now();
        let mut fail_safe_seen = false;
        while began.elapsed() < Duration::from_secs(seconds) {
            let during = status(&mut hosts, "1");
            fail_safe_seen |= answered(&during)
                && during["reasons"]
                    .to_string()
                    .contains("light states are stale");
        }
        start(false);
        let back = Instant::now();
        assert!(
            fail_safe_seen,
            "{fault} {seconds} s: the observer never saw the stepper's fail-safe:\n{}",
            logs()
        );
        loop {
            let health = status(&mut hosts, "1");
            if answered(&health) && health["degraded"] == false {
                break;
            }
            assert!(
                back.elapsed() < Duration::from_secs(5),
                "{fault} {seconds} s: not healthy 5 s after its end: {health}\n{}",
                logs()
            );
        }
        eprintln!(
            "{fault} {seconds} s: healthy again {:.1} s after its end",
            back.elapsed().as_secs_f64()
        );
        assert!(decisions() >= saved, "{fault}: branch statistics lost");
    }

    let up = last.rsplit("up: ").next().unwrap();
    let services = placement.iter().flat_map(|(_, s)| s.iter());
    for service in services.filter(|&&s| s != "router") {
        assert!(
            up.split(',').any(|s| s == *service),
            "{service} not alive as seen from host {observer}: {last}\n{}",
            logs()
        );
    }
}
