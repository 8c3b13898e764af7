//! The trainer end to end on rendered scenes (needs the simulator, so it
//! lives beside the other cross-crate tests).

/// The trainer end to end on one tiny rendered scene: the loss on that
/// scene falls, and a second run resumes from the checkpoint.
mod trainer {
    use matscan_estimate::net::weights;
    use matscan_estimate::pipeline::truth_fed::load_scene;
    use matscan_estimate::train::{evaluate, train, Event, TrainConfig};
    use matscan_estimate::{cpu_device, NetConfig, ParamNet};
    use matscan_scan::Param;
    use matscan_sim::render::{write_scan_bundle, SimOptions};
    use matscan_sim::scene::{generate, GeometryKind, GeometrySource, SceneKind, SceneOptions};

    #[test]
    fn a_tiny_network_learns_a_tiny_scene_and_resumes() {
        let dir = tempfile::tempdir().expect("temp dir");
        let data = dir.path().join("data");
        let scene = generate(&SceneOptions {
            seed: 7,
            kind: SceneKind::TwoMat,
            geometry: GeometrySource::Kind(GeometryKind::Sphere),
            width: 24,
            height: 24,
            positions: 2,
            map_size: 16,
        });
        let options = SimOptions {
            samples: 2,
            seed: 3,
            threads: Some(2),
            ..SimOptions::default()
        };
        write_scan_bundle(&scene, &options, &data.join("scene-1")).expect("render");

        let kind = Param::Basecolor;
        let device = cpu_device().autodiff();
        let out = dir.path().join("out");
        let mut config = TrainConfig::new(kind, data.clone(), out.clone());
        config.width = Some(8);
        config.steps = 60;
        config.crop = 24;
        config.max_views = 2;
        config.log_every = 20;
        config.checkpoint_every = 20;
        config.seed = 11;
        let scene = load_scene(&data.join("scene-1"), kind)
            .expect("scene loads")
            .expect("basecolor uses every view");

        // The network train() starts from: same seed, same configuration.
        device.seed(config.seed);
        let initial = ParamNet::new(NetConfig::new(kind, 8).expect("width"), &device);
        let before = evaluate(&initial, &scene, 2, &device).expect("evaluates");

        let summary = train(&config, &device, &mut |_| {}).expect("trains");
        assert_eq!(summary.steps, 60);
        let trained = weights::load_file(&summary.weights, kind, &device).expect("weights load");
        let after = evaluate(&trained, &scene, 2, &device).expect("evaluates");
        eprintln!("loss on the scene: {before} -> {after}");
        assert!(
            after < 0.7 * before,
            "the loss did not fall enough: {before} -> {after}"
        );
        let csv = std::fs::read_to_string(out.join("loss.csv")).expect("loss.csv");
        assert_eq!(csv.lines().count(), 1 + 3, "{csv}");
        // The library writes the numbers only; `matscan train` draws them.
        assert!(!out.join("loss.png").exists());

        // More steps resume at the checkpoint, not from scratch.
        config.steps = 80;
        let mut resumed_at = None;
        train(&config, &device, &mut |e| {
            if let Event::Start { step, .. } = e {
                resumed_at = Some(step);
            }
        })
        .expect("resumes");
        assert_eq!(resumed_at, Some(60));
        let csv = std::fs::read_to_string(out.join("loss.csv")).expect("loss.csv");
        assert_eq!(csv.lines().count(), 1 + 4, "{csv}");
    }
}
