//! The label columns of `targets.csv`: what a network can be trained to read from an image.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::row::Row;

/// A label column of `targets.csv` (mm for positions, deg for rotations): the sensor pose
/// `pose_*` and a slide's touch-down offset `shear_*` (see the crate documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[allow(missing_docs)]
pub enum Column {
    #[serde(rename = "pose_x")]
    PoseX,
    #[serde(rename = "pose_y")]
    PoseY,
    #[serde(rename = "pose_z")]
    PoseZ,
    #[serde(rename = "pose_Rx")]
    PoseRx,
    #[serde(rename = "pose_Ry")]
    PoseRy,
    #[serde(rename = "pose_Rz")]
    PoseRz,
    #[serde(rename = "shear_x")]
    ShearX,
    #[serde(rename = "shear_y")]
    ShearY,
    #[serde(rename = "shear_z")]
    ShearZ,
    #[serde(rename = "shear_Rx")]
    ShearRx,
    #[serde(rename = "shear_Ry")]
    ShearRy,
    #[serde(rename = "shear_Rz")]
    ShearRz,
}

impl Column {
    /// How many columns there are.
    pub const COUNT: usize = 12;

    /// Every column, in `targets.csv` order (pose x, y, z, Rx, Ry, Rz, then shear's).
    pub const ALL: [Column; Column::COUNT] = [
        Column::PoseX,
        Column::PoseY,
        Column::PoseZ,
        Column::PoseRx,
        Column::PoseRy,
        Column::PoseRz,
        Column::ShearX,
        Column::ShearY,
        Column::ShearZ,
        Column::ShearRx,
        Column::ShearRy,
        Column::ShearRz,
    ];

    /// Position in [`Column::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// The `targets.csv` header (`pose_x`, `pose_Rz`, `shear_y`, ...).
    pub fn name(self) -> &'static str {
        const NAMES: [&str; Column::COUNT] = [
            "pose_x", "pose_y", "pose_z", "pose_Rx", "pose_Ry", "pose_Rz", "shear_x", "shear_y", "shear_z", "shear_Rx",
            "shear_Ry", "shear_Rz",
        ];
        NAMES[self.index()]
    }

    /// Whether the column is a rotation (deg), else a position (mm).
    pub fn is_angle(self) -> bool {
        self.index() % 6 >= 3
    }

    /// Whether the column is a slide's offset (zero on taps).
    pub fn is_shear(self) -> bool {
        self.index() >= 6
    }

    /// `"mm"` or `"deg"`.
    pub fn unit(self) -> &'static str {
        if self.is_angle() { "deg" } else { "mm" }
    }

    /// The column's value in a row.
    pub fn of(self, row: &Row) -> f64 {
        let i = self.index();
        if i < 6 { row.pose()[i] } else { row.shear()[i - 6] }
    }

    /// Sets the column's value in a row.
    pub fn set(self, row: &mut Row, v: f64) {
        let field = match self.index() {
            0 => &mut row.pose_x,
            1 => &mut row.pose_y,
            2 => &mut row.pose_z,
            3 => &mut row.pose_rx,
            4 => &mut row.pose_ry,
            5 => &mut row.pose_rz,
            6 => &mut row.shear_x,
            7 => &mut row.shear_y,
            8 => &mut row.shear_z,
            9 => &mut row.shear_rx,
            10 => &mut row.shear_ry,
            _ => &mut row.shear_rz,
        };
        *field = v;
    }
}

impl fmt::Display for Column {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Column {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Column::ALL.into_iter().find(|c| c.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Column::ALL.iter().map(|c| c.name()).collect();
            format!("`{s}` is not a label column; the columns are {}", names.join(", "))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_kinds_and_values_agree_with_the_row() {
        let row = Row { pose_z: 3.0, pose_rz: -20.0, shear_x: 1.5, shear_rz: 2.0, ..Row::default() };
        let mut set = Row::default();
        for (k, c) in Column::ALL.into_iter().enumerate() {
            c.set(&mut set, k as f64 + 0.5);
        }
        assert!(Column::ALL.into_iter().enumerate().all(|(k, c)| c.of(&set) == k as f64 + 0.5), "{set:?}");
        for c in Column::ALL {
            assert_eq!(c.name().parse::<Column>(), Ok(c));
            let json = serde_json::to_string(&c).expect("serialise");
            assert_eq!(json, format!("\"{}\"", c.name()));
            assert_eq!(c.is_angle(), c.name().contains('R'), "{c}");
        }
        assert_eq!(Column::PoseZ.of(&row), 3.0);
        assert_eq!(Column::PoseRz.of(&row), -20.0);
        assert_eq!(Column::ShearX.of(&row), 1.5);
        assert_eq!(Column::ShearRz.of(&row), 2.0);
        assert!("pose_rz".parse::<Column>().expect_err("case matters").contains("pose_Rz"));
    }
}
