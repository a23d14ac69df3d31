//! `cargo xtask image-diff A B`: how two dataset folders differ, image by image in decoded
//! pixels (two PNGs that encode the same pixels differently are the same image) and byte by
//! byte for every other file. The measure behind "N of M images differ by P pixels" in the
//! docs whenever a change moves the images.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use tacsim_sim::read_png;

/// What two folders' comparison found.
#[derive(Debug, Default, PartialEq)]
pub struct Difference {
    /// PNGs in both folders.
    pub images: usize,
    /// Of those, the ones whose pixels differ.
    pub images_differing: usize,
    /// Differing pixels over all images, and the most in one image.
    pub pixels: u64,
    pub pixels_max: u64,
    /// Other files in both folders whose bytes differ (relative paths).
    pub files_differing: Vec<PathBuf>,
    /// Files in only one of the folders (relative paths).
    pub only_in_one: Vec<PathBuf>,
}

impl Difference {
    /// Whether the folders hold the same pixels and the same other files.
    pub fn is_same(&self) -> bool {
        self.images_differing == 0 && self.files_differing.is_empty() && self.only_in_one.is_empty()
    }
}

/// Every file under `dir`, relative to it.
fn files(dir: &Path) -> Result<BTreeSet<PathBuf>> {
    let mut out = BTreeSet::new();
    let mut stack = vec![PathBuf::new()];
    while let Some(rel) = stack.pop() {
        let here = dir.join(&rel);
        for entry in std::fs::read_dir(&here).with_context(|| format!("reading the folder {}", here.display()))? {
            let entry = entry.with_context(|| format!("reading the folder {}", here.display()))?;
            let path = rel.join(entry.file_name());
            if entry.file_type()?.is_dir() {
                stack.push(path);
            } else {
                out.insert(path);
            }
        }
    }
    Ok(out)
}

/// Compares the folders `a` and `b`.
pub fn compare(a: &Path, b: &Path) -> Result<Difference> {
    for dir in [a, b] {
        if !dir.is_dir() {
            bail!("{} is not a folder: give two dataset folders (`cargo xtask image-diff A B`)", dir.display());
        }
    }
    let (in_a, in_b) = (files(a)?, files(b)?);
    let mut diff =
        Difference { only_in_one: in_a.symmetric_difference(&in_b).cloned().collect(), ..Default::default() };
    for rel in in_a.intersection(&in_b) {
        let (pa, pb) = (a.join(rel), b.join(rel));
        if rel.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
            let (ia, ib) = (read_png(&pa)?, read_png(&pb)?);
            diff.images += 1;
            let pixels = if ia.dimensions() != ib.dimensions() {
                u64::from(ia.width().max(ib.width())) * u64::from(ia.height().max(ib.height()))
            } else {
                ia.as_raw().iter().zip(ib.as_raw()).filter(|(x, y)| x != y).count() as u64
            };
            if pixels > 0 {
                diff.images_differing += 1;
                diff.pixels += pixels;
                diff.pixels_max = diff.pixels_max.max(pixels);
            }
        } else {
            let read = |p: &Path| std::fs::read(p).with_context(|| format!("reading {}", p.display()));
            if read(&pa)? != read(&pb)? {
                diff.files_differing.push(rel.clone());
            }
        }
    }
    Ok(diff)
}

/// Prints the comparison of `a` and `b`; an error (exit status 1) when they differ.
pub fn run(a: &Path, b: &Path) -> Result<()> {
    let d = compare(a, b)?;
    println!(
        "{} of {} images differ, by {} pixels in all (at most {} in one image)",
        d.images_differing, d.images, d.pixels, d.pixels_max
    );
    for f in &d.files_differing {
        println!("differs: {}", f.display());
    }
    for f in &d.only_in_one {
        println!("only in one folder: {}", f.display());
    }
    if !d.is_same() {
        bail!("{} and {} differ", a.display(), b.display());
    }
    println!("the same pixels and files");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use tacsim_sim::{PngDepth, write_png};

    #[test]
    fn the_same_pixels_in_another_encoding_are_the_same_image() {
        let root = std::env::temp_dir().join(format!("xtask-image-diff-{}", std::process::id()));
        let (a, b) = (root.join("a"), root.join("b"));
        for d in [&a, &b] {
            std::fs::create_dir_all(d.join("images")).expect("mkdir");
        }
        let mut img = image::GrayImage::new(16, 4);
        img.put_pixel(3, 2, image::Luma([255]));
        write_png(&a.join("images/0.png"), &img, PngDepth::Grey8).expect("png");
        write_png(&b.join("images/0.png"), &img, PngDepth::OneBit).expect("png");
        std::fs::write(a.join("targets.csv"), "x\n1\n").expect("csv");
        std::fs::write(b.join("targets.csv"), "x\n1\n").expect("csv");
        assert!(compare(&a, &b).expect("compare").is_same());

        img.put_pixel(0, 0, image::Luma([255]));
        img.put_pixel(1, 0, image::Luma([255]));
        write_png(&b.join("images/0.png"), &img, PngDepth::Grey8).expect("png");
        std::fs::write(b.join("targets.csv"), "x\n2\n").expect("csv");
        std::fs::write(b.join("extra.txt"), "").expect("extra");
        let d = compare(&a, &b).expect("compare");
        assert_eq!((d.images, d.images_differing, d.pixels, d.pixels_max), (1, 1, 2, 2));
        assert_eq!(d.files_differing, vec![PathBuf::from("targets.csv")]);
        assert_eq!(d.only_in_one, vec![PathBuf::from("extra.txt")]);
        std::fs::remove_dir_all(&root).ok();
    }
}
