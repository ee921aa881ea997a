//! `mpm render` and `mpm plot` on a real run: the two-disk impact run by the program, its
//! frames and GIF decoded back (with the png and gif decoders, not the code that wrote them),
//! the particles found in the pixels where the snapshots put them, and the report plot written.

#[path = "../../tests/common/scratch.rs"]
mod scratch;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use sparse_mpm_cli::render::viridis;
use sparse_mpm_cli::vtk::{read_pvd, read_vtp};

fn mpm(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mpm"))
        .args(args)
        .output()
        .expect("the mpm binary runs")
}

fn ok(o: Output) -> String {
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "{text}");
    text
}

fn scratch(name: &str) -> scratch::Scratch {
    scratch::Scratch::new("render", name)
}

/// The RGB pixels of a PNG, and its size.
fn decode_png(path: &Path) -> (Vec<u8>, u32, u32) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb, "{}", path.display());
    buf.truncate(info.buffer_size());
    (buf, info.width, info.height)
}

/// Whether a pixel is a colour of the viridis map (within the rounding of the drawing), not the
/// white, black and greys of the background, frame and text.
fn is_viridis(p: &[u8]) -> bool {
    (0..=200).any(|k| {
        let c = viridis(f64::from(k) / 200.0);
        [c.0, c.1, c.2].iter().zip(p).all(|(a, b)| a.abs_diff(*b) <= 3)
    }) && !(p[0] == p[1] && p[1] == p[2])
}

#[test]
fn a_run_renders_to_frames_and_a_gif_that_decode_and_show_its_particles() {
    let dir = scratch("two_disks");
    let run = dir.join("run");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/two_disks.toml");
    ok(mpm(&["run", scene, "--out", run.to_str().unwrap(), "--quiet"]));
    let text = ok(mpm(&["render", run.to_str().unwrap(), "--grid"]));
    assert!(text.contains("frame(s)"), "{text}");
    let snapshots = read_pvd(&run.join("particles.pvd")).unwrap();

    // One PNG per snapshot, each of the size the program reports, with particles in it.
    let frames_dir = run.join("frames_velocity");
    let mut frames: Vec<PathBuf> = std::fs::read_dir(&frames_dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    frames.sort();
    assert_eq!(frames.len(), snapshots.len());
    let (first, width, height) = decode_png(&frames[0]);
    assert!(text.contains(&format!("{width} × {height} pixels")), "{text}");
    let coloured = |rgb: &[u8]| rgb.chunks_exact(3).filter(|p| is_viridis(p)).count();
    let (last, ..) = decode_png(frames.last().unwrap());
    let particles = read_vtp(&snapshots[0].1).unwrap().len();
    for rgb in [&first, &last] {
        // Each particle is a disk of a few pixels: at least one coloured pixel per particle.
        assert!(
            coloured(rgb) >= particles,
            "{} coloured pixels for {particles} particles",
            coloured(rgb)
        );
    }
    assert_ne!(first, last, "the particles moved between the first and the last frame");

    // The particles are where the snapshot puts them: the first frame's coloured pixels lie
    // in the two disks (centres 0.2 and 0.8 of the unit grid along the diagonal, radius 0.2),
    // mapped by the frame's plot box (from its black border).
    let px = |x: u32, y: u32| &first[((y * width + x) * 3) as usize..((y * width + x) * 3 + 3) as usize];
    let border: Vec<u32> = (0..width).filter(|&x| px(x, height / 2) == [0, 0, 0]).collect();
    // The plot's left and right borders (the colour bar's come after them).
    let (left, right) = (border[0], *border.iter().find(|&&x| x > border[0] + 1).unwrap());
    let side = f64::from(right - left);
    let top = (0..height).find(|&y| px(right - 5, y) == [0, 0, 0]).unwrap();
    let mut outside = 0;
    for y in top..top + side as u32 {
        for x in left..right {
            if is_viridis(px(x, y)) {
                let (gx, gy) = (f64::from(x - left) / side, 1.0 - f64::from(y - top) / side);
                let near = |c: f64| ((gx - c).powi(2) + (gy - c).powi(2)).sqrt() < 0.2 + 0.05;
                if !near(0.2) && !near(0.8) {
                    outside += 1;
                }
            }
        }
    }
    assert_eq!(outside, 0, "coloured pixels outside the two disks");

    // The GIF: one frame per snapshot, of the same size, and its first frame has the particles.
    let file = std::fs::File::open(run.join("velocity.gif")).unwrap();
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::RGBA);
    let mut decoder = options.read_info(file).unwrap();
    assert_eq!(
        (u32::from(decoder.width()), u32::from(decoder.height())),
        (width, height)
    );
    let mut count = 0;
    while let Some(frame) = decoder.read_next_frame().unwrap() {
        if count == 0 {
            let rgb: Vec<u8> = frame.buffer.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
            let non_white = rgb.chunks_exact(3).filter(|p| p != &[255, 255, 255]).count();
            assert!(non_white >= particles, "{non_white} non-white GIF pixels");
        }
        count += 1;
    }
    assert_eq!(count, snapshots.len());

    // A component, a fixed scale, every 10th frame into another folder, no GIF.
    let other = dir.join("pictures");
    let text = ok(mpm(&[
        "render",
        run.to_str().unwrap(),
        "--field",
        "stress:xy",
        "--range",
        "-50",
        "50",
        "--every",
        "10",
        "--no-gif",
        "--out",
        other.to_str().unwrap(),
    ]));
    assert!(text.contains("from -5.000000e1 to 5.000000e1"), "{text}");
    let written = std::fs::read_dir(other.join("frames_stress_xy")).unwrap().count();
    assert_eq!(
        written,
        snapshots.len().div_ceil(10) + usize::from(!(snapshots.len() - 1).is_multiple_of(10))
    );
    assert!(!other.join("stress_xy.gif").exists());

    // Mistakes are named.
    for (args, expected) in [
        (vec!["--field", "speed"], "the arrays are id, body, mass"),
        (vec!["--field", "stress"], "give a component, e.g. `stress:xy`"),
        (vec!["--every", "0"], "every"),
    ] {
        let mut all = vec!["render", run.to_str().unwrap()];
        all.extend(args);
        let o = mpm(&all);
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(expected), "{err}");
    }
    let o = mpm(&["render", dir.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("no .pvd series here"));

    // The report plot.
    let text = ok(mpm(&["plot", run.to_str().unwrap()]));
    assert!(text.contains("report.png"), "{text}");
    let (rgb, w, h) = decode_png(&run.join("report.png"));
    assert_eq!((w, h), (900, 1000));
    assert!(rgb.chunks_exact(3).filter(|p| p != &[255, 255, 255]).count() > 10_000);
    std::fs::remove_dir_all(dir).unwrap();
}
