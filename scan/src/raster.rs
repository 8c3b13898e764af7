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
