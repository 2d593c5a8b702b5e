//! A small HTTP client over ureq for the admin tests: every answer comes back
//! with its status, content type and body, errors included.

use std::time::Duration;

use serde_json::Value;

pub struct Reply {
    pub status: u16,
    pub content_type: String,
    pub headers: Vec<(String, String)>,
    pub body: String,
}

impl Reply {
    pub fn json(&self) -> Value {
        serde_json::from_str(&self.body).unwrap_or_else(|e| panic!("not JSON ({e}): {}", self.body))
    }

    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }

    /// A problem+json error with this status whose detail or problems mention `needle`.
    #[track_caller]
    pub fn assert_problem(&self, status: u16, needle: &str) {
        assert_eq!(self.status, status, "{}", self.body);
        assert_eq!(
            self.content_type, "application/problem+json",
            "{}",
            self.body
        );
        let p = self.json();
        assert_eq!(p["status"], status);
        let text = format!("{} {}", p["detail"], p["problems"]);
        assert!(
            text.contains(needle),
            "problem does not name {needle}: {text}"
        );
    }
}

pub struct Api {
    agent: ureq::Agent,
    base: String,
}

pub enum Auth<'a> {
    None,
    Bearer(&'a str),
}

impl Api {
    pub fn new(base: &str) -> Api {
        let agent: ureq::Agent = ureq::Agent::config_builder()
            .http_status_as_error(false)
            .timeout_global(Some(Duration::from_secs(20)))
            .build()
            .into();
        Api {
            agent,
            base: base.to_string(),
        }
    }

    pub fn get(&self, path: &str) -> Reply {
        let r = self.agent.get(format!("{}{path}", self.base)).call();
        reply(r)
    }

    /// `method` with a raw body (`None`: no body) and a content type.
    pub fn send(
        &self,
        method: &str,
        path: &str,
        auth: Auth,
        content_type: Option<&str>,
        body: Option<&[u8]>,
    ) -> Reply {
        let url = format!("{}{path}", self.base);
        let mut req = ureq::http::Request::builder().method(method).uri(url);
        if let Auth::Bearer(t) = auth {
            req = req.header("Authorization", format!("Bearer {t}"));
        }
        if let Some(ct) = content_type {
            req = req.header("Content-Type", ct);
        }
        let r = match body {
            Some(b) => self.agent.run(req.body(b.to_vec()).unwrap()),
            None => self.agent.run(req.body(()).unwrap()),
        };
        reply(r)
    }

    /// A POST without a body, with the bearer token (the save and load actions).
    pub fn post_empty(&self, path: &str, token: &str) -> Reply {
        self.send("POST", path, Auth::Bearer(token), None, None)
    }

    /// `method` with a JSON body and the bearer token.
    pub fn json(&self, method: &str, path: &str, token: &str, body: &Value) -> Reply {
        self.send(
            method,
            path,
            Auth::Bearer(token),
            Some("application/json"),
            Some(body.to_string().as_bytes()),
        )
    }
}

/// The status line's code for a request that announces `length` body bytes
/// and sends them only if `send` (a server that refuses by Content-Length
/// answers without waiting for them).
pub fn status_for_announced_length(
    base: &str,
    path: &str,
    token: &str,
    length: usize,
    send: bool,
) -> u16 {
    use std::io::{Read, Write};
    let host = base.trim_start_matches("http://");
    let mut stream = std::net::TcpStream::connect(host).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    write!(
        stream,
        "PUT {path} HTTP/1.1\r\nHost: {host}\r\nAuthorization: Bearer {token}\r\nContent-Type: application/json\r\nContent-Length: {length}\r\n\r\n"
    )
    .unwrap();
    if send {
        stream.write_all(&vec![b' '; length]).unwrap();
    }
    let mut head = [0u8; 12];
    stream.read_exact(&mut head).unwrap();
    let line = String::from_utf8_lossy(&head);
    line[9..12]
        .parse()
        .unwrap_or_else(|_| panic!("bad status line: {line}"))
}

fn reply(r: Result<ureq::http::Response<ureq::Body>, ureq::Error>) -> Reply {
    let mut r = r.expect("HTTP request failed");
    let headers = r
        .headers()
        .iter()
        .map(|(n, v)| (n.to_string(), v.to_str().unwrap_or("").to_string()))
        .collect::<Vec<_>>();
    let content_type = r
        .headers()
        .get("content-type")
        .and_then(|v| v.to_str().ok())
        .unwrap_or("")
        .to_string();
    Reply {
        status: r.status().as_u16(),
        content_type,
        headers,
        body: r.body_mut().read_to_string().unwrap_or_default(),
    }
}
