//! Forward-pass timings of the parameter networks on the CPU.
//!
//! ```text
//! cargo run --release -p matscan-estimate --example net_bench -- [options]
//!   --backend flex|ndarray   backend (default: flex)
//!   --kinds a,b,...          networks (default: transmission)
//!   --widths 32,64,128       feature widths (default: 32,64,128)
//!   --views 1,3,9            view counts (default: 1,3,9)
//!   --sizes 128,256,512      square image sides (default: 128,256,512)
//!   --five                   instead: the five networks at their shipped
//!                            widths, 9 views, 256x256, total time
//!   --memory SIDE            instead: one network at its shipped width, 9
//!                            views at SIDE x SIDE, peak resident memory
//! ```
//!
//! GFLOP/s counts the convolutions' multiply-adds as two operations each.

use burn::tensor::{Distribution, Tensor};
use matscan_estimate::{CpuBackend, NetConfig, ParamNet};
use matscan_scan::Param;
use std::time::Instant;

fn main() {
    if let Err(message) = run() {
        eprintln!("net_bench: {message}");
        std::process::exit(2);
    }
}

struct Options {
    backend: CpuBackend,
    kinds: Vec<Param>,
    widths: Vec<usize>,
    views: Vec<usize>,
    sizes: Vec<usize>,
    five: bool,
    memory: Option<usize>,
}

fn list<T>(text: &str, parse: impl Fn(&str) -> Option<T>) -> Result<Vec<T>, String> {
    text.split(',')
        .map(|item| parse(item.trim()).ok_or_else(|| format!("cannot read {item:?}")))
        .collect()
}

fn options() -> Result<Options, String> {
    let mut options = Options {
        backend: CpuBackend::Flex,
        kinds: vec![Param::Transmission],
        widths: vec![32, 64, 128],
        views: vec![1, 3, 9],
        sizes: vec![128, 256, 512],
        five: false,
        memory: None,
    };
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let mut value = || args.next().ok_or_else(|| format!("{flag} needs a value"));
        match flag.as_str() {
            "--backend" => {
                options.backend = match value()?.as_str() {
                    "flex" => CpuBackend::Flex,
                    "ndarray" => CpuBackend::NdArray,
                    other => return Err(format!("unknown backend {other:?}")),
                }
            }
            "--kinds" => options.kinds = list(&value()?, |s| s.parse::<Param>().ok())?,
            "--widths" => options.widths = list(&value()?, |s| s.parse().ok())?,
            "--views" => options.views = list(&value()?, |s| s.parse().ok())?,
            "--sizes" => options.sizes = list(&value()?, |s| s.parse().ok())?,
            "--five" => options.five = true,
            "--memory" => {
                options.memory = Some(value()?.parse().map_err(|_| "--memory needs a side")?)
            }
            other => return Err(format!("unknown option {other:?}")),
        }
    }
    Ok(options)
}

/// Seconds for one forward pass (outputs read back, so nothing is pending).
fn time_forward(net: &ParamNet, views: usize, side: usize) -> Result<f64, String> {
    let device = net.device();
    let c = net.config().in_channels();
    let inputs: Vec<Tensor<4>> = (0..views)
        .map(|_| {
            Tensor::random(
                [1, c, side, side],
                Distribution::Uniform(-1.0, 1.0),
                &device,
            )
        })
        .collect();
    let start = Instant::now();
    let out = net.forward(&inputs).map_err(|e| e.to_string())?;
    let checksum: f32 = out
        .fused
        .into_data()
        .try_to_vec::<f32>()
        .map_err(|e| format!("{e:?}"))?
        .iter()
        .take(1)
        .sum();
    let seconds = start.elapsed().as_secs_f64();
    if !checksum.is_finite() {
        return Err("non-finite output".to_string());
    }
    Ok(seconds)
}

fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

fn run() -> Result<(), String> {
    let options = options()?;
    let device = options.backend.device().map_err(|e| e.to_string())?;
    println!(
        "backend {}, {} rayon threads",
        options.backend,
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    if let Some(side) = options.memory {
        let kind = options.kinds[0];
        let config = NetConfig::shipped(kind);
        let net = ParamNet::new(config, &device);
        let seconds = time_forward(&net, 9, side)?;
        let peak = peak_rss_mib().ok_or("no /proc/self/status")?;
        println!(
            "memory: {kind} width {} track {}, 9 views at {side}x{side}: {seconds:.2} s, peak RSS {peak:.0} MiB",
            config.width(),
            config.track()
        );
        return Ok(());
    }
    if options.five {
        let mut total = 0.0;
        let mut flops = 0.0;
        for kind in matscan_estimate::PIPELINE_ORDER {
            let config = NetConfig::shipped(kind);
            let net = ParamNet::new(config, &device);
            let seconds = time_forward(&net, 9, 256)?;
            let gflop = config
                .forward_flops(256, 256, 9)
                .map_err(|e| e.to_string())?
                / 1e9;
            println!(
                "{kind:>12} width {:>3} track {:>2}: {seconds:6.2} s, {gflop:6.1} GFLOP, {:5.1} GFLOP/s",
                config.width(),
                config.track(),
                gflop / seconds
            );
            total += seconds;
            flops += gflop;
        }
        println!(
            "five networks, 9 views, 256x256: {total:.2} s, {flops:.1} GFLOP, {:.1} GFLOP/s",
            flops / total
        );
        return Ok(());
    }
    println!(
        "{:>12} {:>5} {:>5} {:>5} {:>9} {:>9} {:>8}",
        "network", "width", "views", "side", "seconds", "GFLOP", "GFLOP/s"
    );
    for &kind in &options.kinds {
        for &width in &options.widths {
            let config = NetConfig::new(kind, width).map_err(|e| e.to_string())?;
            let net = ParamNet::new(config, &device);
            for &side in &options.sizes {
                for &views in &options.views {
                    let seconds = time_forward(&net, views, side)?;
                    let gflop = config
                        .forward_flops(side, side, views)
                        .map_err(|e| e.to_string())?
                        / 1e9;
                    println!(
                        "{:>12} {width:>5} {views:>5} {side:>5} {seconds:>9.3} {gflop:>9.2} {:>8.1}",
                        kind.name(),
                        gflop / seconds
                    );
                }
            }
        }
    }
    Ok(())
}
