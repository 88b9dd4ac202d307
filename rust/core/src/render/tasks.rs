//! A render split into tasks, as distributed rendering runs it: workers render ranges of
//! sample passes into sums ([`Driver::render_passes`]); the client adds them up in a
//! [`Merge`], which also keeps adaptive sampling's state between groups of passes.
//!
//! Adaptive sampling stays exact across tasks by keeping the pass loop's groups
//! ([`Driver::groups`]): every task of a group samples the pixels that were active when
//! the group started and lies wholly in the group's first or second half; the first
//! halves' sums feed the error estimate; the group ends ([`Merge::end_group`]) once all
//! its tasks are added. So the same seed and settings give the same image as
//! [`Driver::run`], whatever the number of workers or the order tasks finish in.

use super::adaptive::{Adaptive, AdaptiveState};
use super::driver::{Driver, PassesDone, Timing};
use super::{RenderControl, RenderOutput};
use crate::film::{Film, FilmBuffer};
use std::ops::Range;

/// What a [`Merge`] holds between tasks: saved in a checkpoint, restored on resume.
#[derive(Clone, Debug)]
pub struct MergeState {
    /// The sums of every task added so far.
    pub buffer: FilmBuffer,
    /// Passes of the groups ended so far.
    pub passes: u32,
    /// Adaptive sampling's per-pixel state (None: adaptive off).
    pub adaptive: Option<AdaptiveState>,
}

/// The client's image of a render whose passes are rendered elsewhere.
pub struct Merge {
    film: Film,
    adaptive: Option<Adaptive>,
    done: PassesDone,
}

impl Merge {
    /// An empty image for `driver`'s render.
    pub fn new(driver: &Driver) -> Self {
        Self { film: driver.new_film(), adaptive: Adaptive::new(driver.settings()), done: PassesDone::default() }
    }

    /// Adaptive sampling: the pixels the tasks of the current group sample (row-major);
    /// None when adaptive sampling is off (every pixel).
    pub fn active(&self) -> Option<&[bool]> {
        self.adaptive.as_ref().map(|a| a.active())
    }

    /// Whether another group is worth rendering (false once adaptive sampling stopped
    /// every pixel).
    pub fn any_active(&self) -> bool {
        self.adaptive.as_ref().is_none_or(|a| a.any_active())
    }

    /// Adds a task's sums; `first_half`: the task lies in its group's first half
    /// ([`Merge::halves`]), whose sums adaptive sampling also keeps apart.
    pub fn add(&mut self, sums: &FilmBuffer, first_half: bool) {
        self.film.buffer.merge(sums);
        if let (true, Some(a)) = (first_half, &mut self.adaptive) {
            for (i, (xyz, &count)) in sums.xyz.iter().zip(&sums.count).enumerate() {
                a.add_first_half(i, xyz, count);
            }
        }
    }

    /// Adds a task's sums of the pixels of `rect` (`[x0, y0, x1, y1)`, row-major in it;
    /// [`Driver::render_rect`]); `first_half` as for [`Merge::add`].
    pub fn add_rect(&mut self, sums: &FilmBuffer, rect: [u32; 4], first_half: bool) {
        let [x0, y0, x1, y1] = rect;
        let w = x1 - x0;
        self.film.merge_tile(x0, y0, w, y1 - y0, sums);
        if let (true, Some(a)) = (first_half, &mut self.adaptive) {
            for (k, (xyz, &count)) in sums.xyz.iter().zip(&sums.count).enumerate() {
                let (x, y) = (x0 + k as u32 % w, y0 + k as u32 / w);
                a.add_first_half((y * self.film.width + x) as usize, xyz, count);
            }
        }
    }

    /// A copy of what was added so far (for a checkpoint).
    pub fn state(&self) -> MergeState {
        MergeState {
            buffer: self.film.buffer.clone(),
            passes: self.done.passes,
            adaptive: self.adaptive.as_ref().map(|a| a.state()),
        }
    }

    /// Continues from a saved state of the same render; the error says what does not
    /// match (image size, spectral output, adaptive sampling).
    pub fn restore(&mut self, state: MergeState) -> Result<(), String> {
        let (have, want) = (state.buffer.count.len(), self.film.buffer.count.len());
        if have != want {
            return Err(format!("{have} pixels, expected {want}"));
        }
        let sums_len = |b: &FilmBuffer| b.spectral.as_ref().map(|s| s.len());
        if sums_len(&state.buffer) != sums_len(&self.film.buffer)
            || [
                state.buffer.xyz.len(),
                state.buffer.albedo_xyz.len(),
                state.buffer.normal.len(),
                state.buffer.depth.len(),
            ] != [want; 4]
        {
            return Err("the pass sums do not match this render's image (spectral output?)".into());
        }
        match (&mut self.adaptive, state.adaptive) {
            (Some(a), Some(s)) => a.restore(s)?,
            (None, None) => {}
            _ => return Err("adaptive sampling differs".into()),
        }
        self.film.buffer = state.buffer;
        self.done.passes = state.passes;
        Ok(())
    }

    /// After every task of a group of `passes` passes was added: counts them and, with
    /// adaptive sampling, stops the pixels that reached the target.
    pub fn end_group(&mut self, driver: &Driver, passes: u32) {
        self.done.passes += passes;
        if let Some(a) = &mut self.adaptive {
            a.update(&self.film.buffer, driver.samples_per_pixel(self.done.passes));
        }
    }

    /// A group's two halves, as the pass loop splits it for the error estimate (without
    /// adaptive sampling the first half is the whole group).
    pub fn halves(&self, group: Range<u32>) -> [Range<u32>; 2] {
        if self.adaptive.is_some() {
            let mid = group.start + group.len() as u32 / 2;
            [group.start..mid, mid..group.end]
        } else {
            [group.clone(), group.end..group.end]
        }
    }

    /// Passes counted so far.
    pub fn passes(&self) -> u32 {
        self.done.passes
    }

    pub fn film(&self) -> &Film {
        &self.film
    }

    /// The images and stats of what was added (`control` cancelled: marked partial).
    pub fn output(&self, driver: &Driver, time_limited: bool, control: &RenderControl, timing: Timing) -> RenderOutput {
        let done = PassesDone {
            time_limited,
            converged_pixels: self.adaptive.as_ref().map(|a| a.converged_pixels()),
            ..self.done
        };
        driver.output(&self.film, done, control, timing)
    }
}
