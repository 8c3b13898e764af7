//! A card's outputs as plain values, and which one drives the projector.
//!
//! Boundaries: no device access; the hardware part fills
//! [`ConnectorInfo`] from the kernel.

use crate::error::DriverError;
use crate::projector::kms::edid::Edid;
use crate::projector::kms::mode::ListedMode;

/// One output of a card.
#[derive(Debug, Clone, PartialEq)]
pub struct ConnectorInfo {
    /// The kernel's name: type name, `-`, type index (`HDMI-A-1`, `DP-2`).
    pub name: String,
    pub connected: bool,
    /// The modes it lists, best first.
    pub modes: Vec<ListedMode>,
    /// Its EDID, when it has a readable one.
    pub edid: Option<Edid>,
}

impl ConnectorInfo {
    /// "HDMI-A-1 (connected, Optoma XGA (OTM 0x0815), 12 modes)".
    pub fn describe(&self) -> String {
        let mut parts = vec![if self.connected {
            "connected"
        } else {
            "disconnected"
        }
        .to_string()];
        if let Some(e) = &self.edid {
            parts.push(e.describe());
        }
        if self.connected {
            parts.push(format!("{} modes", self.modes.len()));
        }
        format!("{} ({})", self.name, parts.join(", "))
    }
}

fn listing(connectors: &[ConnectorInfo]) -> String {
    if connectors.is_empty() {
        return "the card has no outputs".into();
    }
    connectors
        .iter()
        .map(ConnectorInfo::describe)
        .collect::<Vec<_>>()
        .join("; ")
}

/// The index of the connector to drive on `card`: the one named `wanted`
/// (which must be connected), or with none named the only connected one.
pub fn pick_connector(
    connectors: &[ConnectorInfo],
    wanted: Option<&str>,
    card: &str,
) -> Result<usize, DriverError> {
    let fail = |reason: String| DriverError::InvalidSetting {
        device: card.to_string(),
        reason,
    };
    match wanted {
        Some(name) => {
            let i = connectors
                .iter()
                .position(|c| c.name == name)
                .ok_or_else(|| {
                    fail(format!(
                        "no output `{name}`; it has: {}",
                        listing(connectors)
                    ))
                })?;
            if !connectors[i].connected {
                return Err(fail(format!(
                    "output `{name}` is disconnected (is the projector on and its cable \
                     plugged in?); outputs: {}",
                    listing(connectors)
                )));
            }
            Ok(i)
        }
        None => {
            let connected: Vec<usize> = (0..connectors.len())
                .filter(|&i| connectors[i].connected)
                .collect();
            match connected[..] {
                [i] => Ok(i),
                [] => Err(fail(format!(
                    "no output is connected (is the projector on and its cable plugged \
                     in?); outputs: {}",
                    listing(connectors)
                ))),
                _ => Err(fail(format!(
                    "{} outputs are connected; name the projector's, e.g. `{}`; outputs: {}",
                    connected.len(),
                    connectors[connected[0]].name,
                    listing(connectors)
                ))),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn out(name: &str, connected: bool) -> ConnectorInfo {
        ConnectorInfo {
            name: name.into(),
            connected,
            modes: Vec::new(),
            edid: None,
        }
    }

    #[test]
    fn named_connector_is_found_by_its_kernel_name() {
        let cs = [
            out("eDP-1", true),
            out("HDMI-A-1", true),
            out("DP-1", false),
        ];
        assert_eq!(pick_connector(&cs, Some("HDMI-A-1"), "card0").unwrap(), 1);
    }

    #[test]
    fn unknown_name_lists_the_outputs() {
        let cs = [out("HDMI-A-1", true), out("DP-1", false)];
        let err = pick_connector(&cs, Some("HDMI-1"), "/dev/dri/card0")
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("/dev/dri/card0: "), "{err}");
        assert!(err.contains("no output `HDMI-1`"), "{err}");
        assert!(err.contains("HDMI-A-1 (connected, 0 modes)"), "{err}");
        assert!(err.contains("DP-1 (disconnected)"), "{err}");
    }

    #[test]
    fn named_but_disconnected_output_is_refused() {
        let cs = [out("HDMI-A-1", false)];
        let err = pick_connector(&cs, Some("HDMI-A-1"), "card0")
            .unwrap_err()
            .to_string();
        assert!(err.contains("`HDMI-A-1` is disconnected"), "{err}");
    }

    #[test]
    fn without_a_name_the_only_connected_output_is_used() {
        let cs = [out("DP-1", false), out("HDMI-A-2", true)];
        assert_eq!(pick_connector(&cs, None, "card0").unwrap(), 1);
    }

    #[test]
    fn without_a_name_several_connected_outputs_are_listed() {
        let cs = [out("eDP-1", true), out("HDMI-A-1", true)];
        let err = pick_connector(&cs, None, "card0").unwrap_err().to_string();
        assert!(err.contains("2 outputs are connected"), "{err}");
        assert!(err.contains("eDP-1 (connected"), "{err}");
        assert!(err.contains("HDMI-A-1 (connected"), "{err}");
    }

    #[test]
    fn without_a_name_and_nothing_connected_says_so() {
        let err = pick_connector(&[out("DP-1", false)], None, "card0")
            .unwrap_err()
            .to_string();
        assert!(err.contains("no output is connected"), "{err}");
        let err = pick_connector(&[], None, "card0").unwrap_err().to_string();
        assert!(err.contains("the card has no outputs"), "{err}");
    }
}
