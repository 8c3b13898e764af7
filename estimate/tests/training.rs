//! Training readiness: gradients reach every block through the pyramid and
//! the fusion, an optimizer step moves the weights, and the blocks reused at
//! every level and view stay one set of parameters. (The test build enables
//! burn's autodiff and optimizers; the library's `train` feature does the
//! same for a trainer.)

use burn::module::{Module, ModuleVisitor, Param, ParamId};
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::{Distribution, Tensor};
use matscan_estimate::{cpu_device, NetConfig, ParamNet};
use std::collections::HashMap;

/// Every parameter's id and values, and the ranks of those ids.
#[derive(Default)]
struct Snapshot(Vec<(ParamId, Vec<f32>)>, HashMap<ParamId, usize>);

impl ModuleVisitor for Snapshot {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let values = param.val().into_data().try_to_vec::<f32>().expect("f32");
        self.0.push((param.id, values));
        self.1.insert(param.id, D);
    }
}

fn snapshot(net: &ParamNet) -> Snapshot {
    let mut snapshot = Snapshot::default();
    net.visit(&mut snapshot);
    snapshot
}

fn loss(net: &ParamNet, views: &[Tensor<4>]) -> Tensor<1> {
    let out = net.forward(views).expect("valid views");
    let mut loss = out.fused.powi_scalar(2).mean();
    for illumination in out.per_view {
        loss = loss + (illumination - 0.5).powi_scalar(2).mean();
    }
    loss
}

#[test]
fn one_adam_step_moves_every_shared_block_and_lowers_the_loss() {
    let device = cpu_device().autodiff();
    device.seed(5);
    let config = NetConfig::new(matscan_scan::Param::Roughness, 8).expect("valid");
    let mut net = ParamNet::new(config, &device);
    let c = config.in_channels();
    // 40x24: two pyramid levels, so core and core' run at one level and the
    // input stem at the other; three views exercise the fusion tree.
    let views: Vec<Tensor<4>> = (0..3)
        .map(|_| Tensor::random([1, c, 40, 24], Distribution::Uniform(-1.0, 1.0), &device))
        .collect();

    let before = snapshot(&net);
    let ids: Vec<ParamId> = before.0.iter().map(|(id, _)| *id).collect();
    let unique: std::collections::HashSet<_> = ids.iter().collect();
    assert_eq!(unique.len(), ids.len(), "no two fields share a parameter");
    // 5 blocks (input stem, core, core', two output tracks) x 8 convolutions x (weight, bias).
    assert_eq!(ids.len(), 5 * 8 * 2);

    let first_loss = loss(&net, &views);
    let first_value = first_loss.clone().into_scalar::<f32>();
    let grads = GradientsParams::from_grads(first_loss.backward(), &net);
    for id in &ids {
        // Gradients are stored by rank: weights are 4-D, biases 1-D.
        let gradient = match before.1[id] {
            4 => grads
                .get::<4>(*id)
                .map(|g| g.abs().sum().into_scalar::<f32>()),
            _ => grads
                .get::<1>(*id)
                .map(|g| g.abs().sum().into_scalar::<f32>()),
        };
        let size = gradient.unwrap_or_else(|| panic!("parameter {id} got no gradient"));
        assert!(
            size > 0.0 && size.is_finite(),
            "parameter {id}: gradient size {size}"
        );
    }
    let mut optimizer = AdamConfig::new().init();
    net = optimizer.step(1.0e-3, net, grads);

    let after: HashMap<ParamId, Vec<f32>> = snapshot(&net).0.into_iter().collect();
    assert_eq!(
        after.len(),
        ids.len(),
        "the step kept one parameter per field"
    );
    for (id, old) in &before.0 {
        let new = after.get(id).expect("same parameter ids after the step");
        assert_ne!(new, old, "parameter {id} did not move");
    }
    let second_value = loss(&net, &views).into_scalar::<f32>();
    assert!(
        second_value < first_value,
        "loss {first_value} -> {second_value}"
    );
}
