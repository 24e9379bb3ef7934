//! Which device renders, and what it turned out to be.

use serde::{Deserialize, Serialize};

/// Which device a headless run asks for.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Adapter {
    /// Mesa's lavapipe (`llvmpipe`), the CPU Vulkan device. The default, so that
    /// golden images are produced by the same rasteriser on every machine.
    #[default]
    Software,
    /// Whatever adapter wgpu picks first: a GPU where there is one.
    Auto,
    /// An adapter whose name contains this string (case-insensitive), e.g. `"H200"`.
    Named(String),
    /// wgpu's noop backend: shaders and pipelines are validated, nothing is
    /// drawn. For [`Headless::check_pipelines`](crate::Headless::check_pipelines)
    /// on machines with no driver.
    Noop,
}

impl Adapter {
    /// Parses a command-line choice: `software`, `auto`, `noop`, or any other
    /// text as [`Adapter::Named`].
    ///
    /// ```
    /// use optica_harness::Adapter;
    /// assert_eq!(Adapter::parse("software"), Adapter::Software);
    /// assert_eq!(Adapter::parse("H200"), Adapter::Named("H200".into()));
    /// ```
    pub fn parse(text: &str) -> Self {
        match text.trim().to_ascii_lowercase().as_str() {
            "software" | "lavapipe" | "llvmpipe" => Adapter::Software,
            "auto" => Adapter::Auto,
            "noop" => Adapter::Noop,
            _ => Adapter::Named(text.trim().to_string()),
        }
    }
}

/// The adapter a run actually used, as wgpu describes it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct AdapterInfo {
    /// Adapter name, e.g. `llvmpipe (LLVM 15.0.6, 256 bits)` or `NVIDIA H200`.
    pub name: String,
    /// Graphics backend, e.g. `Vulkan`.
    pub backend: String,
    /// Device type: `Cpu`, `DiscreteGpu`, `IntegratedGpu`, `VirtualGpu` or `Other`.
    pub device_type: String,
    /// Driver name, e.g. `llvmpipe` or `NVIDIA`.
    pub driver: String,
    /// Driver version, e.g. `Mesa 22.3.6 (LLVM 15.0.6)`.
    pub driver_info: String,
}

impl AdapterInfo {
    pub(crate) fn from_wgpu(info: &wgpu::AdapterInfo) -> Self {
        Self {
            name: info.name.clone(),
            backend: format!("{:?}", info.backend),
            device_type: format!("{:?}", info.device_type),
            driver: info.driver.clone(),
            driver_info: info.driver_info.clone(),
        }
    }

    /// The adapter's family: its name up to the first parenthesis, lower
    /// case, spaces as dashes (`llvmpipe`, `nvidia-h200`). Renders of one
    /// family are compared with one golden; the LLVM version or vector width
    /// in lavapipe's full name does not change its rasterisation rules.
    ///
    /// ```
    /// use optica_harness::AdapterInfo;
    /// let info = AdapterInfo {
    ///     name: "llvmpipe (LLVM 15.0.6, 256 bits)".into(),
    ///     backend: "Vulkan".into(),
    ///     device_type: "Cpu".into(),
    ///     driver: "llvmpipe".into(),
    ///     driver_info: "Mesa 22.3.6 (LLVM 15.0.6)".into(),
    /// };
    /// assert_eq!(info.family(), "llvmpipe");
    /// ```
    pub fn family(&self) -> String {
        let head = self.name.split('(').next().unwrap_or_default().trim();
        let slug: String = head
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() {
                    c.to_ascii_lowercase()
                } else {
                    '-'
                }
            })
            .collect();
        let slug = slug
            .split('-')
            .filter(|s| !s.is_empty())
            .collect::<Vec<_>>()
            .join("-");
        if slug.is_empty() {
            "unknown".into()
        } else {
            slug
        }
    }

    /// Whether this is a CPU rasteriser (lavapipe, WARP, SwiftShader).
    pub fn is_software(&self) -> bool {
        self.device_type == "Cpu"
    }

    /// The Mesa release of a Mesa driver (lavapipe included), read from
    /// its driver info; `None` for other drivers. Tests that a Mesa release
    /// cannot run (Mesa 22.3's lavapipe crashes compiling some shaders)
    /// check it and fail with the fix, instead of taking the test process
    /// down with them.
    ///
    /// ```
    /// use optica_harness::AdapterInfo;
    /// let mut info = AdapterInfo {
    ///     name: "llvmpipe (LLVM 15.0.6, 256 bits)".into(),
    ///     backend: "Vulkan".into(),
    ///     device_type: "Cpu".into(),
    ///     driver: "llvmpipe".into(),
    ///     driver_info: "Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)".into(),
    /// };
    /// assert_eq!(info.mesa_version(), Some((25, 0, 7)));
    /// info.driver_info = "Mesa 22.3.6 (LLVM 15.0.6)".into();
    /// assert_eq!(info.mesa_version(), Some((22, 3, 6)));
    /// info.driver_info = "570.124.06".into();
    /// assert_eq!(info.mesa_version(), None);
    /// ```
    pub fn mesa_version(&self) -> Option<(u32, u32, u32)> {
        let rest = self.driver_info.strip_prefix("Mesa ")?;
        let release: String = rest
            .chars()
            .take_while(|c| c.is_ascii_digit() || *c == '.')
            .collect();
        let mut parts = release.split('.').map(|p| p.parse::<u32>().ok());
        let major = parts.next()??;
        let minor = parts.next().flatten().unwrap_or(0);
        let patch = parts.next().flatten().unwrap_or(0);
        Some((major, minor, patch))
    }

    /// One line for logs and reports: `name, driver_info (backend)`.
    pub fn summary(&self) -> String {
        if self.driver_info.is_empty() {
            format!("{} ({})", self.name, self.backend)
        } else {
            format!("{}, {} ({})", self.name, self.driver_info, self.backend)
        }
    }
}

impl std::fmt::Display for AdapterInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.summary())
    }
}
