//! (10) of the implicit steps (Newmark's and the quasi-static one): the particles moved,
//! strained and given their velocities by the explicit step's grid-to-particle pass, with the
//! converged grid displacement over the step as its motion field.

use super::phases::{particle_phases, StepInput, StepOutput};
use super::{Options, Setup, State};
use crate::error::{MpmError, Result};
use crate::fields::VectorField;
use crate::transfer::interpolate;

/// (10) of an implicit step: the grid-to-particle pass with the motion field `u/Δt` and the
/// grid velocities `w` (`None`: the particles come to rest), after checking that every particle
/// stays where the shape functions accept it.
pub(super) fn move_by(
    input: StepInput,
    out: StepOutput,
    u: &[f64],
    w: Option<&[f64]>,
    dt: f64,
    step: usize,
) -> Result<()> {
    let mut out = out;
    let n = out.cache.ops.num_nodes();
    let motion = VectorField {
        x: u[..n].iter().map(|u| u / dt).collect(),
        y: u[n..].iter().map(|u| u / dt).collect(),
    };
    let moved = interpolate(&out.cache.ops, &motion);
    inside(input.options, input.setup, out.state, &moved, dt, step)?;
    let nodes = &mut out.cache.nodes;
    nodes.motion = motion;
    match w {
        Some(w) => {
            nodes.updated.x.copy_from_slice(&w[..n]);
            nodes.updated.y.copy_from_slice(&w[n..]);
        }
        None => {
            for field in [&mut nodes.projected, &mut nodes.updated] {
                field.x.iter_mut().chain(field.y.iter_mut()).for_each(|v| *v = 0.0);
            }
        }
    }
    particle_phases(input, out.reborrow(), dt)
}

/// A field's x components, then its y components.
pub(super) fn stacked(f: &VectorField) -> Vec<f64> {
    [&f.x[..], &f.y[..]].concat()
}

/// Whether the particles moved by `Δt Nᵀ w` (`moved`, the interpolated motion field) stay
/// where the shape functions accept them; the step's error naming the first that does not.
fn inside(options: &Options, setup: &Setup, state: &State, moved: &VectorField, dt: f64, step: usize) -> Result<()> {
    let [x0, x1, y0, y1] = options.shape.allowed_region(&setup.grid);
    let p = &state.particles;
    let to = |q: usize| [p.x[q] + dt * moved.x[q], p.y[q] + dt * moved.y[q]];
    let Some(q) = (0..p.len()).find(|&q| {
        let [x, y] = to(q);
        !(x >= x0 && x <= x1 && y >= y0 && y <= y1)
    }) else {
        return Ok(());
    };
    let [x, y] = to(q);
    Err(MpmError::StepRejected {
        step,
        reason: format!(
            "the converged step moves particle {q} from ({:.6}, {:.6}) to ({x:.6}, {y:.6}), outside the region \
             [{x0}, {x1}] x [{y0}, {y1}] where the {} shape functions accept particles: take a smaller time.dt",
            p.x[q],
            p.y[q],
            options.shape.name()
        ),
    })
}
