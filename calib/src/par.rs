//! Row-parallel construction of rasters (rayon over rows): every per-pixel
//! map of this crate is built this way so the work spreads over all cores.

use matscan_scan::Raster;
use rayon::prelude::*;

/// A raster whose pixel (x, y) is `f(x, y)`, computed one row per task.
pub(crate) fn par_raster<T, F>(width: u32, height: u32, f: F) -> Raster<T>
where
    T: Send + Clone + Default,
    F: Fn(u32, u32) -> T + Sync,
{
    let mut data = vec![T::default(); width as usize * height as usize];
    if width > 0 {
        data.par_chunks_mut(width as usize)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, px) in row.iter_mut().enumerate() {
                    *px = f(x as u32, y as u32);
                }
            });
    }
    Raster {
        width,
        height,
        data,
    }
}
