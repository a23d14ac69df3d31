//! Fuzz properties (issue 32): random and adversarial bytes, and absurd but parseable numbers
//! in otherwise valid files, fed to every parser and validator of what users write: sensor,
//! recipe and scenario TOML, dataset and lab CSV, OBJ meshes, PNG images. Each must give a
//! clear error or a valid result, never a panic; a valid result must then be usable (a sensor
//! builds its contact model and renderer, a recipe its plan); and every numeric flag of the
//! command line (issue 88), where the command must end with a clear error or its result,
//! never a panic, an abort or a hang. The case counts keep the whole file to seconds.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use proptest::prelude::*;
use tacsim_sim::contact::ContactModel;
use tacsim_sim::dataset::Plan;
use tacsim_sim::dataset::Recipe;
use tacsim_sim::stimulus::{Catalogue, Mesh};
use tacsim_sim::{PinRenderer, SensorParams};

mod common;

/// Values that have broken parsers and validators elsewhere: signs, zeros, extremes, the
/// non-finite, integer overflow, and values of the wrong type.
const ADVERSARIAL: [&str; 20] = [
    "0",
    "-0.0",
    "-1",
    "1e300",
    "-1e300",
    "1e-300",
    "nan",
    "inf",
    "-inf",
    "18446744073709551615",
    "9223372036854775807",
    "-9223372036854775808",
    "0.5",
    "3",
    "1000000",
    "\"x\"",
    "[]",
    "[1e300, -1e300]",
    "[nan, 1.0]",
    "true",
];

/// `text` with the value of its `index`-th `key = value` line (modulo their count) replaced by
/// `value`.
fn mutate(text: &str, index: usize, value: &str) -> String {
    let assignments: Vec<usize> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim_start().starts_with('#') && l.contains(" = "))
        .map(|(i, _)| i)
        .collect();
    if assignments.is_empty() {
        return text.to_owned();
    }
    let target = assignments[index % assignments.len()];
    text.lines()
        .enumerate()
        .map(
            |(i, l)| {
                if i == target { format!("{} = {value}", l.split(" = ").next().unwrap_or(l)) } else { l.to_owned() }
            },
        )
        .collect::<Vec<_>>()
        .join("\n")
}

/// An adversarial value, or a random finite or non-finite number.
fn value() -> impl Strategy<Value = String> {
    prop_oneof![
        (0..ADVERSARIAL.len()).prop_map(|i| ADVERSARIAL[i].to_owned()),
        any::<f64>().prop_map(|v| format!("{v:?}")),
        any::<i64>().prop_map(|v| v.to_string()),
    ]
}

/// Random bytes, mostly printable (TOML- and CSV-like), sometimes anything.
fn text() -> impl Strategy<Value = String> {
    prop_oneof![
        "[ -~\n\\[\\]=\"#.,]{0,400}",
        prop::collection::vec(any::<u8>(), 0..400).prop_map(|b| String::from_utf8_lossy(&b).into_owned()),
    ]
}

fn catalogue() -> &'static Catalogue {
    static C: OnceLock<Catalogue> = OnceLock::new();
    C.get_or_init(|| tacsim::commands::load_catalogue(None).expect("the built-in catalogue"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = common::fresh_path("fuzz", name);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

/// A validated sensor must build what every command builds from it.
fn use_sensor(s: &SensorParams) {
    let _ = ContactModel::new(s).expect("contact model");
    let _ = PinRenderer::new(s, s.camera.image_size.min(256));
}

/// A validated recipe must plan (kept small: a valid recipe may ask for millions of poses).
fn use_recipe(r: &Recipe) {
    if r.poses.per_shape * r.shapes.len() <= 5_000 {
        let _ = Plan::new(r, catalogue(), "fuzz");
    }
}

const SENSORS: [&str; 2] =
    [include_str!("../sim/presets/tactip-331-calibrated.toml"), include_str!("../sim/presets/tactip-331-edge2d.toml")];
const RECIPES: [&str; 3] = [
    include_str!("../scenarios/datasets/quick.toml"),
    include_str!("../scenarios/datasets/edge-2d.toml"),
    include_str!("../scenarios/datasets/surface-3d.toml"),
];
/// Every numeric flag of the commands, `{}` standing for the value. Each command's output is
/// one it cannot write (a path under /proc) or its input an empty folder, so that an accepted
/// value ends at that check instead of running the command's whole work.
const FLAGS: [&str; 29] = [
    "render -o OUT --size {}",
    "render -o OUT --pins {}",
    "render -o OUT --seed {} --grey",
    "render -o OUT --shape disk --pose {},0,1,0",
    "render -o OUT --shape disk --pose 0,0,{},0",
    "render -o OUT --shape disk --pose 0,0,1,{}",
    "render -o OUT --shape disk --pose 0,0,1,0,{},0",
    "render -o OUT --shape disk --slide-from {},0",
    "render -o OUT --shape disk --slide-from 1,0 --step {}",
    "generate quick --out /proc/tacsim-fuzz --size {}",
    "generate quick --out /proc/tacsim-fuzz --cells {}",
    "generate quick --out /proc/tacsim-fuzz --seed {}",
    "generate quick --out /proc/tacsim-fuzz --threads {}",
    "bench --plot /proc/tacsim-fuzz.svg --samples {}",
    "bench --plot /proc/tacsim-fuzz.svg --cells {}",
    "bench --plot /proc/tacsim-fuzz.svg --edge-subcells {}",
    "bench --plot /proc/tacsim-fuzz.svg --pins {}",
    "train posenet --data EMPTY --out OUT --epochs {}",
    "train posenet --data EMPTY --out OUT --batch {}",
    "train posenet --data EMPTY --out OUT --size {}",
    "train posenet --data EMPTY --out OUT --max-batches {}",
    "train unshear --data EMPTY --out OUT --lr-scale {}",
    "train unshear --data EMPTY --out OUT --label-fraction {}",
    "sim2real --real EMPTY --out OUT --epochs {}",
    "sim2real --real EMPTY --out OUT --size {}",
    "sim2real --real EMPTY --out OUT --threshold {}",
    "sim2real --real EMPTY --out OUT --input motion --turns {}",
    "eval --data EMPTY --out OUT --max-pairs {} EMPTY",
    "calibrate --real EMPTY -o /proc/tacsim-fuzz.toml --edge square --edge-contact {},0",
];

/// Runs `tacsim args`, killed after `limit` (a hang, not a speed check): `None` where it
/// had to be killed.
fn run_bounded(args: &[String], limit: std::time::Duration) -> Option<std::process::Output> {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_tacsim"))
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("tacsim runs");
    let start = std::time::Instant::now();
    loop {
        if child.try_wait().expect("wait").is_some() {
            return Some(child.wait_with_output().expect("output"));
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
}

const SCENARIO: &str = include_str!("../scenarios/explore/disk-geometric.toml");
const OBJ: &str = "v 0 0 0\nv 10 0 0\nv 0 10 0\nv 0 0 10\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn sensor_files_are_an_error_or_a_usable_sensor(t in text(), which in 0..2usize, i in 0..200usize, v in value()) {
        if let Ok(s) = SensorParams::from_toml_str(&t, "fuzz.toml") {
            use_sensor(&s);
        }
        if let Ok(s) = SensorParams::from_toml_str(&mutate(SENSORS[which], i, &v), "fuzz.toml") {
            use_sensor(&s);
        }
    }

    #[test]
    fn recipes_are_an_error_or_a_plan(t in text(), which in 0..3usize, i in 0..200usize, v in value()) {
        if let Ok(r) = Recipe::from_toml_str(&t, "fuzz.toml") {
            use_recipe(&r);
        }
        if let Ok(r) = Recipe::from_toml_str(&mutate(RECIPES[which], i, &v), "fuzz.toml") {
            use_recipe(&r);
        }
    }

    #[test]
    fn scenarios_are_an_error_or_a_scenario(t in text(), i in 0..100usize, v in value()) {
        let dir = scratch("scenario");
        for body in [t, mutate(SCENARIO, i, &v)] {
            let f = dir.join("s.toml");
            std::fs::write(&f, body).expect("write");
            let _ = tacsim_explore::Scenario::load(&f);
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn obj_meshes_are_an_error_or_a_solid(t in text(), i in 0..40usize, v in value()) {
        let _ = Mesh::from_obj_str(&t, "fuzz.obj");
        // A valid tetrahedron with one coordinate or index replaced.
        let mut words: Vec<String> = OBJ.split(' ').map(str::to_owned).collect();
        let k = i % words.len();
        let keep_newline = words[k].ends_with('\n');
        words[k] = if keep_newline { format!("{v}\n") } else { v };
        let _ = Mesh::from_obj_str(&words.join(" "), "fuzz.obj");
    }

    #[test]
    fn command_line_numbers_are_an_error_or_a_result(which in 0..FLAGS.len(), v in value()) {
        let dir = scratch("flags");
        let empty = dir.join("empty");
        std::fs::create_dir_all(&empty).expect("empty");
        let out = dir.join("out");
        let v = v.trim_matches('"').replace(['[', ']', ' '], "");
        let args: Vec<String> = FLAGS[which]
            .split(' ')
            .map(|a| a.replace("{}", &v).replace("OUT", &out.to_string_lossy()).replace("EMPTY", &empty.to_string_lossy()))
            .collect();
        // The limit only tells a hang from a run: a refused value ends in milliseconds.
        let o = run_bounded(&args, std::time::Duration::from_secs(60));
        let Some(o) = o else { panic!("tacsim {args:?} still ran after 60 s") };
        let err = String::from_utf8_lossy(&o.stderr);
        prop_assert!(o.status.code().is_some(), "tacsim {:?} died on a signal: {}", args, err);
        prop_assert!(!err.contains("panicked") && !err.contains("memory allocation"), "tacsim {:?}: {}", args, err);
        prop_assert!(o.status.success() || err.contains("rror"), "tacsim {:?} failed without an error: {}", args, err);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn png_bytes_are_an_error_or_an_image(bytes in prop::collection::vec(any::<u8>(), 0..300), at in any::<usize>(), flip in any::<u8>()) {
        let _ = tacsim_sim::decode_png(&bytes, Path::new("fuzz.png"));
        let mut valid = Vec::new();
        image::GrayImage::from_fn(9, 7, |x, y| image::Luma([((x * 31 + y * 7) % 256) as u8]))
            .write_to(&mut std::io::Cursor::new(&mut valid), image::ImageFormat::Png)
            .expect("encode");
        let k = at % valid.len();
        valid[k] ^= flip;
        let _ = tacsim_sim::decode_png(&valid, Path::new("fuzz.png"));
    }

    #[test]
    fn csv_files_are_an_error_or_rows(t in text(), line in 0..4usize, field in 0..20usize, v in value()) {
        let dir = scratch("csv");
        std::fs::create_dir_all(dir.join("images")).expect("images");
        let header = "sensor_image,pose_1,pose_2,pose_3,pose_4,pose_5,pose_6,move_1,move_2,move_3,move_4,move_5,move_6";
        let mut rows: Vec<Vec<String>> = (1..4)
            .map(|k| {
                let mut r = vec![format!("image_{k}.png")];
                r.extend((0..12).map(|j| format!("{}", 0.5 * (k + j) as f64)));
                r
            })
            .collect();
        let r = line % rows.len();
        let f = field % rows[r].len();
        rows[r][f] = v;
        let body = std::iter::once(header.to_owned()).chain(rows.iter().map(|r| r.join(","))).collect::<Vec<_>>().join("\n");
        for text in [t, body] {
            std::fs::write(dir.join("targets.csv"), text).expect("write");
            let _ = tacsim_data::read_csv(&dir.join("targets.csv"));
            let _ = tacsim_data::LabFolder::open(&dir);
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
