//! The protocol end to end: the host against the simulated board over a
//! pseudo-terminal pair, with injected faults.

use super::*;
use crate::{DriverError, Level, LightController, LightId, LightState};
use std::time::Duration;

fn quick() -> HostConfig {
    HostConfig {
        reply_timeout: Duration::from_millis(150),
        attempts: 3,
        ready_timeout: Duration::from_secs(2),
        max_resets: 2,
        keepalive: None,
    }
}

fn rig(
    faults: BoardFaults,
    config: HostConfig,
) -> (Result<SerialLights, DriverError>, RunningBoard) {
    let (master, slave) = pty_pair().expect("openpty");
    let board = RunningBoard::spawn(Box::new(slave), Board::new(BoardConfig::default(), faults));
    (SerialLights::connect(Box::new(master), config), board)
}

// Requests the board sees in `connect`: HELLO (1), ALLOFF (2).
const AFTER_CONNECT: u64 = 2;

#[test]
fn happy_path_switches_lights_and_reports_the_board() {
    let (lights, board) = rig(BoardFaults::default(), quick());
    let mut lights = lights.unwrap();
    assert_eq!(lights.board_info().protocol, 1);
    assert_eq!(lights.board_info().firmware, board::SIM_FIRMWARE);
    lights.on(LightId::Flash0, Level::FULL).unwrap();
    lights
        .on(LightId::Backlight, Level::new(0.5).unwrap())
        .unwrap();
    assert_eq!(board.board().output(LightId::Flash0), 255);
    assert_eq!(board.board().output(LightId::Backlight), 128);
    lights.off(LightId::Flash0).unwrap();
    assert_eq!(board.board().output(LightId::Flash0), 0);
    assert_eq!(
        lights.state(LightId::Backlight),
        LightState::On(Level::new(0.5).unwrap())
    );
    lights.all_off().unwrap();
    assert_eq!(board.board().output(LightId::Backlight), 0);
    lights.ping().unwrap();
}

#[test]
fn lost_reply_is_retried_under_the_same_seq_and_executed_once() {
    let faults = BoardFaults {
        drop_reply: vec![AFTER_CONNECT + 1],
        ..BoardFaults::default()
    };
    let (lights, board) = rig(faults, quick());
    let mut lights = lights.unwrap();
    let executed = board.board().executed();
    lights.on(LightId::Flash1, Level::FULL).unwrap();
    assert_eq!(board.board().output(LightId::Flash1), 255);
    assert_eq!(
        board.board().executed(),
        executed + 1,
        "the retry must be answered from memory"
    );
}

#[test]
fn corrupt_reply_crc_is_ignored_and_retried() {
    let faults = BoardFaults {
        corrupt_reply: vec![AFTER_CONNECT + 1, AFTER_CONNECT + 2],
        ..BoardFaults::default()
    };
    let (lights, board) = rig(faults, quick());
    let mut lights = lights.unwrap();
    lights
        .on(LightId::Flash0, Level::new(0.25).unwrap())
        .unwrap();
    assert_eq!(board.board().output(LightId::Flash0), 64);
    assert_eq!(
        lights.state(LightId::Flash0),
        LightState::On(Level::new(0.25).unwrap())
    );
}

#[test]
fn board_reset_mid_sequence_is_resynced_and_state_reapplied() {
    // The board resets on the request after the backlight went on.
    let faults = BoardFaults {
        reset_on: vec![AFTER_CONNECT + 2],
        ..BoardFaults::default()
    };
    let (lights, board) = rig(faults, quick());
    let mut lights = lights.unwrap();
    lights.on(LightId::Backlight, Level::FULL).unwrap();
    lights.on(LightId::Flash0, Level::FULL).unwrap();
    let b = board.board();
    assert_eq!(b.resets(), 2, "power-on plus the injected reset");
    assert_eq!(
        b.output(LightId::Backlight),
        255,
        "re-applied after the reset"
    );
    assert_eq!(b.output(LightId::Flash0), 255);
    drop(b);
    assert_eq!(lights.resyncs(), 1);
}

#[test]
fn a_board_that_keeps_resetting_gives_a_clear_error() {
    let faults = BoardFaults {
        reset_on: (AFTER_CONNECT + 1..AFTER_CONNECT + 20).collect(),
        ..BoardFaults::default()
    };
    let (lights, _board) = rig(faults, quick());
    let mut lights = lights.unwrap();
    let err = lights.on(LightId::Flash0, Level::FULL).unwrap_err();
    assert!(
        matches!(err, DriverError::KeepsResetting { resets: 3, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("pty-master"), "{err}");
}

#[test]
fn persistent_silence_is_a_timeout_naming_the_port_and_command() {
    let faults = BoardFaults {
        silent_after: Some(AFTER_CONNECT),
        ..BoardFaults::default()
    };
    let (lights, _board) = rig(faults, quick());
    let mut lights = lights.unwrap();
    let err = lights.on(LightId::Flash1, Level::FULL).unwrap_err();
    match &err {
        DriverError::Timeout {
            port,
            command,
            attempts,
            ..
        } => {
            assert_eq!(port, "pty-master");
            assert_eq!(command, "ON F1 255");
            assert_eq!(*attempts, 3);
        }
        other => panic!("expected a timeout, got {other}"),
    }
    assert_eq!(
        lights.state(LightId::Flash1),
        LightState::Off,
        "not acknowledged, not recorded"
    );
}

#[test]
fn keepalive_holds_the_lights_past_the_board_heartbeat() {
    let (master, slave) = pty_pair().unwrap();
    let config = BoardConfig {
        heartbeat: Duration::from_millis(400),
        ..BoardConfig::default()
    };
    let board = RunningBoard::spawn(Box::new(slave), Board::new(config, BoardFaults::default()));
    let host = HostConfig {
        keepalive: Some(Duration::from_millis(500)),
        ..quick()
    };
    let mut lights = SerialLights::connect(Box::new(master), host).unwrap();
    lights.on(LightId::Flash0, Level::FULL).unwrap();
    // Several heartbeat periods with no request from the test itself: only
    // the keepalive's pings (every heartbeat / 3) keep the flash on.
    std::thread::sleep(Duration::from_millis(1200));
    assert_eq!(board.board().output(LightId::Flash0), 255);
    assert_eq!(board.board().heartbeat_expiries(), 0);
}

#[test]
fn without_a_host_the_heartbeat_switches_lights_off() {
    let (master, slave) = pty_pair().unwrap();
    let config = BoardConfig {
        heartbeat: Duration::from_millis(100),
        ..BoardConfig::default()
    };
    let board = RunningBoard::spawn(Box::new(slave), Board::new(config, BoardFaults::default()));
    let mut lights = SerialLights::connect(Box::new(master), quick()).unwrap();
    lights.on(LightId::Backlight, Level::FULL).unwrap();
    assert_eq!(board.board().output(LightId::Backlight), 255);
    let since = std::time::Instant::now();
    while board.board().output(LightId::Backlight) != 0 && since.elapsed() < Duration::from_secs(5)
    {
        std::thread::sleep(Duration::from_millis(10));
    }
    assert_eq!(board.board().output(LightId::Backlight), 0);
    assert!(
        since.elapsed() >= Duration::from_millis(90),
        "went off before the heartbeat expired"
    );
    assert_eq!(board.board().heartbeat_expiries(), 1);
}

#[test]
fn wrong_protocol_version_is_refused_with_both_versions() {
    let (master, slave) = pty_pair().unwrap();
    let config = BoardConfig {
        protocol: 7,
        ..BoardConfig::default()
    };
    let _board = RunningBoard::spawn(Box::new(slave), Board::new(config, BoardFaults::default()));
    let err = match SerialLights::connect(Box::new(master), quick()) {
        Err(e) => e,
        Ok(_) => panic!("accepted protocol 7"),
    };
    assert!(
        matches!(err, DriverError::ProtocolMismatch { expected: 1, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("protocol 7"), "{err}");
}

#[test]
fn a_silent_port_on_open_is_not_ready() {
    let (master, _slave) = pty_pair().unwrap();
    let config = HostConfig {
        ready_timeout: Duration::from_millis(100),
        reply_timeout: Duration::from_millis(50),
        attempts: 2,
        ..quick()
    };
    let err = match SerialLights::connect(Box::new(master), config) {
        Err(e) => e,
        Ok(_) => panic!("connected to nothing"),
    };
    assert!(matches!(err, DriverError::NotReady { .. }), "{err}");
}
