//! A plain row-major image of any pixel type; row 0 is the top row.

/// Row-major pixels, `data[y * width + x]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Raster<T> {
    pub width: u32,
    pub height: u32,
    pub data: Vec<T>,
}

/// Linear RGB radiance or colour.
pub type RgbRaster = Raster<[f32; 3]>;
/// One channel (roughness, depth, a cosine, ...).
pub type ScalarRaster = Raster<f32>;
/// Object / validity masks.
pub type MaskRaster = Raster<bool>;

impl<T: Clone> Raster<T> {
    pub fn filled(width: u32, height: u32, value: T) -> Self {
        Self {
            width,
            height,
            data: vec![value; width as usize * height as usize],
        }
    }
}

impl Raster<[f32; 3]> {
    /// Adds `weight` times `other`, pixel by pixel (over the pixels both
    /// have).
    pub fn add_scaled(&mut self, other: &RgbRaster, weight: f32) {
        for (o, v) in self.data.iter_mut().zip(&other.data) {
            for c in 0..3 {
                o[c] += weight * v[c];
            }
        }
    }

    /// The mean of this image and `more` further ones, the `k`-th made by
    /// `next(k)` for `k` in `1..=more`; the first error stops it.
    pub fn mean_with<E>(
        mut self,
        more: usize,
        mut next: impl FnMut(usize) -> Result<RgbRaster, E>,
    ) -> Result<RgbRaster, E> {
        for k in 1..=more {
            self.add_scaled(&next(k)?, 1.0);
        }
        let scale = 1.0 / (more + 1) as f32;
        for v in self.data.iter_mut().flatten() {
            *v *= scale;
        }
        Ok(self)
    }
}

impl<T> Raster<T> {
    /// Wraps `data`; `None` when its length is not `width * height`.
    pub fn from_vec(width: u32, height: u32, data: Vec<T>) -> Option<Self> {
        (data.len() == width as usize * height as usize).then_some(Self {
            width,
            height,
            data,
        })
    }

    pub fn from_fn(width: u32, height: u32, mut f: impl FnMut(u32, u32) -> T) -> Self {
        let mut data = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                data.push(f(x, y));
            }
        }
        Self {
            width,
            height,
            data,
        }
    }

    #[inline]
    pub fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    #[inline]
    pub fn get(&self, x: u32, y: u32) -> &T {
        &self.data[self.index(x, y)]
    }

    #[inline]
    pub fn get_mut(&mut self, x: u32, y: u32) -> &mut T {
        let i = self.index(x, y);
        &mut self.data[i]
    }

    pub fn map<U>(&self, f: impl FnMut(&T) -> U) -> Raster<U> {
        Raster {
            width: self.width,
            height: self.height,
            data: self.data.iter().map(f).collect(),
        }
    }

    pub fn same_size<U>(&self, other: &Raster<U>) -> bool {
        self.width == other.width && self.height == other.height
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mean_with_further_frames_averages_them_and_stops_at_an_error() {
        let first = RgbRaster::filled(2, 1, [1.0, 2.0, 3.0]);
        let mean = first
            .clone()
            .mean_with(3, |k| Ok::<_, ()>(RgbRaster::filled(2, 1, [k as f32; 3])))
            .unwrap();
        // (1 + 1 + 2 + 3) / 4 and (2 + 6) / 4, (3 + 6) / 4.
        assert_eq!(mean.data, vec![[1.75, 2.0, 2.25]; 2]);
        let stopped = first.mean_with(2, |k| {
            if k == 2 {
                Err(k)
            } else {
                Ok(RgbRaster::filled(2, 1, [0.0; 3]))
            }
        });
        assert_eq!(stopped, Err(2));
    }
}
