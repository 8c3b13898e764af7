//! `matscan bench`: error against run time over the knobs that trade one
//! for the other (see `matscan_evaluate::bench`).

use anyhow::Result;
use clap::Args;
use matscan_evaluate::bench::{self, BenchOptions, Knob};
use matscan_sim::dataset::Recipe;
use std::path::PathBuf;

/// The flags of `matscan bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// The evaluation set's folder: rendered here where missing, reused
    /// where present.
    #[arg(long, value_name = "DIR")]
    pub data: PathBuf,
    /// Also write bench.csv and bench.png here.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// A quick run: 1 scene, only the base size, views 1 and all, the
    /// shipped width only (explicit flags still win).
    #[arg(long)]
    pub quick: bool,
    /// Scenes per size [default: 3; quick: 1].
    #[arg(long)]
    pub scenes: Option<usize>,
    /// Image sizes of the resolution knob, comma-separated [default:
    /// 128,256,512,768; quick: the base size].
    #[arg(long, value_delimiter = ',')]
    pub sizes: Option<Vec<u32>>,
    /// Image size of every other knob's rows.
    #[arg(long, default_value_t = bench::DEFAULT_BASE_SIZE)]
    pub base_size: u32,
    /// View counts of the views knob; 0 = every view [default: 1,3,0;
    /// quick: 1,0].
    #[arg(long, value_delimiter = ',')]
    pub views: Option<Vec<usize>>,
    /// Multiples of the shipped network widths [default: 0.5,1,2; quick:
    /// 1].
    #[arg(long, value_delimiter = ',')]
    pub widths: Option<Vec<f64>>,
    /// Refinement iterations of the refine knob, comma-separated (0 =
    /// networks only) [default: 0,2,5,10; quick: 0,3].
    #[arg(long, value_delimiter = ',')]
    pub refine: Option<Vec<u32>>,
    /// Knobs to leave out, comma-separated: method, views, resolution,
    /// width, backend, refine.
    #[arg(long, value_delimiter = ',')]
    pub skip: Vec<Knob>,
    /// The recipe of the evaluation set (data/recipes/*.toml); its first
    /// --scenes scenes, the sets in turn, at every size the knobs need
    /// [default: data/recipes/bench.toml, built in].
    #[arg(long, value_name = "FILE")]
    pub recipe: Option<PathBuf>,
    /// Folder with `<param>.weights` per network (default: the weights
    /// built into this binary).
    #[arg(long, value_name = "DIR")]
    pub weights: Option<PathBuf>,
}

/// Runs `matscan bench`: progress on stderr, the report on stdout.
pub fn run(a: &BenchArgs) -> Result<()> {
    let options = BenchOptions {
        data: a.data.clone(),
        out: a.out.clone(),
        quick: a.quick,
        scenes: a.scenes,
        sizes: a.sizes.clone(),
        base_size: a.base_size,
        views: a.views.clone(),
        widths: a.widths.clone(),
        refine: a.refine.clone(),
        skip: a.skip.clone(),
        recipe: match &a.recipe {
            Some(path) => Recipe::read(path)?,
            None => bench::default_recipe(),
        },
        weights: a.weights.clone(),
    };
    let report = bench::run(&options, &mut |line| eprintln!("{line}"))?;
    print!("{report}");
    Ok(())
}
