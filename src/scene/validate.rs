//! The checks of a scene that the file format cannot express ([`Scene::validate`]).

use super::{
    invalid, BodySpec, Geometry, Scene, MAX_ACCELERATION, MAX_GEOMETRY_DEPTH, MAX_GEOMETRY_PARTS, MAX_NODES,
    MAX_ORIGIN_CELLS, MAX_PARTICLES_PER_CELL, MAX_SPEED,
};
use crate::error::{MpmError, Result};
use crate::mass::{SingularityPolicy, Stabilization};
use crate::numbers::exact;

/// `[x, y]` with [`exact`].
fn pair(v: [f64; 2]) -> String {
    format!("[{}, {}]", exact(v[0]), exact(v[1]))
}

/// An [`MpmError::InvalidParameter`] of a part of the scene (a material, a mass scheme …)
/// restated at the key `{prefix}.{name}` with its value; other errors at `prefix`.
fn parameter_error(prefix: &str, e: MpmError) -> MpmError {
    match e {
        MpmError::InvalidParameter { name, value, reason } => invalid(
            format!("{prefix}.{name}"),
            format!("{} is invalid: {reason}", exact(value)),
        ),
        e => invalid(prefix, e.to_string()),
    }
}

impl Scene {
    /// Checks what the file format cannot: positive sizes and times, one time-step rule, at
    /// least one body, sensible body parameters, finite and bounded numbers everywhere (see the
    /// [module docs](crate::scene)), boundary conditions that fit the grid.
    ///
    /// # Errors
    /// [`MpmError::InvalidScene`] naming the key (`time.dt`, `bodies[1].density`,
    /// `schemes.mass.pivot_tolerance` …) and its value.
    pub fn validate(&self) -> Result<()> {
        self.validate_grid()?;
        self.validate_time_and_output()?;
        self.check_vector("loads.gravity", self.loads.gravity, MAX_ACCELERATION)?;
        self.validate_schemes()?;
        // Before the options' own checks, which cannot name a boundary's key.
        self.validate_boundaries()?;
        self.validate_contact()?;
        self.options().validate().map_err(|e| self.scene_error(e))?;
        if self.bodies.is_empty() {
            return Err(invalid("bodies", "the scene needs at least one [[bodies]] entry"));
        }
        for (k, b) in self.bodies.iter().enumerate() {
            self.validate_body(k, b)?;
        }
        Ok(())
    }

    /// Positive finite cell sizes, a finite origin within [`MAX_ORIGIN_CELLS`] cells of zero,
    /// at least one cell per axis, at most [`MAX_NODES`] nodes, and a far edge that does not
    /// overflow.
    fn validate_grid(&self) -> Result<()> {
        let g = &self.grid;
        for (k, h) in g.cell_size.iter().enumerate() {
            if !(h.is_finite() && *h > 0.0) {
                return Err(invalid(
                    format!("grid.cell_size[{k}]"),
                    format!("{} must be positive and finite", exact(*h)),
                ));
            }
        }
        for (k, o) in g.origin.iter().enumerate() {
            if !o.is_finite() {
                return Err(invalid(
                    format!("grid.origin[{k}]"),
                    format!("{} must be finite", exact(*o)),
                ));
            }
            let h = g.cell_size[k];
            if o.abs() > MAX_ORIGIN_CELLS * h {
                return Err(invalid(
                    format!("grid.origin[{k}]"),
                    format!(
                        "{} is too far from zero for cells of {}: at most {} cell sizes are accepted (further out, \
                         positions within a cell lose their precision)",
                        exact(*o),
                        exact(h),
                        exact(MAX_ORIGIN_CELLS)
                    ),
                ));
            }
        }
        for (k, c) in g.cells.iter().enumerate() {
            if *c == 0 {
                return Err(invalid(
                    format!("grid.cells[{k}]"),
                    "the grid needs at least one cell per axis",
                ));
            }
        }
        let nodes = (g.cells[0] as f64 + 1.0) * (g.cells[1] as f64 + 1.0);
        if nodes > MAX_NODES {
            return Err(invalid(
                "grid.cells",
                format!(
                    "{:?} cells make {nodes:.3e} nodes, more than the {MAX_NODES:.0e} this program accepts \
                     (about 20 values per node are kept)",
                    g.cells
                ),
            ));
        }
        for k in 0..2 {
            let far = g.origin[k] + g.cells[k] as f64 * g.cell_size[k];
            if !far.is_finite() {
                return Err(invalid(
                    format!("grid.cell_size[{k}]"),
                    format!(
                        "{} cells of {} from the origin {} overflow (the far edge is at {})",
                        g.cells[k],
                        exact(g.cell_size[k]),
                        exact(g.origin[k]),
                        exact(far)
                    ),
                ));
            }
        }
        Ok(())
    }

    /// A positive finite end time, at most one of `dt` and `cfl`, a positive finite snapshot
    /// interval.
    fn validate_time_and_output(&self) -> Result<()> {
        let t = &self.time;
        if !(t.end.is_finite() && t.end > 0.0) {
            return Err(invalid(
                "time.end",
                format!("{} must be positive and finite", exact(t.end)),
            ));
        }
        if t.dt.is_some() && t.cfl.is_some() {
            return Err(invalid("time", "give `dt` or `cfl`, not both"));
        }
        if let crate::simulation::Integrator::QuasiStatic(q) = self.schemes.integrator {
            if let Some(key) = [("time.dt", t.dt.is_some()), ("time.cfl", t.cfl.is_some())]
                .into_iter()
                .find_map(|(key, given)| given.then_some(key))
            {
                return Err(invalid(
                    key,
                    format!(
                        "the quasi-static integrator takes its step from time.end / load_steps ({} increments): \
                         leave out {key}",
                        q.load_steps
                    ),
                ));
            }
        }
        if let Some(s) = self.output.snapshot_interval {
            if !(s.is_finite() && s > 0.0) {
                return Err(invalid(
                    "output.snapshot_interval",
                    format!("{} must be positive and finite", exact(s)),
                ));
            }
        }
        Ok(())
    }

    /// Each boundary condition on the grid ([`BoundaryCondition::validate`]), with prescribed
    /// speeds within [`MAX_SPEED`].
    ///
    /// [`BoundaryCondition::validate`]: crate::boundary::BoundaryCondition::validate
    fn validate_boundaries(&self) -> Result<()> {
        let grid = self.grid()?;
        for (k, bc) in self.boundaries.iter().enumerate() {
            bc.validate(k, &grid, self.schemes.shape)?;
            for (name, v) in [("vx", bc.vx), ("vy", bc.vy)] {
                if let Some(v) = v {
                    if v.abs() > MAX_SPEED {
                        return Err(invalid(
                            format!("boundaries[{k}].{name}"),
                            format!(
                                "{} is too large: prescribed speeds of at most {} are accepted",
                                exact(v),
                                exact(MAX_SPEED)
                            ),
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// The shape function, the mass schemes and the mass solves' tolerances and policies, each
    /// at its own key.
    fn validate_schemes(&self) -> Result<()> {
        let s = &self.schemes;
        s.shape
            .validate()
            .map_err(|e| parameter_error(&format!("schemes.shape.{}", s.shape.name()), e))?;
        for (role, scheme) in [("velocity", s.mass.velocity), ("acceleration", s.mass.acceleration)] {
            scheme
                .validate()
                .map_err(|e| parameter_error(&format!("schemes.mass.{role}.{}", scheme.name()), e))?;
        }
        for (name, value, meaning) in [
            (
                "active_tolerance",
                s.mass.active_tolerance,
                "the relative lumped mass at or below which a node is inactive",
            ),
            (
                "pivot_tolerance",
                s.mass.pivot_tolerance,
                "the scaled Cholesky pivot at or below which the matrix counts as singular",
            ),
        ] {
            if !(0.0..1.0).contains(&value) {
                return Err(invalid(
                    format!("schemes.mass.{name}"),
                    format!("{} must be a number in [0, 1) ({meaning})", exact(value)),
                ));
            }
        }
        if let SingularityPolicy::Regularize { epsilon } = s.mass.singularity {
            if !(epsilon > 0.0 && epsilon <= 1.0) {
                return Err(invalid(
                    "schemes.mass.singularity.regularize.epsilon",
                    format!(
                        "{} must lie in (0, 1] (the weight of the lumped mass in the regularized matrix)",
                        exact(epsilon)
                    ),
                ));
            }
        }
        let stabilization = match s.mass.stabilization {
            Stabilization::None => "schemes.mass.stabilization",
            Stabilization::GhostPenalty { .. } => "schemes.mass.stabilization.ghost_penalty",
            Stabilization::PartialLumping { .. } => "schemes.mass.stabilization.partial_lumping",
            Stabilization::LinearExtension { .. } => "schemes.mass.stabilization.linear_extension",
        };
        s.mass
            .stabilization
            .validate()
            .map_err(|e| parameter_error(stabilization, e))
    }

    /// One body's density, particle count, material, velocity, body force and geometry.
    fn validate_body(&self, k: usize, b: &BodySpec) -> Result<()> {
        let key = |f: &str| format!("bodies[{k}].{f}");
        if !(b.density.is_finite() && b.density > 0.0) {
            return Err(invalid(
                key("density"),
                format!("{} must be positive and finite", exact(b.density)),
            ));
        }
        let [low, high] = crate::material::DENSITY_RANGE;
        if !(low..=high).contains(&b.density) {
            return Err(invalid(
                key("density"),
                format!("{} must lie between {low:e} and {high:e}", exact(b.density)),
            ));
        }
        let [hx, hy] = self.grid.cell_size;
        if !(b.density * hx * hy).is_finite() {
            return Err(invalid(
                key("density"),
                format!(
                    "{} is too large for cells of {} x {}: the mass of a cell's particles overflows",
                    exact(b.density),
                    exact(hx),
                    exact(hy)
                ),
            ));
        }
        if b.particles_per_cell == 0 || b.particles_per_cell > MAX_PARTICLES_PER_CELL {
            return Err(invalid(
                key("particles_per_cell"),
                format!(
                    "{} must lie between 1 and {MAX_PARTICLES_PER_CELL} (per axis)",
                    b.particles_per_cell
                ),
            ));
        }
        b.material
            .validate()
            .map_err(|e| parameter_error(&key("material"), e))?;
        let c = b.material.wave_speed(b.density);
        if !(c.is_finite() && c > 0.0) {
            return Err(invalid(
                key("material"),
                format!(
                    "the wave speed of this material at `density` = {} is {}: it must be positive and finite",
                    exact(b.density),
                    exact(c)
                ),
            ));
        }
        self.check_vector(&key("velocity"), b.velocity, MAX_SPEED)?;
        self.check_vector(&key("body_force"), b.body_force, MAX_ACCELERATION)?;
        check_geometry(&key("geometry"), &b.geometry)?;
        if b.regions.len() > super::MAX_REGIONS {
            return Err(invalid(
                key("regions"),
                format!("{} regions: at most {} per body", b.regions.len(), super::MAX_REGIONS),
            ));
        }
        for (r, region) in b.regions.iter().enumerate() {
            let at = |f: &str| key(&format!("regions[{r}].{f}"));
            check_geometry(&at("geometry"), &region.geometry)?;
            if matches!(region.geometry, Geometry::File(_)) {
                return Err(invalid(at("geometry"), "a region is a shape, not a particle file"));
            }
            if let Some(m) = &region.material {
                if self.contact.is_some() {
                    return Err(invalid(
                        at("material"),
                        "a region with its own material is a body of its own in the solver, which under \
                         [contact] would meet the rest of its body through contact: give the region as a body",
                    ));
                }
                m.validate().map_err(|e| parameter_error(&at("material"), e))?;
                let c = m.wave_speed(b.density);
                if !(c.is_finite() && c > 0.0) {
                    return Err(invalid(
                        at("material"),
                        format!(
                            "the wave speed of this material at `density` = {} is {}: it must be positive and finite",
                            exact(b.density),
                            exact(c)
                        ),
                    ));
                }
            }
            if let Some(v) = region.velocity {
                self.check_vector(&at("velocity"), v, MAX_SPEED)?;
            }
        }
        if matches!(b.geometry, Geometry::File(_)) && !b.sampling.is_regular() {
            return Err(invalid(
                key("sampling"),
                "a particle file gives its own particles: `sampling` is for shapes",
            ));
        }
        super::bodies::inside_grid(k, &b.geometry, &self.grid()?)
    }

    /// A vector of the scene at `key` (an acceleration or a velocity): finite, of magnitude at
    /// most `bound`, and such that its magnitude times `time.end` and times the cell size do
    /// not overflow.
    fn check_vector(&self, key: &str, v: [f64; 2], bound: f64) -> Result<()> {
        if !v.iter().all(|c| c.is_finite()) {
            return Err(invalid(key, format!("{} must be finite", pair(v))));
        }
        let magnitude = v[0].hypot(v[1]);
        if magnitude > bound {
            return Err(invalid(
                key,
                format!(
                    "{} is too large: its magnitude {} exceeds the {} this program accepts",
                    pair(v),
                    exact(magnitude),
                    exact(bound)
                ),
            ));
        }
        let h = self.grid.cell_size[0].max(self.grid.cell_size[1]);
        for (factor, what) in [(self.time.end, "`time.end`"), (h, "the cell size")] {
            if !(magnitude * factor).is_finite() {
                return Err(invalid(
                    key,
                    format!(
                        "{} is too large: its magnitude {} times {what} ({}) overflows",
                        pair(v),
                        exact(magnitude),
                        exact(factor)
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Every part of a body's geometry well formed: finite numbers, positive sizes, a polygon of at
/// least three vertices enclosing an area, nesting at most [`MAX_GEOMETRY_DEPTH`] deep, a
/// particle file only as the whole geometry.
fn check_geometry(key: &str, geometry: &Geometry) -> Result<()> {
    if geometry.depth() > MAX_GEOMETRY_DEPTH {
        return Err(invalid(
            key,
            format!(
                "unions, differences and transforms nest {} deep; at most {MAX_GEOMETRY_DEPTH} are read",
                geometry.depth()
            ),
        ));
    }
    if geometry.size() > MAX_GEOMETRY_PARTS {
        return Err(invalid(
            key,
            format!(
                "holds {} shapes and vertices; at most {MAX_GEOMETRY_PARTS} are read (every particle is tested against \
                 each): give a large outline as a particle file",
                geometry.size()
            ),
        ));
    }
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    for (at, part) in geometry.parts(key) {
        match part {
            Geometry::Rectangle { min, max } if !(finite(min) && finite(max) && min[0] < max[0] && min[1] < max[1]) => {
                return Err(invalid(
                    at,
                    format!(
                        "min = {}, max = {}: needs finite values with min < max in x and y",
                        pair(*min),
                        pair(*max)
                    ),
                ));
            }
            Geometry::Disk { center, radius } if !(finite(center) && radius.is_finite() && *radius > 0.0) => {
                return Err(invalid(
                    at,
                    format!(
                        "center = {}, radius = {}: needs a finite centre and a positive finite radius",
                        pair(*center),
                        exact(*radius)
                    ),
                ));
            }
            Geometry::Annulus {
                center,
                inner_radius,
                outer_radius,
            } if !(finite(center)
                && inner_radius.is_finite()
                && outer_radius.is_finite()
                && *inner_radius >= 0.0
                && inner_radius < outer_radius) =>
            {
                return Err(invalid(
                    at,
                    format!(
                        "center = {}, inner_radius = {}, outer_radius = {}: needs a finite centre and \
                         0 ≤ inner_radius < outer_radius, both finite",
                        pair(*center),
                        exact(*inner_radius),
                        exact(*outer_radius)
                    ),
                ));
            }
            Geometry::Polygon { vertices } => check_polygon(&at, part, vertices)?,
            Geometry::Union(parts) if parts.is_empty() => {
                return Err(invalid(at, "is empty: a union needs at least one shape"));
            }
            Geometry::Transformed {
                angle,
                about,
                translate,
                ..
            } if !(angle.is_finite() && about.is_none_or(|c| finite(&c)) && finite(translate)) => {
                return Err(invalid(
                    at,
                    format!(
                        "angle = {}, about = {}, translate = {}: needs finite values",
                        exact(*angle),
                        about.map_or("(the box's centre)".to_string(), pair),
                        pair(*translate)
                    ),
                ));
            }
            Geometry::File(_) if at != format!("{key}.file") => {
                return Err(invalid(
                    at,
                    "a particle file is a whole geometry: it cannot be part of a union, a difference or a transform",
                ));
            }
            _ => {}
        }
    }
    Ok(())
}

/// A polygon of at least three finite vertices enclosing an area.
fn check_polygon(at: &str, part: &Geometry, vertices: &[[f64; 2]]) -> Result<()> {
    if vertices.len() < 3 {
        return Err(invalid(
            format!("{at}.vertices"),
            format!("has {} vertices: a polygon needs at least 3", vertices.len()),
        ));
    }
    if let Some(i) = vertices.iter().position(|v| !v.iter().all(|x| x.is_finite())) {
        return Err(invalid(
            format!("{at}.vertices[{i}]"),
            format!("{} is not a finite point", pair(vertices[i])),
        ));
    }
    if part.area().is_none_or(|a| !(a > 0.0 && a.is_finite())) {
        return Err(invalid(
            format!("{at}.vertices"),
            "enclose no area (the vertices lie on a line, or the outline cancels itself)",
        ));
    }
    Ok(())
}
