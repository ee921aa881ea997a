//! Particle state as a struct of arrays.
//!
//! Every field is a `Vec<f64>` with one entry per particle, in particle order `p = 0..P`
//! (column `p` of N, Gx, Gy). Stresses are Cauchy stresses in Voigt-like components
//! `σxx, σyy, σxy`; the body force `b` is per unit mass (an acceleration, e.g. gravity).
//! Each particle also carries its deformation gradient `F` (identity at the start), the APIC
//! moment `B` (zero unless APIC transfers are used), the index of the body it
//! belongs to (which selects its material in a [`crate::simulation::Simulation`]) and a
//! permanent id that survives re-sorting.

use crate::error::{MpmError, Result};
use crate::grid::Grid;

/// Largest magnitude of an acceleration accepted (a particle's body force `(bx, by)`,
/// `Options::gravity`, a scene's `loads.gravity` and `bodies[k].body_force`): 10¹² in the
/// scene's units, some 10¹¹ g in SI units. Above it a run only overflows (a particle's velocity
/// after one step, its travel over the run).
pub const MAX_ACCELERATION: f64 = 1e12;

/// Largest speed accepted (a particle's `(vx, vy)`, a boundary's prescribed `vx`, `vy`, a
/// scene's `bodies[k].velocity` and particle-file columns): 10¹² in the scene's units. The
/// step's reports square speeds, which overflows from about 10¹⁵⁴ on.
pub const MAX_SPEED: f64 = 1e12;

/// Defines [`Particles`] from the one list of its fields (each a `Vec` of one entry per
/// particle) and, from the same list, the views the sort's permutation, `append`, the checks and
/// the checkpoint record take: a new particle field is one line here.
macro_rules! particle_fields {
    (
        real { $($(#[$doc:meta])* $real:ident,)* }
        state { $($(#[$sdoc:meta])* $state:ident,)* }
        index { $($(#[$idoc:meta])* $index:ident,)* }
    ) => {
        /// The state of all particles. Fields are public so a program can read and set them
        /// directly; [`Particles::validate`] checks a state built by hand.
        #[derive(Debug, Clone, PartialEq, Default)]
        pub struct Particles {
            $($(#[$doc])* pub $real: Vec<f64>,)*
            $($(#[$sdoc])* pub $state: Vec<f64>,)*
            $($(#[$idoc])* pub $index: Vec<usize>,)*
        }

        /// The number of real-valued particle fields (the plastic state's among them).
        pub(crate) const REAL_FIELDS: usize = [$(stringify!($real)),* $(, stringify!($state))*].len();

        /// The names of the plastic state's fields: empty vectors unless a body is plastic.
        pub(crate) const STATE_FIELDS: [&str; [$(stringify!($state)),*].len()] = [$(stringify!($state)),*];

        impl Particles {
            /// Each real-valued field with its name, in the list's order (the plastic state's
            /// last).
            pub(crate) fn fields(&self) -> [(&'static str, &Vec<f64>); REAL_FIELDS] {
                [$((stringify!($real), &self.$real),)* $((stringify!($state), &self.$state)),*]
            }

            /// [`Particles::fields`], to write.
            pub(crate) fn fields_mut(&mut self) -> [(&'static str, &mut Vec<f64>); REAL_FIELDS] {
                [$((stringify!($real), &mut self.$real),)* $((stringify!($state), &mut self.$state)),*]
            }

            /// Each index field (body, id), in the list's order.
            pub(crate) fn index_fields(&self) -> [&Vec<usize>; 2] {
                [$(&self.$index),*]
            }

            /// [`Particles::index_fields`], to write.
            pub(crate) fn index_fields_mut(&mut self) -> [&mut Vec<usize>; 2] {
                [$(&mut self.$index),*]
            }
        }
    };
}

particle_fields! {
    real {
        /// x coordinate `x_p`.
        x,
        /// y coordinate `y_p`.
        y,
        /// x velocity `vx_p`.
        vx,
        /// y velocity `vy_p`.
        vy,
        /// Mass `m_p` (positive).
        mass,
        /// Volume `V_p` (positive; an area times unit thickness in 2D).
        volume,
        /// Stress `σxx_p`.
        sxx,
        /// Stress `σyy_p`.
        syy,
        /// Shear stress `σxy_p`.
        sxy,
        /// Body force per unit mass, x component `bx_p`.
        bx,
        /// Body force per unit mass, y component `by_p`.
        by,
        /// Deformation gradient `F_xx`.
        fxx,
        /// Deformation gradient `F_xy = ∂x/∂X_y`.
        fxy,
        /// Deformation gradient `F_yx = ∂y/∂X_x`.
        fyx,
        /// Deformation gradient `F_yy`.
        fyy,
        /// APIC moment `B_xx` of `B_p = Σ_I N_I w_I (x_I − x_p)ᵀ`; the particle's affine velocity
        /// is `C_p = B_p D_p⁻¹` with `D_p = Σ_I N_I (x_I − x_p)(x_I − x_p)ᵀ` at its current position.
        /// With linear shape functions the four fields hold `C_p = Σ_I w_I ∇N_Iᵀ` itself.
        affine_xx,
        /// APIC moment `B_xy`.
        affine_xy,
        /// APIC moment `B_yx`.
        affine_yx,
        /// APIC moment `B_yy`.
        affine_yy,
    }
    state {
        /// The equivalent plastic strain `ε̄ᵖ` of an elastoplastic body's particle
        /// ([`crate::material::hencky`]); this and the four fields after it are empty unless
        /// a body is elastoplastic (then every particle has them, zero for the others).
        plastic_strain,
        /// The elastic logarithmic strain `ε_e = ½ ln(F_e F_eᵀ)`, `xx` (the elastic part of the
        /// deformation, up to its rotation).
        elastic_xx,
        /// `ε_e,yy`.
        elastic_yy,
        /// `ε_e,xy` (tensor shear).
        elastic_xy,
        /// `ε_e,zz`, out of the plane.
        elastic_zz,
    }
    index {
        /// Index of the body (material) the particle belongs to.
        body,
        /// Permanent particle id: the particle's index when the state was created. Re-sorting
        /// permutes the particles but not their ids.
        id,
    }
}

impl Particles {
    /// Gives every particle a plastic state (zero: no plastic strain, no elastic strain) if
    /// it has none.
    pub fn with_plastic_state(&mut self) {
        let n = self.len();
        for field in self.plastic_state_mut() {
            if field.is_empty() {
                field.resize(n, 0.0);
            }
        }
    }

    /// Whether the particles carry a plastic state.
    pub fn has_plastic_state(&self) -> bool {
        !self.plastic_strain.is_empty()
    }

    /// The plastic state's fields `[ε̄ᵖ, ε_e,xx, ε_e,yy, ε_e,xy, ε_e,zz]`, to write.
    pub(crate) fn plastic_state_mut(&mut self) -> [&mut Vec<f64>; 5] {
        [
            &mut self.plastic_strain,
            &mut self.elastic_xx,
            &mut self.elastic_yy,
            &mut self.elastic_xy,
            &mut self.elastic_zz,
        ]
    }

    /// The plastic state of particle `p` (zero when the particles carry none).
    pub fn plastic_state(&self, p: usize) -> crate::material::PlasticState {
        if !self.has_plastic_state() {
            return crate::material::PlasticState::default();
        }
        crate::material::PlasticState {
            elastic_strain: [
                self.elastic_xx[p],
                self.elastic_yy[p],
                self.elastic_xy[p],
                self.elastic_zz[p],
            ],
            plastic_strain: self.plastic_strain[p],
        }
    }

    /// Particles at `(x[p], y[p])` with mass `mass[p]` and volume `volume[p]`, at rest,
    /// stress-free and without body force.
    ///
    /// # Errors
    /// [`MpmError::LengthMismatch`] when the vectors differ in length, and the errors of
    /// [`Particles::validate`].
    pub fn new(x: Vec<f64>, y: Vec<f64>, mass: Vec<f64>, volume: Vec<f64>) -> Result<Particles> {
        let n = x.len();
        check_len("y", n, y.len())?;
        check_len("mass", n, mass.len())?;
        check_len("volume", n, volume.len())?;
        let mut particles = Particles {
            x,
            y,
            mass,
            volume,
            fxx: vec![1.0; n],
            fyy: vec![1.0; n],
            body: vec![0; n],
            id: (0..n).collect(),
            ..Particles::default()
        };
        // The rest start at zero: at rest, stress-free, no body force or APIC moment.
        for (name, field) in particles.fields_mut() {
            if !STATE_FIELDS.contains(&name) {
                field.resize(n, 0.0);
            }
        }
        particles.validate()?;
        Ok(particles)
    }

    /// Sets the velocities.
    ///
    /// # Errors
    /// As [`Particles::new`].
    pub fn with_velocity(mut self, vx: Vec<f64>, vy: Vec<f64>) -> Result<Particles> {
        check_len("vx", self.len(), vx.len())?;
        check_len("vy", self.len(), vy.len())?;
        self.vx = vx;
        self.vy = vy;
        self.validate()?;
        Ok(self)
    }

    /// Sets the stresses `σxx, σyy, σxy`.
    ///
    /// # Errors
    /// As [`Particles::new`].
    pub fn with_stress(mut self, sxx: Vec<f64>, syy: Vec<f64>, sxy: Vec<f64>) -> Result<Particles> {
        check_len("sxx", self.len(), sxx.len())?;
        check_len("syy", self.len(), syy.len())?;
        check_len("sxy", self.len(), sxy.len())?;
        self.sxx = sxx;
        self.syy = syy;
        self.sxy = sxy;
        self.validate()?;
        Ok(self)
    }

    /// Sets the same body force per unit mass `(bx, by)` on every particle (gravity, or the
    /// seed's `b = (5, 10)`).
    ///
    /// # Errors
    /// As [`Particles::new`].
    pub fn with_uniform_body_force(mut self, bx: f64, by: f64) -> Result<Particles> {
        self.bx = vec![bx; self.len()];
        self.by = vec![by; self.len()];
        self.validate()?;
        Ok(self)
    }

    /// Sets a body force per unit mass for each particle.
    ///
    /// # Errors
    /// As [`Particles::new`].
    pub fn with_body_force(mut self, bx: Vec<f64>, by: Vec<f64>) -> Result<Particles> {
        check_len("bx", self.len(), bx.len())?;
        check_len("by", self.len(), by.len())?;
        self.bx = bx;
        self.by = by;
        self.validate()?;
        Ok(self)
    }

    /// Number of particles `P`.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Total mass `Σ_p m_p`.
    pub fn total_mass(&self) -> f64 {
        self.mass.iter().sum()
    }

    /// Total linear momentum `(Σ_p m_p vx_p, Σ_p m_p vy_p)`.
    pub fn momentum(&self) -> [f64; 2] {
        let px = self.mass.iter().zip(&self.vx).map(|(m, v)| m * v).sum();
        let py = self.mass.iter().zip(&self.vy).map(|(m, v)| m * v).sum();
        [px, py]
    }

    /// Kinetic energy `½ Σ_p m_p (vx_p² + vy_p²)`.
    pub fn kinetic_energy(&self) -> f64 {
        (0..self.len())
            .map(|p| 0.5 * self.mass[p] * (self.vx[p].powi(2) + self.vy[p].powi(2)))
            .sum()
    }

    /// Checks every field: all lengths equal, every value finite, mass and volume positive,
    /// speeds within [`MAX_SPEED`], body forces within [`MAX_ACCELERATION`], `det F > 0`.
    ///
    /// # Errors
    /// [`MpmError::LengthMismatch`] naming the field, or [`MpmError::InvalidParticleValue`]
    /// naming the first offending particle, field and value.
    pub fn validate(&self) -> Result<()> {
        let n = self.len();
        for (name, field) in self.fields() {
            if field.is_empty() && STATE_FIELDS.contains(&name) {
                continue;
            }
            check_len(name, n, field.len())?;
            if let Some(p) = field.iter().position(|v| !v.is_finite()) {
                return Err(MpmError::InvalidParticleValue {
                    particle: p,
                    field: name,
                    value: field[p],
                    reason: "values must be finite",
                });
            }
        }
        for (name, field) in [("mass", &self.mass), ("volume", &self.volume)] {
            if let Some(p) = field.iter().position(|&v| v <= 0.0) {
                return Err(MpmError::InvalidParticleValue {
                    particle: p,
                    field: name,
                    value: field[p],
                    reason: "must be positive",
                });
            }
        }
        for (name, x, y, bound, reason) in [
            (
                "velocity",
                &self.vx,
                &self.vy,
                MAX_SPEED,
                "the speed exceeds MAX_SPEED = 1e12 (the energies square it)",
            ),
            (
                "body force",
                &self.bx,
                &self.by,
                MAX_ACCELERATION,
                "the magnitude exceeds MAX_ACCELERATION = 1e12",
            ),
        ] {
            if let Some(p) = (0..n).find(|&p| x[p].hypot(y[p]) > bound) {
                return Err(MpmError::InvalidParticleValue {
                    particle: p,
                    field: name,
                    value: x[p].hypot(y[p]),
                    reason,
                });
            }
        }
        check_len("body", n, self.body.len())?;
        check_len("id", n, self.id.len())?;
        for p in 0..n {
            let det = self.fxx[p] * self.fyy[p] - self.fxy[p] * self.fyx[p];
            if det <= 0.0 {
                return Err(MpmError::InvalidParticleValue {
                    particle: p,
                    field: "det F",
                    value: det,
                    reason: "the deformation gradient must have a positive determinant",
                });
            }
        }
        Ok(())
    }

    /// Appends the particles of `other` (ids continue from this state's largest id + 1).
    ///
    /// # Errors
    /// The errors of [`Particles::validate`] for `other`.
    pub fn append(&mut self, other: Particles) -> Result<()> {
        let next = self.id.iter().max().map_or(0, |m| m + 1);
        self.append_from(other, next)
    }

    /// [`Particles::append`] with the appended particles' ids starting at `next` (at least one
    /// past every id here: the caller knows it, and need not search for it once per body).
    pub(crate) fn append_from(&mut self, mut other: Particles, next: usize) -> Result<()> {
        other.validate()?;
        other.id.iter_mut().for_each(|i| *i += next);
        let (n, m) = (self.len(), other.len());
        for ((_, a), (_, b)) in self.fields_mut().into_iter().zip(other.fields_mut()) {
            // A plastic state on one side only: the other side's particles start at zero.
            if a.is_empty() != b.is_empty() {
                a.resize(n, 0.0);
                b.resize(m, 0.0);
            }
            a.append(b);
        }
        for (a, b) in self.index_fields_mut().into_iter().zip(other.index_fields_mut()) {
            a.append(b);
        }
        Ok(())
    }

    /// Reorders the particles: particle `k` of the result is particle `order[k]` before.
    /// `scratch` and `scratch_index` are work buffers (no allocation once they have grown to `P`).
    ///
    /// # Panics
    /// If `order` is not a permutation of `0..P` of the right length (checked by length only).
    pub fn permute(&mut self, order: &[usize], scratch: &mut Vec<f64>, scratch_index: &mut Vec<usize>) {
        scratch_index.clear();
        self.permute_by(order.len(), |k| order[k], scratch);
    }

    /// [`Particles::permute`] with the order as 32-bit indices and one work buffer.
    ///
    /// # Panics
    /// As [`Particles::permute`].
    pub(crate) fn permute_u32(&mut self, order: &[u32], scratch: &mut Vec<f64>) {
        self.permute_by(order.len(), |k| order[k] as usize, scratch);
    }

    /// Particle `k` of the result is particle `from(k)` before, for the `len` particles.
    fn permute_by(&mut self, len: usize, from: impl Fn(usize) -> usize, scratch: &mut Vec<f64>) {
        let n = self.len();
        assert_eq!(len, n, "the order must list every particle once");
        scratch.resize(n, 0.0);
        for (_, field) in self.fields_mut() {
            if field.is_empty() {
                continue;
            }
            for (k, s) in scratch.iter_mut().enumerate() {
                *s = field[from(k)];
            }
            std::mem::swap(field, scratch);
        }
        // The index fields go through the same buffer as bit patterns, then back.
        for field in self.index_fields_mut() {
            for (k, s) in scratch.iter_mut().enumerate() {
                *s = f64::from_bits(field[from(k)] as u64);
            }
            for (f, s) in field.iter_mut().zip(scratch.iter()) {
                *f = s.to_bits() as usize;
            }
        }
    }
}

fn check_len(field: &'static str, expected: usize, found: usize) -> Result<()> {
    if expected == found {
        Ok(())
    } else {
        Err(MpmError::LengthMismatch { field, expected, found })
    }
}

/// The centres of a regular sub-lattice of `per_cell × per_cell` points in every cell of `grid`
/// that lie inside a region, and the volume each stands for:
///
/// ```text
/// x = x₀ + (i + ½) hx / n,   y = y₀ + (j + ½) hy / n,   V = hx hy / n²      (n = per_cell)
/// ```
///
/// Points come row by row (y outer), x ascending.
pub fn lattice(grid: &Grid, per_cell: usize, inside: impl Fn(f64, f64) -> bool) -> (Vec<f64>, Vec<f64>, f64) {
    lattice_within(grid, per_cell, None, inside)
}

/// [`lattice`] over the lattice points of the box `[min, max]` only (`None`: the whole grid):
/// the same points in the same order where `inside` holds nowhere outside the box, at a cost
/// in the box's points rather than the grid's (a scene of many small bodies on a large grid).
pub fn lattice_within(
    grid: &Grid,
    per_cell: usize,
    bounds: Option<[[f64; 2]; 2]>,
    inside: impl Fn(f64, f64) -> bool,
) -> (Vec<f64>, Vec<f64>, f64) {
    let n = per_cell.max(1);
    let [hx, hy] = grid.cell_size();
    let [ox, oy] = grid.origin();
    let (dx, dy) = (hx / n as f64, hy / n as f64);
    let (is, js) = lattice_ranges(grid, n, bounds);
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for j in js {
        for i in is.clone() {
            let (px, py) = (ox + (i as f64 + 0.5) * dx, oy + (j as f64 + 0.5) * dy);
            if inside(px, py) {
                x.push(px);
                y.push(py);
            }
        }
    }
    (x, y, dx * dy)
}

/// The sub-cell indices along x and y of [`lattice_within`]'s points (`n` per cell and axis)
/// that the box `[min, max]` can hold (`None`: the whole grid): from just below the box to just
/// above it, one more each way, so that rounding cannot drop a point or sub-cell the box holds.
pub(crate) fn lattice_ranges(
    grid: &Grid,
    n: usize,
    bounds: Option<[[f64; 2]; 2]>,
) -> (std::ops::Range<usize>, std::ops::Range<usize>) {
    let [hx, hy] = grid.cell_size();
    let [ox, oy] = grid.origin();
    let [cx, cy] = grid.cells();
    let (dx, dy) = (hx / n as f64, hy / n as f64);
    // Point k of an axis is at o + (k + 1/2) d.
    let range = |lo: f64, hi: f64, o: f64, d: f64, count: usize| -> std::ops::Range<usize> {
        let first = ((lo - o) / d - 0.5).floor() - 1.0;
        let last = ((hi - o) / d - 0.5).ceil() + 2.0;
        if !(first.is_finite() && last.is_finite()) {
            return 0..count;
        }
        let clamp = |v: f64| v.clamp(0.0, count as f64) as usize;
        clamp(first)..clamp(last)
    };
    match bounds {
        Some([min, max]) => (
            range(min[0], max[0], ox, dx, cx * n),
            range(min[1], max[1], oy, dy, cy * n),
        ),
        None => (0..cx * n, 0..cy * n),
    }
}
