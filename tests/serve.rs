//! `tandem serve`: the teleoperation session (commands, NaN, stale
//! commands, modes, recordings in the simulator's Parquet layout) and the
//! WebSocket server under abuse (malformed, binary and oversized frames,
//! 10,000 messages a second, abrupt disconnects), which must keep serving.

use futures_util::{SinkExt, StreamExt};
use std::time::{Duration, Instant};
use tandem::teleop::{ServeSettings, Server, SessionSettings, TeleopSession, TeleopTask};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_tungstenite::tungstenite::Message;

fn planar(record: Option<std::path::PathBuf>) -> TeleopSession {
    let settings = SessionSettings { record_dir: record, ..SessionSettings::default() };
    TeleopSession::prepare(&settings, TeleopTask::Planar, 0).expect("the planar task prepares")
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

#[test]
fn a_person_driving_toward_a_cylinder_gets_there_and_the_episode_is_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let mut session = planar(Some(dir.path().into()));
    let scene = session.scene();
    assert_eq!(scene.task, "planar");
    assert_eq!(scene.goals.len(), 2);
    assert!(scene.goals.iter().all(|g| g.reference.len() > 10), "each goal's reference is drawn");
    assert!(!scene.links.is_empty() && session.state().links.len() == scene.links.len());
    let goal = scene.goals[0].position;
    let start = session.state().gripper;
    let mut now = Instant::now();
    for _ in 0..600 {
        let g = session.state().gripper;
        let d = distance(goal, g).max(1e-9);
        session.set_command([0.08 * (goal[0] - g[0]) / d, 0.08 * (goal[1] - g[1]) / d, 0.0], now);
        session.tick(now).unwrap();
        now += Duration::from_millis(33);
        if session.outcome().is_some() {
            break;
        }
    }
    let state = session.state().clone();
    assert_eq!(state.outcome, Some("success"), "driving straight at a cylinder succeeds: {state:?}");
    assert_eq!((state.reason, state.reason_detail.as_deref()), (Some("success"), Some("the task is done")));
    assert!(state.min_clearance >= 0.0);
    assert!(state.beliefs[0] > state.beliefs[1], "the beliefs follow the driven goal: {:?}", state.beliefs);
    assert!(distance(state.gripper, goal) < distance(start, goal));
    let file = session.finish().unwrap().expect("the episode is saved");
    assert!(session.finish().unwrap().is_none(), "an episode is saved once");
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let reader = SerializedFileReader::new(std::fs::File::open(&file).unwrap()).unwrap();
    assert_eq!(reader.metadata().file_metadata().num_rows() as usize, state.steps);
    let columns: Vec<String> = reader
        .metadata()
        .file_metadata()
        .schema_descr()
        .root_schema()
        .get_fields()
        .iter()
        .map(|f| f.name().to_string())
        .collect();
    let layout = [
        "episode", "step", "time", "q", "qdot", "human", "executed", "robot", "beliefs", "status", "outcome", "reason",
    ];
    assert_eq!(columns, layout, "the simulator's episode layout");
}

#[test]
fn the_episode_starts_at_the_first_command_and_an_undriven_one_is_not_saved() {
    let dir = tempfile::tempdir().unwrap();
    let mut session = planar(Some(dir.path().into()));
    let start = session.state().clone();
    assert_eq!(start.status, "waiting");
    let [link, obstacle] = start.nearest.clone().expect("the planar scene has obstacles");
    assert_eq!(link, "gripper_body", "the finger-pad group of the gripper link");
    assert!(["pole", "red", "yellow"].contains(&obstacle.as_str()), "{obstacle}");
    assert!(start.clearance.is_finite());
    // The page sends zeros while no key is held: the clock stays at zero.
    let mut now = Instant::now();
    for k in 0..30 {
        if k % 2 == 0 {
            session.set_command([0.0; 3], now);
        }
        session.tick(now).unwrap();
        now += Duration::from_millis(33);
    }
    let idle = session.state().clone();
    assert_eq!((idle.steps, idle.time, idle.status), (0, 0.0, "waiting"));
    assert!(!session.driven() && distance(idle.gripper, start.gripper) == 0.0);
    assert!(session.finish().unwrap().is_none() && session.outcome().is_none(), "an undriven page saves nothing");
    assert_eq!(std::fs::read_dir(dir.path()).map_or(0, |d| d.count()), 0);
    // The first command that is not zero starts it.
    session.set_command([0.05, 0.0, 0.0], now);
    session.tick(now).unwrap();
    let moving = session.state().clone();
    assert!(session.driven() && moving.steps == 1 && moving.status != "waiting", "{moving:?}");
    assert!(moving.time > 0.0 && moving.time < 0.05, "the clock starts at the first command: {}", moving.time);
    // The gripper frame's pose goes with its position.
    assert_eq!(&moving.gripper_pose[..3], &moving.gripper[..]);
    assert!(session.finish().unwrap().is_some(), "a driven episode is saved");
    // Stopped by the person far from both cylinders: how far short.
    let stopped = session.state().clone();
    assert_eq!((stopped.outcome, stopped.reason), (Some("failed"), Some("stopped_short")), "{stopped:?}");
    let detail = stopped.reason_detail.expect("the reason in words");
    assert!(detail.starts_with("the operator stopped ") && detail.contains(" cm from the goal"), "{detail}");
    // A restart waits for the next first command, its reason cleared.
    session.restart(TeleopTask::Planar, 0).unwrap();
    assert!(!session.driven() && session.state().status == "waiting" && session.state().steps == 0);
    assert!(session.state().reason.is_none() && session.state().reason_detail.is_none() && session.reason().is_none());
}

#[test]
fn a_timeout_says_how_far_the_gripper_is_from_the_goal_the_beliefs_favour() {
    let settings = SessionSettings { max_episode_time: 0.5, ..SessionSettings::default() };
    let mut session = TeleopSession::prepare(&settings, TeleopTask::Planar, 0).unwrap();
    let goal = session.scene().goals[0].position;
    let mut now = Instant::now();
    while session.outcome().is_none() {
        let g = session.state().gripper;
        let d = distance(goal, g).max(1e-9);
        session.set_command([0.05 * (goal[0] - g[0]) / d, 0.05 * (goal[1] - g[1]) / d, 0.0], now);
        session.tick(now).unwrap();
        now += Duration::from_millis(33);
    }
    let state = session.state().clone();
    assert_eq!((state.outcome, state.reason), (Some("timeout"), Some("timeout")), "{state:?}");
    assert!(state.beliefs[0] > state.beliefs[1], "{:?}", state.beliefs);
    let cm = format!("{:.1} cm", 100.0 * distance(state.gripper, goal));
    assert_eq!(state.reason_detail.as_deref(), Some(format!("time ran out {cm} from the goal").as_str()));
    // Ticks after the end hold the reason; finishing keeps it.
    session.tick(now).unwrap();
    session.finish().unwrap();
    assert_eq!(session.state().reason, Some("timeout"));
}

#[test]
fn nan_and_stale_commands_hold_the_arm_and_fast_ones_are_clamped() {
    let mut session = planar(None);
    let t0 = Instant::now();
    session.set_command([0.05, 0.0, 0.0], t0);
    session.tick(t0).unwrap();
    let moved = session.state().clone();
    assert_eq!(moved.status, "nominal");
    assert!(moved.executed.iter().any(|v| v.abs() > 1e-3));
    session.set_command([f64::NAN, 0.0, 0.0], t0);
    session.tick(t0).unwrap();
    let held = session.state().clone();
    assert_eq!(held.status, "invalid_command");
    // A hold brakes within the motion limits, then stands exactly still.
    let speed = |s: &[f64; 3]| s.iter().map(|v| v * v).sum::<f64>().sqrt();
    assert!(speed(&held.executed) < speed(&moved.executed), "{held:?}");
    let mut still = held;
    for _ in 0..30 {
        session.tick(t0).unwrap();
        let next = session.state().clone();
        assert_eq!(next.status, "invalid_command");
        assert!(speed(&next.executed) <= speed(&still.executed) + 1e-12, "{next:?}");
        still = next;
    }
    assert!(still.executed == [0.0; 3], "{still:?}");
    session.tick(t0).unwrap();
    assert!(distance(session.state().gripper, still.gripper) < 1e-12);
    // A command older than the timeout (0.5 s) is not executed.
    session.set_command([0.05, 0.0, 0.0], t0);
    session.tick(t0 + Duration::from_secs(1)).unwrap();
    let stale = session.state().clone();
    assert!(stale.stale_command && stale.human == [0.0; 3]);
    assert!(stale.executed.iter().all(|v| v.abs() < 1e-9), "{:?}", stale.executed);
    // 10 m/s becomes the speed limit.
    session.set_command([10.0, 0.0, 0.0], t0);
    session.tick(t0).unwrap();
    assert!((session.state().human[0] - SessionSettings::default().max_speed).abs() < 1e-12);
    assert_eq!(session.state().commands, 4);
    // So do 1e308 m/s, whose squared norm overflows (it executed as zero,
    // status nominal), along their direction.
    for huge in [[1e308, 0.0, 0.0], [1e308, 1e308, 0.0], [f64::MAX, 0.0, 0.0]] {
        session.set_command(huge, t0);
        session.tick(t0).unwrap();
        let state = session.state();
        let speed = state.human.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!((speed - SessionSettings::default().max_speed).abs() < 1e-12, "{huge:?}: {:?}", state.human);
        assert!(state.human[0] > 0.0 && state.executed[0] > 1e-3, "{huge:?} moves along +x: {state:?}");
    }
}

#[test]
fn modes_switch_and_unknown_or_unavailable_ones_are_refused() {
    let mut session = planar(None);
    assert_eq!(session.scene().modes.len(), 8, "every mode but learned, which needs an actor");
    // Before the first command no tick runs, yet the state names the new
    // mode (the page sets its mode menu from it).
    session.set_mode("direct").unwrap();
    session.tick(Instant::now()).unwrap();
    assert_eq!((session.state().status, session.state().mode), ("waiting", "direct"));
    for name in session.scene().modes {
        session.set_mode(name).unwrap();
        session.set_command([0.03, 0.02, 0.0], Instant::now());
        session.tick(Instant::now()).unwrap();
        assert_eq!(session.state().mode, name);
    }
    assert!(session.set_mode("fly").unwrap_err().contains("fly"));
    assert!(session.set_mode("learned").unwrap_err().contains("--arbiter"));
    session.restart(TeleopTask::Planar, 0).unwrap();
    assert_eq!(session.state().steps, 0);
    assert_eq!(session.state().mode, "sos", "a restart keeps the last mode");
}

// ------------------------------------------------------------------ server

async fn start() -> (std::net::SocketAddr, tempfile::TempDir) {
    start_with(ServeSettings::default()).await
}

async fn start_with(settings: ServeSettings) -> (std::net::SocketAddr, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let settings = ServeSettings {
        address: "127.0.0.1:0".parse().unwrap(),
        session: SessionSettings { record_dir: Some(dir.path().into()), ..SessionSettings::default() },
        task: TeleopTask::Planar,
        ..settings
    };
    let server = Server::bind(settings).await.unwrap();
    let address = server.local_addr().unwrap();
    tokio::spawn(server.run());
    (address, dir)
}

async fn stats(address: std::net::SocketAddr) -> serde_json::Value {
    let mut stream = tokio::net::TcpStream::connect(address).await.unwrap();
    stream.write_all(b"GET /stats HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n").await.unwrap();
    let mut response = String::new();
    stream.read_to_string(&mut response).await.unwrap();
    let body = response.split("\r\n\r\n").nth(1).expect("an HTTP body");
    serde_json::from_str(body).unwrap_or_else(|e| panic!("{e}: {response}"))
}

type Client = tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

async fn connect(address: std::net::SocketAddr) -> Client {
    tokio_tungstenite::connect_async(format!("ws://{address}/ws")).await.unwrap().0
}

/// Reads until a message of type `kind` (the messages before it returned too).
async fn until(client: &mut Client, kind: &str) -> Vec<serde_json::Value> {
    until_message(client, Duration::from_secs(60), |m| m["type"] == kind).await
}

/// Reads until a message `done` accepts, within `timeout` (the messages
/// before it returned too).
async fn until_message(
    client: &mut Client,
    timeout: Duration,
    done: impl Fn(&serde_json::Value) -> bool,
) -> Vec<serde_json::Value> {
    let mut seen = vec![];
    let deadline = tokio::time::Instant::now() + timeout;
    loop {
        let message = tokio::time::timeout_at(deadline, client.next()).await.expect("in time").expect("open").unwrap();
        if let Message::Text(text) = message {
            let value: serde_json::Value = serde_json::from_str(&text).unwrap();
            let finished = done(&value);
            seen.push(value);
            if finished {
                return seen;
            }
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_server_survives_garbage_floods_and_disconnects() {
    let (address, dir) = start().await;
    let mut client = connect(address).await;
    let opening = until(&mut client, "state").await;
    let kinds: Vec<&str> = opening.iter().filter_map(|m| m["type"].as_str()).collect();
    assert_eq!(&kinds[..3], ["hello", "preparing", "scene"]);

    // Malformed and binary frames: an error each, the session goes on.
    for bad in ["not json", r#"{"type":"command","linear":[1]}"#, r#"{"type":"reset","task":"juggle"}"#] {
        client.send(Message::Text(bad.into())).await.unwrap();
        let error = until(&mut client, "error").await.pop().unwrap();
        assert!(!error["message"].as_str().unwrap().is_empty());
    }
    client.send(Message::Binary(vec![0, 159, 146, 150].into())).await.unwrap();
    assert!(until(&mut client, "error").await.pop().unwrap()["message"].as_str().unwrap().contains("binary"));

    // 10,000 commands a second for 3 s, half with NaN; the states keep coming.
    let began = Instant::now();
    let mut sent = 0u64;
    while began.elapsed() < Duration::from_secs(3) {
        for k in 0..100 {
            let x = if k % 2 == 0 { "0.02" } else { "null" };
            client.feed(Message::Text(format!(r#"{{"type":"command","linear":[{x},0.01,0]}}"#).into())).await.unwrap();
        }
        client.flush().await.unwrap();
        sent += 100;
        let target = Duration::from_micros(sent * 100);
        if let Some(wait) = target.checked_sub(began.elapsed()) {
            tokio::time::sleep(wait).await;
        }
    }
    assert!(sent >= 25_000, "the flood reached {sent} messages");
    // The states queued while the client only wrote come first; the
    // session counted every command.
    let mut state = serde_json::Value::Null;
    while state["commands"].as_u64().unwrap_or(0) < sent {
        state = until(&mut client, "state").await.pop().unwrap();
    }
    assert_eq!(state["rejected"], 4, "{state}");
    assert!(matches!(state["status"].as_str(), Some("nominal" | "invalid_command" | "constrained")), "{state}");
    let health = stats(address).await;
    assert!(health["messages"].as_u64().unwrap() >= sent, "{health}");
    assert_eq!(health["sessions_open"], 1);

    // An oversized frame closes that connection with 1009.
    client.send(Message::Text("x".repeat(10_000).into())).await.unwrap();
    let mut code = None;
    while let Some(Ok(message)) = client.next().await {
        if let Message::Close(Some(frame)) = message {
            code = Some(u16::from(frame.code));
        }
    }
    assert_eq!(code, Some(1009));

    // A page that never drives: its states hold at zero time, its status
    // waits, and leaving saves nothing.
    let mut idle = connect(address).await;
    let mut state = until(&mut idle, "state").await.pop().unwrap();
    for _ in 0..20 {
        idle.send(Message::Text(r#"{"type":"command","linear":[0,0,0]}"#.into())).await.unwrap();
        state = until(&mut idle, "state").await.pop().unwrap();
    }
    assert_eq!((state["steps"].as_u64(), state["time"].as_f64()), (Some(0), Some(0.0)), "{state}");
    assert_eq!(state["status"], "waiting", "{state}");
    assert_eq!(state["nearest"][0], "gripper_body", "{state}");
    idle.close(None).await.unwrap();
    drop(idle);

    // A client that drives, then vanishes mid-flood, without a close frame.
    let mut rude = connect(address).await;
    until(&mut rude, "scene").await;
    rude.send(Message::Text(r#"{"type":"command","linear":[0.01,0,0]}"#.into())).await.unwrap();
    while until(&mut rude, "state").await.pop().unwrap()["steps"].as_u64().unwrap_or(0) == 0 {}
    for _ in 0..1000 {
        rude.feed(Message::Text(r#"{"type":"command","linear":[0.01,0,0]}"#.into())).await.unwrap();
    }
    rude.flush().await.unwrap();
    drop(rude);

    // Still serving: a new page gets its scene and states, and the ended
    // sessions were saved and closed.
    let mut fresh = connect(address).await;
    until(&mut fresh, "state").await;
    tokio::time::sleep(Duration::from_millis(500)).await;
    let health = stats(address).await;
    assert_eq!(health["sessions_open"], 1, "{health}");
    assert_eq!(health["closed_oversized"], 1, "{health}");
    // The flooding page's and the rude one's: not the idle one's.
    assert_eq!(health["episodes_saved"], 2, "{health}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    assert!(health["tick_us"]["count"].as_u64().unwrap() > 50, "{health}");
    // Every executed step of every session within the hard and the motion limits.
    assert_eq!(
        (health["hard_violations"].as_u64(), health["limit_violations"].as_u64()),
        (Some(0), Some(0)),
        "{health}"
    );

    // A reset ends the driven episode; the page is told how and why.
    fresh.send(Message::Text(r#"{"type":"command","linear":[0.01,0,0]}"#.into())).await.unwrap();
    while until(&mut fresh, "state").await.pop().unwrap()["steps"].as_u64().unwrap_or(0) == 0 {}
    fresh.send(Message::Text(r#"{"type":"reset"}"#.into())).await.unwrap();
    let episode = until(&mut fresh, "episode").await.pop().unwrap();
    assert_eq!((episode["outcome"].as_str(), episode["reason"].as_str()), (Some("failed"), Some("stopped_short")));
    assert!(episode["reason_detail"].as_str().unwrap().contains("cm from the goal"), "{episode}");
}

/// How the server ended the connection (within 20 s): `Ok` with the close
/// frame's code, or `Err` with the read error once the socket is gone (a
/// client that answers the server's pings after the close finds a broken
/// pipe first); "still open" if it did not.
async fn closed(client: &mut Client) -> Result<Option<u16>, String> {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(20);
    loop {
        match tokio::time::timeout_at(deadline, client.next()).await {
            Ok(Some(Ok(Message::Close(frame)))) => return Ok(frame.map(|f| u16::from(f.code))),
            Ok(Some(Ok(_))) => {}
            Ok(Some(Err(e))) => return Err(e.to_string()),
            Ok(None) => return Ok(None),
            Err(_) => return Err("still open after 20 s".into()),
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_server_caps_sessions_and_closes_idle_pages_and_half_sent_requests() {
    let settings = ServeSettings {
        max_sessions: 2,
        header_timeout: Duration::from_millis(500),
        idle_timeout: Duration::from_millis(1500),
        ..ServeSettings::default()
    };
    let (address, _dir) = start_with(settings).await;
    let mut first = connect(address).await;
    let mut second = connect(address).await;
    until(&mut first, "scene").await;
    until(&mut second, "scene").await;
    // A third page is refused with the reason, and counted.
    match tokio_tungstenite::connect_async(format!("ws://{address}/ws")).await {
        Err(tokio_tungstenite::tungstenite::Error::Http(response)) => {
            assert_eq!(response.status(), 503);
            let body = String::from_utf8_lossy(response.body().as_deref().unwrap_or_default()).to_string();
            assert!(body.contains("--max-sessions") && body.contains('2'), "{body}");
        }
        other => panic!("a third session was not refused: {other:?}"),
    }
    let health = stats(address).await;
    assert_eq!((health["sessions_open"].as_u64(), health["refused_full"].as_u64()), (Some(2), Some(1)), "{health}");

    // A page that keeps reading answers the pings and stays past the idle
    // timeout; one that reads but sends nothing is closed with 1001.
    let reading = tokio::spawn(async move {
        let began = Instant::now();
        while began.elapsed() < Duration::from_secs(3) {
            let next = tokio::time::timeout(Duration::from_millis(200), first.next()).await;
            assert!(!matches!(next, Ok(None | Some(Ok(Message::Close(_))))), "a reading page was closed");
        }
        first
    });
    tokio::time::sleep(Duration::from_millis(2500)).await;
    let ended = closed(&mut second).await;
    assert!(matches!(ended, Ok(Some(1001))) || ended.as_ref().is_err_and(|e| e.contains("pipe")), "{ended:?}");
    let first = reading.await.unwrap();
    let health = stats(address).await;
    assert_eq!((health["sessions_open"].as_u64(), health["closed_idle"].as_u64()), (Some(1), Some(1)), "{health}");
    drop(first);
    drop(second);

    // Half a frame, then nothing: the session is closed as idle and its
    // place given back (the page may see a reset instead of the close frame:
    // the server drops the socket with the rest of the frame unread).
    let mut half_frame = connect(address).await;
    until(&mut half_frame, "scene").await;
    if let tokio_tungstenite::MaybeTlsStream::Plain(tcp) = half_frame.get_mut() {
        // A masked text frame's first byte and a 16-bit length marker, then nothing.
        tcp.write_all(&[0x81, 0xFE]).await.unwrap();
    } else {
        panic!("a plain TCP stream");
    }
    tokio::time::sleep(Duration::from_millis(2500)).await;
    let health = stats(address).await;
    assert_eq!(health["closed_idle"].as_u64(), Some(2), "{health}");
    assert!(health["sessions_open"].as_u64() <= Some(1), "{health}");

    // A request head that never ends is closed after the header timeout.
    let mut half = tokio::net::TcpStream::connect(address).await.unwrap();
    half.write_all(b"GET /stats HTTP/1.1\r\nHost: localhost\r\n").await.unwrap();
    let began = Instant::now();
    let mut rest = vec![];
    let read = tokio::time::timeout(Duration::from_secs(10), half.read_to_end(&mut rest)).await;
    assert!(read.is_ok(), "a half-sent request head held the connection for 10 s");
    assert!(began.elapsed() < Duration::from_secs(5), "closed after {:?}", began.elapsed());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_mode_asked_for_while_a_task_is_prepared_is_applied_or_refused_when_it_is_ready() {
    let (address, _dir) = start().await;
    let mut client = connect(address).await;
    until(&mut client, "scene").await;
    // Right after a reset (the task is being prepared): a known mode is
    // applied when the task is ready (it was dropped silently).
    client.send(Message::Text(r#"{"type":"reset","seed":1}"#.into())).await.unwrap();
    client.send(Message::Text(r#"{"type":"mode","mode":"constrained"}"#.into())).await.unwrap();
    let mut seen = until(&mut client, "scene").await;
    // Read while the task is prepared, the mode is in the scene; read after
    // a quick planar restart is ready (both orders happen), it is applied
    // at once and the states say so.
    if seen.last().unwrap()["mode"] != "constrained" {
        assert_eq!(seen.last().unwrap()["mode"], "sos", "{:?}", seen.last());
        let applied = |m: &serde_json::Value| m["type"] == "state" && m["mode"] == "constrained";
        seen.extend(until_message(&mut client, Duration::from_secs(10), applied).await);
    }
    assert!(seen.iter().all(|m| m["type"] != "error"), "{seen:?}");
    // An unknown name is refused at once, one the task does not offer
    // when it is ready; the mode stays.
    client.send(Message::Text(r#"{"type":"reset","seed":2}"#.into())).await.unwrap();
    client.send(Message::Text(r#"{"type":"mode","mode":"fly"}"#.into())).await.unwrap();
    client.send(Message::Text(r#"{"type":"mode","mode":"learned"}"#.into())).await.unwrap();
    let seen = until(&mut client, "scene").await;
    let mut refused = vec![];
    while let Ok(Some(Ok(Message::Text(text)))) = tokio::time::timeout(Duration::from_millis(500), client.next()).await
    {
        refused.push(serde_json::from_str::<serde_json::Value>(&text).unwrap());
    }
    let errors: Vec<&serde_json::Value> = seen.iter().chain(&refused).filter(|m| m["type"] == "error").collect();
    assert!(errors.iter().any(|e| e["message"].as_str().unwrap().contains("'fly'")), "{errors:?}");
    let kinds: Vec<_> = seen.iter().chain(&refused).map(|m| m["type"].as_str().unwrap_or_default()).collect();
    assert!(errors.iter().any(|e| e["message"].as_str().unwrap().contains("--arbiter")), "{kinds:?} {errors:?}");
    assert_eq!(seen.last().unwrap()["mode"], "constrained");
}

/// Ending an episode does no I/O: the recording comes back to be written
/// elsewhere (the server writes it on a blocking thread, not in the
/// session's tick), even where the folder cannot be made; writing it then
/// fails naming the folder, and the episode is handed out once.
#[test]
fn an_ended_episode_is_handed_out_unwritten_once() {
    let dir = tempfile::tempdir().unwrap();
    let blocker = dir.path().join("a-file");
    std::fs::write(&blocker, "not a folder").unwrap();
    let record = blocker.join("recordings");
    let mut session = planar(Some(record.clone()));
    let now = Instant::now();
    session.set_command([0.05, 0.0, 0.0], now);
    for k in 0..5 {
        session.tick(now + Duration::from_millis(33 * k)).unwrap();
    }
    let recording = session.finish_unwritten().expect("a driven episode with ticks is to be saved");
    assert!(recording.path().starts_with(&record), "{:?}", recording.path());
    assert!(!record.exists());
    assert!(session.finish_unwritten().is_none(), "handed out once");
    let e = recording.write().unwrap_err().to_string();
    assert!(e.contains("a-file"), "{e}");
}
