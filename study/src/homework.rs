//! The worked problem (one explicit MPM step on a 6-node grid with 4 particles: shape functions,
//! masses, forces, accelerations, the step; a course assignment, ME 7953 Project II, Fall 2002)
//! solved through the matrix-form API.
//!
//! [`solve`] answers every question 1(A)–4(F) and keeps every quantity in a [`Homework`];
//! [`Homework::report`] prints them labelled by question and [`Homework::to_json`] gives one
//! JSON object. `cargo run --release --example homework [-- --json]` prints either. Nodes and
//! particles are labelled 1-based in the output, as in the assignment; the library counts from
//! 0. docs/homework.md maps each question to the API and says how the assignment's formulas,
//! which lost parentheses in typesetting, are read.

use std::fmt::Write;

use nalgebra::DMatrix;
use serde_json::{json, Value};

use sparse_mpm::error::Result;
use sparse_mpm::grid::Grid;
use sparse_mpm::mass::{Constraints, GridMass, MassOptions, MassScheme, Role};
use sparse_mpm::material::{LinearElastic, PlaneCondition};
use sparse_mpm::operators::Operators;
use sparse_mpm::particles::Particles;
use sparse_mpm::shape::{dshape, shape, ShapeFunction};
use sparse_mpm::step::{explicit_step, PositionUpdate, StepOptions, StepRecord};
use sparse_mpm::transfer::{update_positions, StrainRate, VectorField};

/// The assignment's data, exactly as given.
pub mod data {
    /// Node x coordinates `x_g`.
    pub const X_G: [f64; 6] = [0.0, 0.0, 1.0, 1.0, 2.0, 2.0];
    /// Node y coordinates `y_g`.
    pub const Y_G: [f64; 6] = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0];
    /// Particle x coordinates `x_p`.
    pub const X_P: [f64; 4] = [1.2, 1.7, 1.3, 1.8];
    /// Particle y coordinates `y_p`.
    pub const Y_P: [f64; 4] = [0.75, 0.81, 0.26, 0.24];
    /// Mass of every particle.
    pub const MASS: f64 = 1.0;
    /// Volume of every particle.
    pub const VOLUME: f64 = 2.0;
    /// Body force per unit mass `(b_x, b_y)` of every particle.
    pub const BODY_FORCE: [f64; 2] = [5.0, 10.0];
    /// Particle velocities `vx_p`.
    pub const VX: [f64; 4] = [1.25, 1.1, 0.9, 0.8];
    /// Particle velocities `vy_p`.
    pub const VY: [f64; 4] = [0.25, 0.3, 0.33, 0.34];
    /// Stresses `sigxx_p`.
    pub const SXX: [f64; 4] = [-5.1, -4.7, -4.1, -3.5];
    /// Stresses `sigyy_p`.
    pub const SYY: [f64; 4] = [-0.1, -0.2, -0.25, -0.3];
    /// Stresses `sigxy_p`.
    pub const SXY: [f64; 4] = [2.1, 2.2, 2.3, 2.5];
    /// Time step.
    pub const DT: f64 = 0.001;
    /// Young's modulus.
    pub const E: f64 = 100.0;
    /// Poisson's ratio.
    pub const NU: f64 = 0.3;
}

use data::*;

/// Every answer of the assignment. Matrices are nodes × particles (or nodes × nodes), 0-based.
#[derive(Debug)]
pub struct Homework {
    /// The grid recovered from `x_g`, `y_g`.
    pub grid: Grid,
    /// The particles before the step.
    pub particles: Particles,
    /// The particles after the step (the assignment's position rule).
    pub after: Particles,
    /// 1(A): `shape(n, x_p, y_p)` for every node and particle.
    pub shape_values: DMatrix<f64>,
    /// 1(B): `dshape(n, x_p, y_p).0`.
    pub shape_dx: DMatrix<f64>,
    /// 1(B): `dshape(n, x_p, y_p).1`.
    pub shape_dy: DMatrix<f64>,
    /// 1(C): `N(3,2)` (1-based).
    pub n_3_2: f64,
    /// 1(D): the operator N as a dense matrix.
    pub n: DMatrix<f64>,
    /// The operator Gx as a dense matrix.
    pub gx: DMatrix<f64>,
    /// The operator Gy as a dense matrix.
    pub gy: DMatrix<f64>,
    /// 1(D): column sums of N.
    pub column_sums: Vec<f64>,
    /// 2(A): the consistent mass matrix.
    pub mass_matrix: DMatrix<f64>,
    /// 2(C): its row sums.
    pub row_sums: Vec<f64>,
    /// 3(C): accelerations with the consistent mass, beside the lumped ones in `step`.
    pub acceleration_consistent: VectorField,
    /// 4(C): positions by the standard rule `x + Δt Nᵀ v̄'`.
    pub position_standard: VectorField,
    /// 4(F): the stress update literally as typed (no `Δt`, shear `G ε̇xy`), `[σxx, σyy, σxy]`.
    pub stress_literal: [Vec<f64>; 3],
    /// 2(B), 3(A)–4(E): every intermediate quantity of the step.
    pub step: StepRecord,
}

/// The assignment's grid (recovered from `x_g`, `y_g`), particles (positions, masses, volumes,
/// velocities, stresses, body force) and plane-stress material, before the step.
///
/// # Errors
/// None in practice: the assignment's data are valid.
pub fn setup() -> Result<(Grid, Particles, LinearElastic)> {
    let grid = Grid::from_node_coordinates(&X_G, &Y_G)?;
    let np = X_P.len();
    let particles = Particles::new(X_P.to_vec(), Y_P.to_vec(), vec![MASS; np], vec![VOLUME; np])?
        .with_velocity(VX.to_vec(), VY.to_vec())?
        .with_stress(SXX.to_vec(), SYY.to_vec(), SXY.to_vec())?
        .with_uniform_body_force(BODY_FORCE[0], BODY_FORCE[1])?;
    let material = LinearElastic::new(E, NU, PlaneCondition::Stress)?;
    Ok((grid, particles, material))
}

/// Solves the assignment.
///
/// # Errors
/// None in practice: the assignment's data are valid. The signature is a `Result` because every
/// step of the computation checks its inputs.
pub fn solve() -> Result<Homework> {
    let (grid, particles, material) = setup()?;
    let np = particles.len();

    // Question 1: shape functions pointwise, and as the operators N, Gx, Gy.
    let nodes = grid.num_nodes();
    let pointwise = |f: &dyn Fn(usize, usize) -> f64| DMatrix::from_fn(nodes, np, f);
    let shape_values = pointwise(&|n, p| shape(&grid, n, X_P[p], Y_P[p]));
    let shape_dx = pointwise(&|n, p| dshape(&grid, n, X_P[p], Y_P[p]).0);
    let shape_dy = pointwise(&|n, p| dshape(&grid, n, X_P[p], Y_P[p]).1);
    let n_3_2 = shape(&grid, 2, X_P[1], Y_P[1]);
    let ops = Operators::assemble(&grid, ShapeFunction::Linear, &particles)?;
    let n = DMatrix::from(&ops.n_matrix());
    let column_sums = (0..np).map(|p| n.column(p).sum()).collect();

    // Question 2: the consistent mass matrix (the lumped mass is step (2) below).
    let consistent = GridMass::new(
        &ops,
        &particles.mass,
        &MassOptions::plain(MassScheme::Consistent),
        &Constraints::none(),
    )?;
    let mass_matrix = DMatrix::from(&*consistent.consistent_matrix().expect("consistent mass requested"));
    let row_sums = (0..nodes).map(|i| mass_matrix.row(i).sum()).collect();

    // Questions 3 and 4: one explicit step with the assignment's position rule.
    let mut after = particles.clone();
    let options = StepOptions {
        dt: DT,
        position_update: PositionUpdate::Trapezoidal,
        ..StepOptions::default()
    };
    let step = explicit_step(&grid, &mut after, &material, &options)?;
    let total_force = step.external_force.add_scaled(1.0, &step.internal_force);
    let (acceleration_consistent, _) = consistent.solve(Role::Acceleration, &total_force, None, &ops)?;
    let mut position_standard = VectorField {
        x: particles.x.clone(),
        y: particles.y.clone(),
    };
    update_positions(
        &ops,
        &mut position_standard.x,
        &mut position_standard.y,
        &step.updated_grid_velocity,
        DT,
    );
    let stress_literal = literal_stress_update(&material, &particles, &step.strain_rate);

    Ok(Homework {
        gx: DMatrix::from(&ops.gx_matrix()),
        gy: DMatrix::from(&ops.gy_matrix()),
        grid,
        particles,
        after,
        shape_values,
        shape_dx,
        shape_dy,
        n_3_2,
        n,
        column_sums,
        mass_matrix,
        row_sums,
        acceleration_consistent,
        position_standard,
        stress_literal,
        step,
    })
}

/// The assignment's 4(F) exactly as typed: `C ε̇` added without `Δt`, shear `G ε̇xy`.
fn literal_stress_update(material: &LinearElastic, p: &Particles, rate: &StrainRate) -> [Vec<f64>; 3] {
    let (c11, c12) = material.normal_stiffness();
    let g = material.shear_modulus();
    let n = p.len();
    [
        (0..n).map(|i| p.sxx[i] + c11 * rate.xx[i] + c12 * rate.yy[i]).collect(),
        (0..n).map(|i| p.syy[i] + c12 * rate.xx[i] + c11 * rate.yy[i]).collect(),
        (0..n).map(|i| p.sxy[i] + g * rate.xy[i]).collect(),
    ]
}

impl Homework {
    /// Active nodes, 1-based as in the assignment.
    pub fn active_nodes_1_based(&self) -> Vec<usize> {
        self.step.mass.active_nodes().iter().map(|i| i + 1).collect()
    }

    /// One JSON object with every quantity, keyed by question (`"2A_mass_matrix"` …).
    /// Matrices are lists of rows; arrays are in node or particle order.
    pub fn to_json(&self) -> Value {
        let m = |d: &DMatrix<f64>| -> Value {
            (0..d.nrows())
                .map(|i| d.row(i).iter().cloned().collect::<Vec<_>>())
                .collect()
        };
        let v = |f: &VectorField| json!({"x": f.x, "y": f.y});
        let (s, a, r) = (&self.step, &self.after, &self.step.strain_rate);
        json!({
            "conventions": {
                "indexing": "arrays in node order 1..6 or particle order 1..4; matrices are lists of rows (nodes)",
                "node_order": "y-fastest, as the assignment's x_g, y_g",
                "4C_position_seed_rule": "x + dt/2 (v_p + N^T v_grid_updated)",
                "4C_position_standard": "x + dt N^T v_grid_updated",
                "4F_stress": "sigma + C:(strain_rate dt), plane stress, shear 2 G exy",
                "4F_stress_literal_as_typed": "sigma + C strain_rate (no dt), shear G exy",
            },
            "grid": {"x_g": self.grid.node_x(), "y_g": self.grid.node_y()},
            "1A_shape_N": m(&self.shape_values),
            "1B_dshape_dN_dx": m(&self.shape_dx),
            "1B_dshape_dN_dy": m(&self.shape_dy),
            "1C_N_3_2": self.n_3_2,
            "1D_N": m(&self.n),
            "1D_column_sums": self.column_sums,
            "Gx": m(&self.gx),
            "Gy": m(&self.gy),
            "2A_mass_matrix": m(&self.mass_matrix),
            "2B_lumped_mass": s.mass.lumped(),
            "2C_row_sums": self.row_sums,
            "active_nodes": self.active_nodes_1_based(),
            "3A_external_force": v(&s.external_force),
            "3B_internal_force": v(&s.internal_force),
            "3C_acceleration_lumped": v(&s.acceleration),
            "3C_acceleration_consistent": v(&self.acceleration_consistent),
            "4A_grid_velocity": v(&s.grid_velocity),
            "4B_updated_grid_velocity": v(&s.updated_grid_velocity),
            "4C_position_seed_rule": {"x": a.x, "y": a.y},
            "4C_position_standard": v(&self.position_standard),
            "4D_velocity": {"x": a.vx, "y": a.vy},
            "4E_strain_rate": {"xx": r.xx, "yy": r.yy, "xy": r.xy},
            "4F_stress": {"xx": a.sxx, "yy": a.syy, "xy": a.sxy},
            "4F_stress_literal_as_typed": {"xx": self.stress_literal[0], "yy": self.stress_literal[1], "xy": self.stress_literal[2]},
        })
    }

    /// The answers as readable text, labelled by question, 7 significant digits.
    pub fn report(&self) -> String {
        let mut out = String::new();
        self.write_report(&mut out).expect("writing to a String cannot fail");
        out
    }

    /// Writes [`Homework::report`]: the data, then the answers question by question.
    fn write_report(&self, out: &mut String) -> std::fmt::Result {
        self.write_data(out)?;
        self.write_shape_functions(out)?;
        self.write_masses(out)?;
        self.write_forces_and_accelerations(out)?;
        self.write_step(out)
    }

    /// The heading and the assignment's grid and particles.
    fn write_data(&self, out: &mut String) -> std::fmt::Result {
        writeln!(
            out,
            "One explicit MPM step worked by hand: bilinear shape functions, masses, forces, the step\n(the ME 7953 Project II problem; nodes n = 1..6, particles p = 1..4)\n"
        )?;
        writeln!(
            out,
            "Grid: x_g = {:?}, y_g = {:?} (nodes numbered up each column)",
            X_G, Y_G
        )?;
        writeln!(
            out,
            "Particles: x_p = {X_P:?}, y_p = {Y_P:?}, m = {MASS}, V = {VOLUME}\n"
        )
    }

    /// Question 1: shape functions and their gradients at the particles, `N(3,2)`, the
    /// operator N and its column sums, each checked against the operators.
    fn write_shape_functions(&self, out: &mut String) -> std::fmt::Result {
        section(
            out,
            "1(A) shape(n, x, y) at every particle: N(n)(x_p, y_p)",
            "shape(&grid, n - 1, x, y)",
        )?;
        table(out, &self.shape_values, "n", "p")?;
        section(
            out,
            "1(B) dshape(n, x, y) at every particle",
            "dshape(&grid, n - 1, x, y)",
        )?;
        writeln!(out, "dN/dx:")?;
        table(out, &self.shape_dx, "n", "p")?;
        writeln!(out, "dN/dy:")?;
        table(out, &self.shape_dy, "n", "p")?;
        let gap = max_diff(&self.shape_dx, &self.gx).max(max_diff(&self.shape_dy, &self.gy));
        writeln!(
            out,
            "(the operators Gx, Gy hold the same numbers: max difference {gap:.1e})\n"
        )?;
        section(
            out,
            "1(C) N(3,2): node 3 at (1.0, 0.0), particle 2 at (1.7, 0.81)",
            "shape(&grid, 2, 1.7, 0.81)",
        )?;
        writeln!(out, "N(3,2) = {}\n", sig(self.n_3_2))?;
        section(
            out,
            "1(D) the operator N (nodes x particles) and its column sums",
            "Operators::n_matrix",
        )?;
        table(out, &self.n, "n", "p")?;
        writeln!(out, "sum_n N(n,p) for p = 1..4: {}", join(&self.column_sums))?;
        writeln!(
            out,
            "(N equals shape() entrywise: max difference {:.1e})\n",
            max_diff(&self.shape_values, &self.n)
        )
    }

    /// Question 2: the consistent mass matrix, the lumped mass, and the row sums of the one
    /// against the other.
    fn write_masses(&self, out: &mut String) -> std::fmt::Result {
        let lumped = self.step.mass.lumped();
        section(
            out,
            "2(A) mass matrix m(n,n') = sum_p N(n',p) N(n,p) m(p)",
            "mass::consistent_mass",
        )?;
        table(out, &self.mass_matrix, "n", "n'")?;
        section(out, "2(B) lumped mass M(n) = sum_p N(n,p) m(p)", "mass::lumped_mass")?;
        for (i, m) in lumped.iter().enumerate() {
            writeln!(out, "  n = {}: {:>13}", i + 1, sig(*m))?;
        }
        writeln!(out)?;
        section(out, "2(C) row sums of the mass matrix vs the lumped mass", "")?;
        for (i, (rs, m)) in self.row_sums.iter().zip(lumped).enumerate() {
            writeln!(
                out,
                "  n = {}: sum_n' m(n,n') = {:>12}   M(n) = {:>12}   difference {:.1e}",
                i + 1,
                sig(*rs),
                sig(*m),
                rs - m
            )?;
        }
        writeln!(out)
    }

    /// Question 3: the external and internal nodal forces, and the accelerations with the
    /// lumped and the consistent mass side by side.
    fn write_forces_and_accelerations(&self, out: &mut String) -> std::fmt::Result {
        let s = &self.step;
        section(out, "3(A) external force F = N (m o b)", "transfer::external_force")?;
        nodal(out, &s.external_force)?;
        section(
            out,
            "3(B) internal force f = -(Gx (V o sxx) + Gy (V o sxy), Gx (V o sxy) + Gy (V o syy))",
            "transfer::internal_force",
        )?;
        nodal(out, &s.internal_force)?;
        section(
            out,
            "3(C) acceleration a = (F + f)/M(n) at nodes with mass; consistent mass beside it",
            "GridMass::solve",
        )?;
        writeln!(
            out,
            "active nodes (non-zero lumped mass): {:?}",
            self.active_nodes_1_based()
        )?;
        writeln!(
            out,
            "  {:>4} {:>14} {:>14} | {:>14} {:>14}",
            "n", "a_x lumped", "a_y lumped", "a_x consistent", "a_y consistent"
        )?;
        let c = &self.acceleration_consistent;
        for i in 0..s.acceleration.len() {
            let (ax, ay) = (sig(s.acceleration.x[i]), sig(s.acceleration.y[i]));
            writeln!(
                out,
                "  {:>4} {:>14} {:>14} | {:>14} {:>14}",
                i + 1,
                ax,
                ay,
                sig(c.x[i]),
                sig(c.y[i])
            )?;
        }
        writeln!(out, "(nodes without mass get exactly 0)\n")
    }

    /// Question 4: the grid velocities, then the particles' positions (both rules),
    /// velocities, strain rates and stresses (also as literally typed) after the step.
    fn write_step(&self, out: &mut String) -> std::fmt::Result {
        let (s, a, r, lit) = (&self.step, &self.after, &self.step.strain_rate, &self.stress_literal);
        section(
            out,
            "4(A) grid velocity v = N (m o v_p) / M(n)",
            "transfer::momentum, GridMass::solve",
        )?;
        nodal(out, &s.grid_velocity)?;
        section(out, "4(B) updated grid velocity v + a dt", "VectorField::add_scaled")?;
        nodal(out, &s.updated_grid_velocity)?;
        section(
            out,
            "4(C) positions, the assignment's rule x + dt/2 (v_p + sum_n N v_n)",
            "PositionUpdate::Trapezoidal",
        )?;
        per_particle(out, ["x", "y"], [&a.x, &a.y])?;
        writeln!(
            out,
            "standard MPM rule x + dt sum_n N v_n [PositionUpdate::GridVelocity]:"
        )?;
        per_particle(out, ["x", "y"], [&self.position_standard.x, &self.position_standard.y])?;
        section(
            out,
            "4(D) particle velocities v + dt sum_n N a_n",
            "transfer::update_velocities",
        )?;
        per_particle(out, ["vx", "vy"], [&a.vx, &a.vy])?;
        section(
            out,
            "4(E) strain rates from the updated grid velocities",
            "transfer::strain_rate",
        )?;
        per_particle(out, ["exx", "eyy", "exy"], [&r.xx, &r.yy, &r.xy])?;
        section(
            out,
            "4(F) stresses sigma + C:(strain rate dt), plane stress, E = 100, nu = 0.3",
            "LinearElastic::update_stress",
        )?;
        per_particle(out, ["sxx", "syy", "sxy"], [&a.sxx, &a.syy, &a.sxy])?;
        writeln!(
            out,
            "The formula literally as typed (C times the rate without dt, shear G exy):"
        )?;
        per_particle(out, ["sxx", "syy", "sxy"], [&lit[0], &lit[1], &lit[2]])
    }
}

/// `v` to 7 significant digits, without an exponent for ordinary magnitudes.
fn sig(v: f64) -> String {
    if v == 0.0 {
        return "0".to_string();
    }
    let magnitude = v.abs().log10().floor() as i32;
    if !(-4..=8).contains(&magnitude) {
        return format!("{v:.6e}");
    }
    let decimals = (6 - magnitude).max(0) as usize;
    format!("{v:.decimals$}")
}

fn join(v: &[f64]) -> String {
    v.iter().map(|x| sig(*x)).collect::<Vec<_>>().join(", ")
}

fn max_diff(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).abs().max()
}

fn section(out: &mut String, title: &str, api: &str) -> std::fmt::Result {
    if api.is_empty() {
        writeln!(out, "{title}")
    } else {
        writeln!(out, "{title}    [{api}]")
    }
}

fn table(out: &mut String, m: &DMatrix<f64>, row: &str, col: &str) -> std::fmt::Result {
    write!(out, "  {:>6}", "")?;
    for j in 0..m.ncols() {
        write!(out, " {:>13}", format!("{col}={}", j + 1))?;
    }
    writeln!(out)?;
    for i in 0..m.nrows() {
        write!(out, "  {:>6}", format!("{row}={}", i + 1))?;
        for j in 0..m.ncols() {
            write!(out, " {:>13}", sig(m[(i, j)]))?;
        }
        writeln!(out)?;
    }
    writeln!(out)
}

fn nodal(out: &mut String, f: &VectorField) -> std::fmt::Result {
    writeln!(out, "  {:>4} {:>14} {:>14}", "n", "x", "y")?;
    for i in 0..f.len() {
        writeln!(out, "  {:>4} {:>14} {:>14}", i + 1, sig(f.x[i]), sig(f.y[i]))?;
    }
    writeln!(out)
}

fn per_particle<const K: usize>(out: &mut String, names: [&str; K], v: [&Vec<f64>; K]) -> std::fmt::Result {
    write!(out, "  {:>4}", "p")?;
    for name in names {
        write!(out, " {name:>14}")?;
    }
    writeln!(out)?;
    for p in 0..v[0].len() {
        write!(out, "  {:>4}", p + 1)?;
        for field in v {
            write!(out, " {:>14}", sig(field[p]))?;
        }
        writeln!(out)?;
    }
    writeln!(out)
}
