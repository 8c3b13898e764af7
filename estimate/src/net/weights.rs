//! Weight files: one versioned file per network that carries its own
//! architecture, so a file can only be loaded into the network it was made
//! for, and every failure names the file and what was expected.
//!
//! Layout (all integers little-endian):
//!
//! ```text
//! magic        8 bytes  "MATSCNET"
//! version      u32      FORMAT_VERSION
//! length       u64      length of the whole file, checksum included
//! architecture u32      ARCHITECTURE (the block layout of `blocks`/`network`)
//! kind         str      network name, e.g. "roughness"
//! width        u32      feature channels
//! track        u32      channels per inception track
//! inputs       u32 n, then n str: the input channel names, in order
//! outputs      u32 fused, u32 per-view
//! tensors      u32 n, then n times: str name, u8 rank, u32 dims[rank],
//!              f32 values[product of dims]
//! checksum     u64      FNV-1a of every byte before it
//! ```
//!
//! `str` is a u16 byte length and UTF-8 bytes. Tensors appear in the order
//! of the network's convolutions (`input_stem.reduce.weight`, ...).
//!
//! Trained weights (`estimate/weights/<param>.weights`, see
//! `estimate/MODEL_CARD.md`) are embedded into the binary with
//! [`EMBEDDED`]; a network without embedded weights makes
//! [`WeightSource::Embedded`] report that clearly, and callers pass a file.
//!
//! Out of scope: training, and the networks themselves.

use crate::net::network::{NetConfig, ParamNet};
use crate::net::spec::NetworkSpec;
use burn::module::Param as BurnParam;
use burn::tensor::{Device, Tensor, TensorData};
use matscan_scan::Param;
use std::fmt;
use std::path::{Path, PathBuf};

mod codec;

use codec::{fnv1a, put_str, put_u32, to_u32, Reader, CHECKSUM_LEN};

/// First bytes of every weight file.
pub const MAGIC: &[u8; 8] = b"MATSCNET";
/// Version of the file layout this build reads and writes.
pub const FORMAT_VERSION: u32 = 1;
/// Version of the network layout (blocks, their order, linear output stem).
pub const ARCHITECTURE: u32 = 1;

/// Weight files compiled into the binary, by network: the trained weights
/// of `estimate/weights/` (how they were made: `estimate/MODEL_CARD.md`).
pub const EMBEDDED: &[(Param, &[u8])] = &[
    (
        Param::Roughness,
        include_bytes!("../../weights/roughness.weights"),
    ),
    (
        Param::Transmission,
        include_bytes!("../../weights/transmission.weights"),
    ),
    (
        Param::Subsurface,
        include_bytes!("../../weights/subsurface.weights"),
    ),
    (
        Param::Metallic,
        include_bytes!("../../weights/metallic.weights"),
    ),
    (
        Param::Basecolor,
        include_bytes!("../../weights/basecolor.weights"),
    ),
];

/// Where a network's weights come from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum WeightSource {
    /// The file compiled into this binary.
    Embedded,
    /// A weight file on disk.
    File(PathBuf),
}

/// What the caller expects to load.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Expected {
    /// The network.
    pub kind: Param,
    /// A required feature width, or any.
    pub width: Option<usize>,
}

impl From<Param> for Expected {
    fn from(kind: Param) -> Self {
        Expected { kind, width: None }
    }
}

impl From<NetConfig> for Expected {
    fn from(config: NetConfig) -> Self {
        Expected {
            kind: config.kind(),
            width: Some(config.width()),
        }
    }
}

/// A weight file that cannot be used. `origin` is the file's path, or
/// "embedded <kind> weights".
#[derive(Debug, thiserror::Error)]
pub enum WeightsError {
    /// The file does not exist.
    #[error("weight file {origin} does not exist")]
    Missing {
        /// The file.
        origin: String,
    },
    /// Reading or writing failed.
    #[error("weight file {origin}: {source}")]
    Io {
        /// The file.
        origin: String,
        /// The failure.
        #[source]
        source: std::io::Error,
    },
    /// The file ends early.
    #[error("weight file {origin} is truncated: {what} needs {needed} bytes at offset {offset}, the file has {len}")]
    Truncated {
        /// The file.
        origin: String,
        /// The field being read.
        what: String,
        /// Its length.
        needed: usize,
        /// Where it starts.
        offset: usize,
        /// The file's length.
        len: usize,
    },
    /// Not a weight file.
    #[error("{origin} is not a matscan weight file (its first bytes are not \"MATSCNET\")")]
    NotWeights {
        /// The file.
        origin: String,
    },
    /// A file layout this build does not read.
    #[error("weight file {origin} has format version {found}; this build reads version {FORMAT_VERSION}")]
    Version {
        /// The file.
        origin: String,
        /// The file's version.
        found: u32,
    },
    /// The bytes were altered after writing.
    #[error("weight file {origin} is corrupt: checksum {found:#018x}, its contents give {computed:#018x}")]
    Checksum {
        /// The file.
        origin: String,
        /// Stored.
        found: u64,
        /// Computed.
        computed: u64,
    },
    /// The file is for another network, architecture, width or input set.
    #[error("weight file {origin} does not fit: {what} is {found}, expected {expected}")]
    Mismatch {
        /// The file.
        origin: String,
        /// Which property.
        what: &'static str,
        /// What this build or the caller wants.
        expected: String,
        /// What the file holds.
        found: String,
    },
    /// A tensor is absent, misnamed, misshapen or not finite.
    #[error("weight file {origin}: tensor {index} ({name}): {problem}")]
    Tensor {
        /// The file.
        origin: String,
        /// Position in the file.
        index: usize,
        /// Its name in the file, or the expected name.
        name: String,
        /// What is wrong.
        problem: String,
    },
    /// Bytes beyond what the file declares or its tensors need.
    #[error("weight file {origin} has {extra} unexpected bytes at its end")]
    TrailingBytes {
        /// The file.
        origin: String,
        /// How many.
        extra: usize,
    },
    /// No weights compiled in for this network.
    #[error("this build embeds no {kind} weights; pass a weight file")]
    NoEmbedded {
        /// The network.
        kind: Param,
    },
    /// The network's weights could not be read back from the device.
    #[error("cannot read the {kind} network's tensor {name} from the device: {message}")]
    Device {
        /// The network.
        kind: Param,
        /// The tensor.
        name: String,
        /// The backend's message.
        message: String,
    },
}

/// The header of a weight file: everything but the tensors.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WeightsHeader {
    /// Network layout version.
    pub architecture: u32,
    /// Network name as stored.
    pub kind: String,
    /// Feature channels.
    pub width: usize,
    /// Channels per inception track.
    pub track: usize,
    /// Input channel names.
    pub inputs: Vec<String>,
    /// Fused output channels.
    pub fused_outputs: usize,
    /// Per-view output channels.
    pub per_view_outputs: usize,
}

/// The serialized weights of `net`.
pub fn to_bytes(net: &ParamNet) -> Result<Vec<u8>, WeightsError> {
    let config = net.config();
    let mut out = Vec::new();
    out.extend_from_slice(MAGIC);
    put_u32(&mut out, FORMAT_VERSION);
    let length_at = out.len();
    out.extend_from_slice(&0u64.to_le_bytes());
    put_u32(&mut out, ARCHITECTURE);
    put_str(&mut out, config.kind().name());
    put_u32(&mut out, to_u32(config.width()));
    put_u32(&mut out, to_u32(config.track()));
    let inputs = input_names(config.kind());
    put_u32(&mut out, to_u32(inputs.len()));
    for name in &inputs {
        put_str(&mut out, name);
    }
    put_u32(&mut out, to_u32(config.fused_out_channels()));
    put_u32(&mut out, to_u32(config.per_view_out_channels()));
    let convs = net.named_convs();
    put_u32(&mut out, to_u32(2 * convs.len()));
    for (name, conv) in convs {
        let weight = conv.weight.val();
        let bias = conv.bias.val();
        let weight_dims = weight.dims().to_vec();
        let bias_dims = bias.dims().to_vec();
        for (suffix, dims, data) in [
            ("weight", weight_dims, weight.into_data()),
            ("bias", bias_dims, bias.into_data()),
        ] {
            let tensor_name = format!("{name}.{suffix}");
            let values = data.try_to_vec::<f32>().map_err(|e| WeightsError::Device {
                kind: config.kind(),
                name: tensor_name.clone(),
                message: format!("{e:?}"),
            })?;
            put_str(&mut out, &tensor_name);
            out.push(dims.len() as u8);
            for d in dims {
                put_u32(&mut out, to_u32(d));
            }
            for v in values {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    let length = (out.len() + CHECKSUM_LEN) as u64;
    out[length_at..length_at + 8].copy_from_slice(&length.to_le_bytes());
    let checksum = fnv1a(&out);
    out.extend_from_slice(&checksum.to_le_bytes());
    Ok(out)
}

/// Writes `net`'s weights to `path` (through a temporary file and a rename,
/// so a crash never leaves a half-written file under the final name).
pub fn save_file(net: &ParamNet, path: &Path) -> Result<(), WeightsError> {
    let origin = path.display().to_string();
    let bytes = to_bytes(net)?;
    let mut temp = path.as_os_str().to_owned();
    temp.push(".partial");
    let temp = PathBuf::from(temp);
    let io = |source| WeightsError::Io {
        origin: origin.clone(),
        source,
    };
    std::fs::write(&temp, bytes).map_err(io)?;
    std::fs::rename(&temp, path).map_err(io)
}

/// Loads a network from `source`.
pub fn load(
    source: &WeightSource,
    expected: impl Into<Expected>,
    device: &Device,
) -> Result<ParamNet, WeightsError> {
    let expected = expected.into();
    match source {
        WeightSource::Embedded => load_embedded(expected, device),
        WeightSource::File(path) => load_file(path, expected, device),
    }
}

/// Loads a network from the weight file at `path`.
pub fn load_file(
    path: &Path,
    expected: impl Into<Expected>,
    device: &Device,
) -> Result<ParamNet, WeightsError> {
    let origin = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| match source.kind() {
        std::io::ErrorKind::NotFound => WeightsError::Missing {
            origin: origin.clone(),
        },
        _ => WeightsError::Io {
            origin: origin.clone(),
            source,
        },
    })?;
    from_bytes(&bytes, &origin, expected, device)
}

/// Loads the network compiled into this binary.
pub fn load_embedded(
    expected: impl Into<Expected>,
    device: &Device,
) -> Result<ParamNet, WeightsError> {
    let expected = expected.into();
    let Some((_, bytes)) = EMBEDDED.iter().find(|(kind, _)| *kind == expected.kind) else {
        return Err(WeightsError::NoEmbedded {
            kind: expected.kind,
        });
    };
    let origin = format!("embedded {} weights", expected.kind);
    from_bytes(bytes, &origin, expected, device)
}

/// Reads only the header of a weight file's bytes (after checking its
/// integrity).
pub fn read_header(bytes: &[u8], origin: &str) -> Result<WeightsHeader, WeightsError> {
    let mut reader = Reader::new(bytes, origin);
    reader.verify()?;
    reader.header()
}

/// Loads a network from a weight file's bytes; `origin` names them in errors.
pub fn from_bytes(
    bytes: &[u8],
    origin: &str,
    expected: impl Into<Expected>,
    device: &Device,
) -> Result<ParamNet, WeightsError> {
    let expected = expected.into();
    let mut reader = Reader::new(bytes, origin);
    reader.verify()?;
    let header = reader.header()?;
    let config = check_header(&header, expected, origin)?;
    let mut net = ParamNet::new(config, device);
    let names: Vec<String> = net
        .named_convs()
        .into_iter()
        .map(|(name, _)| name)
        .collect();
    let shapes: Vec<([usize; 4], usize)> = net
        .named_convs()
        .iter()
        .map(|(_, conv)| {
            let shape = conv.weight_shape();
            (shape, shape[0])
        })
        .collect();
    let count = reader.u32("tensor count")? as usize;
    if count != 2 * names.len() {
        return Err(mismatch(origin, "tensor count", 2 * names.len(), count));
    }
    for ((conv, name), (weight_shape, bias_len)) in
        net.convs_mut().into_iter().zip(&names).zip(shapes)
    {
        let weight = reader.tensor(&format!("{name}.weight"), &weight_shape)?;
        let bias = reader.tensor(&format!("{name}.bias"), &[bias_len])?;
        let weight = Tensor::<4>::from_data(TensorData::new(weight, weight_shape), device);
        let bias = Tensor::<1>::from_data(TensorData::new(bias, [bias_len]), device);
        conv.weight = BurnParam::from_tensor(weight);
        conv.bias = BurnParam::from_tensor(bias);
    }
    let extra = reader.remaining_before_checksum();
    if extra != 0 {
        return Err(WeightsError::TrailingBytes {
            origin: origin.to_string(),
            extra,
        });
    }
    Ok(net)
}

fn check_header(
    header: &WeightsHeader,
    expected: Expected,
    origin: &str,
) -> Result<NetConfig, WeightsError> {
    if header.architecture != ARCHITECTURE {
        return Err(mismatch(
            origin,
            "architecture",
            ARCHITECTURE,
            header.architecture,
        ));
    }
    let kind = expected.kind;
    if header.kind != kind.name() {
        return Err(mismatch(origin, "network", kind, &header.kind));
    }
    let inputs = input_names(kind);
    if header.inputs != inputs {
        return Err(mismatch(
            origin,
            "input channel list",
            inputs.join(", "),
            header.inputs.join(", "),
        ));
    }
    let outputs = (kind.fused_outputs().len(), kind.per_view_outputs().len());
    let found = (header.fused_outputs, header.per_view_outputs);
    if found != outputs {
        return Err(mismatch(
            origin,
            "(fused, per-view) output channels",
            format!("{outputs:?}"),
            format!("{found:?}"),
        ));
    }
    if let Some(width) = expected.width {
        if header.width != width {
            return Err(mismatch(origin, "feature width", width, header.width));
        }
    }
    NetConfig::with_track(kind, header.width, header.track).map_err(|e| WeightsError::Mismatch {
        origin: origin.to_string(),
        what: "network shape",
        expected: "a buildable network".to_string(),
        found: e.to_string(),
    })
}

fn mismatch(
    origin: &str,
    what: &'static str,
    expected: impl fmt::Display,
    found: impl fmt::Display,
) -> WeightsError {
    WeightsError::Mismatch {
        origin: origin.to_string(),
        what,
        expected: expected.to_string(),
        found: found.to_string(),
    }
}

fn input_names(kind: Param) -> Vec<String> {
    kind.inputs().iter().map(|c| format!("{c:?}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::backend::cpu_device;

    fn small(kind: Param, width: usize) -> ParamNet {
        let config = NetConfig::with_track(kind, width, 2).expect("valid");
        ParamNet::new(config, &cpu_device())
    }

    fn output_bits(net: &ParamNet) -> Vec<u32> {
        let device = cpu_device();
        let c = net.config().in_channels();
        // Fixed inputs, not the backend's global generator: tests running
        // in parallel reseed and draw from that one.
        let views: Vec<Tensor<4>> = (0..2usize)
            .map(|v| {
                let data: Vec<f32> = (0..c * 20 * 18)
                    .map(|i| ((i * 7919 + v * 104_729) % 2001) as f32 / 1000.0 - 1.0)
                    .collect();
                Tensor::from_data(TensorData::new(data, [1, c, 20, 18]), &device)
            })
            .collect();
        let out = net.forward(&views).expect("valid views");
        std::iter::once(out.fused)
            .chain(out.per_view)
            .flat_map(|t| t.into_data().try_to_vec::<f32>().expect("f32"))
            .map(f32::to_bits)
            .collect()
    }

    /// Rewrites the checksum after a deliberate edit, so the edit itself is
    /// what the loader sees.
    fn reseal(mut bytes: Vec<u8>) -> Vec<u8> {
        let body = bytes.len() - CHECKSUM_LEN;
        let sum = fnv1a(&bytes[..body]);
        bytes[body..].copy_from_slice(&sum.to_le_bytes());
        bytes
    }

    fn error_of(result: Result<ParamNet, WeightsError>) -> WeightsError {
        match result {
            Ok(_) => panic!("expected an error"),
            Err(e) => e,
        }
    }

    #[test]
    fn saved_weights_load_back_to_the_same_outputs() {
        let dir = tempfile::tempdir().expect("temp dir");
        for kind in [Param::Roughness, Param::Basecolor] {
            let net = small(kind, 6);
            let path = dir.path().join(format!("{kind}.mscnet"));
            save_file(&net, &path).expect("saved");
            let loaded = load_file(&path, kind, &cpu_device()).expect("loaded");
            assert_eq!(loaded.config(), net.config());
            assert_eq!(output_bits(&loaded), output_bits(&net), "{kind}");
            let source = WeightSource::File(path);
            let again = load(&source, net.config(), &cpu_device()).expect("loaded");
            assert_eq!(again.config(), net.config());
        }
    }

    #[test]
    fn the_header_describes_the_network() {
        let net = small(Param::Metallic, 6);
        let bytes = to_bytes(&net).expect("serialized");
        let header = read_header(&bytes, "memory").expect("valid");
        assert_eq!(header.kind, "metallic");
        assert_eq!((header.width, header.track), (6, 2));
        assert_eq!(header.inputs.len(), 10);
        assert_eq!(header.inputs[0], "MappedMask");
        assert_eq!((header.fused_outputs, header.per_view_outputs), (2, 0));
        assert_eq!(header.architecture, ARCHITECTURE);
    }

    #[test]
    fn a_missing_file_is_named() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("absent.mscnet");
        let err = error_of(load_file(&path, Param::Metallic, &cpu_device()));
        assert!(matches!(err, WeightsError::Missing { .. }), "{err:?}");
        assert!(err.to_string().contains("absent.mscnet"), "{err}");
    }

    #[test]
    fn truncated_files_are_reported_as_truncated() {
        let bytes = to_bytes(&small(Param::Transmission, 4)).expect("serialized");
        for keep in [3, 14, 30, bytes.len() / 2, bytes.len() - 1] {
            let err = error_of(from_bytes(
                &bytes[..keep],
                "cut.mscnet",
                Param::Transmission,
                &cpu_device(),
            ));
            assert!(
                matches!(err, WeightsError::Truncated { .. }),
                "{keep} bytes: {err:?}"
            );
            assert!(err.to_string().contains("cut.mscnet is truncated"), "{err}");
        }
    }

    #[test]
    fn a_flipped_byte_fails_the_checksum() {
        let mut bytes = to_bytes(&small(Param::Transmission, 4)).expect("serialized");
        let middle = bytes.len() / 2;
        bytes[middle] ^= 0x10;
        let err = error_of(from_bytes(
            &bytes,
            "flip.mscnet",
            Param::Transmission,
            &cpu_device(),
        ));
        assert!(matches!(err, WeightsError::Checksum { .. }), "{err:?}");
        assert!(err.to_string().contains("flip.mscnet is corrupt"), "{err}");
    }

    #[test]
    fn other_files_and_versions_are_refused() {
        let err = error_of(from_bytes(
            b"P3\n# an image, not weights\n",
            "photo.ppm",
            Param::Subsurface,
            &cpu_device(),
        ));
        assert!(matches!(err, WeightsError::NotWeights { .. }), "{err:?}");
        let mut bytes = to_bytes(&small(Param::Subsurface, 4)).expect("serialized");
        bytes[8..12].copy_from_slice(&2u32.to_le_bytes());
        let err = error_of(from_bytes(
            &reseal(bytes),
            "future.mscnet",
            Param::Subsurface,
            &cpu_device(),
        ));
        assert!(
            matches!(err, WeightsError::Version { found: 2, .. }),
            "{err:?}"
        );
    }

    #[test]
    fn a_file_for_another_network_or_width_is_a_mismatch() {
        let bytes = to_bytes(&small(Param::Roughness, 6)).expect("serialized");
        let err = error_of(from_bytes(
            &bytes,
            "r.mscnet",
            Param::Basecolor,
            &cpu_device(),
        ));
        match &err {
            WeightsError::Mismatch {
                what,
                expected,
                found,
                ..
            } => {
                assert_eq!(
                    (*what, expected.as_str(), found.as_str()),
                    ("network", "basecolor", "roughness")
                );
            }
            other => panic!("expected a mismatch, got {other:?}"),
        }
        let want_eight = Expected {
            kind: Param::Roughness,
            width: Some(8),
        };
        let err = error_of(from_bytes(&bytes, "r.mscnet", want_eight, &cpu_device()));
        assert!(
            err.to_string().contains("feature width is 6, expected 8"),
            "{err}"
        );
    }

    #[test]
    fn a_changed_input_list_is_a_mismatch() {
        let bytes = to_bytes(&small(Param::Transmission, 4)).expect("serialized");
        // Rename the first input channel in place (same length, resealed).
        let at = bytes
            .windows(10)
            .position(|w| w == b"MappedMask")
            .expect("input names are stored");
        let mut edited = bytes.clone();
        edited[at..at + 10].copy_from_slice(b"MappedMusk");
        let err = error_of(from_bytes(
            &reseal(edited),
            "t.mscnet",
            Param::Transmission,
            &cpu_device(),
        ));
        assert!(
            matches!(
                err,
                WeightsError::Mismatch {
                    what: "input channel list",
                    ..
                }
            ),
            "{err:?}"
        );
    }

    #[test]
    fn misshapen_or_non_finite_tensors_are_named() {
        let bytes = to_bytes(&small(Param::Transmission, 4)).expect("serialized");
        // Claim width 6 in the header: the first weight no longer fits it.
        let width_at = bytes
            .windows(12)
            .position(|w| w == b"transmission")
            .expect("kind is stored")
            + 12;
        let mut edited = bytes.clone();
        edited[width_at..width_at + 4].copy_from_slice(&6u32.to_le_bytes());
        let err = error_of(from_bytes(
            &reseal(edited),
            "w.mscnet",
            Param::Transmission,
            &cpu_device(),
        ));
        // The reductions depend on the track only; the expansion meets the width.
        assert!(
            err.to_string().contains("input_stem.expand.weight"),
            "{err}"
        );
        assert!(
            err.to_string()
                .contains("shape [4, 6, 1, 1], expected [6, 6, 1, 1]"),
            "{err}"
        );
        // A NaN in the last value of the last tensor.
        let mut edited = bytes;
        let last = edited.len() - CHECKSUM_LEN - 4;
        edited[last..last + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        let err = error_of(from_bytes(
            &reseal(edited),
            "n.mscnet",
            Param::Transmission,
            &cpu_device(),
        ));
        assert!(matches!(err, WeightsError::Tensor { .. }), "{err:?}");
        assert!(err.to_string().contains("output_stem.expand.bias"), "{err}");
    }

    #[test]
    fn embedded_weights_load_or_the_error_says_to_pass_a_file() {
        for kind in crate::net::spec::PIPELINE_ORDER {
            let result = load(&WeightSource::Embedded, kind, &cpu_device());
            if EMBEDDED.iter().any(|(k, _)| *k == kind) {
                assert!(result.is_ok(), "{kind}");
            } else {
                let err = error_of(result);
                assert!(
                    err.to_string()
                        .contains(&format!("embeds no {kind} weights")),
                    "{err}"
                );
            }
        }
    }
}
