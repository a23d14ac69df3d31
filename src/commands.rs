//! One function per `tacsim` subcommand. Library errors carry file and field; this layer adds
//! what the user was doing (anyhow context).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use tacsim_sim::contact::ContactModel;
use tacsim_sim::stimulus::Catalogue;
use tacsim_sim::{
    ObjectPose, PinLayout, PinPose, PinRenderer, PngDepth, Realism, Scene, SensorParams, SensorPath, SensorPose,
    SkinModel, detect_blobs, write_png,
};

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

/// The sensor a command simulates: a file or built-in preset, with the overrides a user may
/// give on the command line. [`SensorArgs::load`] is the one loader behind them.
#[derive(Args, Clone, Debug, Default)]
pub struct SensorArgs {
    /// Sensor TOML or built-in preset (tactip-331-calibrated, tactip-331-camera,
    /// tactip-331-edge2d, tactip-331-dome, tactip-331-edge2d-dome; default: tactip-331-dome,
    /// the TacTip calibrated to the lab's flat-surface recordings with its finite-element
    /// dome, on `run` and `bench` tactip-331-calibrated, the same TacTip over a half-space;
    /// with --skin alone, that TacTip as fitted for the body named).
    #[arg(long)]
    pub sensor: Option<PathBuf>,
    /// Pin count, centred hexagonal (331 default, 127, ...).
    #[arg(long)]
    pub pins: Option<usize>,
    /// Elastic body behind the skin: half-space, layer, skin-on-gel or dome (default: the
    /// sensor's skin.model).
    #[arg(long)]
    pub skin: Option<SkinModel>,
}

impl SensorArgs {
    /// The sensor named (or the built-in calibrated TacTip, as fitted for the `--skin` body
    /// where one is named), with the pin count and skin model given.
    pub fn load(&self) -> Result<SensorParams> {
        self.load_or(SensorParams::default)
    }

    /// [`SensorArgs::load`] with `default` where neither `--sensor` nor `--skin` names one.
    pub fn load_or(&self, default: fn() -> SensorParams) -> Result<SensorParams> {
        let mut sensor = match (&self.sensor, self.skin) {
            (Some(p), _) => sensor_file_or_preset(&p.to_string_lossy(), None)?,
            (None, Some(m)) => SensorParams::calibrated_for(m),
            (None, None) => default(),
        };
        if let Some(n) = self.pins {
            sensor = sensor.with_pin_count(n)?;
        }
        if let Some(m) = self.skin {
            sensor.skin.model = m;
        }
        Ok(sensor)
    }
}

/// Options of `tacsim render`.
#[derive(Args, Clone, Debug)]
pub struct RenderOptions {
    /// The sensor drawn.
    #[command(flatten)]
    pub sensor: SensorArgs,
    /// Image size in px (default: the sensor's camera.image_size, 256).
    #[arg(long)]
    pub size: Option<u32>,
    /// Grey rendering with blur and noise, then the lab's adaptive threshold and mask.
    #[arg(long, conflicts_with = "grey")]
    pub realism: bool,
    /// Write the raw grey frame (blur and noise, no threshold).
    #[arg(long)]
    pub grey: bool,
    /// Noise seed for --realism / --grey.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Write a 1-bit PNG (binary images only).
    #[arg(long)]
    pub one_bit: bool,
    /// Output PNG.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Press onto this stimulus (see `tacsim shapes`); without it the sensor is undeformed.
    #[arg(long)]
    pub shape: Option<String>,
    /// Catalogue directory for --shape (default: the built-in shapes).
    #[arg(long)]
    pub shapes_dir: Option<PathBuf>,
    /// Pose over the stimulus: `x,y,depth,yaw[,rx,ry]` (mm, deg); depth below the top face.
    #[arg(long, value_parser = parse_pose, default_value = "0,0,2,0", allow_hyphen_values = true)]
    pub pose: SensorPose,
    /// Touch down at pose + dx,dy (mm) and slide to the pose; without it the sensor taps.
    #[arg(long, value_parser = parse_offset, allow_hyphen_values = true)]
    pub slide_from: Option<[f64; 2]>,
    /// Largest slide step (mm).
    #[arg(long = "step", value_name = "MM", default_value_t = 0.25)]
    pub step_mm: f64,
}

impl RenderOptions {
    /// The rendering mode the flags ask for.
    pub fn mode(&self) -> RenderMode {
        if self.realism {
            RenderMode::Realistic
        } else if self.grey {
            RenderMode::Grey
        } else {
            RenderMode::Binary
        }
    }
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
    let model = ContactModel::new(sensor).context("building the contact model")?;
    let frames = path.run(&model, &scene).context("solving the contact")?;
    let frame = frames.last().context("the path captured no frame")?;
    let r = &frame.report;
    let summary = if r.in_contact {
        format!(
            "; {} over `{shape}`: indentation {:.3} mm, normal force {:.3} N, shear ({:.3}, {:.3}) N, {} contact \
             cells ({} slipping)",
            if opts.slide_from.is_some() { "slide" } else { "tap" },
            r.indentation_mm,
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

/// The folders a command made for its outputs. Dropped, each one still empty is removed
/// again (the deepest first), so a run that fails leaves no empty folder behind (issue 88:
/// `sim2real --out A --report FILE/x` and `calibrate` with a bad `--edge-contact` left `A/`
/// and `NAME-report/`). Hold it until the command ends.
#[must_use = "hold it until the command ends, or its folders are removed at once"]
pub struct MadeDirs(Vec<PathBuf>);

impl MadeDirs {
    /// One guard for both, `later`'s folders (which may lie inside these) removed first.
    pub fn and(mut self, mut later: MadeDirs) -> MadeDirs {
        later.0.append(&mut self.0);
        MadeDirs(std::mem::take(&mut later.0))
    }
}

impl Drop for MadeDirs {
    fn drop(&mut self) {
        for dir in &self.0 {
            // Only an empty folder goes: one the run wrote into stays.
            let _ = std::fs::remove_dir(dir);
        }
    }
}

/// Creates `dir` and checks that files can be written in it, before any work; the folders it
/// made are removed again, where still empty, when the guard is dropped.
pub fn ensure_writable(dir: &Path) -> Result<MadeDirs> {
    let made = MadeDirs(
        dir.ancestors().take_while(|a| !a.as_os_str().is_empty() && !a.exists()).map(Path::to_owned).collect(),
    );
    std::fs::create_dir_all(dir).with_context(|| format!("creating {} for the output", dir.display()))?;
    let probe = dir.join(".tacsim-write-check");
    std::fs::write(&probe, b"").with_context(|| format!("{} is not writable", dir.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(made)
}

/// Checks before any work that the file `path` can be written: not a folder, in a folder
/// that exists or can be made and takes a file ([`ensure_writable`]). Regression (issue 88):
/// `bench --plot` under a file or in /proc, and `calibrate -o` naming a folder, failed only
/// after the computation, whose results were then lost.
pub fn ensure_file_writable(path: &Path) -> Result<MadeDirs> {
    anyhow::ensure!(!path.is_dir(), "{} is a folder: name the file to write", path.display());
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    ensure_writable(dir).with_context(|| format!("{} cannot be written", path.display()))
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
    let sensor = opts.sensor.load()?;
    let size = opts.size.unwrap_or(sensor.camera.image_size);
    let renderer = PinRenderer::new(&sensor, size)?;
    let (pins, contact) = pressed_pins(&sensor, opts)?;
    let realism = Realism { seed: opts.seed, ..Realism::default() };
    let (img, depth) = match opts.mode() {
        RenderMode::Binary => (renderer.render(&pins), if opts.one_bit { PngDepth::OneBit } else { PngDepth::Grey8 }),
        RenderMode::Realistic => {
            (realism.render(&renderer, &pins)?, if opts.one_bit { PngDepth::OneBit } else { PngDepth::Grey8 })
        }
        RenderMode::Grey => (realism.grey_frame(&renderer, &pins), PngDepth::Grey8),
    };
    write_png(&opts.output, &img, depth).with_context(|| format!("writing {}", opts.output.display()))?;
    let blobs =
        if opts.mode() == RenderMode::Grey { String::new() } else { format!(", {} blobs", detect_blobs(&img).len()) };
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
        None => tacsim_sim::builtin_catalogue().context("loading the built-in shapes"),
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
