//! The tangent stiffness product `K u` without forming `K`, for one particle or for four or
//! eight side by side ([`Real`]): the product of the stable step's LOBPCG.
//!
//! Per particle, from its factored columns ([`Columns`]: along a run `α`, across the runs `β`):
//!
//! ```text
//! ∂u/∂α = Σ_b wβ_b (Σ_a w′α_a u_ab),   ∂u/∂β = Σ_b w′β_b (Σ_a wα_a u_ab)
//! σ = C : sym L,   t = V σ
//! f_ab −= w′α_a wβ_b t_α + wα_a w′β_b t_β      (t_α, t_β: the rows of t along α and β)
//! ```
//!
//! The terms reach the nodes particle after particle (lane after lane), so every lane width
//! gives the same bits.

use super::columns::Columns;
use crate::lanes::dispatch;
use crate::lanes::Real;
#[cfg(target_arch = "x86_64")]
use crate::lanes::{F64x4, F64x8};
use crate::operators::Operators;

/// The internal force of the displacement `u` subtracted from `f` (so that `f = K u` from
/// `f = 0` after a negation), for the particle tangents `[C11, C12, G]`:
///
/// ```text
/// f_I −= Σ_p V_p σ_p ∇N_I(x_p),   σ_p = C_p : sym (Σ_J u_J ⊗ ∇N_J(x_p))
/// ```
///
/// Node `i` is at `i + shift` (wrapping) of `u` and `f`.
///
/// # Panics
/// If a stencil reaches past `u` or `f`, or `volume` and `tangents` do not have one entry per
/// particle.
pub(crate) fn subtract_tangent_forces(
    ops: &Operators,
    volume: &[f64],
    tangents: &[[f64; 3]],
    u: [&[f64]; 2],
    f: [&mut [f64]; 2],
    shift: usize,
) {
    let np = ops.num_particles();
    assert!(
        volume.len() == np && tangents.len() == np,
        "one volume and one tangent per particle"
    );
    crate::with_support!(ops, tangent_block::<S>(ops, volume, tangents, u, f, shift));
}

dispatch! {
    /// The particle loop of [`subtract_tangent_forces`] for a support of `S` nodes per axis.
    fn tangent_block / tangent_block_avx2, tangent_block_avx512 = tangent_block_body(
        ops: &Operators,
        volume: &[f64],
        tangents: &[[f64; 3]],
        u: [&[f64]; 2],
        f: [&mut [f64]; 2],
        shift: usize
    ) -> ()
}

#[inline(always)]
fn tangent_block_body<const S: usize, const V: usize>(
    ops: &Operators,
    volume: &[f64],
    tangents: &[[f64; 3]],
    u: [&[f64]; 2],
    f: [&mut [f64]; 2],
    shift: usize,
) {
    let np = ops.num_particles();
    let [fx, fy] = f;
    let mut k = 0;
    #[cfg(target_arch = "x86_64")]
    {
        while V >= 8 && k + 8 <= np {
            particles::<F64x8, S>(ops, volume, tangents, u, [&mut *fx, &mut *fy], shift, k);
            k += 8;
        }
        while V >= 4 && k + 4 <= np {
            particles::<F64x4, S>(ops, volume, tangents, u, [&mut *fx, &mut *fy], shift, k);
            k += 4;
        }
    }
    while k < np {
        particles::<f64, S>(ops, volume, tangents, u, [&mut *fx, &mut *fy], shift, k);
        k += 1;
    }
}

/// Particles `k … k + R::LANES − 1`.
#[inline(always)]
fn particles<R: Real, const S: usize>(
    ops: &Operators,
    volume: &[f64],
    tangents: &[[f64; 3]],
    [ux, uy]: [&[f64]; 2],
    [fx, fy]: [&mut [f64]; 2],
    shift: usize,
    k: usize,
) {
    let z = R::splat(0.0);
    let cols = Columns::<R, S>::load(ops, k, z, z);
    // Each lane's node `(a, b)` in the fields.
    let node = |l: usize, b: usize, a: usize| (cols.run_start(l, b) + a).wrapping_add(shift);
    let (mut d_along, mut d_across) = ([z; 2], [z; 2]);
    for b in 0..S {
        let (mut w, mut dw) = ([z; 2], [z; 2]);
        for a in 0..S {
            let u = [R::from_fn(|l| ux[node(l, b, a)]), R::from_fn(|l| uy[node(l, b, a)])];
            for c in 0..2 {
                w[c] = w[c] + cols.wa[a] * u[c];
                dw[c] = dw[c] + cols.dwa[a] * u[c];
            }
        }
        for c in 0..2 {
            d_along[c] = d_along[c] + cols.wb[b] * dw[c];
            d_across[c] = d_across[c] + cols.dwb[b] * w[c];
        }
    }
    // `∂u_c/∂x`, `∂u_c/∂y`.
    let (dx, dy) = cols.xy(d_along, d_across);
    let (lxx, lxy, lyx, lyy) = (dx[0], dy[0], dx[1], dy[1]);
    let tangent = |j: usize| R::from_fn(|l| tangents[k + l][j]);
    let (c11, c12, g) = (tangent(0), tangent(1), tangent(2));
    let v = R::load(volume, k);
    let (txx, tyy, txy) = (
        v * (c11 * lxx + c12 * lyy),
        v * (c12 * lxx + c11 * lyy),
        v * (g * (lxy + lyx)),
    );
    // Rows of t along α and across (β) for f_x (`[txx, txy]`) and f_y (`[txy, tyy]`).
    let (x_along, x_across) = cols.xy(txx, txy);
    let (y_along, y_across) = cols.xy(txy, tyy);
    let mut terms = [[[[0.0; 8]; 2]; S]; S];
    for b in 0..S {
        let (xa, xb) = (cols.wb[b] * x_along, cols.dwb[b] * x_across);
        let (ya, yb) = (cols.wb[b] * y_along, cols.dwb[b] * y_across);
        for a in 0..S {
            terms[b][a][0] = (cols.dwa[a] * xa + cols.wa[a] * xb).lanes();
            terms[b][a][1] = (cols.dwa[a] * ya + cols.wa[a] * yb).lanes();
        }
    }
    for l in 0..R::LANES {
        for b in 0..S {
            for a in 0..S {
                let i = node(l, b, a);
                fx[i] -= terms[b][a][0][l];
                fy[i] -= terms[b][a][1][l];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::subtract_tangent_forces;
    use crate::fields::VectorField;
    use crate::{Grid, Operators, Particles, ShapeFunction};

    /// A jittered block (odd count: lanes of eight, then four, then one) and its operators.
    fn block(shape: ShapeFunction) -> (Operators, Particles) {
        let grid = Grid::new([0.0, 0.0], [0.5, 0.5], [12, 10]).unwrap();
        let mut state = 99u64;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for _ in 0..1013 {
            x.push(1.5 + 3.0 * rnd());
            y.push(1.5 + 2.0 * rnd());
        }
        let np = x.len();
        let p = Particles::new(x, y, vec![1.0; np], vec![0.01; np]).unwrap();
        (Operators::assemble(&grid, shape, &p).unwrap(), p)
    }

    #[test]
    fn the_tangent_forces_in_lanes_equal_the_scalar_stiffness_product_and_every_width_the_same_bits() {
        for shape in crate::shape::FAMILIES {
            let (ops, p) = block(shape);
            let n = ops.num_nodes();
            let np = p.len();
            let tangents: Vec<[f64; 3]> = (0..np)
                .map(|k| [2.0 + (k % 7) as f64, 0.5, 0.75 + (k % 3) as f64])
                .collect();
            let u = VectorField {
                x: (0..n).map(|i| ((i * 7 % 11) as f64 - 5.0) * 0.3).collect(),
                y: (0..n).map(|i| ((i * 5 % 13) as f64 - 6.0) * 0.2).collect(),
            };
            let expected = crate::stiffness::apply_tangent_stiffness(&ops, &p.volume, &tangents, &u);
            let scale = expected.x.iter().chain(&expected.y).fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(scale > 0.0, "{shape:?}: a product to compare");
            let mut bits: Option<Vec<u64>> = None;
            for lanes in [1, 4, 8] {
                crate::lanes::set_kernel_lanes(lanes);
                let (mut fx, mut fy) = (vec![0.0; n], vec![0.0; n]);
                subtract_tangent_forces(&ops, &p.volume, &tangents, [&u.x, &u.y], [&mut fx, &mut fy], 0);
                for (got, want) in fx.iter().zip(&expected.x).chain(fy.iter().zip(&expected.y)) {
                    assert!(
                        (-got - want).abs() <= 1e-12 * scale,
                        "{shape:?}, {lanes} lanes: {} against {want}",
                        -got
                    );
                }
                let now: Vec<u64> = fx.iter().chain(&fy).map(|v| v.to_bits()).collect();
                match &bits {
                    None => bits = Some(now),
                    Some(b) => assert!(*b == now, "{shape:?}: {lanes} lanes change the bits"),
                }
            }
            crate::lanes::set_kernel_lanes(8);
        }
    }
}
