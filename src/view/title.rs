//! The window's title: what is shown and how fast.

use std::fmt;

use isomarch::method::Method;

/// Everything the title says.
pub struct Title<'a> {
    /// The scene file's name without folder and extension.
    pub name: &'a str,
    pub method: Method,
    pub frame_ms: f64,
    pub fps: f64,
    pub steps_per_ray: f64,
    /// Scene time, seconds.
    pub time: f64,
    /// The fraction of a full-resolution pass marched, while one is.
    pub refining: Option<f64>,
    /// The preview's resolution divisor (1: full resolution).
    pub preview_divisor: u32,
    /// A trajectory's frame, its frame count and its simulation time.
    pub frame: Option<(usize, usize, Option<f64>)>,
    pub speed: f64,
    pub paused: bool,
    pub heatmap: bool,
    /// The anti-aliasing pass under way, of how many.
    pub pass: Option<(u32, u32)>,
    /// A transparent scene shown opaque (T).
    pub opaque: bool,
}

impl fmt::Display for Title<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "isomarch: {} | {} | {:.1} ms/frame | {:.1} FPS | {:.2} steps/ray | t = {:.2} s",
            self.name, self.method, self.frame_ms, self.fps, self.steps_per_ray, self.time
        )?;
        if let Some(done) = self.refining {
            write!(f, " | refining {:.0}%", 100.0 * done)?;
        } else if self.preview_divisor > 1 {
            write!(f, " | preview 1/{}", self.preview_divisor)?;
        }
        if let Some((frame, len, time_ps)) = self.frame {
            write!(f, " | frame {frame}/{len}")?;
            if let Some(t) = time_ps {
                write!(f, " ({} ps)", isomarch::molecule::trajectory::ps(t))?;
            }
        }
        if self.speed != 1.0 {
            write!(f, " | speed x{}", self.speed)?;
        }
        if self.paused {
            f.write_str(" | paused")?;
        }
        if self.heatmap {
            f.write_str(" | steps")?;
        }
        if let Some((k, n)) = self.pass {
            write!(f, " | anti-aliasing {}/{n}", k + 1)?;
        }
        if self.opaque {
            f.write_str(" | opaque")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::Title;
    use isomarch::method::Method;

    #[test]
    fn the_title_names_what_is_shown() {
        let mut t = Title {
            name: "fig10",
            method: Method::QuadraticTaylor,
            frame_ms: 12.34,
            fps: 25.0,
            steps_per_ray: 3.456,
            time: 1.5,
            refining: None,
            preview_divisor: 1,
            frame: None,
            speed: 1.0,
            paused: false,
            heatmap: false,
            pass: None,
            opaque: false,
        };
        assert_eq!(t.to_string(), "isomarch: fig10 | quadratic-taylor | 12.3 ms/frame | 25.0 FPS | 3.46 steps/ray | t = 1.50 s");
        t.preview_divisor = 4;
        assert!(t.to_string().ends_with(" | preview 1/4"));
        // A pass under way is said over the preview.
        (t.refining, t.pass) = (Some(0.25), Some((1, 8)));
        (t.speed, t.paused, t.heatmap, t.opaque) = (2.0, true, true, true);
        assert!(t.to_string().ends_with(" | refining 25% | speed x2 | paused | steps | anti-aliasing 2/8 | opaque"), "{t}");
    }
}
