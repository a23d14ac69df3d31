//! Which burn device the networks run on. `flex` is the default CPU backend (it trains these
//! networks far faster than `ndarray`, whose transposed convolution is 30-60x slower); `ndarray`
//! (deprecated in burn 0.22), `wgpu` and `cuda` are selectable behind the crate features of the
//! same names, so a default build does not compile them.

use std::fmt;
use std::str::FromStr;

use burn::tensor::Device;

/// A burn backend.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Backend {
    /// burn's `flex` CPU backend (default).
    #[default]
    Flex,
    /// burn's `ndarray` CPU backend (feature `ndarray`; deprecated in burn 0.22).
    #[cfg(feature = "ndarray")]
    Ndarray,
    /// The default wgpu device (feature `wgpu`).
    #[cfg(feature = "wgpu")]
    Wgpu,
    /// The first CUDA device (feature `cuda`).
    #[cfg(feature = "cuda")]
    Cuda,
}

impl Backend {
    /// The plain (inference) device.
    pub fn device(self) -> Device {
        match self {
            Backend::Flex => Device::flex(),
            #[cfg(feature = "ndarray")]
            #[allow(deprecated)] // burn-ndarray is deprecated in 0.22 but kept selectable.
            Backend::Ndarray => Device::ndarray(),
            #[cfg(feature = "wgpu")]
            Backend::Wgpu => Device::wgpu(burn::tensor::DeviceKind::DefaultDevice),
            #[cfg(feature = "cuda")]
            Backend::Cuda => Device::cuda(0),
        }
    }

    /// The device with autodiff, for training.
    pub fn training_device(self) -> Device {
        self.device().autodiff()
    }

    /// Names accepted by [`FromStr`].
    pub fn names() -> &'static [&'static str] {
        &[
            "flex",
            #[cfg(feature = "ndarray")]
            "ndarray",
            #[cfg(feature = "wgpu")]
            "wgpu",
            #[cfg(feature = "cuda")]
            "cuda",
        ]
    }
}

impl FromStr for Backend {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "flex" => Ok(Backend::Flex),
            #[cfg(feature = "ndarray")]
            "ndarray" => Ok(Backend::Ndarray),
            #[cfg(feature = "wgpu")]
            "wgpu" => Ok(Backend::Wgpu),
            #[cfg(feature = "cuda")]
            "cuda" => Ok(Backend::Cuda),
            // A backend of this list that the arms above did not take is left out of the build.
            _ if ["ndarray", "wgpu", "cuda"].contains(&s) => {
                Err(format!("backend `{s}` needs the `{s}` feature: rebuild with --features {s}"))
            }
            _ => Err(format!("unknown backend `{s}`: use one of {}", Backend::names().join(", "))),
        }
    }
}

impl fmt::Display for Backend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self {
            Backend::Flex => "flex",
            #[cfg(feature = "ndarray")]
            Backend::Ndarray => "ndarray",
            #[cfg(feature = "wgpu")]
            Backend::Wgpu => "wgpu",
            #[cfg(feature = "cuda")]
            Backend::Cuda => "cuda",
        };
        f.write_str(name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_listed_backend_parses_back_to_its_name() {
        for name in Backend::names() {
            let backend: Backend = name.parse().expect("a listed name parses");
            assert_eq!(backend.to_string(), *name);
        }
    }

    #[test]
    fn a_backend_left_out_of_the_build_names_the_feature_that_brings_it() {
        for (name, built) in
            [("ndarray", cfg!(feature = "ndarray")), ("wgpu", cfg!(feature = "wgpu")), ("cuda", cfg!(feature = "cuda"))]
        {
            if !built {
                let err = name.parse::<Backend>().expect_err("not in this build");
                assert!(err.contains(&format!("--features {name}")), "{err}");
            }
        }
        let err = "tpu".parse::<Backend>().expect_err("unknown");
        assert!(err.contains("flex"), "{err}");
    }
}
