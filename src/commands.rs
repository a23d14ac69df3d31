//! One function per `tacsim` subcommand. Library errors carry file and field; this layer adds
//! what the user was doing (anyhow context).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use tacsim_sim::contact::engine::ContactModel;
use tacsim_sim::contact::pose::SensorPose;
use tacsim_sim::contact::trajectory::{self, Path as SensorPath};
use tacsim_sim::detect::detect_blobs;
use tacsim_sim::pins::{PinLayout, PinPose};
use tacsim_sim::png_io::{PngDepth, write_png};
use tacsim_sim::realism::Realism;
use tacsim_sim::scene::{ObjectPose, Scene};
use tacsim_sim::sensor::SkinModel;
use tacsim_sim::stimulus::Catalogue;
use tacsim_sim::{PinRenderer, SensorParams};

/// How `tacsim render` produces its image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RenderMode {
    /// Exact disc coverage thresholded at 1/2 (default).
    Binary,
    /// Grey frame (blur, noise), then the lab's adaptive threshold and circular mask.
    Realistic,
    /// The grey frame alone (8-bit).
    Grey,
}

/// Options of `tacsim render`.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Sensor TOML; `None` for the built-in calibrated TacTip.
    pub sensor: Option<PathBuf>,
    /// Image size (px); `None` for the sensor's `camera.image_size`.
    pub size: Option<u32>,
    /// Pin count override (centred hexagonal: 127, 331, ...).
    pub pins: Option<usize>,
    /// Elastic model behind the skin; `None` for the sensor's `skin.model`.
    pub skin: Option<SkinModel>,
    /// Rendering mode.
    pub mode: RenderMode,
    /// Noise seed for the realistic modes.
    pub seed: u64,
    /// Write 1-bit instead of 8-bit PNG (binary modes only).
    pub one_bit: bool,
    /// Output PNG.
    pub output: PathBuf,
    /// Press the sensor onto this stimulus (catalogue name); `None` renders the undeformed sensor.
    pub shape: Option<String>,
    /// Catalogue directory for `shape` (default: the built-in shapes).
    pub shapes_dir: Option<PathBuf>,
    /// Sensor pose over the stimulus.
    pub pose: SensorPose,
    /// Touch down this far (mm, world x, y) from the pose and slide to it; `None` taps.
    pub slide_from: Option<[f64; 2]>,
    /// Largest slide step (mm).
    pub step_mm: f64,
}

/// Parses `x,y,depth,yaw[,rx,ry]` (mm, deg).
pub fn parse_pose(text: &str) -> Result<SensorPose, String> {
    SensorPose::from_values(&parse_list(text)?)
}

/// Parses `dx,dy` (mm).
pub fn parse_offset(text: &str) -> Result<[f64; 2], String> {
    match parse_list(text)?.as_slice() {
        [x, y] => Ok([*x, *y]),
        v => Err(format!("expected dx,dy (mm), got {} values", v.len())),
    }
}

fn parse_list(text: &str) -> Result<Vec<f64>, String> {
    text.split(',')
        .map(|t| {
            let v: f64 = t.trim().parse().map_err(|_| format!("`{}` is not a number", t.trim()))?;
            if v.is_finite() { Ok(v) } else { Err(format!("`{}` is not finite", t.trim())) }
        })
        .collect()
}

/// Pins of the sensor pressed as `opts` says, with a one-line contact summary.
fn pressed_pins(sensor: &SensorParams, opts: &RenderOptions) -> Result<(Vec<PinPose>, String)> {
    let Some(shape) = &opts.shape else { return Ok((PinLayout::new(sensor).poses(), String::new())) };
    let catalogue = load_catalogue(opts.shapes_dir.as_deref())?;
    let mut scene = Scene::new();
    scene.add(catalogue.get(shape)?, ObjectPose::default())?;
    let path = match opts.slide_from {
        Some(from) => SensorPath::slide(opts.pose, from, opts.step_mm)?,
        None => SensorPath::tap(opts.pose),
    };
    let model = ContactModel::new(sensor);
    let frames = trajectory::run(&model, &scene, &path).context("solving the contact")?;
    let frame = frames.last().context("the path captured no frame")?;
    let r = &frame.report;
    let summary = if r.in_contact {
        format!(
            "; {} over `{shape}`: normal force {:.3} N, shear ({:.3}, {:.3}) N, {} contact cells ({} slipping)",
            if opts.slide_from.is_some() { "slide" } else { "tap" },
            r.force_n[2],
            r.force_n[0],
            r.force_n[1],
            r.contact_cells,
            r.slip_cells
        )
    } else {
        format!("; no contact with `{shape}` at this pose")
    };
    Ok((frame.pins.clone(), summary))
}

/// Loads the sensor of `path` (or the default) and applies a pin-count override.
pub fn load_sensor(path: Option<&Path>, pins: Option<usize>) -> Result<SensorParams> {
    let sensor = match path {
        Some(p) => sensor_file_or_preset(&p.to_string_lossy(), None)?,
        None => SensorParams::default(),
    };
    match pins {
        Some(n) => Ok(sensor.with_pin_count(n)?),
        None => Ok(sensor),
    }
}

/// Creates `dir` and checks that files can be written in it, before any work.
pub fn ensure_writable(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {} for the output", dir.display()))?;
    let probe = dir.join(".tacsim-write-check");
    std::fs::write(&probe, b"").with_context(|| format!("{} is not writable", dir.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// A sensor named by a file path or, where no such file exists, by a built-in preset's name
/// (`tactip-331-edge2d`); a relative path is taken from `dir` when given.
pub fn sensor_file_or_preset(arg: &str, dir: Option<&Path>) -> Result<SensorParams> {
    let path = dir.map_or_else(|| PathBuf::from(arg), |d| d.join(arg));
    SensorParams::file_or_preset(arg, dir).with_context(|| {
        if path.is_file() {
            "loading the sensor file (see sim/presets/tactip-331-calibrated.toml for the format)".to_owned()
        } else {
            format!("{} does not exist", path.display())
        }
    })
}

/// `tacsim render`: renders the undeformed sensor. Returns a one-line summary.
pub fn render(opts: &RenderOptions) -> Result<String> {
    let mut sensor = load_sensor(opts.sensor.as_deref(), opts.pins)?;
    if let Some(m) = opts.skin {
        sensor.skin.model = m;
    }
    let size = opts.size.unwrap_or(sensor.camera.image_size);
    let renderer = PinRenderer::new(&sensor, size)?;
    let (pins, contact) = pressed_pins(&sensor, opts)?;
    let realism = Realism { seed: opts.seed, ..Realism::default() };
    let (img, depth) = match opts.mode {
        RenderMode::Binary => (renderer.render(&pins), if opts.one_bit { PngDepth::OneBit } else { PngDepth::Grey8 }),
        RenderMode::Realistic => {
            (realism.render(&renderer, &pins)?, if opts.one_bit { PngDepth::OneBit } else { PngDepth::Grey8 })
        }
        RenderMode::Grey => (realism.grey_frame(&renderer, &pins), PngDepth::Grey8),
    };
    write_png(&opts.output, &img, depth).with_context(|| format!("writing {}", opts.output.display()))?;
    let blobs =
        if opts.mode == RenderMode::Grey { String::new() } else { format!(", {} blobs", detect_blobs(&img).len()) };
    Ok(format!(
        "wrote {}: {size}x{size} px, sensor `{}` with {} pins{blobs}{contact}",
        opts.output.display(),
        sensor.name,
        sensor.pin_count()
    ))
}

/// The catalogue of `dir`, or the built-in one.
pub fn load_catalogue(dir: Option<&Path>) -> Result<Catalogue> {
    match dir {
        Some(d) => Catalogue::load_dir(d).with_context(|| format!("loading the shape catalogue in {}", d.display())),
        None => crate::embedded::catalogue().context("loading the built-in shapes"),
    }
}

/// `tacsim shapes`: a table of the stimuli.
pub fn shapes_table(catalogue: &Catalogue) -> String {
    let mut out = format!(
        "{:<10} {:>22} {:>10} {:>10} {:<8} {:>8}  {}\n",
        "shape", "size x*y*z (mm)", "area mm2", "edge mm", "material", "friction", "contact (mm)"
    );
    for s in &catalogue.stimuli {
        let e = s.extent_mm();
        let contact = s.entry.contact_mm.map_or("-".to_owned(), |c| format!("({:.1}, {:.1})", c[0], c[1]));
        out.push_str(&format!(
            "{:<10} {:>22} {:>10.1} {:>10.1} {:<8} {:>8.2}  {}\n",
            s.name(),
            format!("{:.1} x {:.1} x {:.1}", e[0], e[1], e[2]),
            s.contour.area_mm2(),
            s.contour.perimeter_mm(),
            s.entry.material,
            s.entry.friction,
            contact
        ));
    }
    out
}
