//! The axis-aligned manufactured solution at its published amplitude (A = 0.05, uGIMP, FLIP
//! unless stated, Courant number 0.2): the displacement error on 32, 64 and 128 cells for each
//! update scheme and transfer, and for MUSL with FLIP at smaller Courant numbers. With FLIP,
//! MUSL and USF the error grows on the finest grid; USL, PIC and APIC do not.
//!
//! ```text
//! cargo run --release --example finite_amplitude
//! ```

use sparse_mpm::simulation::{Transfer, UpdateScheme};
use sparse_mpm::ShapeFunction;
use sparse_mpm_study::verification::manufactured::{self, AxisAlignedMms};
use sparse_mpm_study::verification::Choices;

fn error(update: UpdateScheme, transfer: Transfer, cfl: f64, cells: usize) -> f64 {
    let choices = Choices {
        shape: ShapeFunction::Gimp { half_width: 0.25 },
        update,
        transfer,
        cfl,
        ..Choices::default()
    };
    manufactured::run(&AxisAlignedMms::default(), cells, &choices)
        .map_or(f64::NAN, |o| o.metric("displacement_error_l2").unwrap_or(f64::NAN))
}

fn main() {
    println!("| update | transfer | Courant number | 32 cells | 64 cells | 128 cells |");
    println!("|---|---|---|---|---|---|");
    let cases = [
        (UpdateScheme::Musl, Transfer::Flip, 0.2),
        (UpdateScheme::Usf, Transfer::Flip, 0.2),
        (UpdateScheme::Usl, Transfer::Flip, 0.2),
        (UpdateScheme::Musl, Transfer::Pic, 0.2),
        (UpdateScheme::Musl, Transfer::Apic, 0.2),
        (UpdateScheme::Musl, Transfer::Flip, 0.1),
        (UpdateScheme::Musl, Transfer::Flip, 0.05),
    ];
    for (update, transfer, cfl) in cases {
        let e: Vec<String> = [32, 64, 128]
            .iter()
            .map(|&c| format!("{:.2e}", error(update, transfer, cfl, c)))
            .collect();
        println!("| {update:?} | {transfer} | {cfl} | {} |", e.join(" | "));
    }
}
