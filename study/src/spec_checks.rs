//! The checks of a study spec ([`StudySpec::validate`]): every value in its range, every list
//! bounded and without a value listed twice, each mass pair held to a scene's bounds.

use super::{StudySpec, MAX_LIST_VALUES, MIN_STUDY_CFL};
use sparse_mpm::error::{MpmError, Result};

impl StudySpec {
    /// Refuses a spec with a value out of its range, a list longer than [`MAX_LIST_VALUES`], a
    /// value listed twice, or a mass pair a scene would refuse, naming the key.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] naming the key.
    pub(super) fn validate(&self) -> Result<()> {
        let bad = |key: &str, reason: &str| {
            Err(MpmError::InvalidScene {
                key: key.into(),
                reason: reason.into(),
            })
        };
        if !(self.cfl >= MIN_STUDY_CFL && self.cfl <= 1.0) {
            return bad(
                "cfl",
                "the Courant number must lie in [0.01, 1] (study::MIN_STUDY_CFL: a study's runs take about 1/cfl times their steps)",
            );
        }
        // The work of a study grows as the product of its lists: each list is bounded before
        // anything is compared or planned.
        for (key, len) in [
            ("parts", self.parts.len()),
            ("masses", self.masses.len()),
            ("shapes", self.shapes.len()),
            ("bar_cells", self.bar_cells.len()),
            ("vortex_cells", self.vortex_cells.len()),
            ("cantilever_cells", self.cantilever_cells.len()),
            ("particles_per_cell", self.particles_per_cell.len()),
            ("stabilizations", self.stabilizations.len()),
            ("wave_cells", self.wave_cells.len()),
            ("impulse_cells", self.impulse_cells.len()),
            ("column_cells", self.column_cells.len()),
            ("collapse_aspects", self.collapse_aspects.len()),
        ] {
            if len > MAX_LIST_VALUES {
                return bad(
                    key,
                    &format!("lists {len} values, more than the {MAX_LIST_VALUES} a study takes in one list"),
                );
            }
        }
        for (key, cells) in [
            ("bar_cells", &self.bar_cells),
            ("vortex_cells", &self.vortex_cells),
            ("cantilever_cells", &self.cantilever_cells),
            ("column_cells", &self.column_cells),
        ] {
            if cells.iter().any(|&c| c == 0 || c > 4096) {
                return bad(key, "cell counts must lie between 1 and 4096");
            }
        }
        if self.collapse_cells < 4 || self.collapse_cells > 256 {
            return bad("collapse_cells", "must lie between 4 and 256");
        }
        if self.collapse_aspects.iter().any(|a| !(0.1..=10.0).contains(a)) {
            return bad("collapse_aspects", "aspect ratios must lie between 0.1 and 10");
        }
        if self.disks_cells == 0 || self.disks_cells > 4096 {
            return bad("disks_cells", "must lie between 1 and 4096");
        }
        if self.rotation_cells < 4 || self.rotation_cells > 4096 {
            return bad("rotation_cells", "must lie between 4 and 4096");
        }
        for s in &self.stabilizations {
            if let Err(e) = s.validate() {
                return bad("stabilizations", &e.to_string());
            }
        }
        // Each mass pair as a scene's `schemes.mass` is held (its tolerances and policy too).
        for (k, m) in self.masses.iter().enumerate() {
            if let Err(e) = m.validate() {
                return bad(&format!("masses[{k}]"), &e.to_string());
            }
        }
        if self.wave_cells.is_empty() || self.wave_cells.iter().any(|&c| !(20..=4096).contains(&c)) {
            return bad("wave_cells", "cell counts must lie between 20 and 4096 (at least one)");
        }
        if self.impulse_cells.iter().any(|&c| !(10..=4096).contains(&c)) {
            return bad("impulse_cells", "cell counts must lie between 10 and 4096");
        }
        if !(2..=12).contains(&self.time_steps) {
            return bad("time_steps", "must lie between 2 and 12");
        }
        if self.particles_per_cell.iter().any(|&n| n == 0 || n > 8) {
            return bad("particles_per_cell", "must lie between 1 and 8");
        }
        // A value listed twice would plan the same run twice (one run folder for two entries).
        // Each value as the spec spells it.
        fn twice<T: PartialEq>(values: &[T], spell: impl Fn(&T) -> String) -> Option<String> {
            (1..values.len()).find_map(|j| values[..j].contains(&values[j]).then(|| spell(&values[j])))
        }
        let number = |c: &usize| c.to_string();
        for (key, repeated) in [
            ("parts", twice(&self.parts, |p| format!("\"{}\"", p.name()))),
            (
                "masses",
                twice(&self.masses, |m| {
                    format!(
                        "{{ velocity = \"{:#}\", acceleration = \"{:#}\" }}",
                        m.velocity, m.acceleration
                    )
                }),
            ),
            ("shapes", twice(&self.shapes, |s| format!("\"{s:#}\""))),
            ("bar_cells", twice(&self.bar_cells, number)),
            ("vortex_cells", twice(&self.vortex_cells, number)),
            ("cantilever_cells", twice(&self.cantilever_cells, number)),
            ("particles_per_cell", twice(&self.particles_per_cell, number)),
            ("stabilizations", twice(&self.stabilizations, |s| format!("\"{s:#}\""))),
            ("wave_cells", twice(&self.wave_cells, number)),
            ("impulse_cells", twice(&self.impulse_cells, number)),
            ("collapse_aspects", twice(&self.collapse_aspects, |a| a.to_string())),
        ] {
            if let Some(value) = repeated {
                return bad(key, &format!("lists {value} twice: give each value once"));
            }
        }
        Ok(())
    }
}
