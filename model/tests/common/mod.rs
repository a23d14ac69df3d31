//! A tiny synthetic dataset in tacsim's format for the model tests (the model crate never
//! depends on the simulator): a lattice of pins, pushed outward around the contact point of
//! the pose (position x, y; the push is stretched along the yaw), and, for slides, moved as a
//! whole by the touch-down offset (the global shear).

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use image::{GrayImage, Luma};
use tacsim_data::to_csv;
use tacsim_data::{Kind, Meta, Row, Split};

/// A fresh scratch directory for a test.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tacsim-model-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

/// Renders a synthetic pin image of side `side`.
pub fn render(side: usize, pose: [f64; 3], shear: [f64; 2]) -> GrayImage {
    let mut img = GrayImage::new(side as u32, side as u32);
    let s = side as f64 / 64.0;
    let spacing = 8.0 * s;
    let (cx, cy) = (side as f64 / 2.0 + 2.0 * s * pose[0], side as f64 / 2.0 + 2.0 * s * pose[1]);
    let (c, sn) = (pose[2].to_radians().cos(), pose[2].to_radians().sin());
    let mut pins = Vec::new();
    let mut row = 0;
    let mut y = spacing / 2.0;
    while y < side as f64 {
        let mut x = spacing / 2.0 + if row % 2 == 1 { spacing / 2.0 } else { 0.0 };
        while x < side as f64 {
            // Push outward from the contact point, stronger along the yaw direction.
            let (dx, dy) = (x - cx, y - cy);
            let along = dx * c + dy * sn;
            let across = -dx * sn + dy * c;
            let r2 = (along / 1.6).powi(2) + across.powi(2);
            let push = 3.0 * s * (-r2 / (2.0 * (10.0 * s).powi(2))).exp();
            let r = (dx * dx + dy * dy).sqrt().max(1e-9);
            pins.push((x + push * dx / r + 1.5 * s * shear[0], y + push * dy / r + 1.5 * s * shear[1]));
            x += spacing;
        }
        y += spacing * 0.866;
        row += 1;
    }
    let radius = 2.2 * s;
    for (px, py) in pins {
        for yy in (py - radius).floor().max(0.0) as i64..=((py + radius).ceil() as i64).min(side as i64 - 1) {
            for xx in (px - radius).floor().max(0.0) as i64..=((px + radius).ceil() as i64).min(side as i64 - 1) {
                if (xx as f64 - px).powi(2) + (yy as f64 - py).powi(2) <= radius * radius {
                    img.put_pixel(xx as u32, yy as u32, Luma([255]));
                }
            }
        }
    }
    img
}

/// Writes a dataset: `poses` poses of one shape (split 8:2:2 of 12 by default order, the
/// first `paired` training poses paired), `taps` taps and `slides` slides per pose.
pub fn write_dataset(dir: &Path, side: usize, poses: usize, taps: usize, slides: usize, paired: usize) {
    std::fs::create_dir_all(dir.join("images")).expect("images dir");
    let mut rows = Vec::new();
    let mut k = 1;
    let n_test = poses / 6;
    let n_val = poses / 6;
    let n_train = poses - n_test - n_val;
    render(side, [0.0, 0.0, 0.0], [0.0, 0.0]).save(dir.join("images/image_0.png")).expect("reference");
    for p in 0..poses {
        let f = |a: f64| ((p as f64 * a).sin() * 43758.5453).fract().abs();
        let pose = [10.0 * f(12.9898) - 5.0, 10.0 * f(78.233) - 5.0, 90.0 * f(37.719) - 45.0];
        let split = if p < n_train {
            Split::Train
        } else if p < n_train + n_val {
            Split::Val
        } else {
            Split::Test
        };
        for kind in [Kind::Tap, Kind::Slide] {
            let count = if kind == Kind::Tap { taps } else { slides };
            for i in 0..count {
                let shear = if kind == Kind::Slide {
                    let g = |a: f64| ((((p * 31 + i) as f64) * a).sin() * 12345.678).fract();
                    [2.5 * g(1.7), 2.5 * g(2.9)]
                } else {
                    [0.0, 0.0]
                };
                let name = format!("image_{k}.png");
                render(side, pose, shear).save(dir.join("images").join(&name)).expect("image");
                rows.push(Row {
                    sensor_image: name,
                    pose_x: pose[0],
                    pose_y: pose[1],
                    pose_z: -3.0,
                    pose_rx: 0.0,
                    pose_ry: 0.0,
                    pose_rz: pose[2],
                    shear_x: shear[0],
                    shear_y: shear[1],
                    shear_z: 0.0,
                    shear_rx: 0.0,
                    shear_ry: 0.0,
                    shear_rz: 0.0,
                    kind,
                    shape: "disk".into(),
                    pose_id: p,
                    split,
                    paired: split == Split::Train && p < paired,
                    ..Default::default()
                });
                k += 1;
            }
        }
    }
    let meta = Meta {
        format: Meta::FORMAT,
        tool: "synthetic test data".into(),
        seed: 0,
        image_size: side as u32,
        samples: rows.len(),
        taps: poses * taps,
        slides: poses * slides,
        reference_image: "image_0.png".into(),
        recipe: serde_json::json!({"poses": {"x_mm": [-5.0, 5.0], "y_mm": [-5.0, 5.0], "yaw_deg": [-45.0, 45.0]}}),
        sensor: serde_json::json!({}),
        shard: None,
    };
    std::fs::write(dir.join("meta.json"), meta.to_json().expect("meta")).expect("meta.json");
    std::fs::write(dir.join("targets.csv"), to_csv(&rows).expect("csv")).expect("targets.csv");
}
