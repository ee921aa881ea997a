//! The per-particle updates that follow a particle's sums: (12)–(13), the stress update from the
//! velocity gradient, and the particle sums of the step report. Each is written once, for one
//! particle or four side by side ([`Real`]), and run both inside the grid-to-particle pass
//! (USL, [`super::g2p`]) and as a pass of its own (USF, MUSL).

use crate::fields::{deformation_increment_of, mat2_mul};
use crate::lanes::Real;
use crate::material::Prepared;
use crate::parallel::Splittable;

/// Eight partial sums (or maxima) over a block of particles: particle `j` of the block goes to
/// partial `j mod 8`, so that four or eight particles side by side add lane by lane. The
/// partials are added in order at the end ([`Partials::sum`]); every build and any thread count
/// gives the same bits.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Partials(pub [f64; 8]);

impl Partials {
    /// Adds the lanes of `v`, particles `j …`, to their partials.
    #[inline(always)]
    pub(crate) fn add<R: Real>(&mut self, j: usize, v: R) {
        let at = Self::at::<R>(j);
        (R::load(&self.0, at) + v).store(&mut self.0, at);
    }

    /// The first partial of particles `j …` side by side (a constant for eight lanes, so that
    /// the partials of a block's eight-lane loop can stay in a register).
    #[inline(always)]
    fn at<R: Real>(j: usize) -> usize {
        debug_assert!(
            j.is_multiple_of(R::LANES),
            "particles side by side start at a multiple of their count"
        );
        if R::LANES == 8 {
            0
        } else {
            j % 8
        }
    }

    /// Raises the partials to the lanes of `v` (`v.max(partial)`: a NaN in `v` leaves the
    /// partial as it is).
    #[inline(always)]
    pub(crate) fn max<R: Real>(&mut self, j: usize, v: R) {
        let at = Self::at::<R>(j);
        v.max(R::load(&self.0, at)).store(&mut self.0, at);
    }

    /// Adds `v` to the partial of particle `j` alone.
    #[inline(always)]
    pub(crate) fn add_one(&mut self, j: usize, v: f64) {
        self.0[j % 8] += v;
    }

    /// Raises the partial of particle `j` alone to `v` (as [`Partials::max`]).
    #[inline(always)]
    pub(crate) fn max_one(&mut self, j: usize, v: f64) {
        let p = &mut self.0[j % 8];
        *p = Real::max(v, *p);
    }

    /// `(…((s₀ + s₁) + s₂) … ) + s₇`.
    pub fn sum(&self) -> f64 {
        self.0.iter().fold(0.0, |a, &b| a + b)
    }

    /// The largest partial.
    pub fn max_all(&self) -> f64 {
        self.0.iter().fold(0.0f64, |m, &v| m.max(v))
    }
}

/// What the stress update of a block of particles returns: its strain energy, the largest
/// `C11 V / m`, and the first inverted particle (index, `det(I + Δt L)`, `det F`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StressSums {
    /// `Σ_p` strain energy.
    pub energy: f64,
    /// `max_p C11_p V_p / m_p` (the squared tangent P-wave speed).
    pub wave_squared: f64,
    /// The first particle with `det(I + Δt L) ≤ 0` or `det F ≤ 0` (or not finite).
    pub inverted: Option<(usize, f64, f64)>,
}

impl StressSums {
    /// The sums of consecutive blocks, in order.
    pub fn total(blocks: impl IntoIterator<Item = StressPartials>) -> StressSums {
        let mut t = StressSums::default();
        for b in blocks {
            t.energy += b.energy.sum();
            t.wave_squared = t.wave_squared.max(b.wave_squared.max_all());
            t.inverted = t.inverted.or(b.inverted);
        }
        t
    }
}

/// [`StressSums`] of one block of particles, in [`Partials`] partials.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StressPartials {
    /// Strain energy.
    pub energy: Partials,
    /// `C11 V / m`.
    pub wave_squared: Partials,
    /// The first inverted particle.
    pub inverted: Option<(usize, f64, f64)>,
}

/// What the stress update writes, per particle of a block: `F`, `σ`, `V`.
pub(crate) struct StressOutput<'a> {
    /// `F` row-major.
    pub f: [&'a mut [f64]; 4],
    /// `σxx, σyy, σxy`.
    pub sigma: [&'a mut [f64]; 3],
    /// `V`.
    pub volume: &'a mut [f64],
}

impl Splittable for StressOutput<'_> {
    fn len(&self) -> usize {
        self.volume.len()
    }
    fn split_at(self, mid: usize) -> (Self, Self) {
        let (f0, f1) = Splittable::split_at(self.f, mid);
        let (s0, s1) = Splittable::split_at(self.sigma, mid);
        let (v0, v1) = Splittable::split_at(self.volume, mid);
        (
            StressOutput {
                f: f0,
                sigma: s0,
                volume: v0,
            },
            StressOutput {
                f: f1,
                sigma: s1,
                volume: v1,
            },
        )
    }
}

/// What the stress update reads besides its outputs: each body's material, each particle's
/// body and mass.
#[derive(Clone, Copy)]
pub(crate) struct StressInput<'a> {
    pub materials: &'a [Prepared],
    pub body: &'a [usize],
    pub mass: &'a [f64],
    pub dt: f64,
}

/// (12) `F ← (I + Δt L) F`, `σ ← material(σ, L, F)`; (13) `V ← V det(I + Δt L)` for the particles
/// `k …` (global index; `j` in the block's `out`), with velocity gradient `l`; their strain
/// energy, wave speed and any inversion into `sums` in particle order. After an inversion in
/// its block (recorded in `sums`) a particle is left as it is.
#[inline(always)]
pub(crate) fn update_stress<R: Real>(
    input: &StressInput,
    l: [R; 4],
    k: usize,
    j: usize,
    out: &mut StressOutput,
    sums: &mut StressPartials,
) {
    if sums.inverted.is_some() {
        return;
    }
    let (g, j_inc) = deformation_increment_of(l, input.dt);
    let old = [
        R::load(out.f[0], j),
        R::load(out.f[1], j),
        R::load(out.f[2], j),
        R::load(out.f[3], j),
    ];
    let f = mat2_mul(g, old);
    let det_f = f[0] * f[3] - f[1] * f[2];
    let volume = R::load(out.volume, j) * j_inc;
    let sigma = [
        R::load(out.sigma[0], j),
        R::load(out.sigma[1], j),
        R::load(out.sigma[2], j),
    ];
    let body = &input.body[k..k + R::LANES];
    let (s, e, c11) = if let [material] = input.materials {
        material.update_with_modulus(sigma, l, f, input.dt, volume)
    } else if body.iter().all(|&b| b == body[0]) {
        input.materials[body[0]].update_with_modulus(sigma, l, f, input.dt, volume)
    } else {
        // Bodies of different materials side by side: lane by lane, with the same operations.
        let each = mixed_bodies(
            input,
            body,
            sigma.map(R::lanes),
            l.map(R::lanes),
            f.map(R::lanes),
            volume.lanes(),
        );
        (
            [0, 1, 2].map(|c| R::from_fn(|i| each[i].0[c])),
            R::from_fn(|i| each[i].1),
            R::from_fn(|i| each[i].2),
        )
    };
    let zero = R::splat(0.0);
    if !(j_inc.all_gt(zero) && det_f.all_gt(zero) && R::splat(f64::INFINITY).all_gt(det_f)) {
        // The block stops at its first inverted particle, which keeps its state, as do the
        // block's particles after it: the state holds together for a checkpoint.
        let (j_inc, det_f) = (j_inc.lanes(), det_f.lanes());
        let i = (0..R::LANES)
            .find(|&i| !(j_inc[i] > 0.0 && det_f[i] > 0.0 && det_f[i].is_finite()))
            .expect("some lane is inverted");
        sums.inverted = Some((k + i, j_inc[i], det_f[i]));
        store_lanes(&f, &s, &volume, j, i, out);
        for lane in 0..i {
            sums.energy.add_one(j + lane, e.lanes()[lane]);
            let wave = c11.lanes()[lane] * volume.lanes()[lane] / input.mass[k + lane];
            sums.wave_squared.max_one(j + lane, wave);
        }
        return;
    }
    sums.energy.add(j, e);
    sums.wave_squared.max(j, c11 * volume / R::load(input.mass, k));
    for c in 0..4 {
        f[c].store(out.f[c], j);
    }
    volume.store(out.volume, j);
    for c in 0..3 {
        s[c].store(out.sigma[c], j);
    }
}

/// Stores the first `count` lanes of `F`, `σ`, `V` at `j …` of the block.
#[inline(never)]
fn store_lanes<R: Real>(f: &[R; 4], s: &[R; 3], volume: &R, j: usize, count: usize, out: &mut StressOutput) {
    for i in 0..count {
        for c in 0..4 {
            out.f[c][j + i] = f[c].lanes()[i];
        }
        for c in 0..3 {
            out.sigma[c][j + i] = s[c].lanes()[i];
        }
        out.volume[j + i] = volume.lanes()[i];
    }
}

/// [`update_stress`]'s material update, lane by lane, where the lanes' particles belong to
/// different bodies (each lane's `σ`, `L`, `F`, `V`; `(σ, energy, C11)` per lane).
#[inline(never)]
#[allow(clippy::type_complexity)]
fn mixed_bodies(
    input: &StressInput,
    body: &[usize],
    sigma: [[f64; 8]; 3],
    l: [[f64; 8]; 4],
    f: [[f64; 8]; 4],
    volume: [f64; 8],
) -> [([f64; 3], f64, f64); 8] {
    let mut each = [([0.0; 3], 0.0, 0.0); 8];
    for (i, e) in each.iter_mut().enumerate().take(body.len()) {
        *e = input.materials[body[i]].update_with_modulus(
            sigma.map(|v| v[i]),
            l.map(|v| v[i]),
            f.map(|v| v[i]),
            input.dt,
            volume[i],
        );
    }
    each
}

/// The particles' sums of the step report, over a block of particles in order.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ParticleSums {
    /// `½ Σ m |v|²`.
    pub kinetic: f64,
    /// `−Σ m (b + g) · x`.
    pub potential: f64,
    /// `Σ m (x × v)`.
    pub angular: f64,
    /// `Σ m`.
    pub mass: f64,
    /// `max |v|`.
    pub max_speed: f64,
    /// `Σ m v`.
    pub momentum: [f64; 2],
    /// The first particle with a non-finite velocity.
    pub non_finite: Option<usize>,
}

impl ParticleSums {
    /// The sums of consecutive blocks, in order.
    pub fn total(blocks: impl IntoIterator<Item = SumPartials>) -> ParticleSums {
        let mut t = ParticleSums::default();
        for b in blocks {
            t.non_finite = t.non_finite.or(b.non_finite);
            t.max_speed = t.max_speed.max(b.max_speed.max_all());
            t.mass += b.mass.sum();
            t.kinetic += b.kinetic.sum();
            t.momentum[0] += b.momentum[0].sum();
            t.momentum[1] += b.momentum[1].sum();
            t.angular += b.angular.sum();
            t.potential += b.potential.sum();
        }
        t
    }
}

/// [`ParticleSums`] of one block of particles, in [`Partials`] partials.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SumPartials {
    /// `½ m |v|²`.
    pub kinetic: Partials,
    /// `−m (b + g) · x`.
    pub potential: Partials,
    /// `m (x × v)`.
    pub angular: Partials,
    /// `m`.
    pub mass: Partials,
    /// `|v|`.
    pub max_speed: Partials,
    /// `m v`.
    pub momentum: [Partials; 2],
    /// The first particle with a non-finite velocity.
    pub non_finite: Option<usize>,
}

/// One particle's or four particles' values for [`SumPartials::add`].
pub(crate) struct SumInput<R> {
    pub x: [R; 2],
    pub v: [R; 2],
    pub m: R,
    pub b: [R; 2],
}

impl SumPartials {
    /// Adds particles `k …` (`j …` in the block) at `x` with velocity `v`, mass `m`, body force
    /// `b` under gravity `g`; a particle with a non-finite speed is only recorded (the speed
    /// taken as `hypot` where the squares overflow).
    #[inline(always)]
    pub(crate) fn add<R: Real>(&mut self, j: usize, k: usize, p: SumInput<R>, [gx, gy]: [f64; 2]) {
        let SumInput {
            x: [x, y],
            v: [vx, vy],
            m,
            b: [bx, by],
        } = p;
        let speed = (vx * vx + vy * vy).sqrt();
        if !R::splat(f64::INFINITY).all_gt(speed) {
            self.add_lanes(j, k, [x, y], [vx, vy], m, [bx, by], [gx, gy]);
            return;
        }
        let half = R::splat(0.5);
        self.max_speed.max(j, speed);
        self.mass.add(j, m);
        self.kinetic.add(j, half * m * (vx * vx + vy * vy));
        self.momentum[0].add(j, m * vx);
        self.momentum[1].add(j, m * vy);
        self.angular.add(j, m * (x * vy - y * vx));
        self.potential
            .add(j, -(m * ((bx + R::splat(gx)) * x + (by + R::splat(gy)) * y)));
    }

    /// [`SumPartials::add`] lane by lane, where some speed is not finite.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn add_lanes<R: Real>(&mut self, j: usize, k: usize, x: [R; 2], v: [R; 2], m: R, b: [R; 2], g: [f64; 2]) {
        let (x, v, m, b) = (x.map(R::lanes), v.map(R::lanes), m.lanes(), b.map(R::lanes));
        for l in 0..R::LANES {
            let (vx, vy) = (v[0][l], v[1][l]);
            let mut speed = (vx * vx + vy * vy).sqrt();
            if speed == f64::INFINITY && vx.is_finite() && vy.is_finite() {
                // Finite but beyond 1e154: the squares overflowed, the speed did not.
                speed = vx.hypot(vy);
            }
            if !speed.is_finite() {
                self.non_finite.get_or_insert(k + l);
                continue;
            }
            let lane = SumInput {
                x: [x[0][l], x[1][l]],
                v: [vx, vy],
                m: m[l],
                b: [b[0][l], b[1][l]],
            };
            let i = j + l;
            let (x, y) = (lane.x[0], lane.x[1]);
            self.max_speed.max_one(i, speed);
            self.mass.add_one(i, lane.m);
            self.kinetic.add_one(i, 0.5 * lane.m * (vx * vx + vy * vy));
            self.momentum[0].add_one(i, lane.m * vx);
            self.momentum[1].add_one(i, lane.m * vy);
            self.angular.add_one(i, lane.m * (x * vy - y * vx));
            self.potential
                .add_one(i, -(lane.m * ((lane.b[0] + g[0]) * x + (lane.b[1] + g[1]) * y)));
        }
    }
}
