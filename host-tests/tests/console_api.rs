//! The console's HTTP API (`kerf serve`, [`kerf_host::serve`]) over the simulated
//! single axis (`kerf_sim::linked_axis`) on a socket pair: malformed requests are
//! answered 4xx with words and the server goes on; two clients that change settings
//! while a job runs are served one after the other, each answered for its own value;
//! a client that leaves mid-run changes nothing on the machine; the settings and the
//! loaded job stay between clients.

use host_tests::link::{axis_machine, MachineThread};
use kerf_host::link::MachineLink;
use kerf_host::serve::client::{Client, ClientError};
use kerf_host::serve::{self, station::Station};
use kerf_host::session::Session;
use kerf_sim::scenario::Scenario;
use serde_json::{json, Value};
use std::io::{BufRead, Write};
use std::os::unix::net::UnixStream;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Duration, Instant};

struct Rig {
    /// First, so that the console (and its session) ends before the machine.
    _served: serve::Served,
    station: Arc<Station>,
    _machine: MachineThread,
    client: Client,
}

fn rig() -> Rig {
    let (host, far) = UnixStream::pair().unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let thread = axis_machine(Scenario::TRACKING, far, Arc::clone(&stop));
    let link = MachineLink::connect(
        Box::new(host.try_clone().unwrap()),
        Box::new(host),
        Duration::from_secs(5),
    )
    .expect("the simulated axis answers");
    let station = Station::start(Session::over(link), 200.0).expect("the station starts");
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let served = serve::spawn(Arc::clone(&station), listener).unwrap();
    let client = Client::new(&served.address.to_string());
    Rig {
        _served: served,
        station,
        _machine: MachineThread::new(stop, thread),
        client,
    }
}

fn moves_job() -> Vec<u8> {
    std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../data/axis_moves.krfj"
    ))
    .unwrap()
}

/// The status and words of a refused request.
fn refused(outcome: Result<Value, ClientError>) -> (u16, String) {
    match outcome {
        Err(ClientError::Refused { status, words }) => (status, words),
        other => panic!("expected a refusal, got {other:?}"),
    }
}

/// Raw bytes to the server; the status line of its answer.
fn raw(address: &str, bytes: &[u8]) -> String {
    let mut s = std::net::TcpStream::connect(address).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    s.write_all(bytes).unwrap();
    let mut line = String::new();
    let _ = std::io::BufReader::new(s).read_line(&mut line);
    line
}

/// Waits until the job loaded has run and ended; the station's status then.
fn wait_run_end(client: &Client) -> Value {
    let since = Instant::now();
    loop {
        let st = client.get("/api/status").unwrap();
        if st["running"] == false && st["runs"].as_u64() > Some(0) {
            return st;
        }
        assert!(since.elapsed() < Duration::from_secs(120), "{st}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn malformed_requests_are_answered_4xx_with_words_and_the_console_goes_on() {
    let rig = rig();
    let c = &rig.client;
    let m = c.get("/api/machine").unwrap();
    assert_eq!(m["machine"]["name"], "single-axis");
    assert_eq!(m["settings"].as_array().unwrap().len(), 7);
    let cases: Vec<(Result<Value, ClientError>, u16, &str)> = vec![
        (
            c.post_bytes("/api/set", b"{not json"),
            400,
            "send {\"path\"",
        ),
        (c.post("/api/set", &json!({"value": 1})), 400, "path"),
        (
            c.post("/api/set", &json!({"path": "/nope", "value": 1})),
            404,
            "/dob/bandwidth_hz",
        ),
        (
            c.post(
                "/api/set",
                &json!({"path": "/dob/bandwidth_hz", "value": "1 2"}),
            ),
            400,
            "a number",
        ),
        (
            c.post(
                "/api/set",
                &json!({"path": "/dob/bandwidth_hz", "value": [1]}),
            ),
            400,
            "a number",
        ),
        (
            c.post(
                "/api/set",
                &json!({"path": "/dob/bandwidth_hz", "value": 5000}),
            ),
            409,
            "takes > 0 and ≤ 3183 Hz",
        ),
        (c.get("/api/nothing"), 404, "the API is under /api"),
        (c.get("/api/settings?under=/nope"), 404, "no setting there"),
        (c.get("/api/job/preview"), 404, "no job is loaded"),
        (c.post("/api/start", &json!({})), 409, "no job is loaded"),
        (c.post("/api/stop", &json!({})), 409, "no job is running"),
        (c.post_bytes("/api/job?name=empty.krfj", b""), 400, "empty"),
        (
            c.post_bytes("/api/job?name=noise.bin", &[7u8; 300]),
            422,
            "neither a job file",
        ),
        (
            c.post_bytes("/api/job?name=far.gcode", b"G1 X900 F100\n"),
            422,
            "far.gcode",
        ),
        (
            c.post_bytes(
                "/api/job?name=photo.png",
                include_bytes!("../../host/tests/data/horse.png"),
            ),
            422,
            "planned for the Keops slave only, not single-axis",
        ),
    ];
    for (outcome, status, words) in cases {
        let (got, text) = refused(outcome);
        println!("console api: {got} {text}");
        assert_eq!(got, status, "{text}");
        assert!(text.contains(words), "{text:?} lacks {words:?}");
    }
    // Not HTTP at all, and a request line with a bad method: 4xx, not a crash.
    let address = rig._served.address.to_string();
    assert!(raw(&address, b"\x00\x01garbage\r\n\r\n").contains(" 400 "));
    assert!(raw(&address, b"BREW /api/status HTTP/1.1\r\nHost: x\r\n\r\n").contains(" 4"));
    // The console goes on, the setting unchanged.
    let listed = c.get("/api/settings?under=/dob/bandwidth_hz").unwrap();
    assert_eq!(listed[0]["value"], 150.0);
    assert_eq!(listed[0]["range"], "> 0 and ≤ 3183");
    assert_eq!(listed[0]["preset"], 150.0);
}

#[test]
fn two_clients_setting_during_a_run_are_served_one_after_the_other() {
    let rig = rig();
    let loaded = rig
        .client
        .post_bytes("/api/job?name=axis_moves.krfj", &moves_job())
        .unwrap();
    assert_eq!(loaded["kind"], "G-code");
    // The job stays loaded for a client that comes later.
    let other = Client::new(&rig._served.address.to_string());
    assert_eq!(
        other.get("/api/status").unwrap()["job"]["name"],
        "axis_moves.krfj"
    );
    let started = other.post("/api/start", &json!({})).unwrap();
    assert_eq!(started["answer"], "axis_moves.krfj: running");
    let address = rig._served.address.to_string();
    let clients: Vec<_> = [100.0, 200.0]
        .into_iter()
        .map(|base| {
            let address = address.clone();
            std::thread::spawn(move || {
                let c = Client::new(&address);
                (0..15)
                    .map(|k| {
                        let value = base + f64::from(k);
                        let answer = c
                            .post(
                                "/api/set",
                                &json!({"path": "/dob/bandwidth_hz", "value": value}),
                            )
                            .unwrap();
                        (value, answer["answer"].as_str().unwrap().to_owned())
                    })
                    .collect::<Vec<_>>()
            })
        })
        .collect();
    let mut during = 0;
    for c in clients {
        for (value, answer) in c.join().unwrap() {
            // Each answer is for its own request, nothing interleaved: `set PATH =
            // VALUE` from the run, `PATH = VALUE` read back once it has ended.
            let (path, said) = answer.trim_start_matches("set ").split_once(" = ").unwrap();
            assert_eq!(path, "/dob/bandwidth_hz");
            assert_eq!(said.parse::<f64>().unwrap(), value, "{answer}");
            during += usize::from(answer.starts_with("set "));
        }
    }
    println!("console api: {during} of 30 changes answered by the running job");
    assert!(during > 0);
    let st = wait_run_end(&rig.client);
    assert!(
        st["last_run"]["Ok"]
            .as_str()
            .unwrap()
            .contains("ran to its end"),
        "{st}"
    );
    let now = rig
        .client
        .get("/api/settings?under=/dob/bandwidth_hz")
        .unwrap()[0]["value"]
        .as_f64()
        .unwrap();
    assert!(now == 114.0 || now == 214.0, "{now}");
}

#[test]
fn a_client_that_leaves_mid_run_changes_nothing_on_the_machine() {
    let rig = rig();
    rig.client
        .post_bytes("/api/job?name=axis_moves.krfj", &moves_job())
        .unwrap();
    let mut stream = rig.client.stream().unwrap();
    rig.client.post("/api/start", &json!({})).unwrap();
    // A few samples, then the client goes.
    let mut samples = 0;
    let mut line = String::new();
    while samples < 20 {
        line.clear();
        stream.read_line(&mut line).unwrap();
        samples += usize::from(line.starts_with("event: sample"));
    }
    drop(stream);
    let st = wait_run_end(&rig.client);
    let summary = st["last_run"]["Ok"].as_str().unwrap_or_default();
    assert!(summary.contains("ran to its end"), "{st}");
    let log = st["log"].to_string();
    assert!(!log.contains("stop"), "{log}");
}

#[test]
fn the_station_keeps_the_state_the_recent_samples_and_tells_its_listeners() {
    let rig = rig();
    let mut updates = rig.station.listen();
    // Telemetry flows between jobs too, at the station's rate.
    let since = Instant::now();
    let mut heard = Vec::new();
    while heard.len() < 50 {
        match updates.try_recv() {
            Ok(kerf_host::serve::station::Update::Sample { t, values, .. }) => {
                heard.push((t, values))
            }
            Ok(_) => {}
            Err(_) => std::thread::sleep(Duration::from_millis(5)),
        }
        assert!(since.elapsed() < Duration::from_secs(30));
    }
    // 200 samples a second of machine time: 5 ms apart, in order.
    for pair in heard.windows(2) {
        assert!(
            (pair[1].0 - pair[0].0 - 5e-3).abs() < 1e-9,
            "{:?}",
            (pair[0].0, pair[1].0)
        );
        assert_eq!(pair[1].1.len(), 6);
    }
    let recent = rig.station.recent();
    let last = heard.last().unwrap();
    assert!(recent.iter().any(|(t, v)| t == &last.0 && v == &last.1));
    assert!(recent.windows(2).all(|w| w[0].0 < w[1].0));
    let snapshot = rig.station.snapshot();
    assert_eq!(snapshot.mode, "ready");
    assert!(snapshot.samples >= heard.len() as u64);
    assert_eq!(snapshot.closed, None);
    // Heard within the last samples' time, not since the start.
    assert!(snapshot.quiet_ms < 1000, "{}", snapshot.quiet_ms);
    // What a status answers is the snapshot.
    let status = rig.client.get("/api/status").unwrap();
    assert_eq!(status["mode"], "ready");
    assert_eq!(status["values"][2][0], "/dob/bandwidth_hz");
}
