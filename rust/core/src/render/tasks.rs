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

use super::adaptive::Adaptive;
use super::driver::{Driver, PassesDone, Timing};
use super::{RenderControl, RenderOutput};
use crate::film::{Film, FilmBuffer};
use std::ops::Range;

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
