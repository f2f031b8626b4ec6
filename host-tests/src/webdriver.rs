//! A WebDriver client for the console's browser test: Debian's `chromedriver`
//! started on a free loopback port, driving headless Chromium.

use base64::Engine;
use serde_json::{json, Value};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The key under which WebDriver names an element.
const ELEMENT: &str = "element-6066-11e4-a52e-4f735466cecf";

/// One browser, closed when dropped.
pub struct Browser {
    agent: ureq::Agent,
    session: String,
    driver: Child,
}

/// A free loopback port (bound, then released for the driver).
fn free_port() -> std::io::Result<u16> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?
        .local_addr()?
        .port())
}

impl Browser {
    /// Starts chromedriver and a headless Chromium of `width` × `height` pixels.
    pub fn start(width: u32, height: u32) -> Result<Self, String> {
        let port = free_port().map_err(|e| e.to_string())?;
        let driver = Command::new("chromedriver")
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| format!("chromedriver: {e} (apt-get install chromium-driver)"))?;
        let agent: ureq::Agent = ureq::Agent::config_builder()
            .http_status_as_error(false)
            .timeout_global(Some(Duration::from_secs(60)))
            .build()
            .into();
        let mut browser = Browser {
            agent,
            session: format!("http://127.0.0.1:{port}"),
            driver,
        };
        let ready = Instant::now();
        while browser.call("GET", "/status", None).is_err() {
            if ready.elapsed() > Duration::from_secs(20) {
                return Err("chromedriver did not answer within 20 s".into());
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        let user_data = std::env::temp_dir().join(format!("kerf-console-chromium-{port}"));
        // The flags keep Chromium off the network it does not have here.
        let args = [
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-dev-shm-usage",
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([
            format!("--window-size={width},{height}"),
            format!("--user-data-dir={}", user_data.display()),
        ])
        .collect::<Vec<_>>();
        let created = browser.call(
            "POST",
            "/session",
            Some(json!({"capabilities": {"alwaysMatch": {
                "browserName": "chrome",
                "goog:chromeOptions": {"binary": "/usr/bin/chromium", "args": args}
            }}})),
        )?;
        let id = created["sessionId"]
            .as_str()
            .ok_or_else(|| format!("no session: {created}"))?;
        browser.session = format!("{}/session/{id}", browser.session);
        Ok(browser)
    }

    fn call(&self, method: &str, path: &str, body: Option<Value>) -> Result<Value, String> {
        let url = if path.starts_with("/session") || path == "/status" {
            // Before the session: the driver's own address.
            let base = self.session.split("/session/").next().unwrap_or_default();
            format!("{base}{path}")
        } else {
            format!("{}{path}", self.session)
        };
        let sent = match (method, body) {
            ("GET", _) => self.agent.get(&url).call(),
            ("DELETE", _) => self.agent.delete(&url).call(),
            (_, b) => self.agent.post(&url).send_json(b.unwrap_or(json!({}))),
        };
        let mut response = sent.map_err(|e| format!("{method} {path}: {e}"))?;
        let status = response.status().as_u16();
        let value: Value = response
            .body_mut()
            .read_json()
            .map_err(|e| format!("{method} {path}: {e}"))?;
        if status >= 400 {
            return Err(format!("{method} {path}: {}", value["value"]["message"]));
        }
        Ok(value["value"].clone())
    }

    /// Opens `url`.
    pub fn goto(&self, url: &str) -> Result<(), String> {
        self.call("POST", "/url", Some(json!({ "url": url })))
            .map(drop)
    }

    fn find(&self, css: &str) -> Result<String, String> {
        let found = self.call(
            "POST",
            "/element",
            Some(json!({"using": "css selector", "value": css})),
        )?;
        found[ELEMENT]
            .as_str()
            .map(str::to_owned)
            .ok_or_else(|| format!("{css}: no such element ({found})"))
    }

    /// Clicks the element `css` selects.
    pub fn click(&self, css: &str) -> Result<(), String> {
        let id = self.find(css)?;
        self.call("POST", &format!("/element/{id}/click"), None)
            .map(drop)
    }

    /// Types `text` into the element `css` selects, replacing what it holds (selected
    /// with Ctrl-A first, so that the page cannot refill it between a clear and the
    /// typing); a file input takes the file's path.
    pub fn type_into(&self, css: &str, text: &str) -> Result<(), String> {
        let id = self.find(css)?;
        let keys = if css.contains("file") {
            text.to_owned()
        } else {
            // Control down, a, every modifier up, then the text.
            format!("\u{E009}a\u{E000}{text}")
        };
        self.call(
            "POST",
            &format!("/element/{id}/value"),
            Some(json!({ "text": keys })),
        )
        .map(drop)
    }

    /// The visible text of the element `css` selects.
    pub fn text(&self, css: &str) -> Result<String, String> {
        let id = self.find(css)?;
        Ok(self
            .call("GET", &format!("/element/{id}/text"), None)?
            .as_str()
            .unwrap_or_default()
            .to_owned())
    }

    /// Runs `script` in the page (a function body: `return …`).
    pub fn script(&self, script: &str) -> Result<Value, String> {
        self.call(
            "POST",
            "/execute/sync",
            Some(json!({"script": script, "args": []})),
        )
    }

    /// Writes a PNG of the page to `path`.
    pub fn screenshot(&self, path: &Path) -> Result<(), String> {
        let shot = self.call("GET", "/screenshot", None)?;
        let png = base64::engine::general_purpose::STANDARD
            .decode(shot.as_str().unwrap_or_default())
            .map_err(|e| e.to_string())?;
        std::fs::write(path, png).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Polls `ready` every 100 ms until it holds, for at most `limit`; `what` names
    /// the wait in the error.
    pub fn wait(
        &self,
        what: &str,
        limit: Duration,
        mut ready: impl FnMut(&Browser) -> Result<bool, String>,
    ) -> Result<(), String> {
        let since = Instant::now();
        loop {
            if ready(self)? {
                return Ok(());
            }
            if since.elapsed() > limit {
                return Err(format!("{what}: not within {} s", limit.as_secs()));
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.call("DELETE", "", None);
        let _ = self.driver.kill();
        let _ = self.driver.wait();
    }
}
