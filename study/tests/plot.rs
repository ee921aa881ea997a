//! The PNG charts of `mpm study`: valid files of the asked size, text drawn with the embedded font
//! (no system font), log axes that skip what they cannot show, fitted orders.

use sparse_mpm_study::plot::{write_png, Chart, Series, SeriesStyle};
use sparse_mpm_study::verification::fitted_order;
use std::path::PathBuf;

fn out(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    dir.join(name)
}

/// Decodes an RGB PNG: (width, height, pixels).
fn decode(path: &std::path::Path) -> (u32, u32, Vec<u8>) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes)).read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

/// Pixels darker than mid-grey inside the rectangle `x0..x1 × y0..y1`.
fn dark_pixels(img: &(u32, u32, Vec<u8>), (x0, x1): (u32, u32), (y0, y1): (u32, u32)) -> usize {
    let (w, _, px) = img;
    (y0..y1)
        .flat_map(|y| (x0..x1).map(move |x| ((y * w + x) * 3) as usize))
        .filter(|&i| px[i..i + 3].iter().map(|&c| c as u32).sum::<u32>() < 3 * 128)
        .count()
}

fn convergence_chart() -> Chart {
    let h: Vec<f64> = (3..8).map(|k| 0.5f64.powi(k)).collect();
    Chart {
        title: "Convergence of the L2 error".into(),
        x_label: "cell size h".into(),
        y_label: "L2 error".into(),
        log_x: true,
        log_y: true,
        series: vec![
            Series {
                label: "velocity".into(),
                points: h.iter().map(|&h| (h, 3.0 * h * h)).collect(),
                style: SeriesStyle::LineAndMarkers,
            },
            Series {
                label: "position".into(),
                points: h.iter().map(|&h| (h, 0.4 * h)).collect(),
                style: SeriesStyle::Markers,
            },
            Series {
                label: "order 2".into(),
                points: vec![(h[0], 6.0 * h[0] * h[0]), (h[4], 6.0 * h[4] * h[4])],
                style: SeriesStyle::Dashed,
            },
        ],
    }
}

#[test]
fn fitted_order_of_exact_power_laws() {
    let sq: Vec<(f64, f64)> = [0.1, 0.05, 0.025, 0.0125].iter().map(|&h| (h, 7.0 * h * h)).collect();
    assert!((fitted_order(&sq).unwrap() - 2.0).abs() < 1e-12);
    let inv: Vec<(f64, f64)> = [1.0, 2.0, 4.0, 8.0, 16.0].iter().map(|&n| (n, 3.0 / n)).collect();
    assert!((fitted_order(&inv).unwrap() + 1.0).abs() < 1e-12);
}

#[test]
fn fitted_order_needs_two_valid_points() {
    assert_eq!(fitted_order(&[]), None);
    assert_eq!(fitted_order(&[(1.0, 1.0)]), None);
    assert_eq!(
        fitted_order(&[(1.0, 1.0), (2.0, 0.0), (f64::NAN, 1.0), (-1.0, 2.0)]),
        None
    );
    assert_eq!(fitted_order(&[(2.0, 1.0), (2.0, 3.0)]), None, "all x equal");
    let with_junk = [(1.0, 1.0), (2.0, 4.0), (3.0, f64::INFINITY), (0.0, 5.0)];
    assert!((fitted_order(&with_junk).unwrap() - 2.0).abs() < 1e-12);
}

#[test]
fn writes_valid_png_with_text_and_without_system_fonts() {
    // plotters is built without font-kit, so no system font can be consulted:
    // any text in the image comes from the embedded font.
    let path = out("loglog.png");
    write_png(&convergence_chart(), &path, 900, 600).unwrap();
    let img = decode(&path);
    assert_eq!((img.0, img.1), (900, 600));
    // The caption is the only thing drawn in the top band, centred.
    let title = dark_pixels(&img, (250, 650), (0, 48));
    assert!(title > 300, "title text drawn: {title} dark pixels");
    eprintln!(
        "dark pixels: title band {title}, left margin {}",
        dark_pixels(&img, (0, 100), (100, 500))
    );
    // Left margin (y tick labels + rotated axis description) has text too.
    assert!(dark_pixels(&img, (0, 100), (100, 500)) > 100);
}

#[test]
fn log_axes_skip_non_positive_and_non_finite_points() {
    let mut chart = convergence_chart();
    chart.series[0]
        .points
        .extend([(0.0, 1.0), (1e-3, -2.0), (f64::NAN, 1.0), (1e-2, f64::INFINITY)]);
    let path = out("log_nonpositive.png");
    write_png(&chart, &path, 900, 600).unwrap();
    assert_eq!(decode(&path).0, 900);
}

#[test]
fn empty_chart_writes_no_data_png() {
    let chart = Chart {
        title: "Nothing yet".into(),
        log_y: true,
        ..Chart::default()
    };
    let path = out("empty.png");
    write_png(&chart, &path, 640, 400).unwrap();
    let img = decode(&path);
    assert_eq!((img.0, img.1), (640, 400));
    assert!(
        dark_pixels(&img, (220, 420), (170, 240)) > 100,
        "'no data' drawn in the middle"
    );
    // All points invalid on a log axis counts as empty too.
    let chart = Chart {
        log_x: true,
        series: vec![Series {
            points: vec![(-1.0, 1.0)],
            ..Series::default()
        }],
        ..Chart::default()
    };
    write_png(&chart, &out("empty2.png"), 640, 400).unwrap();
}

#[test]
fn single_point_and_constant_series_render() {
    let chart = Chart {
        series: vec![Series {
            label: "one".into(),
            points: vec![(2.0, 5.0)],
            style: SeriesStyle::Markers,
        }],
        ..Chart::default()
    };
    write_png(&chart, &out("single.png"), 300, 200).unwrap();
    let chart = Chart {
        log_x: true,
        log_y: true,
        ..chart
    };
    write_png(&chart, &out("single_log.png"), 300, 200).unwrap();
}

#[test]
fn extreme_values_do_not_panic() {
    let pts = vec![
        (f64::MAX, f64::MIN_POSITIVE),
        (-f64::MAX, 1e300),
        (0.0, -1e-300),
        (1e-320, 1.0),
    ];
    for (log_x, log_y) in [(false, false), (true, false), (false, true), (true, true)] {
        let series = vec![Series {
            label: "x".into(),
            points: pts.clone(),
            style: SeriesStyle::Dashed,
        }];
        let chart = Chart {
            log_x,
            log_y,
            series,
            ..Chart::default()
        };
        write_png(&chart, &out("extreme.png"), 300, 200).unwrap();
    }
}

#[test]
fn errors_name_the_file() {
    let bad = PathBuf::from("/nonexistent-dir/chart.png");
    let err = write_png(&convergence_chart(), &bad, 900, 600).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains("/nonexistent-dir/chart.png"), "{msg}");
    let err = write_png(&convergence_chart(), &out("tiny.png"), 10, 10).unwrap_err();
    assert!(err.to_string().contains("tiny.png"));
}
