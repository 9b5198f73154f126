//! What the window shows: the shaded pixels (sRGB) and each pixel's
//! steps, filled by a preview scaled up to the window or by the tiles of a
//! full-resolution pass, and the running mean of anti-aliasing passes; or
//! a frame made on the GPU, presented from there and read back only when
//! the host needs its pixels (a screenshot, tiles marched over it).

use isomarch::gpu::scale::nearest;
use isomarch::output;

/// The window's pixels.
#[derive(Debug, Default)]
pub struct Canvas {
    /// Shaded colours, 3 bytes per pixel, row by row.
    pub rgb: Vec<u8>,
    /// Steps of each pixel's ray.
    pub steps: Vec<u32>,
    /// Anti-aliasing: the running mean of the passes so far (linear light).
    linear: Vec<[f32; 3]>,
    /// The size of the frame made on the GPU that the window shows, where
    /// it does; `rgb` and `steps` are then empty until it is read back
    /// ([`Canvas::upscale`] fills them).
    pub on_gpu: Option<(u32, u32)>,
}

impl Canvas {
    /// Nothing shown (the window changed size).
    pub fn clear(&mut self) {
        self.rgb.clear();
        self.steps.clear();
        self.on_gpu = None;
    }

    pub fn is_empty(&self) -> bool {
        self.rgb.is_empty() && self.on_gpu.is_none()
    }

    /// The window shows the renderer's frame image of `small` pixels,
    /// scaled on the GPU; no host pixels.
    pub fn show_gpu(&mut self, small: (u32, u32)) {
        self.clear();
        self.on_gpu = Some(small);
    }

    /// Whether the canvas holds a whole `w` x `h` image.
    pub fn is_whole(&self, w: u32, h: u32) -> bool {
        self.rgb.len() == (w * h * 3) as usize
    }

    /// The `small` image (`rgb` at 3 bytes per pixel, and `steps`) scaled
    /// up to `size` by nearest neighbour.
    pub fn upscale(&mut self, small: (u32, u32), rgb: &[u8], steps: &[u32], size: (u32, u32)) {
        let (w, h) = size;
        self.on_gpu = None;
        self.rgb = vec![0; (w * h * 3) as usize];
        self.steps = vec![0; (w * h) as usize];
        // The pixels present.comp shows (isomarch::gpu::scale).
        for y in 0..h {
            let sy = nearest(y, small.1, h);
            for x in 0..w {
                let sx = nearest(x, small.0, w);
                let (i, s) = ((y * w + x) as usize, (sy * small.0 + sx) as usize);
                self.rgb[3 * i..3 * i + 3].copy_from_slice(&rgb[3 * s..3 * s + 3]);
                self.steps[i] = steps[s];
            }
        }
    }

    /// Starts anti-aliasing pass 0 over `pixels` pixels: the mean restarts.
    pub fn restart_mean(&mut self, pixels: usize) {
        self.linear = vec![[0.0; 3]; pixels];
    }

    /// Pixel `i` marched with linear colour `color` and `steps` steps, by
    /// anti-aliasing pass `sample` (`None`: through its centre, shown as
    /// is); a pass shows the mean of the passes so far.
    pub fn put(&mut self, i: usize, mut color: [f32; 3], steps: u32, sample: Option<u32>) {
        if let Some(s) = sample {
            // The running mean of the passes so far, in linear light.
            let mean = &mut self.linear[i];
            for (m, v) in mean.iter_mut().zip(&mut color) {
                *m += (*v - *m) / (s + 1) as f32;
                *v = *m;
            }
        }
        self.rgb[3 * i..3 * i + 3].copy_from_slice(&[output::srgb(color[0]), output::srgb(color[1]), output::srgb(color[2])]);
        self.steps[i] = steps;
    }
}

#[cfg(test)]
mod tests {
    use super::Canvas;

    #[test]
    fn upscaling_repeats_each_pixel_over_its_block() {
        let mut c = Canvas::default();
        // 2x1 image: red with 3 steps, blue with 7, to 4x2.
        c.upscale((2, 1), &[255, 0, 0, 0, 0, 255], &[3, 7], (4, 2));
        assert!(c.is_whole(4, 2) && !c.is_whole(4, 3));
        for y in 0..2 {
            for x in 0..4 {
                let i = y * 4 + x;
                let (rgb, steps) = if x < 2 { ([255, 0, 0], 3) } else { ([0, 0, 255], 7) };
                assert_eq!(&c.rgb[3 * i..3 * i + 3], &rgb, "pixel {x},{y}");
                assert_eq!(c.steps[i], steps, "pixel {x},{y}");
            }
        }
        // Not a multiple, both ways: 3x3 from 2x2 (each small pixel's
        // steps its index, so a row or a column off shows).
        c.upscale((2, 2), &[0; 12], &[0, 1, 2, 3], (3, 3));
        assert_eq!(c.steps, [0, 0, 1, 0, 0, 1, 2, 2, 3]);
        c.clear();
        assert!(c.is_empty());
    }

    #[test]
    fn passes_show_the_running_mean_in_linear_light() {
        let mut c = Canvas::default();
        c.upscale((1, 1), &[0, 0, 0], &[0], (1, 1));
        c.restart_mean(1);
        c.put(0, [1.0, 0.0, 0.5], 4, Some(0));
        assert_eq!(&c.rgb[..], &[255, 0, isomarch::output::srgb(0.5)]);
        c.put(0, [0.0, 0.0, 0.5], 6, Some(1));
        // The mean of 1 and 0 is 0.5 in linear light, not in sRGB.
        assert_eq!(&c.rgb[..], &[isomarch::output::srgb(0.5), 0, isomarch::output::srgb(0.5)]);
        assert_eq!(c.steps[0], 6);
        c.put(0, [0.0, 0.0, 0.0], 2, Some(2));
        assert_eq!(c.rgb[0], isomarch::output::srgb(1.0 / 3.0));
        // Through the centre: shown as is, the mean untouched.
        c.put(0, [0.25, 0.25, 0.25], 1, None);
        assert_eq!(c.rgb[0], isomarch::output::srgb(0.25));
    }
}
